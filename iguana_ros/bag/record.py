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

"""`iguana bag record`: subscribe with raw (serialized) messages and write a rosbag2-compatible MCAP bag."""
from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
import signal
import sys
import time

import rclpy
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions

from iguana_ros.bag.qos import profile_to_dict, request_profile, table_request_profile
from iguana_ros.bag.schema import message_definition
from iguana_ros.bag.storage import BagWriter, CHUNK_AGE_S, qos_profiles_yaml
from iguana_ros.errors import IguanaError
from iguana_ros.ros.endpoints import listener, message_class, RECORDER_NODE_NAME, tool_node
from iguana_ros.ros.wait_loop import ListenerLoop, settle_heap
from iguana_ros.topics import default_topics

BATCH_S = 0.02
"""Seconds the recorder lets messages gather after a wake that took some: each wake waits on every subscription
(two thirds of the recorder's CPU in a py-spy profile of a node run), and a frame brings ~10 messages. Receive
times come from DDS, so they stay exact; the subscriptions' history (qos.RECORD_DEPTH, 100) holds 0.02 s of any
topic at any realistic rate."""

DISCOVERY_PERIOD_S = 0.5
"""How often the graph is polled for publishers of wanted topics that are not recorded yet."""


def absolute_name(name: str) -> str:
    """Topic name with a leading slash (the recorder's node lives in the root namespace)."""
    return name if name.startswith('/') else '/' + name


def default_topic_names() -> list[str]:
    """Absolute names of every topic of msg_configs/topics.yaml."""
    return [absolute_name(spec.name) for spec in default_topics().values()]


class Recorder:
    """Discovers wanted topics, subscribes raw with QoS adapted to the publishers, writes every message."""

    def __init__(self, node: Node, writer: BagWriter, topics: list[str] | None,
                 log: Callable[[str], None] = print,
                 error: Callable[[str], None] = lambda m: print(m, file=sys.stderr, flush=True)) -> None:
        self.node, self.writer = node, writer
        # a remap given to the recorder (`--ros-args -r a:=b`, as `iguana run` passes its nodes') renames what it wants
        self.wanted = None if topics is None else [node.resolve_topic_name(absolute_name(t)) for t in topics]
        self.log, self.error = log, error
        self.subscriptions: dict[str, int] = {}
        self.failed: set[str] = set()
        self.received = 0

    def poll_discovery(self) -> None:
        """Subscribe to every wanted topic that now has a publisher (and was not subscribed yet)."""
        types = dict(self.node.get_topic_names_and_types())
        names = self.wanted if self.wanted is not None else sorted(types)
        for name in names:
            if name in self.subscriptions or name in self.failed or name not in types:
                continue
            endpoints = self.node.get_publishers_info_by_topic(name)
            if endpoints:
                self._subscribe(name, types[name][0], endpoints)

    def _subscribe(self, name: str, type_name: str, endpoints: list) -> None:
        """Create the raw subscription and the MCAP channel of one topic; report and skip bad types."""
        try:
            cls = message_class(type_name)
            schema = message_definition(type_name)
        except (ValueError, IguanaError) as exc:
            self.failed.add(name)
            self.error(f'iguana bag record: error: cannot record {name}: {exc}; recording the others')
            return
        offered = [e.qos_profile for e in endpoints]
        qos_yaml = qos_profiles_yaml([profile_to_dict(p) for p in offered])
        type_hash = str(getattr(endpoints[0], 'topic_type_hash', '') or '')
        channel = self.writer.add_topic(name, type_name, schema, qos_yaml, type_hash)
        qos = table_request_profile(name) or request_profile(offered)
        listener(self.node, cls, name, lambda data, info, ch=channel: self._on_message(ch, data, info), qos, raw=True)
        self.subscriptions[name] = channel
        self.log(f'subscribed {name} [{type_name}] {qos.reliability.name.lower()}/'
                 f'{qos.durability.name.lower()}')

    def _on_message(self, channel: int, data: bytes, info: dict) -> None:
        """Store one serialized message: log time = receive time, publish time = source time."""
        received = int(info.get('received_timestamp') or 0) or time.time_ns()
        published = int(info.get('source_timestamp') or 0) or received
        self.writer.write(channel, bytes(data), received, published)
        self.received += 1


def _install_stop_handlers(stop: list[bool]) -> None:
    """SIGINT and SIGTERM set stop[0] so the main loop finalises the bag."""
    def handler(_signum, _frame):
        stop[0] = True
    signal.signal(signal.SIGINT, handler)
    signal.signal(signal.SIGTERM, handler)


def record(output: str | Path, topics: list[str] | None, chunk_age_s: float = CHUNK_AGE_S,
           duration_s: float | None = None, ros_args: tuple = ()) -> int:
    """
    Record `topics` (None = every discovered topic) into bag directory `output` until SIGINT/SIGTERM.

    `ros_args` (`--ros-args ...`) apply to the recorder's node: a remap records the topic under its new name.

    Returns the number of messages written. The bag is finalised (summary, footer, metadata.yaml)
    on every exit path except SIGKILL, after which every completed chunk remains readable.
    """
    writer = BagWriter(output, chunk_age_s=chunk_age_s)
    stop = [False]
    _install_stop_handlers(stop)
    context = rclpy.Context()
    rclpy.init(args=['iguana', *ros_args], context=context, signal_handler_options=SignalHandlerOptions.NO)
    loop = None
    try:
        node = tool_node(RECORDER_NODE_NAME, context)
        loop = ListenerLoop(node)
        recorder = Recorder(node, writer, topics, log=lambda m: print(m, flush=True))
        settle_heap()
        print(f'recording to {writer.path}', flush=True)
        chores = [(DISCOVERY_PERIOD_S, recorder.poll_discovery),
                  (min(0.25, chunk_age_s / 2), writer.close_chunk_if_old)]
        due = [time.monotonic()] * len(chores)
        deadline = None if duration_s is None else time.monotonic() + duration_s
        while not stop[0] and (deadline is None or time.monotonic() < deadline):
            now = time.monotonic()
            for i, (period, chore) in enumerate(chores):
                if now >= due[i]:
                    chore()
                    due[i] = now + period
            if loop.spin_once(min(0.1, max(0.0, min(due) - time.monotonic()))):
                time.sleep(BATCH_S)                  # let a frame's messages gather: one wake takes them all
        return recorder.received
    finally:
        if loop is not None:
            loop.close()
        writer.close()
        print(f'wrote {sum(t.message_count for t in writer.topics)} messages on '
              f'{len(writer.topics)} topics to {writer.path}', flush=True)
        rclpy.try_shutdown(context=context)
