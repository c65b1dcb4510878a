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

"""Colours and triangle meshes for the markers (ROS-free): the iguana's surface and the terrain."""
from __future__ import annotations

import numpy as np

from iguana_ros.terrain.heightfield import HeightField

IGUANA_GREEN = (0.30, 0.62, 0.25, 1.0)
"""RGBA of the iguana's skin."""

CONTACT_COLOR = (0.95, 0.55, 0.15, 1.0)
"""RGBA of surface nodes touching the ground."""

TERRAIN_LOW, TERRAIN_HIGH = np.array([0.55, 0.47, 0.36, 1.0]), np.array([0.80, 0.74, 0.60, 1.0])
"""RGBA of the terrain's lowest and highest points."""


def body_colors(n_nodes: int, in_contact: np.ndarray | None = None) -> np.ndarray:
    """Per-node RGBA `(n_nodes, 4)`: green skin, orange where a node touches the ground."""
    colors = np.tile(np.asarray(IGUANA_GREEN, np.float32), (n_nodes, 1))
    if in_contact is not None:
        colors[np.asarray(in_contact, bool)] = CONTACT_COLOR
    return colors


def terrain_mesh(terrain: HeightField, center: tuple = (0.0, 0.0), half_size: float = 5.0,
                 max_cells: int = 100) -> tuple:
    """Vertices `(n, 3)`, triangles `(m, 3)` and RGBA `(n, 4)` of the terrain over a square window."""
    x0, x1, y0, y1 = terrain.extent
    n = int(np.clip(np.ceil(2 * half_size / max(terrain.spacing, 1e-6)), 1, max_cells)) + 1
    xs = np.linspace(max(center[0] - half_size, x0), min(center[0] + half_size, x1), n)
    ys = np.linspace(max(center[1] - half_size, y0), min(center[1] + half_size, y1), n)
    gx, gy = np.meshgrid(xs, ys, indexing='ij')
    xy = np.stack([gx.ravel(), gy.ravel()], axis=1)
    z = terrain.height(xy)
    vertices = np.column_stack([xy, z])
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    triangles = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])  # counter-clockwise from above
    span = np.ptp(z)
    t = (z - z.min()) / span if span > 0 else np.full_like(z, 0.5)
    colors = TERRAIN_LOW + t[:, None] * (TERRAIN_HIGH - TERRAIN_LOW)
    return vertices, triangles, colors.astype(np.float32)
