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
Driving a running iguana_ros system from Python, in the style of nav2_simple_commander's BasicNavigator.

    from iguana_ros.nodes.commander import IguanaCommander

    with IguanaCommander() as iguana:          # joins the ROS graph of ROS_DOMAIN_ID
        iguana.go_to(2.0, 0.5, yaw=0.0)        # returns once the planner scheduled it; IguanaError('refused: ...')
        while not iguana.is_task_complete():
            print(iguana.feedback().distance_remaining, 'm to go')
        result = iguana.result()               # reached, code, reason, distance_remaining, time_elapsed
        print(result.reached, result.outcome, result.reason)
        iguana.go_to(-1.0, 0.0)
        iguana.cancel()                        # the planner drops the goal; the iguana comes to rest
        iguana.follow_waypoints([(1.0, 0.0), (1.0, 1.0), (0.0, 1.0)])
        while not iguana.wait_until_reached(timeout=1.0):
            print('heading for waypoint', iguana.feedback().waypoint)
        sent = iguana.push('trunk_left', (0.0, -40.0, 0.0), duration=0.1)
        print(max(abs(s.linear_velocity[1]) for s in iguana.states_since(sent)))
        iguana.pause()                         # the simulator's sim/* services
        print(iguana.step(30).time)            # exactly 30 frames later, held again
        iguana.reset()                         # the body back at the scene's start
        iguana.resume()

