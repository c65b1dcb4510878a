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
What became of the simulated body: still on its terrain and upright, or lost (left the terrain, fell).

A run whose body is lost ends there with that outcome (library loop, simulator node, `iguana run`, `iguana
simulate`): the planner and the terrain adaptation cannot work on a body off the terrain, and figures of a body
lying on its back or thrown off the world are not a gait.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from iguana_ros.constants import FALL_HOLD, FALL_TILT, WORLD_MARGIN
from iguana_ros.geometry import quat_rotate

LEFT_TERRAIN = 'left_terrain'
"""Outcome: the root left the terrain's extent, or rose more than WORLD_MARGIN above its highest point."""

FELL = 'fell'
"""Outcome: the root stayed tilted beyond FALL_TILT for FALL_HOLD seconds."""

BODY_LOST_EXIT_CODES = {LEFT_TERRAIN: 3, FELL: 4}
"""Exit status of the simulator node, `iguana run` and `iguana simulate` when a run ends with the body lost."""


@dataclass(frozen=True)
class BodyLoss:
    """How a run's body was lost: `cause` (LEFT_TERRAIN, FELL), one line saying what happened, simulated time s."""

    cause: str
    message: str
    time: float

    @property
    def exit_code(self) -> int:
        """Exit status of a run that ended so (BODY_LOST_EXIT_CODES)."""
        return BODY_LOST_EXIT_CODES[self.cause]


class BodyWatch:
    """Watches the root pose frame by frame; `lost` says how once the body left the terrain or fell (then stays)."""

    def __init__(self, terrain) -> None:
        """Watch a body on `terrain` (a HeightField, or None: no ground, only the fall is watched)."""
        self.bounds = None if terrain is None else terrain.extent
        self.ceiling = None if terrain is None else float(np.max(terrain.heights)) + WORLD_MARGIN
        self.tilted_since: float | None = None
        self.lost: BodyLoss | None = None

    def check(self, root: np.ndarray, orientation: np.ndarray, time: float) -> BodyLoss | None:
        """Check the root position `(3,)` m and orientation xyzw `(4,)` at `time` s; the first loss, once lost."""
        if self.lost is None:
            self.lost = self._loss(np.asarray(root, float), np.asarray(orientation, float), time)
        return self.lost

    def _loss(self, root: np.ndarray, orientation: np.ndarray, time: float) -> BodyLoss | None:
        """Return the body's loss at this frame, if any."""
        off = self._off_terrain(root, time) if self.bounds is not None else None
        return off if off is not None else self._fallen(orientation, time)

    def _fallen(self, orientation: np.ndarray, time: float) -> BodyLoss | None:
        """Return a FELL loss once the root has been tilted beyond FALL_TILT for FALL_HOLD s."""
        up = quat_rotate(np.asarray(orientation, float), np.array([0.0, 0.0, 1.0]))
        if up[2] >= np.cos(FALL_TILT):
            self.tilted_since = None
            return None
        self.tilted_since = time if self.tilted_since is None else self.tilted_since
        if time - self.tilted_since < FALL_HOLD - 1e-9:
            return None
        tilt = np.degrees(np.arccos(np.clip(up[2], -1.0, 1.0)))
        return BodyLoss(FELL, f'the iguana fell: its root has been tilted {tilt:.0f} deg from upright (beyond '
                              f'{np.degrees(FALL_TILT):.0f}) since t={self.tilted_since:.2f} s', time)

    def _off_terrain(self, root: np.ndarray, time: float) -> BodyLoss | None:
        """Return a LEFT_TERRAIN loss when the root is off the terrain's extent or far above it."""
        x_min, x_max, y_min, y_max = self.bounds
        if not (x_min <= root[0] <= x_max and y_min <= root[1] <= y_max):
            return BodyLoss(LEFT_TERRAIN, f'the iguana left the terrain: its root is at ({root[0]:.2f}, {root[1]:.2f})'
                                          f' m, outside x {x_min:g}..{x_max:g}, y {y_min:g}..{y_max:g} m', time)
        if root[2] > self.ceiling:
            return BodyLoss(LEFT_TERRAIN, f'the iguana left the terrain: its root is {root[2]:.2f} m high, more than '
                                          f'{WORLD_MARGIN:g} m above the highest ground', time)
        return None
