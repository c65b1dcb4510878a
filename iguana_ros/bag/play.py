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
`iguana bag play`: republish a bag's serialized messages with the recorded timing and QoS.

Messages are paced by their log times, whatever the bag's time base (simulated for `iguana run`'s bags, so they replay
at the simulated pace; wall for older bags and `iguana bag record` without --use-sim-time). With `clock` there is
exactly one /clock: the bag's recorded /clock when it has one (played even if `topics` leaves it out), else one the
player derives from the log times; never both (two interleaved clocks would send use_sim_time nodes back and forth).
"""
from __future__ import annotations

from pathlib import Path
import signal
import sys
import time

from builtin_interfaces.msg import Time
import rclpy
from rclpy.duration import Duration
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions
from rosgraph_msgs.msg import Clock

from iguana_ros.bag.qos import offer_profile
from iguana_ros.bag.record import absolute_name
from iguana_ros.bag.sim_time import time_base_description
from iguana_ros.bag.storage import accept, BagReader, BagSummary, parse_qos_profiles, summarize
from iguana_ros.errors import InputError
from iguana_ros.ros.endpoints import message_class, resolve, resolve_service
from iguana_ros.topics import default_topics, service as interface

CLOCK_PERIOD_S = 0.025
"""Wall-clock period of /clock messages with --clock (40 Hz, rosbag2's default)."""
ACK_TIMEOUT_S = 2.0
"""How long the player waits at the end for reliable subscribers to acknowledge everything."""


def _err(message: str) -> None:
    print(message, file=sys.stderr, flush=True)


def select_topics(summary: BagSummary, wanted: list[str] | None) -> list:
    """Return the bag's topics filtered by `wanted` names; InputError listing the bag's topics for unknown ones."""
    if not wanted:
        return list(summary.topics)
    names = [absolute_name(t) for t in wanted]
    have = {t.name for t in summary.topics}
    missing = [n for n in names if n not in have]
    if missing:
        raise InputError(f'topic(s) {missing} not in bag {summary.path}; it has {sorted(have)}')
    return [t for t in summary.topics if t.name in names]


def _create_publishers(node: Node, topics: list) -> dict[str, object]:
    """One publisher per playable topic with its recorded QoS; unknown types are reported and skipped."""
    table_depth = {absolute_name(s.name): s.qos.depth for s in default_topics().values()}
    publishers = {}
    for topic in topics:
        try:
            cls = message_class(topic.type)
        except ValueError as exc:
            _err(f'iguana bag play: error: cannot play {topic.name}: {exc}; playing the others')
            continue
        qos = offer_profile(parse_qos_profiles(topic.offered_qos_profiles),
                            default_depth=table_depth.get(topic.name, 10))
        publishers[topic.name] = node.create_publisher(cls, topic.name, qos)
    return publishers


def _wait_for_subscribers(publishers: dict, timeout_s: float, stop: list[bool]) -> None:
    """Wait until every publisher has a matched subscription, or `timeout_s` passes."""
    deadline = time.monotonic() + timeout_s
    while not stop[0] and time.monotonic() < deadline:
        if all(p.get_subscription_count() > 0 for p in publishers.values()):
            return
        time.sleep(0.02)


def _wait_for_resume(node: Node, count: int, stop: list[bool]) -> None:
    """Serve the bag_player_resume service and spin until it is called (or the player is stopped)."""
    name, srv_type = resolve_service('bag_player_resume')
    resumed = [False]

    def on_resume(_request, response):
        resumed[0] = True
        response.success, response.message = True, f'playing {count} messages'
        return response

    service = node.create_service(srv_type, name, on_resume)
    executor = SingleThreadedExecutor(context=node.context)
    executor.add_node(node)
    print(f'paused: call {service.srv_name} ({interface("bag_player_resume").type}) to play', flush=True)
    try:
        while not stop[0] and not resumed[0]:
            executor.spin_once(timeout_sec=0.05)   # (a call's response goes out in the turn that answers it)
    finally:
        executor.remove_node(node)
        executor.shutdown()
        node.destroy_service(service)


def _stamp(ns: int) -> Time:
    """builtin_interfaces/Time of ns since the epoch."""
    return Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def clock_source(summary: BagSummary, selected: list, clock: bool) -> tuple[list, bool]:
    """
    (topics to play, whether the player publishes its own /clock) for `--clock` (module docstring).

    A bag with a recorded /clock plays that one (added to `selected` if left out) and the player publishes none.
    """
    if not clock:
        return selected, False
    recorded = next((t for t in summary.topics if t.name == summary.clock_topic), None)
    if recorded is None:
        return selected, True
    if all(t.name != recorded.name for t in selected):
        selected = [*selected, recorded]
    return selected, False


class _Pacer:
    """Maps bag time to wall time (scaled by `rate`) and publishes the player's own /clock while waiting."""

    def __init__(self, rate: float, clock_pub) -> None:
        self.rate, self.clock_pub = rate, clock_pub
        self.bag0: int | None = None
        self.wall0 = 0.0
        self.next_clock = 0.0
        self.last_clock = -1
        """Last /clock published (ns): each one is later than the one before (messages of a bag are in file order,
        which is log-time order only per topic)."""

    def wait_until(self, log_time: int, stop: list[bool]) -> None:
        """Sleep until the wall time of bag time `log_time` (first call starts the clock)."""
        if self.bag0 is None:
            self.bag0, self.wall0 = log_time, time.monotonic()
        target = self.wall0 + (log_time - self.bag0) * 1e-9 / self.rate
        while not stop[0]:
            now = time.monotonic()
            if self.clock_pub is not None and now >= self.next_clock:
                bag_now = min(self.bag0 + int((now - self.wall0) * self.rate * 1e9), log_time)
                if bag_now > self.last_clock:
                    self.clock_pub.publish(Clock(clock=_stamp(bag_now)))
                    self.last_clock = bag_now
                self.next_clock = now + CLOCK_PERIOD_S
            if now >= target:
                return
            time.sleep(min(target - now, CLOCK_PERIOD_S))


def _play_once(path: Path, publishers: dict, rate: float, clock_pub, stop: list[bool],
               warn_damage: bool = True) -> int:
    """
    Stream the bag once through the publishers (every intact chunk).

    Returns the number of messages published. With `warn_damage`, damage that the check before playing did not see (the
    file changed) is reported in one line.
    """
    reader = BagReader(path)
    pacer = _Pacer(rate, clock_pub)
    count = 0
    for msg in reader.messages():
        if stop[0]:
            break
        pub = publishers.get(msg.topic)
        if pub is None:
            continue
        pacer.wait_until(msg.log_time, stop)
        if stop[0]:
            break
        pub.publish(msg.data)
        count += 1
    if warn_damage and reader.truncated and not stop[0]:
        _err(f'iguana bag play: warning: {path}: {reader.problem}; played the {count} messages recovered')
    return count


def play(path: str | Path, rate: float = 1.0, loop: bool = False, topics: list[str] | None = None,
         clock: bool = False, wait_for_subscribers_s: float = 0.5, allow_damaged: bool = False,
         start_paused: bool = False) -> int:
    """
    Republish bag `path` (directory or .mcap) until its end (or forever with `loop`); returns count.

    The bag is checked first: a damaged or truncated one raises DamagedBag (nothing is published) unless
    `allow_damaged`, and then the messages of every intact chunk are played after a warning line. With `start_paused`
    the player waits (after its wait for subscribers) until its bag_player_resume service is called.
    """
    if not rate > 0 or rate == float('inf'):
        raise InputError(f'--rate must be a positive finite number, got {rate}')
    summary = summarize(path)
    damage = accept(summary, allow_damaged)
    if damage:
        _err(f'iguana bag play: warning: {damage}; playing the recovered messages')
    selected, own_clock = clock_source(summary, select_topics(summary, topics), clock)
    stop = [False]
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda _s, _f: stop.__setitem__(0, True))
    context = rclpy.Context()
    rclpy.init(context=context, signal_handler_options=SignalHandlerOptions.NO)
    try:
        node = rclpy.create_node('iguana_bag_player', context=context)
        publishers = _create_publishers(node, selected)
        clock_pub = None
        if own_clock:
            name, cls, qos = resolve('clock')
            clock_pub = node.create_publisher(cls, name, qos)
        n_selected = sum(t.message_count for t in selected if t.name in publishers)
        print(f'playing {summary.path}: {n_selected} messages on {len(publishers)} topics '
              f'at rate {rate:g}; time base {time_base_description(summary.time_base, summary.clock_topic)}',
              flush=True)
        if clock:
            what = ('the bag has no /clock: the player publishes one from the bag time' if own_clock
                    else f'the recorded {summary.clock_topic} is the clock (the player publishes no second one)')
            print(f'--clock: {what}', flush=True)
        _wait_for_subscribers(publishers, wait_for_subscribers_s, stop)
        if start_paused:
            _wait_for_resume(node, n_selected, stop)
        warn = summary.health.sound
        total = _play_once(summary.path, publishers, rate, clock_pub, stop, warn)
        while loop and not stop[0]:
            total += _play_once(summary.path, publishers, rate, clock_pub, stop, warn)
        for pub in publishers.values():
            if pub.qos_profile.reliability == ReliabilityPolicy.RELIABLE:
                pub.wait_for_all_acked(Duration(seconds=ACK_TIMEOUT_S))
        print(f'published {total} messages', flush=True)
        return total
    finally:
        rclpy.try_shutdown(context=context)    # not release_context: best-effort messages may still be in flight
