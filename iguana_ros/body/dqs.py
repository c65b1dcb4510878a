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

import numba
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
    rest_positions = np.ascontiguousarray(rest_positions, dtype=float)
    skin_bones = np.ascontiguousarray(skin_bones, dtype=np.int64)
    skin_weights = np.ascontiguousarray(skin_weights, dtype=float)
    motion = skinning_transforms(bone_rest_transforms, bone_pose_transforms)
    _check_binding(rest_positions, skin_bones, skin_weights, len(motion.rotations))
    real, dual = (np.ascontiguousarray(a) for a in to_dual_quaternions(motion))
    out = np.empty_like(rest_positions)
    if not _blend_dual_quaternions(real, dual, skin_bones, skin_weights, rest_positions, out):
        raise InputError('dual_quaternion_skinning: a node has zero total skin weight; each row of '
                         'skin_weights must sum to 1')
    return out


@numba.njit(cache=True)
def _blend_dual_quaternions(real, dual, skin_bones, skin_weights, rest_positions, out):
    """
    Blend each node's bone dual quaternions `(n_bones, 4)` and move its rest position `(n_nodes, 3)` into `out`.

    Each influence is flipped into the hemisphere of the node's dominant bone (antipodality); the blend is
    normalised by its real part, translation = 2 vec(c_dual conj(c_real)). False if a node's blend is zero.
    """
    for n in range(rest_positions.shape[0]):
        dominant = skin_bones[n, np.argmax(skin_weights[n])]
        br0 = br1 = br2 = br3 = bd0 = bd1 = bd2 = bd3 = 0.0
        for k in range(skin_bones.shape[1]):
            b = skin_bones[n, k]
            dot = (real[b, 0] * real[dominant, 0] + real[b, 1] * real[dominant, 1] + real[b, 2] * real[dominant, 2]
                   + real[b, 3] * real[dominant, 3])
            w = -skin_weights[n, k] if dot < 0.0 else skin_weights[n, k]
            br0 += w * real[b, 0]
            br1 += w * real[b, 1]
            br2 += w * real[b, 2]
            br3 += w * real[b, 3]
            bd0 += w * dual[b, 0]
            bd1 += w * dual[b, 1]
            bd2 += w * dual[b, 2]
            bd3 += w * dual[b, 3]
        norm = np.sqrt(br0 * br0 + br1 * br1 + br2 * br2 + br3 * br3)
        if norm < 1e-9:
            return False
        x, y, z, w0 = br0 / norm, br1 / norm, br2 / norm, br3 / norm
        ex, ey, ez, we = bd0 / norm, bd1 / norm, bd2 / norm, bd3 / norm
        tx = 2.0 * (w0 * ex - we * x + (y * ez - z * ey))
        ty = 2.0 * (w0 * ey - we * y + (z * ex - x * ez))
        tz = 2.0 * (w0 * ez - we * z + (x * ey - y * ex))
        px, py, pz = rest_positions[n, 0], rest_positions[n, 1], rest_positions[n, 2]
        cx = 2.0 * (y * pz - z * py)                  # v + w t + u × t with t = 2 u × v
        cy = 2.0 * (z * px - x * pz)
        cz = 2.0 * (x * py - y * px)
        out[n, 0] = px + w0 * cx + (y * cz - z * cy) + tx
        out[n, 1] = py + w0 * cy + (z * cx - x * cz) + ty
        out[n, 2] = pz + w0 * cz + (x * cy - y * cx) + tz
    return True


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
