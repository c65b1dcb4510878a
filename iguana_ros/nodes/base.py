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

"""What every iguana_ros node shares: declared parameters, topics from the table, frame stamps, main()."""
from __future__ import annotations

import sys
import time
from typing import Callable

from rcl_interfaces.msg import (FloatingPointRange, IntegerRange, ParameterDescriptor, ParameterType,
                                SetParametersResult)
import rclpy
from rclpy.clock import Clock, ClockType
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node

from iguana_ros.errors import IguanaError
from iguana_ros.parameters import node_parameters, ParamSpec
from iguana_ros.ros.diagnostics import diagnostics_msg, health_status, HealthSample, NodeHealth, REPORT_PERIOD_S
from iguana_ros.ros.endpoints import listener, resolve, talker
from iguana_ros.ros.run_events import EVENT_LOADED, EVENT_UP, RunEvent
from iguana_ros.ros.run_events import run_event_msg
from iguana_ros.ros.wait_loop import settle_heap
from iguana_ros.scene import load_scene, named_character, Scene, served_characters
from iguana_ros.topics import resolve_frame_prefix, topic
from iguana_ros.validation import check_frame, FRAME_NEW, FRAME_STALE

_PARAM_TYPES = {'string': ParameterType.PARAMETER_STRING, 'double': ParameterType.PARAMETER_DOUBLE,
                'integer': ParameterType.PARAMETER_INTEGER, 'bool': ParameterType.PARAMETER_BOOL}


def descriptor(spec: ParamSpec) -> ParameterDescriptor:
    """`ParameterDescriptor` with the declared description, type and range."""
    desc = ParameterDescriptor(name=spec.name, type=_PARAM_TYPES[spec.type], read_only=not spec.dynamic,
                               description=spec.description)
    if spec.choices:
        desc.additional_constraints = 'one of: ' + ', '.join(spec.choices)
    if spec.range is not None and spec.type == 'double':
        desc.floating_point_range = [FloatingPointRange(from_value=float(spec.range[0]),
                                                        to_value=float(spec.range[1]), step=0.0)]
    if spec.range is not None and spec.type == 'integer':
        desc.integer_range = [IntegerRange(from_value=int(spec.range[0]), to_value=int(spec.range[1]), step=0)]
    return desc


class IguanaNode(Node):
    """
    A node whose parameters come from msg_configs/parameters.yaml and topics from topics.yaml.

    Subclasses set KIND (their entry in parameters.yaml and default node name).
    """

    KIND = ''
    SERVES_WORLD = False
    """Whether the node serves every character of a scene of several when its namespace names none (the simulator)."""
    exit_code = 0
    load_detail = ''
    """What the node's 'loaded' run event says about its build (e.g. 'model from cache')."""

    def __init__(self, **kwargs) -> None:
        """Create the node, say so on run_events, declare its parameters (read-only, with ranges); load its scene."""
        super().__init__(self.KIND, **kwargs)
        self._events = self.publisher('run_events')
        self.report(EVENT_UP)
        self.health = NodeHealth()
        self._diagnostics = self.publisher('diagnostics')
        self._health_since = HealthSample.of(self.health, time.monotonic())
        self.create_timer(REPORT_PERIOD_S, self.report_health, clock=Clock(clock_type=ClockType.STEADY_TIME))
        self._specs = node_parameters(self.KIND)
        for spec in self._specs.values():
            self.declare_parameter(spec.name, spec.default, descriptor(spec))
        self.add_on_set_parameters_callback(self._check_new_parameters)
        world = load_scene(self.param('scene'))
        character, namespace = self.param('character'), self.get_namespace()
        self.characters = served_characters(world, character, namespace, self.SERVES_WORLD)
        """(name, scene alone) of each character served: one, or a world's every character (`SERVES_WORLD`)."""
        self.in_world = bool(world.characters) and named_character(world, character, namespace) is None
        """Whether the node serves a scene's world of characters, each under its name (`<name>/iguana_state`)."""
        self.scene: Scene = world if self.in_world else self.characters[0][1]
        self.world_scene = world

    def report(self, kind: str, detail: str = '', clip: str = '', frame: int = -1) -> None:
        """Publish a run event (EVENT_UP, EVENT_LOADED, EVENT_CLIP) stamped with the wall clock on run_events."""
        self._events.publish(run_event_msg(RunEvent(self.get_name(), kind, time.time(), detail, clip, frame)))

    def report_health(self) -> None:
        """Publish the node's health since its last report on /diagnostics (a wall-clock timer calls it)."""
        now = HealthSample.of(self.health, time.monotonic())
        status = health_status(self.get_fully_qualified_name(), self.health, self._health_since, now)
        self._health_since = now
        self._diagnostics.publish(diagnostics_msg([status], time.time()))

    def _check_new_parameters(self, params: list) -> SetParametersResult:
        """Accept a change of dynamic parameters that fit their declaration; refuse the rest with the reason."""
        for param in params:
            spec = self._specs.get(param.name)
            if spec is None:
                continue
            try:
                spec.check(param.value)
            except IguanaError as exc:
                return SetParametersResult(successful=False, reason=str(exc))
        return SetParametersResult(successful=True)

    def now_stamp(self):
        """
        builtin_interfaces/Time of the node's clock.

        Simulated time (the latest /clock) when use_sim_time is true (the standard params file sets it for the planner),
        else the system clock. Frame data is stamped with `frame_stamp`.
        """
        return self.get_clock().now().to_msg()

    def param(self, name: str):
        """Value of declared parameter `name`, checked against its declaration."""
        return self._specs[name].check(self.get_parameter(name).value)

    def frame_prefix(self) -> str:
        """Return the TF frame prefix: the `frame_prefix` parameter, whose 'auto' is the node's namespace."""
        return resolve_frame_prefix(self.param('frame_prefix'), self.get_namespace())

    def publisher(self, key: str, prefix: str = ''):
        """Return publisher for topic `key` of the topic table (a relative name under `prefix`, e.g. 'iguana_b/')."""
        name, cls, qos = resolve(key, prefix)
        return talker(self, cls, name, qos)

    def subscription(self, key: str, callback: Callable, raw: bool = False, depth: int | None = None,
                     prefix: str = ''):
        """
        Subscription to topic `key` of the topic table (a relative name under `prefix`).

        `depth` (optional) deepens this reader's history beyond the table's (a latched topic's depth 1 is what its
        publisher keeps for late joiners).
        """
        name, cls, qos = resolve(key, prefix)
        if depth is not None:
            qos.depth = max(qos.depth, depth)
        return listener(self, cls, name, callback, qos, raw=raw)

    def guarded(self, what: str, callback: Callable) -> Callable:
        """Wrap a callback so bad input is logged and rejected instead of killing the node."""
        def wrapper(msg):
            try:
                callback(msg)
            except IguanaError as exc:
                self.health.reject(f'{what}: {exc}')
                self.get_logger().error(f'rejected {what}: {exc}')
        return wrapper


