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
`iguana bag record`: subscribe with raw (serialized) messages and write a rosbag2-compatible MCAP bag.

Log times are the wall-clock receive times, or with `use_sim_time` (`--use-sim-time`, as `ros2 bag record
--use-sim-time`; `iguana run` always records so) the simulated time of the latest /clock received before each message
(iguana_ros.bag.sim_time), so a bag of a lockstep run replays at its simulated pace.
"""
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
from iguana_ros.bag.sim_time import CLOCK_TOPIC, SimTimeStamper, TIME_BASE_SIMULATED, TIME_BASE_WALL
from iguana_ros.bag.storage import BagWriter, CHUNK_AGE_S, qos_profiles_yaml
from iguana_ros.errors import IguanaError
from iguana_ros.ros.endpoints import listener, message_class, RECORDER_NODE_NAME, release_context, tool_node
from iguana_ros.ros.wait_loop import ListenerLoop, settle_heap
from iguana_ros.topics import default_topics, topic_name

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


def default_topic_names(namespace: str = '') -> list[str]:
    """Absolute names of every topic of msg_configs/topics.yaml for a run in ROS `namespace` ('' the root)."""
    return [topic_name(key, namespace) for key in default_topics()]


def names_in(topics: list[str], namespace: str) -> list[str]:
    """Return topic names as given on the command line, the relative ones under `namespace` ('' the root)."""
    return [t if t.startswith('/') else f'{namespace}/{t}' for t in topics]


class Recorder:
    """
    Discovers wanted topics, subscribes raw with QoS adapted to the publishers, writes every message.

    On simulated time (`stamper` given) /clock is subscribed to even when it is not recorded, and each wake's messages
    are stamped by `flush` once the wake's /clock messages are known.
    """

    def __init__(self, node: Node, writer: BagWriter, topics: list[str] | None,
                 log: Callable[[str], None] = print,
                 error: Callable[[str], None] = lambda m: print(m, file=sys.stderr, flush=True),
                 stamper: SimTimeStamper | None = None, clock_topic: str = CLOCK_TOPIC) -> None:
        self.node, self.writer, self.clock_topic = node, writer, clock_topic
        # a remap given to the recorder (`--ros-args -r a:=b`, as `iguana run` passes its nodes') renames what it wants
        self.wanted = None if topics is None else [node.resolve_topic_name(absolute_name(t)) for t in topics]
        self.log, self.error = log, error
        self.stamper = stamper
        self.subscriptions: dict[str, int | None] = {}
        """Topic -> its channel (None: /clock subscribed for the clock only, not recorded)."""
        self.failed: set[str] = set()
        self.received = 0

    def _names(self, types: dict) -> list[str]:
        """Topics to subscribe to: the wanted ones (every one for -a), and /clock on simulated time."""
        names = list(self.wanted) if self.wanted is not None else sorted(types)
        if self.stamper is not None and self.clock_topic not in names:
            names.insert(0, self.clock_topic)
        return names

    def poll_discovery(self) -> None:
        """Subscribe to every wanted topic that now has a publisher (and was not subscribed yet)."""
        types = dict(self.node.get_topic_names_and_types())
        for name in self._names(types):
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
        recorded = self.wanted is None or name in self.wanted
        channel = None
        if recorded:
            qos_yaml = qos_profiles_yaml([profile_to_dict(p) for p in offered])
            type_hash = str(getattr(endpoints[0], 'topic_type_hash', '') or '')
            channel = self.writer.add_topic(name, type_name, schema, qos_yaml, type_hash)
        qos = table_request_profile(name) or request_profile(offered)
        handle = self._on_clock if self.stamper is not None and name == self.clock_topic else self._on_message
        listener(self.node, cls, name, lambda data, info, ch=channel, h=handle: h(ch, data, info), qos, raw=True)
        self.subscriptions[name] = channel
        self.log(f'subscribed {name} [{type_name}] {qos.reliability.name.lower()}/'
                 f'{qos.durability.name.lower()}' + ('' if recorded else ' (the clock only, not recorded)'))

    @staticmethod
    def _times(info: dict) -> tuple[int, int]:
        """(receive time, source time) of a message, wall clock ns (now where the middleware gives none)."""
        received = int(info.get('received_timestamp') or 0) or time.time_ns()
        return received, int(info.get('source_timestamp') or 0) or received

    def _on_message(self, channel: int, data: bytes, info: dict) -> None:
        """
        Store one serialized message: publish time = source time; log time = receive time.

        On simulated time: queued for `flush`, which stamps it from /clock.
        """
        received, published = self._times(info)
        if self.stamper is None:
            self.writer.write(channel, bytes(data), received, published)
        else:
            self.stamper.add(channel, bytes(data), received, published)
        self.received += 1

    def _on_clock(self, channel: int | None, data: bytes, info: dict) -> None:
        """Advance the simulated clock (a /clock that does not decode is recorded, not used), then record it."""
        received, _ = self._times(info)
        try:
            self.stamper.clock(received, bytes(data))
        except ValueError as exc:
            self.error(f'iguana bag record: warning: {self.clock_topic} message ignored as a clock: {exc}')
        if channel is not None:
            self._on_message(channel, data, info)

    def flush(self) -> None:
        """Write the messages queued on simulated time that can be stamped (after each wake)."""
        if self.stamper is not None:
            self.stamper.flush()

    def close(self) -> None:
        """Write every queued message (at log time 0 if no /clock ever came)."""
        if self.stamper is not None:
            self.stamper.close()


def _install_stop_handlers(stop: list[bool]) -> None:
    """SIGINT and SIGTERM set stop[0] so the main loop finalises the bag."""
    def handler(_signum, _frame):
        stop[0] = True
    signal.signal(signal.SIGINT, handler)
    signal.signal(signal.SIGTERM, handler)


def record(output: str | Path, topics: list[str] | None, chunk_age_s: float = CHUNK_AGE_S,
           duration_s: float | None = None, use_sim_time: bool = False, ros_args: tuple = (),
           namespace: str = '') -> int:
    """
    Record `topics` (None = every discovered topic) into bag directory `output` until SIGINT/SIGTERM.

    The recorder's node is in ROS `namespace`, and on simulated time its clock is that run's (`<namespace>/clock`).

    `ros_args` (`--ros-args ...`) apply to the recorder's node: a remap records the topic under its new name.

    Returns the number of messages written. The bag is finalised (summary, footer, metadata.yaml)
    on every exit path except SIGKILL, after which every completed chunk remains readable. With `use_sim_time` the log
    times are simulated time from /clock (module docstring), and the bag says so.
    """
    clock = topic_name('clock', namespace)
    writer = BagWriter(output, chunk_age_s=chunk_age_s,
                       time_base=TIME_BASE_SIMULATED if use_sim_time else TIME_BASE_WALL, clock_topic=clock)
    stop = [False]
    _install_stop_handlers(stop)
    context = rclpy.Context()
    rclpy.init(args=['iguana', *ros_args], context=context, signal_handler_options=SignalHandlerOptions.NO)
    loop = recorder = None
    try:
        node = tool_node(RECORDER_NODE_NAME, context, namespace)
        loop = ListenerLoop(node)
        stamper = SimTimeStamper(writer.write, warn=lambda m: print(m, file=sys.stderr, flush=True)) \
            if use_sim_time else None
        recorder = Recorder(node, writer, topics, log=lambda m: print(m, flush=True), stamper=stamper,
                            clock_topic=clock)
        settle_heap()
        print(f'recording to {writer.path}' + (f' on simulated time ({clock})' if use_sim_time else ''),
              flush=True)
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
                recorder.flush()
                time.sleep(BATCH_S)                  # let a frame's messages gather: one wake takes them all
        return recorder.received
    finally:
        if loop is not None:
            loop.close()
        try:
            if recorder is not None and not writer.closed:
                recorder.close()
        finally:
            writer.close()
        print(f'wrote {sum(t.message_count for t in writer.topics)} messages on '
              f'{len(writer.topics)} topics to {writer.path}', flush=True)
        release_context(context)
