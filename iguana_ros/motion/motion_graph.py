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

Stride clips as nodes, an edge wherever a clip may follow another (the gait one ends in is the gait the other starts
in: the paper's complete graph for a library without gaits, Figure 4), and root alignment of a chosen clip to the
simulated body (end of Section VII). Which clip to play is the search's (`iguana_ros.motion.planning`).

Clips are duck-typed (see `iguana_ros.motion.clips.Clip`): `name`, `root_positions (n_frames, 3)`,
`local_rotations (n_frames, n_bones, 4)` in a canonical frame (first root at x = y = 0 facing +x),
`contacts (n_frames, 4)`, `root_displacement (2,)` and `heading_change` (rad) per stride, `entry` and `exit` gaits.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from iguana_ros.geometry import (quat_conjugate, quat_from_rotvec, quat_from_yaw, quat_mul,
                                 quat_normalize, quat_rotate, quat_to_rotvec, yaw_of)
from iguana_ros.motion.planning import may_follow

IDLE_CLIP = 'idle'


@dataclass(frozen=True)
class AlignedClip:
    """A clip placed in the world: root positions `(n_frames, 3)` and local rotations `(n_frames, n_bones, 4)`."""

    name: str
    root_positions: np.ndarray
    local_rotations: np.ndarray
    contacts: np.ndarray
    source: object


class MotionGraph:
    """The graph over a clip library: clip b may follow clip a where a's exit gait is b's entry gait."""

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
        """Every directed edge (a, b): clip b may follow clip a (self-loops included: a cyclic clip repeats)."""
        return [(a, b) for a in self.clips for b in self.clips if may_follow(self.clips[a], self.clips[b])]

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
