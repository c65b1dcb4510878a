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
The root (pelvis) frame of the simulated soft body, from a rigid fit of the pelvis-region nodes.

The paper synchronises the motion graph's root with the simulated iguana (end of Section VII); the soft body
has no skeleton, so its root is the best rigid transform of the nodes skinned mostly to the pelvis and the
first trunk segments, applied to the rest pelvis frame.
"""
from __future__ import annotations

import numpy as np

from iguana_ros.geometry import matrix_to_quat, rigid_fit, yaw_of

ROOT_REGION_BONES = ('pelvis', 'spine_1', 'spine_2', 'hip_hl', 'hip_hr', 'tail_1')
"""Bones whose dominantly-skinned nodes define the root region."""


SINGULAR_INERTIA = 1e-9
"""A group's inertia whose determinant is below this fraction of (trace / 3)³ is singular (collinear nodes): its ω is
the least-norm one."""


def rigid_velocity(positions: np.ndarray, velocities: np.ndarray, mass: np.ndarray) -> tuple:
    """
    Linear `(3,)` and angular `(3,)` velocity of a node group `(n, 3)` with masses `(n,)`.

    The mass-weighted mean velocity and the ω whose rigid rotation about the group's centre has the group's angular
    momentum.
    """
    m = mass / mass.sum()
    com, vcom = m @ positions, m @ velocities
    r, v = positions - com, velocities - vcom
    mr = r * mass[:, None]
    spin = mr.T @ v                                  # Σ m r vᵀ: its antisymmetric part is the angular momentum
    momentum = np.array([spin[1, 2] - spin[2, 1], spin[2, 0] - spin[0, 2], spin[0, 1] - spin[1, 0]])
    second = mr.T @ r                                # Σ m r rᵀ
    inertia = np.trace(second) * np.eye(3) - second
    if np.linalg.det(inertia) > SINGULAR_INERTIA * (np.trace(inertia) / 3.0) ** 3:
        return vcom, np.linalg.solve(inertia, momentum)
    return vcom, np.linalg.lstsq(inertia, momentum, rcond=None)[0]   # collinear or coincident: least-norm ω


class RootTracker:
    """Estimates the root pose of a soft-body iguana from its node positions `(n_nodes, 3)`."""

    def __init__(self, model) -> None:
        """Select the root-region nodes of `model` (an IguanaModel)."""
        skeleton = model.skeleton
        dominant = model.skin_bones[np.arange(model.n_nodes), np.argmax(model.skin_weights, axis=1)]
        region = np.isin(dominant, skeleton.indices(list(ROOT_REGION_BONES)))
        if region.sum() < 4:
            raise ValueError('the root region has fewer than 4 nodes; cannot fit a root frame')
        self.nodes = np.flatnonzero(region)
        self.rest = np.asarray(model.rest_positions, float)[self.nodes]
        self.weights = np.asarray(model.node_mass, float)[self.nodes]
        self.rest_root = np.asarray(skeleton.offsets[0], float)  # pelvis joint at rest, world frame

    def root_pose(self, positions: np.ndarray) -> tuple:
        """(root position (3,), root orientation xyzw (4,)) for node positions `(n_nodes, 3)`."""
        rot, trans = rigid_fit(self.rest, np.asarray(positions, float)[self.nodes], self.weights)
        return rot @ self.rest_root + trans, matrix_to_quat(rot)

    def root_twist(self, positions: np.ndarray, velocities: np.ndarray) -> tuple:
        """
        Return the root region's (linear `(3,)` m/s, angular `(3,)` rad/s) velocity for node positions and velocities.

        Positions and velocities are `(n_nodes, 3)`. The linear velocity is that of the region's centre of mass, the
        angular one that of its momentum about that centre.
        """
        return rigid_velocity(np.asarray(positions, float)[self.nodes], np.asarray(velocities, float)[self.nodes],
                              self.weights)

    def heading(self, positions: np.ndarray) -> float:
        """Yaw (rad) of the root for node positions `(n_nodes, 3)`."""
        return float(yaw_of(self.root_pose(positions)[1]))
