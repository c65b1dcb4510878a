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

"""A body's nodes set down on a terrain: turned, moved and raised so the lowest node has a chosen clearance."""
from __future__ import annotations

import numpy as np

from iguana_ros.geometry import quat_from_yaw, quat_rotate


def place_on_terrain(positions: np.ndarray, terrain, clearance: float = 0.0, xy: tuple = (0.0, 0.0),
                     yaw: float = 0.0, lift_only: bool = False) -> np.ndarray:
    """
    Return nodes `(n, 3)` turned by `yaw` rad about +z, moved by `xy` (m) and set `clearance` m above `terrain`.

    The nodes are shifted vertically so the node lowest relative to `terrain` (a HeightField) is `clearance` m above it;
    with `lift_only`, they are never shifted down.
    """
    moved = quat_rotate(quat_from_yaw(yaw), np.asarray(positions, dtype=float))
    moved[:, :2] += np.asarray(xy, dtype=float)
    shift = clearance - float(np.min(moved[:, 2] - terrain.height(moved[:, :2])))
    moved[:, 2] += max(0.0, shift) if lift_only else shift
    return moved
