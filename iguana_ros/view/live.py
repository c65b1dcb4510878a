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
Live mode.

An rclpy node of the viewer's own feeding a `WorldView` from the running system's topics (QoS as msg_configs/topics.yaml
says) and publishing the user's goals (`goal_pose`, PoseStamped, like RViz2's "2D Goal Pose") and pushes (`push`,
WrenchStamped). It spins in a thread of its own; messages that do not fit their topic are counted and the first of each
topic is logged, never drawn.

Characters: a lone iguana's topics are the namespace's own (`mesh_marker`, `goal_pose`, ...: the character '', always
subscribed, as before worlds). A world's (`iguana run crossing`) are `<name>/mesh_marker`, `<name>/goal_pose`, ... in
the namespace: every DISCOVERY_S the node looks at the graph for topics `<namespace>/<name>/mesh_marker` of the
Marker type and subscribes to a new character's topics, so a late one appears. The world's own topics
(`scene_markers`, the `sim/*` services) stay the namespace's.
"""
from __future__ import annotations

import sys
import threading
import time

import numpy as np
import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.signals import SignalHandlerOptions

from iguana_ros.errors import IguanaError
from iguana_ros.nodes.goal_sender import goal_message, same_goal
from iguana_ros.nodes.sim_control import SimControlClient
from iguana_ros.ros.conversions import time_to_msg
from iguana_ros.ros.endpoints import release_context, resolve
from iguana_ros.topics import topic
from iguana_ros.view import decode
from iguana_ros.view.scene import RunView, WorldView

VIEW_NODE_NAME = 'iguana_view'
"""ROS node name of the viewer."""

SPIN_TIMEOUT_S = 0.05
"""Wall seconds an executor spin waits for work (how quickly the thread notices `close`)."""

DISCOVERY_S = 1.0
"""Wall seconds between two looks at the graph for characters (`<name>/mesh_marker` topics)."""


def character_names(topics: list[tuple[str, list[str]]], namespace: str) -> list[str]:
    """
    Return the names of the characters among the graph's `topics` ((name, types) pairs): sorted, one each.

    A character `east` of the node namespace `namespace` ('/' or '/ns') publishes `<namespace>/east/mesh_marker` of
    the mesh_marker type; a name is one segment of a ROS name (the namespace's own mesh_marker is the character '').
    """
    spec = topic('mesh_marker')
    base = namespace.rstrip('/') + '/'
    suffix = '/' + spec.name.lstrip('/')
    names = set()
    for name, types in topics:
        if spec.type not in types or not name.startswith(base) or not name.endswith(suffix):
            continue
        middle = name[len(base):-len(suffix)]
        if middle and '/' not in middle:
            names.add(middle)
    return sorted(names)


class _Character:
    """One character's publishers and the goals its planner accepted (the character's topics are under `prefix`)."""

    def __init__(self, source: LiveSource, name: str) -> None:
        """Subscribe to character `name`'s topics into its view of the source's world; make its publishers."""
        self.name = name
        self.prefix = f'{name}/' if name else ''
        self.accepted: list = []
        self.view = source.world.character(name)
        self.goal_pub = source._publisher('goal_pose', self.prefix)
        self.push_pub = source._publisher('push', self.prefix)
        view = self.view
        handlers = {
            'mesh_marker': (True, lambda data: decode.take_mesh(view, data)),
            'iguana_state': (True, lambda data: decode.take_state(view, data, time.monotonic())),
            'foot_state': (True, lambda data: decode.take_foot_state(view, data)),
            'foot_positions': (True, lambda data: decode.take_foot_positions(view, data)),
            'motion_clip': (True, lambda data: decode.take_clip(view, data, source.library)),
            'push': (True, lambda data: decode.take_push(view, data, view.end_time, source.push_duration)),
            'accepted_goals': (False, lambda msg: setattr(self, 'accepted', list(msg.poses))),
        }
        for key, (raw, handler) in handlers.items():
            name_, cls, qos = resolve(key, self.prefix)
            source.node.create_subscription(cls, name_, source._guarded(self.prefix + key, handler), qos, raw=raw)


class LiveSource:
    """The viewer's node (see the module docstring); `close()` leaves the graph."""

    def __init__(self, view: RunView | WorldView, library: dict, push_duration: float, namespace: str = '') -> None:
        """Join the graph in ROS `namespace` (rclpy context of its own, no signal handlers), subscribe, spin."""
        self.world = WorldView.of(view)
        self.view, self.library, self.push_duration = self.world.world, library, push_duration
        self.context = rclpy.Context()
        rclpy.init(context=self.context, signal_handler_options=SignalHandlerOptions.NO)
        self.node = rclpy.create_node(VIEW_NODE_NAME, namespace=namespace, context=self.context)
        self.rejected: dict[str, int] = {}
        self.sent: list = []
        self.sent_to: list[str] = []
        """The character each of `sent` went to."""
        self.characters: dict[str, _Character] = {}
        self._subscribe()
        self.characters[''] = _Character(self, '')
        self.sim_control = SimControlClient(self.node)
        self.sim_calls: list = []
        self.node.create_timer(DISCOVERY_S, self.discover)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self._running = True
        self.thread = threading.Thread(target=self._spin, name='iguana-view-ros', daemon=True)
        self.thread.start()

    @property
    def accepted(self) -> list:
        """Return the goals the lone iguana's planner (the character '') accepted."""
        return self.characters[''].accepted

    def _publisher(self, key: str, prefix: str = ''):
        """Return publisher of topic-table key `key` (a relative name under `prefix`)."""
        name, cls, qos = resolve(key, prefix)
        return self.node.create_publisher(cls, name, qos)

    def _subscribe(self) -> None:
        """Subscribe to the world's scene_markers (terrain and goals; raw bytes, read with the nodes' decoders)."""
        world = self.world
        name, cls, qos = resolve('scene_markers')
        self.node.create_subscription(cls, name, self._guarded('scene_markers', lambda data: decode.take_scene(
            world.world, data, world.end_time)), qos, raw=True)

    def discover(self) -> list[str]:
        """Subscribe to the topics of every character on the graph not yet known; return the new ones' names."""
        found = character_names(self.node.get_topic_names_and_types(), self.node.get_namespace())
        new = [name for name in found if name not in self.characters]
        for name in new:
            self.characters[name] = _Character(self, name)
        return new

    def _guarded(self, key: str, handler):
        """Return `handler` that counts (and logs the first of) the messages of `key` that do not fit."""
        def callback(msg) -> None:
            try:
                handler(msg)
            except (IguanaError, ValueError, TypeError) as exc:
                self.rejected[key] = self.rejected.get(key, 0) + 1
                if self.rejected[key] == 1:
                    print(f'iguana view: ignored a {key} message: {exc}', file=sys.stderr, flush=True)
        return callback

    def _spin(self) -> None:
        """Executor loop of the thread (ends at `close`)."""
        while self._running and self.context.ok():
            try:
                self.executor.spin_once(timeout_sec=SPIN_TIMEOUT_S)
            except ExternalShutdownException:
                return

    def send_goal(self, x: float, y: float, yaw_deg: float | None = None, character: str = '') -> None:
        """
        Publish a goal at (x, y) m, to arrive heading `yaw_deg` (None: any), for the planner to adopt at once.

        It goes on `character`'s goal_pose ('': the lone iguana's); KeyError for a character not seen.
        """
        target = self.characters[character]
        msg = goal_message(x, y, yaw_deg=yaw_deg, at=0.0)
        self.sent.append(msg)
        self.sent_to.append(character)
        target.goal_pub.publish(msg)

    def goal_accepted(self) -> bool | None:
        """Whether the planner of the last goal's character lists it among its accepted goals (None before any goal)."""
        if not self.sent:
            return None
        return any(same_goal(self.sent[-1], msg) for msg in self.characters[self.sent_to[-1]].accepted)

    def send_push(self, force: np.ndarray, region: str, character: str = '') -> None:
        """Publish a push of `force (3,)` N in the world frame on tagged region `region` of `character`."""
        from geometry_msgs.msg import WrenchStamped
        target = self.characters[character]
        msg = WrenchStamped()
        msg.header.stamp = time_to_msg(max(target.view.end_time, 0.0))
        msg.header.frame_id = region
        msg.wrench.force.x, msg.wrench.force.y, msg.wrench.force.z = (float(v) for v in force)
        target.push_pub.publish(msg)

    def send_sim(self, command: str, frames: int = 1) -> str:
        """Call the simulator's sim/`command` service without waiting (its answer: `sim_answers`); return a status."""
        if not self.sim_control.ready(command):
            return f'no simulator offers sim/{command} on this ROS_DOMAIN_ID.'
        self.sim_calls.append((command, self.sim_control.call_async(command, frames)))
        return f'{command} sent to the simulator.'

    def sim_answers(self) -> list[str]:
        """Return the answers of the control calls that came back since the last call (one line each)."""
        done = [(command, future) for command, future in self.sim_calls if future.done()]
        self.sim_calls = [call for call in self.sim_calls if not call[1].done()]
        lines = []
        for command, future in done:
            reply = self.sim_control.reply(future.result()) if future.exception() is None else None
            lines.append(f'{command}: {reply.message}.' if reply is not None and reply.success
                         else f'{command} refused: {reply.message if reply else future.exception()}.')
        return lines

    def close(self) -> None:
        """Stop spinning and leave the graph."""
        self._running = False
        self.thread.join(timeout=2.0)
        try:
            self.executor.shutdown()
            self.node.destroy_node()
        finally:
            release_context(self.context)
