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
The motion graph of Section IV.

Stride clips as nodes of a complete graph, a goal-seeking policy that picks the next clip at each stride end, and root
alignment to the simulated body (end of Section VII).

Clips are duck-typed (see `iguana_ros.motion.clips.Clip`): `name`, `root_positions (n_frames, 3)`,
`local_rotations (n_frames, n_bones, 4)` in a canonical frame (first root at x = y = 0 facing +x),
`contacts (n_frames, 4)`, `root_displacement (2,)` and `heading_change` (rad) per stride.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from iguana_ros.geometry import (quat_conjugate, quat_from_rotvec, quat_from_yaw, quat_mul,
                                 quat_normalize, quat_rotate, quat_to_rotvec, wrap_angle, yaw_of)

IDLE_CLIP = 'idle'


@dataclass(frozen=True)
class PolicyParams:
    """Weights of the one-stride look-ahead policy."""

    goal_radius: float = 0.15
    """Inside this distance (m) to the goal the iguana stops (idle clip)."""
    bearing_weight: float = 0.08
    """Cost (m per rad) of the goal's bearing after the stride; favours facing the goal."""
    switch_cost: float = 0.005
    """Cost (m) of changing clip, to avoid dithering between two nearly equal choices."""


@dataclass(frozen=True)
class AlignedClip:
    """A clip placed in the world: root positions `(n_frames, 3)` and local rotations `(n_frames, n_bones, 4)`."""

    name: str
    root_positions: np.ndarray
    local_rotations: np.ndarray
    contacts: np.ndarray
    source: object


class MotionGraph:
    """Complete graph over a clip library (every clip may follow every clip, Figure 4)."""

    def __init__(self, library: dict, blend_frames: int) -> None:
        """
        Build the graph over `library` (name -> clip).

        `blend_frames` frames smooth each transition (the planner's parameter: `stages.motion_graph` gives its declared
        default).
        """
        if not library:
            raise ValueError('the motion graph needs at least one clip')
        self.clips = dict(library)
        self.blend_frames = int(blend_frames)

    @property
    def names(self) -> list[str]:
        """Clip names, the graph nodes."""
        return list(self.clips)

    def edges(self) -> list[tuple[str, str]]:
        """Every directed edge: the complete graph including self-loops (a clip can repeat)."""
        return [(a, b) for a in self.clips for b in self.clips]

    def choose_next(self, root_xy: np.ndarray, heading: float, goal_xy: np.ndarray | None,
                    current: str | None = None, params: PolicyParams = PolicyParams()) -> str:
        """Name of the next clip for a body at `root_xy (2,)` facing `heading` (rad) with goal `goal_xy (2,)`."""
        if goal_xy is None or not np.all(np.isfinite(goal_xy)):
            return self._idle_or_first()
        to_goal = np.asarray(goal_xy, float) - np.asarray(root_xy, float)
        if np.hypot(*to_goal) < params.goal_radius:
            return self._idle_or_first()
        costs = {name: self._stride_cost(clip, root_xy, heading, goal_xy, params)
                 + (params.switch_cost if current is not None and name != current else 0.0)
                 for name, clip in self.clips.items() if name != IDLE_CLIP}
        return min(costs, key=costs.get) if costs else self._idle_or_first()

    def _idle_or_first(self) -> str:
        """Return the idle clip if the library has one, else the first clip."""
        return IDLE_CLIP if IDLE_CLIP in self.clips else next(iter(self.clips))

    @staticmethod
    def _stride_cost(clip, root_xy, heading, goal_xy, params: PolicyParams) -> float:
        """Distance to goal plus weighted bearing error after playing `clip` once from the current pose."""
        c, s = np.cos(heading), np.sin(heading)
        dx, dy = np.asarray(clip.root_displacement, float)[:2]
        end_xy = np.asarray(root_xy, float) + np.array([c * dx - s * dy, s * dx + c * dy])
        end_heading = heading + float(clip.heading_change)
        to_goal = np.asarray(goal_xy, float) - end_xy
        bearing = wrap_angle(np.arctan2(to_goal[1], to_goal[0]) - end_heading)
        return float(np.hypot(*to_goal) + params.bearing_weight * abs(bearing))

    def align(self, name: str, root_xy: np.ndarray, heading: float,
              previous: AlignedClip | None = None) -> AlignedClip:
        """Place clip `name` at the simulated body's `root_xy (2,)` and `heading` (rad); blend from `previous`."""
        clip = self.clips[name]
        start_yaw = float(yaw_of(clip.local_rotations[0, 0]))
        # rotate the canonical clip so its first-frame heading becomes `heading`
        turn = quat_from_yaw(heading - start_yaw)
        rel = np.asarray(clip.root_positions, float) - np.asarray(clip.root_positions[0], float)
        root = quat_rotate(turn, rel)
        root[:, :2] += np.asarray(root_xy, float)
        root[:, 2] += float(clip.root_positions[0][2])
        local = np.array(clip.local_rotations, dtype=float, copy=True)
        local[:, 0] = quat_normalize(quat_mul(turn, local[:, 0]))
        aligned = AlignedClip(name=name, root_positions=root, local_rotations=local,
                              contacts=np.asarray(clip.contacts, bool), source=clip)
        if previous is not None and self.blend_frames > 0:
            aligned = self._blend_from(previous, aligned)
        return aligned

    def _blend_from(self, previous: AlignedClip, new: AlignedClip) -> AlignedClip:
        """Ease the first `blend_frames` frames of `new` from the last pose of `previous` (offset fade)."""
        n = min(self.blend_frames, len(new.root_positions))
        fade = 0.5 * (1.0 + np.cos(np.pi * (np.arange(n) + 1) / (n + 1)))  # 1 -> 0, exclusive ends
        root = new.root_positions.copy()
        root_offset = previous.root_positions[-1] - new.root_positions[0]
        root_offset[:2] = 0.0  # horizontal placement follows the simulated body; only heights ease
        root[:n] += fade[:, None] * root_offset
        local = new.local_rotations.copy()
        # per-bone rotation offset from the new first pose to the previous last pose, faded out
        delta = quat_mul(previous.local_rotations[-1], quat_conjugate(new.local_rotations[0]))
        delta[0] = np.array([0.0, 0.0, 0.0, 1.0])  # the root orientation follows the simulated body
        delta = np.where(delta[:, 3:4] < 0.0, -delta, delta)
        for k in range(n):
            partial = _scale_rotation(delta, fade[k])
            local[k] = quat_normalize(quat_mul(partial, local[k]))
        return AlignedClip(new.name, root, local, new.contacts, new.source)


def _scale_rotation(q: np.ndarray, t: float) -> np.ndarray:
    """Rotations `(..., 4)` scaled in angle by `t` (slerp from identity)."""
    return quat_from_rotvec(quat_to_rotvec(q) * t)