The commander is an rclpy node of its own (its own context, so it can live beside other nodes of the same
process). A goal goes through the planner's go_to_pose action like `iguana goal`'s (`GoToPoseClient`): `feedback()`
is the action's latest feedback, `result()` its result, `cancel()` cancels it. A route goes out on the route topic
(`publish_goals`: the planner must list it on `accepted_goals`); then `feedback()` is the planner's `planner_status`
(state, current waypoint, distance, heading error), which `planner_status()` returns at any time; a push is a
WrenchStamped on `push`, its duration set first on the simulator's dynamic `push_duration`; `pause`, `resume`,
`step` and `reset` call the simulator's sim/* services (`nodes.sim_control`).
"""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass
import math

import numpy as np
import rclpy
from rclpy.parameter import Parameter
from rclpy.parameter_client import AsyncParameterClient
from rclpy.signals import SignalHandlerOptions

from iguana_ros.constants import WORLD_FRAME
from iguana_ros.errors import IguanaError
from iguana_ros.geometry import yaw_of
from iguana_ros.nodes.go_to_pose import goal_request, GoalFeedback, GoToPoseClient
from iguana_ros.nodes.goal_sender import goal_message, publish_goals, route_message, wait_spinning
from iguana_ros.nodes.sim_control import SimControlClient, SimReply
from iguana_ros.ros.conversions import odometry_to_numpy, push_msg, time_from_msg
from iguana_ros.ros.endpoints import release_context, resolve
from iguana_ros.ros.go_to_pose import GoalResult
from iguana_ros.ros.messages import planner_status_from_msg
from iguana_ros.scene import Scene
from iguana_ros.stages import PlannerStatus

SIMULATOR_NODE = 'simulator_node'
"""Name of the simulator node whose push_duration a push with a duration sets."""
HISTORY_LENGTH = 900
"""iguana_state messages kept for `states_since` (30 s of simulated time at 30 Hz)."""


@dataclass(frozen=True)
class IguanaState:
    """
    The simulated iguana's root as the last iguana_state said.

    Simulated time s, position `(3,)` m, orientation `(4,)` xyzw, linear `(3,)` m/s and angular `(3,)` rad/s velocity in
    the world frame.
    """

    time: float
    position: np.ndarray
    orientation: np.ndarray
    linear_velocity: np.ndarray
    angular_velocity: np.ndarray

    @property
    def yaw(self) -> float:
        """Heading about +z, rad."""
        return float(yaw_of(self.orientation))


@dataclass(frozen=True)
class Feedback(PlannerStatus):
    """
    The planner's latest planner_status.

    A PlannerStatus with how many goals and routes the planner has accepted, the stride end's frame and simulated time.
    """

    goals: int
    frame: int
    time: float


class IguanaCommander:
    """Send goals and pushes to a running system and read its state (see the module docstring)."""

    def __init__(self, node_name: str = 'iguana_commander', namespace: str = '',
                 goal_radius: float | None = None) -> None:
        """Join the ROS graph; `goal_radius` m (default: the scene default) decides when a goal is reached."""
        self._context = rclpy.Context()
        rclpy.init(context=self._context, signal_handler_options=SignalHandlerOptions.NO)
        self.node = rclpy.create_node(node_name, namespace=namespace, context=self._context)
        self.goal_radius = float(goal_radius if goal_radius is not None else Scene.__dataclass_fields__[
            'goal_radius'].default)
        self.goal: np.ndarray | None = None
        self._planner_decides = False
        self._request = 0
        self._feedback: Feedback | None = None
        self._state: IguanaState | None = None
        self._history: deque[IguanaState] = deque(maxlen=HISTORY_LENGTH)
        name, cls, qos = resolve('iguana_state')
        self.node.create_subscription(cls, name, self._on_state, qos)
        name, cls, qos = resolve('planner_status')
        self.node.create_subscription(cls, name, self._on_status, qos)
        name, cls, qos = resolve('push')
        self._push_pub = self.node.create_publisher(cls, name, qos)
        self._push_duration: float | None = None
        self._sim_control: SimControlClient | None = None
        self._goals = GoToPoseClient(self.node)
        self._action = False                   # whether the last goal went through the action (go_to)

    def __enter__(self) -> IguanaCommander:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """Leave the ROS graph."""
        if self._context.ok():
            self.node.destroy_node()
            release_context(self._context)

    def _on_state(self, msg) -> None:
        """Keep the latest iguana_state."""
        position, orientation, linear, angular = odometry_to_numpy(msg)
        self._state = IguanaState(time_from_msg(msg.header.stamp), position, orientation, linear, angular)
        self._history.append(self._state)

    def _on_status(self, msg) -> None:
        """Keep the latest planner_status (a malformed one is ignored)."""
        try:
            self._feedback = Feedback(**planner_status_from_msg(msg))
        except (IguanaError, TypeError):
            pass

    def _spin_until(self, condition, timeout: float, failure: str) -> None:
        """Spin until `condition()`; IguanaError(`failure`) after `timeout` wall seconds."""
        wait_spinning(condition, self.node, timeout, lambda: None, lambda: failure)

    def go_to(self, x: float, y: float, yaw: float | None = None, timeout: float = 10.0,
              frame_id: str = WORLD_FRAME, position_tolerance: float = 0.0, yaw_tolerance: float = 0.0) -> None:
        """
        Send a goal at (x, y) m through the go_to_pose action, to arrive heading `yaw` rad (None: any heading).

        Tolerances m and rad (0: the planner's). Returns once the planner scheduled it; IguanaError('refused: <reason>')
        if it refused it (e.g. off the terrain), or if no planner answers within `timeout` s.
        """
        if not all(math.isfinite(v) for v in (x, y, 0.0 if yaw is None else yaw)):
            raise IguanaError(f'goal ({x}, {y}, yaw {yaw}) is not finite')
        msg = goal_message(x, y, None if yaw is None else math.degrees(yaw), frame_id=frame_id)
        self._goals.send(goal_request(msg, position_tolerance, yaw_tolerance), timeout)
        self.goal, self._planner_decides, self._action = np.array([x, y], dtype=float), True, True

    def cancel(self, timeout: float = 10.0) -> GoalResult:
        """Cancel the goal sent last by go_to (the iguana comes to rest); return its result (CANCELED if it ran)."""
        return self._goals.cancel(timeout)

    def result(self, timeout: float = 60.0) -> GoalResult:
        """Spin until the goal sent last by go_to has a result and return it; IguanaError after `timeout` s."""
        return self._goals.result(timeout)

    def is_task_complete(self) -> bool:
        """Whether the goal sent last has ended: go_to's has a result, a route's is arrived (spins briefly)."""
        try:
            self._spin_until(lambda: False, 0.02, '')
        except IguanaError:
            pass
        return self._goals.done() if self._action else self.arrived()

    def follow_waypoints(self, waypoints: list, yaw: float | None = None, timeout: float = 10.0,
                         frame_id: str = WORLD_FRAME) -> None:
        """
        Send a route through `waypoints` ((x, y) m, passed in order), arriving at the last heading `yaw` rad.

        `yaw` None means any heading; returns once the planner accepted it. `feedback().waypoint` is the index of the
        waypoint it heads for.
        """
        points = [(float(x), float(y)) for x, y in waypoints]
        if not points or not all(math.isfinite(v) for p in points for v in p) or \
                (yaw is not None and not math.isfinite(yaw)):
            raise IguanaError(f'route {waypoints!r} (yaw {yaw}) needs one or more finite waypoints')
        self._send([route_message(points, None if yaw is None else math.degrees(yaw), frame_id=frame_id)], 'route',
                   timeout)
        self.goal, self._planner_decides, self._action = np.array(points[-1]), True, False

    def _send(self, messages: list, topic_key: str, timeout: float) -> None:
        """Publish a goal or route once the planner listens and wait until it accepted it; note its request number."""
        self._spin_until(lambda: self._feedback is not None, timeout,
                         f'no planner_status within {timeout:g} s; is planner_node running on this ROS_DOMAIN_ID?')
        before = self._feedback.goals
        publish_goals(self.node, messages, timeout=timeout, topic_key=topic_key)
        self._request = before + 1

    def feedback(self, timeout: float = 5.0) -> GoalFeedback | Feedback:
        """
        Return the go_to goal's latest action feedback, or after follow_waypoints the planner's latest status.

        Spins briefly for news; IguanaError if there has been none within `timeout` s.
        """
        if not self._action:
            return self.planner_status(timeout)
        seen = self._goals.latest
        try:
            self._spin_until(lambda: self._goals.latest is not seen, min(timeout, 0.1), '')
        except IguanaError:
            pass
        if self._goals.latest is None:
            self._spin_until(lambda: self._goals.latest is not None, timeout, f'no feedback within {timeout:g} s')
        return self._goals.latest

    def feedback_history(self) -> list[GoalFeedback]:
        """Return every action feedback of the goal sent last by go_to, in order (`feedback()` is the latest)."""
        return list(self._goals.history)

    def planner_status(self, timeout: float = 5.0) -> Feedback:
        """Return the planner's latest status (spins briefly for news); IguanaError if there has been none."""
        seen = self._feedback
        try:
            self._spin_until(lambda: self._feedback is not seen, min(timeout, 0.1), '')
        except IguanaError:
            pass
        if self._feedback is None:
            self._spin_until(lambda: self._feedback is not None, timeout,
                             f'no planner_status within {timeout:g} s; is planner_node running?')
        return self._feedback

    def distance_to_goal(self) -> float:
        """Horizontal distance m from the root to the last goal sent (nan before a goal and a state)."""
        if self.goal is None or self._state is None:
            return float('nan')
        return float(np.hypot(*(self._state.position[:2] - self.goal)))

    def arrived(self) -> bool:
        """Whether the planner reports the last goal or route done (the body at rest there, facing its heading)."""
        fb = self._feedback
        return fb is not None and fb.goals >= self._request and fb.state == 'arrived'

    def wait_until_reached(self, timeout: float) -> bool:
        """
        Spin until the last goal is reached (True) or `timeout` wall seconds pass (False).

        A go_to goal: its result says reached (False at once if it ended otherwise); a route: the planner reports it
        done (`arrived`).
        """
        if self.goal is None:
            raise IguanaError('wait_until_reached: no goal sent yet (call go_to or follow_waypoints first)')
        if self._action:
            try:
                return self._goals.result(timeout).reached
            except IguanaError:
                return False

        def reached() -> bool:
            return self.arrived() or (not self._planner_decides and self.distance_to_goal() < self.goal_radius)
        try:
            self._spin_until(reached, timeout, 'not reached')
        except IguanaError:
            return False
        return True

    def state(self, timeout: float = 5.0) -> IguanaState:
        """Return the newest `iguana_state` (spins briefly for it); IguanaError if none arrives within `timeout` s."""
        seen = self._state
        try:
            self._spin_until(lambda: self._state is not None and self._state is not seen, timeout, '')
        except IguanaError:
            if self._state is None:
                raise IguanaError(f'no iguana_state within {timeout:g} s; is the simulator running on this '
                                  'ROS_DOMAIN_ID?') from None
        return self._state

    def states_since(self, time: float) -> list[IguanaState]:
        """Every iguana_state received with simulated time ≥ `time` s (the last HISTORY_LENGTH kept), oldest first."""
        return [s for s in self._history if s.time >= time]

    def push(self, region: str, force, duration: float | None = None, timeout: float = 10.0) -> float:
        """
        Push the node group `region` (e.g. 'trunk_left') with `force` `(3,)` N in the world frame for `duration` s.

        `duration` defaults to the simulator's push_duration; the push acts from the simulator's next frame after it
        arrives.

        Returns once the simulator acknowledged it (Fast DDS may take its heartbeat period, ~3 s wall, while
        the run goes on): the simulated time s of the newest state when it was sent, for `states_since`.
        """
        if duration is not None and duration != self._push_duration:
            self._set_push_duration(float(duration), timeout)
        self._spin_until(lambda: self._push_pub.get_subscription_count() > 0, timeout,
                         f'no simulator subscribes {self._push_pub.topic_name} within {timeout:g} s')
        sent = self._state.time if self._state is not None else 0.0
        self._push_pub.publish(push_msg(force, region))
        acked = rclpy.duration.Duration(seconds=0.005)   # spin while waiting, so no iguana_state is dropped
        self._spin_until(lambda: self._push_pub.wait_for_all_acked(acked), timeout,
                         f'the simulator did not acknowledge the push within {timeout:g} s')
        return sent

    def _set_push_duration(self, duration: float, timeout: float) -> None:
        """Set the simulator's push_duration parameter; IguanaError with the simulator's reason if refused."""
        client = AsyncParameterClient(self.node, SIMULATOR_NODE)
        if not client.wait_for_services(timeout_sec=timeout):
            raise IguanaError(f'no {SIMULATOR_NODE} parameter service within {timeout:g} s')
        future = client.set_parameters([Parameter('push_duration', value=duration)])
        self._spin_until(future.done, timeout, f'{SIMULATOR_NODE} did not answer within {timeout:g} s')
        result = future.result().results[0]
        if not result.successful:
            raise IguanaError(f'push duration {duration:g} s refused by {SIMULATOR_NODE}: {result.reason}')
        self._push_duration = duration

    # ------------------------------------------------------------------------------------------ simulation control
    def _sim(self, command: str, frames: int = 1, timeout: float = 10.0) -> SimReply:
        """Call the simulator's sim/`command` service; IguanaError with its message if it refuses."""
        if self._sim_control is None:
            self._sim_control = SimControlClient(self.node)
        reply = self._sim_control.call(command, frames, timeout)
        if not reply.success:
            raise IguanaError(f'sim/{command} refused: {reply.message}')
        return reply

    def pause(self, timeout: float = 10.0) -> SimReply:
        """Hold the simulation at its current frame (the body's state is kept bit-for-bit)."""
        return self._sim('pause', timeout=timeout)

    def resume(self, timeout: float = 10.0) -> SimReply:
        """Let the simulation advance again."""
        return self._sim('resume', timeout=timeout)

    def step(self, frames: int = 1, timeout: float = 30.0) -> SimReply:
        """Advance exactly `frames` frames and hold; returns once they are simulated (frame and time reached)."""
        return self._sim('step', frames, timeout)

    def reset(self, timeout: float = 10.0) -> SimReply:
        """Put the body back at the scene's start, at rest (simulated time goes on)."""
        return self._sim('reset', timeout=timeout)
