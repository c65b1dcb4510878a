# Copyright 2026 iguana_ros developers
#
# Licensed under the Apache License, Version 2.0 (the "License");
# you may not use this file except in compliance with the License.
# You may obtain a copy of the License at
#
#     http://www.apache.org/licenses/LICENSE-2.0
#
# Unless required by applicable law or agreed to in writing, software
# distributed under the License is distributed on an "AS IS" BASIS,
# WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
# See the License for the specific language governing permissions and
# limitations under the License.

"""The recorder's and run monitor's wait loop takes every message over real DDS, as the executor would hand it."""
import time

import pytest

pytestmark = [pytest.mark.ros]


def test_listener_loop_drains_every_message_with_or_without_info(make_node):
    from rclpy.qos import QoSProfile
    from std_msgs.msg import Float64

    from iguana_ros.ros.endpoints import listener, talker
    from iguana_ros.ros.wait_loop import ListenerLoop

    sender = make_node('loop_sender')
    receiver = make_node('loop_receiver')
    qos = QoSProfile(depth=100)
    typed, raw = [], []
    listener(receiver, Float64, 'loop_typed', typed.append, qos)
    listener(receiver, Float64, 'loop_raw', lambda data, info: raw.append((data, info)), qos, raw=True)
    pubs = [talker(sender, Float64, name, qos) for name in ('loop_typed', 'loop_raw')]
    deadline = time.monotonic() + 20.0
    while any(p.get_subscription_count() < 1 for p in pubs) and time.monotonic() < deadline:
        time.sleep(0.05)
    loop = ListenerLoop(receiver)
    assert loop.spin_once(0.0) == 0                          # nothing sent: returns at once with none
    for i in range(40):
        for pub in pubs:
            pub.publish(Float64(data=float(i)))
    while (len(typed) < 40 or len(raw) < 40) and time.monotonic() < deadline:
        loop.spin_once(0.1)
    assert [m.data for m in typed] == [float(i) for i in range(40)]          # in order, none lost
    assert all(isinstance(data, bytes) and info['source_timestamp'] > 0 for data, info in raw) and len(raw) == 40
    got = []                                                  # a subscription made later joins the wait set
    listener(receiver, Float64, 'loop_later', got.append, qos)
    later = talker(sender, Float64, 'loop_later', qos)
    while later.get_subscription_count() < 1 and time.monotonic() < deadline:
        time.sleep(0.05)
    later.publish(Float64(data=7.0))
    while not got and time.monotonic() < deadline:
        loop.spin_once(0.1)
    assert [m.data for m in got] == [7.0]


def test_a_tool_node_serves_no_parameters(ros_context, make_node):
    from iguana_ros.ros.endpoints import tool_node
    node = tool_node('quiet_tool', ros_context)
    try:
        def parameter_services(n):
            return [s.srv_name for s in n.services if 'parameter' in s.srv_name]
        assert not parameter_services(node) and len(parameter_services(make_node('loud_node'))) >= 6
    finally:
        node.destroy_node()


def test_settle_heap_collects_start_up_garbage_and_freezes_the_rest():
    """In a fresh process: a start-up cycle is collected, the survivors are frozen, later cycles are still collected."""
    import subprocess
    import sys

    code = """
import gc, weakref
from iguana_ros.ros.wait_loop import settle_heap
class Node: pass
a = Node(); a.me = a; dead = weakref.ref(a); del a
kept = [Node() for _ in range(100)]
settle_heap()
assert dead() is None, 'start-up garbage survived'
assert gc.get_freeze_count() >= len(kept), gc.get_freeze_count()
b = Node(); b.me = b; later = weakref.ref(b); del b
gc.collect()
assert later() is None, 'a cycle made after the freeze was not collected'
print('ok', gc.get_freeze_count())
"""
    out = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0 and out.stdout.startswith('ok'), out.stderr[-1500:]