RESEND_FRAMES = 100
"""Replies a node keeps for re-sending to a repeated input frame: inputs run up to the terrain adaptation's lookahead
(at most 90 frames) ahead of the frame the simulator waits for."""


class FrameGate:
    """
    Frame gating of one input topic: the newest frame a node has handled from it, and its replies to recent frames.

    `admit(frame)` is True for a new frame. A repeated frame (a peer re-sends its input after a lockstep timeout)
    gets its kept reply again (the last `keep` replies are kept: inputs may run ahead of the frame a peer waits for),
    a stale one is logged and dropped, one too far ahead is an InputError (`check_frame`).
    """

    def __init__(self, node: Node, what: str, publisher=None, keep: int = 1) -> None:
        """Gate topic `what` of `node`; replies (if any) go out on `publisher`, the last `keep` kept for repeats."""
        self.node, self.what, self.publisher, self.keep = node, what, publisher, keep
        self.last_frame = -1
        self.replies: dict[int, object] = {}

    def admit(self, frame: int) -> bool:
        """Whether a message of `frame` is new (to be handled); re-sends the reply to a repeated frame."""
        if frame in self.replies:
            self.publisher.publish(self.replies[frame])
            return False
        order = check_frame(self.what, frame, self.last_frame)
        if order == FRAME_STALE:
            self._health().late += 1
            self.node.get_logger().warning(f'ignored stale {self.what} for frame {frame} (at {self.last_frame})')
        return order == FRAME_NEW

    def _health(self) -> NodeHealth:
        """Return the node's health counters (a throwaway for a node that keeps none)."""
        return getattr(self.node, 'health', None) or NodeHealth()

    def handled(self, frame: int, reply=None, publish: bool = True) -> None:
        """Mark `frame` handled; keep `reply` for a repeat of the frame and publish it (unless not `publish`)."""
        self.last_frame = frame
        self._health().frames += 1
        if reply is not None:
            self.replies[frame] = reply
            while len(self.replies) > self.keep:
                del self.replies[next(iter(self.replies))]
            if publish:
                self.publisher.publish(reply)


READER_HOLD_LIMIT_S = 5.0
"""Longest wall-clock time output is held for readers the graph does not list yet, or lists without a match or a
reported QoS incompatibility: DDS discovery under load has taken over 1 s (a 1 s limit let frame 0 go out before the
spring-length node had matched, and the run waited a 10 s lockstep timeout), and a participant that misses the
initial announcements is seen at the next periodic one (3 s). After it any matched reader makes output go."""

