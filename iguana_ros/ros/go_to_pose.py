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
The GoToPose action's messages (`iguana_interfaces/action/GoToPose`) and a goal task from its request.

Its result codes are the action's constants, named as the outcomes of `stages.GoalTask` (GOAL_OUTCOMES in upper
case); a request is checked like a goal_pose message (`goal_from_msg`) and its tolerances (`check_goal_tolerances`).
"""
from __future__ import annotations

from dataclasses import dataclass
import math

import numpy as np

from iguana_ros.ros.conversions import poses_to_msgs
from iguana_ros.ros.endpoints import resolve_action
from iguana_ros.ros.messages import goal_from_msg
from iguana_ros.stages import GOAL_OUTCOMES, GoalOutcome, GoalProgress, GoalTask, PlannerStage
from iguana_ros.validation import check_goal_tolerances


@dataclass(frozen=True)
class GoalResult:
    """A GoToPose result: reached, its code (see `outcome`), one-line reason, distance m and simulated s."""

    reached: bool
    code: int
    reason: str
    distance_remaining: float
    time_elapsed: float

    @property
    def outcome(self) -> str:
        """Return the code's name (one of GOAL_OUTCOMES; 'unknown' for a code this version does not know)."""
        return GOAL_OUTCOMES[self.code] if self.code < len(GOAL_OUTCOMES) else 'unknown'


def action_class():
    """Return the GoToPose action class."""
    return resolve_action('go_to_pose')[1]


def outcome_code(kind: str) -> int:
    """Return the result code of outcome `kind` (the action's constant of that name)."""
    return int(getattr(action_class().Result, kind.upper()))


def goal_task(request, stage: PlannerStage, half_extent: float) -> GoalTask:
    """Schedule a GoToPose goal `request` on `stage` (terrain of `half_extent` m); InputError with the reason if bad."""
    goal = goal_from_msg(request.pose, half_extent)
    check_goal_tolerances(request.position_tolerance, request.yaw_tolerance)
    return GoalTask(stage, goal.xy, goal.at, goal.yaw, request.position_tolerance, request.yaw_tolerance)


def feedback_msg(progress: GoalProgress, position: np.ndarray, orientation: np.ndarray):
    """Return the GoToPose feedback of `progress` with the root at `position` (3,) m, `orientation` (4,) xyzw."""
    pose = poses_to_msgs(np.asarray(position, float)[None], np.asarray(orientation, float)[None])[0]
    return action_class().Feedback(current_pose=pose, distance_remaining=_finite(progress.distance),
                                   time_elapsed=_finite(progress.time_elapsed), strides=progress.strides,
                                   status=progress.status)


def result_msg(outcome: GoalOutcome):
    """Return the GoToPose result of `outcome`."""
    return action_class().Result(reached=outcome.reached, code=outcome_code(outcome.kind), reason=outcome.reason,
                                 distance_remaining=_finite(outcome.distance),
                                 time_elapsed=_finite(outcome.time_elapsed))


def result_from_msg(msg) -> GoalResult:
    """Return the GoalResult of a GoToPose result message."""
    return GoalResult(bool(msg.reached), int(msg.code), str(msg.reason), float(msg.distance_remaining),
                      float(msg.time_elapsed))


def _finite(value: float) -> float:
    """Return `value`, or 0.0 if it is not finite (nothing non-finite goes out)."""
    return float(value) if math.isfinite(value) else 0.0
