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
A client of the planner's go_to_pose action (GoToPose) on an rclpy node, for `iguana goal` and `IguanaCommander`.

`send` returns once the planner has scheduled the goal (its first feedback) or raises IguanaError('refused: <reason>')
when the planner refused it (its result arrives at once); `feedback` and `result` are the latest of the goal sent last;
a result of a planner whose action server has gone from the graph is PLANNER_STOPPED (its clients do not hang).
`cancel_all` cancels every goal of the server (a CancelGoal request with a zero goal id and stamp).
"""
from __future__ import annotations

from dataclasses import dataclass
import math
from typing import Callable

from action_msgs.srv import CancelGoal
import numpy as np
from rclpy.action import ActionClient

from iguana_ros.errors import IguanaError
from iguana_ros.geometry import yaw_of
from iguana_ros.nodes.goal_sender import wait_spinning
from iguana_ros.ros.conversions import poses_from_msgs
from iguana_ros.ros.endpoints import resolve_action
from iguana_ros.ros.go_to_pose import GoalResult, outcome_code, result_from_msg

NO_PLANNER = 'is planner_node running on this ROS_DOMAIN_ID?'
"""The hint of an error about a planner that does not answer."""


@dataclass(frozen=True)
class GoalFeedback:
    """A GoToPose feedback: the root's position `(3,)` m and yaw rad, distance m, simulated s, strides, status."""

    position: np.ndarray
    yaw: float
    distance_remaining: float
    time_elapsed: float
    strides: int
    status: str


def feedback_from_msg(msg) -> GoalFeedback:
    """Return the GoalFeedback of a GoToPose feedback message."""
    position, orientation = poses_from_msgs([msg.current_pose])
    return GoalFeedback(position[0], float(yaw_of(orientation[0])), float(msg.distance_remaining),
                        float(msg.time_elapsed), int(msg.strides), str(msg.status))


def goal_request(pose, position_tolerance: float = 0.0, yaw_tolerance: float = 0.0):
    """Return a GoToPose goal to PoseStamped `pose` within the tolerances (m, rad; 0 = the planner's)."""
    return resolve_action('go_to_pose')[1].Goal(pose=pose, position_tolerance=float(position_tolerance),
                                                yaw_tolerance=float(yaw_tolerance))


class GoToPoseClient:
    """Send GoToPose goals from an rclpy node and follow the last one (see the module docstring)."""

    def __init__(self, node, on_feedback: Callable[[GoalFeedback], None] = lambda fb: None) -> None:
        """Create the action client on `node`; `on_feedback` is called with each feedback of the goal sent last."""
        self.node, self.on_feedback = node, on_feedback
        self.name, _ = resolve_action('go_to_pose')
        self.client = ActionClient(node, resolve_action('go_to_pose')[1], self.name)
        self.handle = None
        self._result = None
        self.latest: GoalFeedback | None = None
        self.history: list[GoalFeedback] = []        # every feedback of the goal sent last, in order
        self.outcome: GoalResult | None = None

    def wait_for_server(self, timeout: float) -> None:
        """Spin until the planner's action server is on the graph; IguanaError after `timeout` s."""
        wait_spinning(self.client.server_is_ready, self.node, timeout, lambda: None,
                      lambda: f'no planner answers the {self.name} action within {timeout:g} s; {NO_PLANNER}')

    def send(self, goal, timeout: float) -> None:
        """Send GoToPose `goal`; return once the planner scheduled it. IguanaError('refused: <reason>') if refused."""
        self.wait_for_server(timeout)
        self.handle, self._result, self.latest, self.outcome, self.history = None, None, None, None, []
        future = self.client.send_goal_async(goal, feedback_callback=self._on_feedback)
        wait_spinning(future.done, self.node, timeout, lambda: None,
                      lambda: f'the planner did not answer the goal within {timeout:g} s; {NO_PLANNER}')
        self.handle = future.result()
        if not self.handle.accepted:
            raise IguanaError('the planner did not accept the goal')
        self._result = self.handle.get_result_async()   # polled (`done`): a done callback would be a task of the
        wait_spinning(lambda: self.latest is not None or self.done(), self.node, timeout,   # executor of the moment
                      lambda: None, lambda: f'the planner did not start the goal within {timeout:g} s')
        if self.outcome is not None and self.outcome.outcome == 'refused':
            raise IguanaError(f'refused: {self.outcome.reason}')

    def _on_feedback(self, msg) -> None:
        """Keep a feedback of the goal sent last and pass it on."""
        if self.handle is None or bytes(msg.goal_id.uuid) == bytes(self.handle.goal_id.uuid):
            self.latest = feedback_from_msg(msg.feedback)
            self.history.append(self.latest)
            self.on_feedback(self.latest)

    def done(self) -> bool:
        """Whether the goal sent last has a result (a planner gone from the graph makes it PLANNER_STOPPED)."""
        if self.outcome is None and self._result is not None and self._result.done():
            self.outcome = result_from_msg(self._result.result().result)
        if self.outcome is None and self.handle is not None and not self.client.server_is_ready():
            last = self.latest
            self.outcome = GoalResult(False, outcome_code('planner_stopped'), 'the planner stopped before the goal '
                                      f'ended (its {self.name} action server is gone)',
                                      last.distance_remaining if last else math.nan,
                                      last.time_elapsed if last else 0.0)
        return self.outcome is not None

    def result(self, timeout: float) -> GoalResult:
        """Spin until the goal sent last has a result and return it; IguanaError after `timeout` s."""
        if self.handle is None:
            raise IguanaError('no goal sent yet')
        wait_spinning(self.done, self.node, timeout, lambda: None, lambda: f'no result within {timeout:g} s')
        return self.outcome

    def cancel(self, timeout: float) -> GoalResult:
        """Cancel the goal sent last (unless it has ended) and return its result; IguanaError after `timeout` s."""
        if self.handle is None:
            raise IguanaError('no goal sent yet')
        if not self.done():
            self.handle.cancel_goal_async()
        return self.result(timeout)

    def cancel_all(self, timeout: float) -> int:
        """Cancel every goal of the planner's action server; return how many it is cancelling."""
        self.wait_for_server(timeout)
        service = self.node.create_client(CancelGoal, f'{self.name}/_action/cancel_goal')
        try:
            wait_spinning(service.service_is_ready, self.node, timeout, lambda: None,
                          lambda: f'no {self.name} cancel service within {timeout:g} s; {NO_PLANNER}')
            future = service.call_async(CancelGoal.Request())     # zero goal id and stamp: every goal
            wait_spinning(future.done, self.node, timeout, lambda: None,
                          lambda: f'the planner did not answer the cancel request within {timeout:g} s')
            return len(future.result().goals_canceling)
        finally:
            self.node.destroy_client(service)