UNMATCHED_RETRY_S = 0.05
"""Wall-clock period at which output held back for want of matched readers is offered again."""


class ReaderCount:
    """
    A publisher that counts the readers it cannot match (an incompatible QoS, reported by its QoS event).

    `settled()`: every reader the node's graph lists on the topic is matched or known incompatible, so what is
    published now reaches every reader that will ever match it.
    """

    def __init__(self, node: Node, key: str, prefix: str = '') -> None:
        """Create `node`'s publisher of topic `key` (under `prefix`), with an incompatible-QoS event handler."""
        name, cls, qos = resolve(key, prefix)
        self.node, self.incompatible = node, 0
        self.publisher = talker(node, cls, name, qos, on_incompatible=self._on_incompatible)

    def _on_incompatible(self, status) -> None:
        """Note a reader whose requested QoS this writer cannot offer (it never matches)."""
        self.incompatible = int(status.total_count)

    def listed(self) -> int:
        """Return readers of the topic in the node's graph."""
        return self.node.count_subscribers(self.publisher.topic_name)

    def settled(self) -> bool:
        """Whether every listed reader is matched or incompatible (and at least one is matched)."""
        matched = self.publisher.get_subscription_count()
        return matched >= 1 and matched + self.incompatible >= self.listed()


class ReaderHold:
    """
    Holds a volatile publisher's output until its readers can take it.

    Ready once every declared reader of the topic (`topics.yaml` subscribers) is in the node's graph and every reader
    the graph lists is matched by the writer or reported incompatible (`ReaderCount`): a reader's side may match
    first, and what the writer publishes before it has matched the reader is lost (the lockstep run then waits a
    timeout). Anything else holds it for READER_HOLD_LIMIT_S, then any matched reader makes it ready.
    """

    def __init__(self, node: Node, key: str, retry: Callable[[], None]) -> None:
        """Publish topic `key` of topics.yaml from `node` (`.publisher`); `retry` is called periodically while held."""
        self.node = node
        self.readers = ReaderCount(node, key)
        self.publisher = self.readers.publisher
        self.declared = set(topic(key).subscribers)   # until each is seen in the graph
        self.held_since: float | None = None
        self.retry_timer = node.create_timer(UNMATCHED_RETRY_S, retry, clock=Clock(clock_type=ClockType.STEADY_TIME))
        self.retry_timer.cancel()                     # runs only while output is held

    def ready(self) -> bool:
        """Whether output may go out now (see the class docstring); while not, `retry` is called periodically."""
        ok = self.readers_matched()
        if ok:
            self.retry_timer.cancel()
        else:
            self.retry_timer.reset()
        return ok

    def readers_matched(self) -> bool:
        """Whether the declared readers are listed and every listed reader is settled (or the hold's time is up)."""
        if self.declared:
            infos = self.node.get_subscriptions_info_by_topic(self.publisher.topic_name)
            self.declared -= {info.node_name for info in infos}
        if not self.declared and self.readers.settled():
            self.held_since = None
            return True
        now = time.monotonic()
        self.held_since = now if self.held_since is None else self.held_since
        return self.publisher.get_subscription_count() >= 1 and now - self.held_since >= READER_HOLD_LIMIT_S


def run_nodes(factories: list[Callable[[], Node]], args: list[str] | None = None) -> int:
    """Create nodes from `factories` in one process and spin them with one executor until shutdown."""
    rclpy.init(args=args)
    nodes: list[Node] = []
    code = 0
    try:
        nodes = [factory() for factory in factories]
        for node in nodes:
            if isinstance(node, IguanaNode):
                node.report(EVENT_LOADED, node.load_detail)
        executor = SingleThreadedExecutor()
        for node in nodes:
            executor.add_node(node)
        settle_heap()
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except IguanaError as exc:
        print(f'error: {exc}', file=sys.stderr)
        code = 1
    except Exception:
        if rclpy.ok():
            raise
        # the shutdown itself (SIGINT / SIGTERM) interrupted a take or a callback: rclpy raises from inside it
    finally:
        code = max(code, max((getattr(n, 'exit_code', 0) for n in nodes), default=0))
        for node in nodes:
            node.destroy_node()
        rclpy.try_shutdown()
    return code


def node_main(cls: type) -> Callable[[], None]:
    """Return a console-script main() for node class `cls`."""
    def main(args: list[str] | None = None) -> None:
        sys.exit(run_nodes([cls], args if args is not None else sys.argv))
    return main
