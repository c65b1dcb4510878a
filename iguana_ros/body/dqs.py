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
Dual-quaternion skinning (Kavan et al. 2008) and linear blend skinning of the reference mesh (Section VII).

A set of bone transforms is a pair `(rotations (n_bones, 4) xyzw, translations (n_bones, 3))`: the world
frame of each bone. The skeleton's forward kinematics gives exactly this for a pose (joint rotations and
joint positions); the bind pose is the rest pose. Each node follows the blend of its bones' motions
`pose_b * rest_b^-1`, weighted by `skin_weights (n_nodes, k)` over `skin_bones (n_nodes, k)`.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from iguana_ros.errors import InputError
from iguana_ros.geometry import quat_conjugate, quat_mul, quat_rotate


class RigidTransforms(NamedTuple):
    """World frames of bones: rotations `(n_bones, 4)` (xyzw) and translations `(n_bones, 3)` (m)."""

    rotations: np.ndarray
    translations: np.ndarray


def skinning_transforms(bone_rest_transforms: tuple, bone_pose_transforms: tuple) -> RigidTransforms:
    """Per-bone motion `pose_b * rest_b^-1` as rotations `(n_bones, 4)` and translations `(n_bones, 3)`."""
    rest_q, rest_t = (np.asarray(a, dtype=float) for a in bone_rest_transforms)
    pose_q, pose_t = (np.asarray(a, dtype=float) for a in bone_pose_transforms)
    q = quat_mul(pose_q, quat_conjugate(rest_q))
    return RigidTransforms(q, pose_t - quat_rotate(q, rest_t))


def to_dual_quaternions(transforms: tuple) -> tuple:
    """Return unit dual quaternions of rigid transforms: real parts `(n, 4)` and dual parts `(n, 4)` (xyzw)."""
    q, t = (np.asarray(a, dtype=float) for a in transforms)
    t_quat = np.concatenate([t, np.zeros(t.shape[:-1] + (1,))], axis=-1)
    return q, 0.5 * quat_mul(t_quat, q)


def _check_binding(rest_positions: np.ndarray, skin_bones: np.ndarray, skin_weights: np.ndarray,
                   n_bones: int) -> None:
    """Raise InputError unless nodes, bone indices and weights have matching, valid shapes."""
    n = rest_positions.shape[0]
    if rest_positions.shape != (n, 3):
        raise InputError(f'rest_positions must have shape (n_nodes, 3), got {rest_positions.shape}')
    if skin_bones.shape != skin_weights.shape or skin_bones.shape[0] != n or skin_bones.ndim != 2:
        raise InputError(f'skin_bones {skin_bones.shape} and skin_weights {skin_weights.shape} must both '
                         f'have shape (n_nodes={n}, k)')
    if skin_bones.size and (skin_bones.min() < 0 or skin_bones.max() >= n_bones):
        raise InputError(f'skin_bones must index the {n_bones} bone transforms, got indices '
                         f'{skin_bones.min()}..{skin_bones.max()}')


def dual_quaternion_skinning(rest_positions: np.ndarray, skin_bones: np.ndarray, skin_weights: np.ndarray,
                             bone_rest_transforms: tuple, bone_pose_transforms: tuple) -> np.ndarray:
    """
    Skinned node positions `(n_nodes, 3)` by dual-quaternion blending (antipodality fixed per node).

    `rest_positions (n_nodes, 3)`, `skin_bones (n_nodes, k)` int, `skin_weights (n_nodes, k)` (rows sum to
    1), bone transforms as `(rotations (n_bones, 4), translations (n_bones, 3))`.
    """
    rest_positions = np.asarray(rest_positions, dtype=float)
    skin_bones = np.asarray(skin_bones, dtype=np.int64)
    skin_weights = np.asarray(skin_weights, dtype=float)
    motion = skinning_transforms(bone_rest_transforms, bone_pose_transforms)
    _check_binding(rest_positions, skin_bones, skin_weights, len(motion.rotations))
    real, dual = to_dual_quaternions(motion)
    node_real = real[skin_bones]  # (n, k, 4)
    node_dual = dual[skin_bones]
    # antipodality: flip each influence into the hemisphere of the node's dominant bone
    pivot = node_real[np.arange(len(skin_bones)), np.argmax(skin_weights, axis=1)]  # (n, 4)
    sign = np.where(np.einsum('nkc,nc->nk', node_real, pivot) < 0.0, -1.0, 1.0)
    w = skin_weights * sign
    b_real = np.einsum('nk,nkc->nc', w, node_real)
    b_dual = np.einsum('nk,nkc->nc', w, node_dual)
    norm = np.linalg.norm(b_real, axis=1, keepdims=True)
    if np.any(norm < 1e-9):
        raise InputError('dual_quaternion_skinning: a node has zero total skin weight; each row of '
                         'skin_weights must sum to 1')
    c_real, c_dual = b_real / norm, b_dual / norm
    # translation = 2 * vec(c_dual * conj(c_real)), valid for a non-unit blended dual part
    v0, w0 = c_real[:, :3], c_real[:, 3:]
    ve, we = c_dual[:, :3], c_dual[:, 3:]
    translation = 2.0 * (w0 * ve - we * v0 + np.cross(v0, ve))
    return quat_rotate(c_real, rest_positions) + translation


def linear_blend_skinning(rest_positions: np.ndarray, skin_bones: np.ndarray, skin_weights: np.ndarray,
                          bone_rest_transforms: tuple, bone_pose_transforms: tuple) -> np.ndarray:
    """Skinned node positions `(n_nodes, 3)` by linear blending of the bone-transformed rest positions."""
    rest_positions = np.asarray(rest_positions, dtype=float)
    skin_bones = np.asarray(skin_bones, dtype=np.int64)
    skin_weights = np.asarray(skin_weights, dtype=float)
    motion = skinning_transforms(bone_rest_transforms, bone_pose_transforms)
    _check_binding(rest_positions, skin_bones, skin_weights, len(motion.rotations))
    q = motion.rotations[skin_bones]  # (n, k, 4)
    moved = quat_rotate(q, rest_positions[:, None, :]) + motion.translations[skin_bones]
    return np.einsum('nk,nkc->nc', skin_weights, moved)
