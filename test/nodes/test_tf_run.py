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

"""
/tf and /tf_static of a real `iguana run` (four node processes), as a plain rclpy subscriber and bag readers see them.

The run starts paused, so the subscriber matches before frame 1; `iguana sim resume` lets it go. The subscriber gets
odom -> base_link at every frame from frame 1 on (frame 0 too if it matched in time), equal to iguana_state's pose
and stamp, world -> odom latched, the feet and every reference bone; rosbags (types from the bag's own schemas) and
mcap-ros2-support decode /tf from the recorded bag.
"""
import subprocess

import numpy as np
import pytest
import rclpy
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions
from tf2_msgs.msg import TFMessage

from iguana_ros.bag.trajectory import read_root_trajectory
from iguana_ros.body.skeleton import iguana_skeleton
from iguana_ros.constants import FRAME_RATE
from iguana_ros.ros.tf import tf_frames
from ros_harness import IGUANA, start_scene_run, wait_for

pytestmark = [pytest.mark.ros, pytest.mark.slow, pytest.mark.timeout(300)]

FRAMES = 45
SCENE = {'name': 'framed', 'description': 'a short walk whose frames are followed on /tf',
         'terrain': {'kind': 'flat'}, 'goals': [{'x': 1.0, 'y': 0.3}], 'duration': FRAMES / FRAME_RATE}


def _stamp(t) -> float:
    """Return a header stamp in seconds."""
    return t.header.stamp.sec + t.header.stamp.nanosec * 1e-9


class TfListener:
    """A plain rclpy node (its own context) that keeps every transform of /tf and /tf_static."""

    def __init__(self) -> None:
        """Subscribe with tf2_ros's QoS (/tf reliable depth 100; /tf_static transient local)."""
        self.context = rclpy.Context()
        rclpy.init(context=self.context, signal_handler_options=SignalHandlerOptions.NO)
        self.node = rclpy.create_node('plain_tf_listener', context=self.context)
        self.dynamic, self.static = [], []
        self.subscription = self.node.create_subscription(
            TFMessage, '/tf', lambda m: self.dynamic.extend(m.transforms),
            QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE))
        self.node.create_subscription(TFMessage, '/tf_static', lambda m: self.static.extend(m.transforms),
                                      QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                                                 durability=DurabilityPolicy.TRANSIENT_LOCAL))
        self.executor = rclpy.executors.SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)

    def spin(self, seconds: float = 0.05) -> bool:
        """Take what arrived within `seconds`; return False (for wait_for's loop)."""
        self.executor.spin_once(timeout_sec=seconds)
        return False

    def close(self) -> None:
        """Leave the graph."""
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)


@pytest.fixture(scope='module')
def followed(tmp_path_factory):
    """Run the scene paused, let a TfListener match, resume; return (listener's transforms, bag) after the run."""
    listener = TfListener()                # first: matched when frame 0 (sent once, paused) goes out
    run, _, bag = start_scene_run(tmp_path_factory.mktemp('tf'), SCENE, '--paused')
    try:
        # both publishers of /tf matched (the simulator's and the adaptation's) and world -> odom latched: frame 0,
        # published once at the paused start, may have gone out before (a volatile topic); every later frame not
        assert wait_for(lambda: listener.spin() or (listener.subscription.get_publisher_count() >= 2
                                                    and listener.static), 120.0, 0.0), run.output[-2000:]
        resumed = subprocess.run([*IGUANA, 'sim', 'resume'], capture_output=True, text=True, timeout=60)
        assert resumed.returncode == 0, resumed.stderr
        assert wait_for(lambda: listener.spin() or not run.running, 120.0, 0.0), run.output[-2000:]
        for _ in range(20):
            listener.spin()
        assert run.proc.returncode == 0, run.output[-3000:]
        yield listener.dynamic, listener.static, bag
    finally:
        listener.close()
        run.stop()


def test_a_plain_subscriber_follows_base_link_at_every_frame_as_iguana_state(followed):
    dynamic, static, bag = followed
    base = [t for t in dynamic if t.child_frame_id == 'base_link']
    assert {(t.header.frame_id, t.child_frame_id) for t in static} == {('world', 'odom')}
    assert all(t.header.frame_id == 'odom' for t in dynamic)
    stamps = np.array([_stamp(t) for t in base])
    assert np.all(np.diff(stamps) > 0) and len(stamps) >= FRAMES, stamps        # every frame once, in order
    times, roots = read_root_trajectory(bag)
    roots = roots[len(times) - len(stamps):]                                    # frame 0 may have gone before
    assert np.allclose(stamps, times[len(times) - len(stamps):])
    followed_roots = np.array([[t.transform.translation.x, t.transform.translation.y, t.transform.translation.z]
                               for t in base])
    assert np.array_equal(followed_roots, roots)          # the simulated root, bit for bit
    assert np.linalg.norm(roots[-1, :2] - roots[0, :2]) > 0.05   # it walked: the frame moved with it


def test_the_feet_and_every_reference_bone_have_a_frame(followed):
    dynamic, _, _ = followed
    frames = tf_frames('', iguana_skeleton().names)
    children = {t.child_frame_id for t in dynamic}
    assert set(frames.feet) | set(frames.bones) | {'base_link'} == children
    for name in frames.feet:
        stamps = [_stamp(t) for t in dynamic if t.child_frame_id == name]
        assert len(stamps) >= FRAMES and stamps == sorted(stamps), name
    for name in frames.bones:                  # published up to lookahead_frames ahead, some before the match
        stamps = [_stamp(t) for t in dynamic if t.child_frame_id == name]
        assert stamps == sorted(stamps) and stamps[-1] >= (FRAMES - 1) / FRAME_RATE, name


def test_the_bag_readers_decode_tf_from_the_recorded_bag(followed):
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import get_typestore, Stores

    _, _, bag = followed
    times, roots = read_root_trajectory(bag)
    with AnyReader([bag], default_typestore=get_typestore(Stores.ROS2_JAZZY)) as reader:
        connections = [c for c in reader.connections if c.topic in ('/tf', '/tf_static')]
        by_rosbags = [(c.topic, reader.deserialize(raw, c.msgtype)) for c, _t, raw in reader.messages(connections)]
    base = [t for topic, m in by_rosbags if topic == '/tf' for t in m.transforms if t.child_frame_id == 'base_link']
    assert np.array_equal([[t.transform.translation.x, t.transform.translation.y, t.transform.translation.z]
                           for t in base], roots)
    assert [t.child_frame_id for topic, m in by_rosbags if topic == '/tf_static' for t in m.transforms] == ['odom']
    with open(next(bag.glob('*.mcap')), 'rb') as f:
        decoded = [(channel.topic, message) for _s, channel, _m, message in
                   make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages(topics=['/tf'])]
    base = [t for _topic, m in decoded for t in m.transforms if t.child_frame_id == 'base_link']
    assert np.allclose([_stamp(t) for t in base], times)
    assert np.array_equal([t.transform.translation.x for t in base], roots[:, 0])
