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
The feet of the body: sole nodes and pads, and the foot probe (height above the terrain, contact, sole centroid).

The probe reads the simulated body (what `simulator_node` publishes on foot_state / foot_positions) and the reference
mesh skinned to an adapted pose; `run_metrics.metrics_of_run` computes the same figures from a library run.
"""
from __future__ import annotations

import numpy as np

from iguana_ros.body.skeleton import FEET
from iguana_ros.body.spring_lengths import SpringLengthComputer
from iguana_ros.errors import InputError


def contact_offsets(model) -> np.ndarray:
    """Per-node contact offset `(n_nodes,)` m: the model's `contact_offset` (sole pads), zeros if it has none."""
    n = len(model.rest_positions)
    offset = getattr(model, 'contact_offset', None)
    offset = np.zeros(n) if offset is None else np.asarray(offset, dtype=np.float64)
    if offset.shape != (n,) or not np.all(np.isfinite(offset)) or np.any(offset < 0):
        raise InputError('model.contact_offset must be (n_nodes,) finite offsets >= 0 m')
    return np.ascontiguousarray(offset)


def foot_groups(model) -> list[np.ndarray]:
    """Sole node indices of each foot (fl, fr, hl, hr: the model's `foot_*` tags)."""
    return [np.flatnonzero(model.node_tags[f]) for f in FEET]


def foot_heights(node_positions: np.ndarray, feet: list[np.ndarray], terrain, offset: np.ndarray) -> np.ndarray:
    """
    Return the height (m) `(n_frames, n_feet)` of each foot's lowest sole point above the terrain.

    A sole point's height is that of its node minus its contact `offset (n_nodes,)`.
    """
    idx = np.concatenate(feet)                       # every foot's sole nodes: one terrain query for all
    sole = node_positions[:, idx]
    ground = terrain.height(sole[..., :2].reshape(-1, 2)).reshape(sole.shape[:2])
    return np.minimum.reduceat(sole[..., 2] - offset[idx] - ground, _group_starts(feet), axis=1)


def _group_starts(groups: list[np.ndarray]) -> np.ndarray:
    """Offsets `(n_groups,)` of each group in their concatenation (for `ufunc.reduceat`)."""
    return np.cumsum([0] + [len(g) for g in groups[:-1]])


def foot_probe(node_positions: np.ndarray, in_contact: np.ndarray, feet: list[np.ndarray], terrain,
               offset: np.ndarray) -> tuple:
    """
    Return the foot probe of node trajectories `(n_frames, n, 3)` with contact flags `(n_frames, n)`.

    Per frame and foot, the height of the lowest sole point above the terrain `(n_frames, n_feet)` m (`foot_heights`),
    whether any sole node touches the ground `(n_frames, n_feet)` bool, and the sole centroid `(n_frames, n_feet, 3)` m.
    """
    contact = np.logical_or.reduceat(in_contact[:, np.concatenate(feet)], _group_starts(feet), axis=1)
    return foot_heights(node_positions, feet, terrain, offset), contact, group_centroids(node_positions, feet)


def group_centroids(node_positions: np.ndarray, groups: list[np.ndarray]) -> np.ndarray:
    """Centroids `(n_frames, n_groups, 3)` of node groups over node trajectories `(n_frames, n, 3)`."""
    return np.stack([node_positions[:, g].mean(axis=1) for g in groups], axis=1)


def skinned_meshes(computer: SpringLengthComputer, joints: np.ndarray, rotations: np.ndarray) -> np.ndarray:
    """
    Return the reference mesh skinned by `computer` to each pose, `(n_frames, n_nodes, 3)`.

    The poses are joint positions `(n_frames, n_bones, 3)` and bone rotations `(n_frames, n_bones, 4)`.
    """
    out = np.empty((len(joints), len(computer.rest_positions), 3))
    for f, (pos, rot) in enumerate(zip(joints, rotations)):
        out[f] = computer.skin_bones_to(rot, pos)
    return out


class FootProbe:
    """
    One frame's foot probe of a model on a terrain.

    Of the simulated body (what `simulator_node` publishes on foot_state / foot_positions) and of the reference mesh
    skinned to an adapted pose, the same figures `metrics_of_run` computes from a library run's trajectories.
    """

    def __init__(self, model, terrain) -> None:
        """Probe the feet (`foot_groups`) of `model` on `terrain`."""
        self.model = model
        self.terrain = terrain
        self.feet = foot_groups(model)
        self.offset = contact_offsets(model)
        self._skinning: SpringLengthComputer | None = None

    def body(self, positions: np.ndarray, in_contact: np.ndarray) -> tuple:
        """
        Return (heights `(4,)` m, contact `(4,)` bool, sole centroids `(4, 3)` m) of the simulated body.

        It reads nodes `(n, 3)` with contact flags `(n,)`: the simulator's `positions` and `in_contact`.
        """
        heights, contact, soles = foot_probe(np.asarray(positions, float)[None], np.asarray(in_contact, bool)[None],
                                             self.feet, self.terrain, self.offset)
        return heights[0], contact[0], soles[0]

    def reference_heights(self, joints: np.ndarray, rotations: np.ndarray) -> np.ndarray:
        """
        Return reference foot heights `(n_frames, 4)` m.

        The reference mesh skinned (DQS) to adapted poses (joint positions `(n_frames, n_bones, 3)`, bone rotations
        `(n_frames, n_bones, 4)`), by `foot_heights`.
        """
        if self._skinning is None:
            self._skinning = SpringLengthComputer(self.model)
        mesh = skinned_meshes(self._skinning, joints, rotations)
        return foot_heights(mesh, self.feet, self.terrain, self.offset)
