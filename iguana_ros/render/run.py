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

"""A recorded run as plain numpy arrays (ROS-free): what `iguana_ros.bag.frames` reads and `Renderer` draws."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class GoalSet:
    """Goal markers valid from `time` s on: centres `(g, 3)` m, radii `(g,)` m, RGBA `(g, 4)`."""

    time: float
    positions: np.ndarray
    radii: np.ndarray
    colors: np.ndarray


@dataclass
class CharacterFrames:
    """
    Another character of a world, frame-aligned with the followed one's `RecordedRun.times`.

    `mesh_points[i] (3*n_t, 3)` m and `mesh_colors[i] (3*n_t, 4)`: its latest mesh frame at or before frame i's time
    (None before its first); `track_times (k,)`, `track_positions (k, 3)`: its root path for the trail.
    """

    name: str
    mesh_topic: str
    mesh_points: list
    mesh_colors: list
    track_times: np.ndarray
    track_positions: np.ndarray


@dataclass
class RecordedRun:
    """
    Frames of a run: times (s from the first mesh frame), surface triangle soups, root poses, scene.

    `mesh_points[i] (3*n_t, 3)` m and `mesh_colors[i] (3*n_t, 4)` are frame i's TRIANGLE_LIST corners;
    `root_positions (n, 3)` m and `root_yaws (n,)` rad (None without odometry, then the positions are mesh
    centroids); `track_times (k,)`, `track_positions (k, 3)`: the whole root path for the trail;
    `terrain_points (3*m, 3)` / `terrain_colors (3*m, 4)`: the terrain TRIANGLE_LIST or None. In a world of several
    characters these are the followed `character`'s, and `others` holds the rest (`CharacterFrames`, by name).
    """

    times: np.ndarray
    mesh_points: list
    mesh_colors: list
    root_positions: np.ndarray
    root_yaws: np.ndarray | None
    track_times: np.ndarray
    track_positions: np.ndarray
    terrain_points: np.ndarray | None = None
    terrain_colors: np.ndarray | None = None
    goals: list = field(default_factory=list)
    mesh_topic: str = ''
    duration: float = 0.0
    notes: list = field(default_factory=list)
    """Things the reader tolerated (a damaged bag, skipped non-finite frames), one sentence each."""
    damage: str = ''
    """The bag's damage report line ('' when the bag and its metadata.yaml are sound)."""
    character: str = ''
    """Name of the followed character of a world ('' for a lone iguana)."""
    others: list = field(default_factory=list)
    """The world's other characters (`CharacterFrames`); empty for a lone iguana."""

    @property
    def n_frames(self) -> int:
        """Return number of frames."""
        return len(self.times)

    def goals_at(self, t: float) -> GoalSet | None:
        """Return the latest GoalSet whose time is <= `t` (the first one before any), or None without goals."""
        if not self.goals:
            return None
        current = self.goals[0]
        for g in self.goals:  # a handful of scene snapshots, not per-node work
            if g.time <= t:
                current = g
        return current

    def extent_points(self, max_frames: int = 60) -> np.ndarray:
        """
        Points `(m, 3)` a static view must show.

        Mesh corners of up to `max_frames` frames, the root path and the goal spheres (of every character).
        """
        step = max(1, self.n_frames // max_frames)
        parts = list(self.mesh_points[::step]) + [self.mesh_points[-1], self.track_positions]
        for other in self.others:
            parts += [p for p in other.mesh_points[::step] + other.mesh_points[-1:] if p is not None]
            parts.append(other.track_positions.reshape(-1, 3))
        for g in self.goals:
            for sign in (-1.0, 1.0):
                parts.append(g.positions + sign * g.radii[:, None])
        return np.concatenate(parts, axis=0)
