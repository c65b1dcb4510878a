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
Desired spring lengths from the skinned reference mesh (Section VII).

The reference mesh is the soft body's own rest mesh, skinned to the terrain-adapted pose by dual-quaternion
skinning; the desired length `l_d` of every spring (Equation 2) is the distance between its two skinned nodes.
"""
from __future__ import annotations

import numpy as np

from iguana_ros.body.dqs import dual_quaternion_skinning, RigidTransforms
from iguana_ros.body.skeleton import forward_kinematics, Skeleton
from iguana_ros.errors import IguanaError, InputError


def desired_spring_lengths(skinned_positions: np.ndarray, springs: np.ndarray) -> np.ndarray:
    """Distances `(n_springs,)` between the skinned nodes `(n_nodes, 3)` joined by `springs (n_springs, 2)`."""
    skinned_positions = np.asarray(skinned_positions, dtype=float)
    springs = np.asarray(springs, dtype=np.int64)
    if springs.ndim != 2 or springs.shape[1] != 2:
        raise InputError(f'springs must have shape (n_springs, 2), got {springs.shape}')
    if springs.size and (springs.min() < 0 or springs.max() >= len(skinned_positions)):
        raise InputError(f'springs index nodes {springs.min()}..{springs.max()} but the mesh has '
                         f'{len(skinned_positions)} nodes')
    d = skinned_positions[springs[:, 1]] - skinned_positions[springs[:, 0]]
    return np.sqrt(np.einsum('sc,sc->s', d, d))


def rest_bone_transforms(skeleton: Skeleton) -> RigidTransforms:
    """Bind-pose bone frames of the skeleton's rest pose: rotations `(n_bones, 4)`, positions `(n_bones, 3)`."""
    root, local = skeleton.rest_pose()
    positions, rotations = forward_kinematics(skeleton, root, local)
    return RigidTransforms(rotations, positions)


class SpringLengthComputer:
    """
    Binds a soft-body model so that each frame's pose -> desired spring lengths is one vectorised pass.

    The model needs `rest_positions (n_nodes, 3)`, `springs (n_springs, 2)`, `skin_bones (n_nodes, k)`,
    `skin_weights (n_nodes, k)` and `skeleton`; the bind pose is the skeleton's rest pose.
    """

    def __init__(self, model) -> None:
        self.skeleton = model.skeleton
        self.rest_positions = np.ascontiguousarray(model.rest_positions, dtype=float)
        self.springs = np.ascontiguousarray(model.springs, dtype=np.int64)
        self.skin_bones = np.ascontiguousarray(model.skin_bones, dtype=np.int64)
        self.skin_weights = np.ascontiguousarray(model.skin_weights, dtype=float)
        self.rest_transforms = rest_bone_transforms(self.skeleton)

    @property
    def n_springs(self) -> int:
        """Return number of springs (length of each output vector)."""
        return len(self.springs)

    def load_kernels(self) -> None:
        """Compute the rest pose's lengths once: a process's first frame then loads no compiled code."""
        self.lengths_from_bones(self.rest_transforms.rotations, self.rest_transforms.translations)

    def skin_bones_to(self, bone_rotations: np.ndarray, bone_positions: np.ndarray) -> np.ndarray:
        """Reference-mesh nodes `(n_nodes, 3)` skinned to world bone frames `(n_bones, 4)`, `(n_bones, 3)`."""
        expected = (self.skeleton.n_bones,)
        if bone_rotations.shape != expected + (4,) or bone_positions.shape != expected + (3,):
            raise InputError(f'bone transforms must have shapes {expected + (4,)} and {expected + (3,)}, '
                             f'got {bone_rotations.shape} and {bone_positions.shape}')
        return dual_quaternion_skinning(self.rest_positions, self.skin_bones, self.skin_weights,
                                        self.rest_transforms, (bone_rotations, bone_positions))

    def skin_pose(self, root_position: np.ndarray, local_rotations: np.ndarray) -> np.ndarray:
        """Reference-mesh nodes `(n_nodes, 3)` skinned to a pose (root `(3,)`, local rotations `(n_bones, 4)`)."""
        positions, rotations = forward_kinematics(self.skeleton, root_position, local_rotations)
        return self.skin_bones_to(rotations, positions)

    def lengths_from_bones(self, bone_rotations: np.ndarray, bone_positions: np.ndarray) -> np.ndarray:
        """Desired spring lengths `(n_springs,)` for world bone frames `(n_bones, 4)`, `(n_bones, 3)`."""
        lengths = desired_spring_lengths(self.skin_bones_to(np.asarray(bone_rotations, dtype=float),
                                                            np.asarray(bone_positions, dtype=float)),
                                         self.springs)
        if not np.all(np.isfinite(lengths)):
            raise IguanaError('desired spring lengths are not finite; the pose contains NaN or Inf')
        return lengths

    def __call__(self, root_position: np.ndarray, local_rotations: np.ndarray) -> np.ndarray:
        """Desired spring lengths `(n_springs,)` for a pose (root `(3,)`, local rotations `(n_bones, 4)`)."""
        positions, rotations = forward_kinematics(self.skeleton, root_position, local_rotations)
        return self.lengths_from_bones(rotations, positions)
