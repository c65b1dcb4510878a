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
Active degrees of freedom of the iguana skeleton.

The reduced joint parametrisation that the synthetic gait drives and the full-body IK solves for, with matrix forward
kinematics and analytic marker gradients.

15 markers cannot determine the ~100 rotational DOFs of the 34-bone skeleton, so a pose is described by
`theta (..., n_dof)` (29 values): root position (3) and yaw/pitch/roll (3); trunk yaw at three control points
(spine_1, spine_3, spine_5, linearly interpolated between) and one trunk pitch shared by the five spine
joints; neck+head yaw and pitch (split evenly between neck and head); tail yaw at three control points
(tail_1, mid-tail, tail_8) and tail pitch at two (tail_1, tail_8); per leg shoulder/hip yaw and roll and
elbow/knee roll. Every bone's local rotation is `Rz(a_z) Ry(a_y) Rx(a_x)` with Euler angles
`angles = basis @ theta` (a fixed linear map); the root entry is the world orientation of the pelvis.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numba
import numpy as np

from iguana_ros.body.markers import iguana_markers, MarkerSet
from iguana_ros.body.skeleton import iguana_skeleton, Skeleton
from iguana_ros.geometry import quat_from_euler

AXIS_Z, AXIS_Y, AXIS_X = 0, 1, 2
"""Euler-angle slots of a bone: yaw (about z) first, then pitch (y), then roll (x)."""
_LIMIT_COLUMN = {AXIS_Z: 2, AXIS_Y: 1, AXIS_X: 0}  # skeleton limits are (roll x, pitch y, yaw z)
LEGS = ('fl', 'fr', 'hl', 'hr')
"""Foot order used for leg DOFs, contacts and foot heights."""


@dataclass(frozen=True)
class ActiveDofs:
    """Reduced pose parametrisation: names `(n_dof,)`, Euler basis `(n_bones, 3, n_dof)`, bounds `(n_dof,)`."""

    names: tuple
    basis: np.ndarray
    translation: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    scale: np.ndarray

    @property
    def n_dof(self) -> int:
        """Return number of active DOFs."""
        return len(self.names)

    def index(self, name: str) -> int:
        """Index of DOF `name`; KeyError lists the DOF names."""
        try:
            return self.names.index(name)
        except ValueError:
            raise KeyError(f'no DOF {name!r}; DOFs: {", ".join(self.names)}') from None

    def angles(self, theta: np.ndarray) -> np.ndarray:
        """Euler angles `(..., n_bones, 3)` (z, y, x slots) of poses `theta (..., n_dof)`."""
        return np.einsum('bkd,...d->...bk', self.basis, np.asarray(theta, dtype=float))


def _hat(n: int, centres: tuple) -> np.ndarray:
    """Piecewise-linear interpolation weights `(n, len(centres))` of joints 0..n-1 from control points."""
    x = np.arange(n, dtype=float)
    eye = np.eye(len(centres))
    return np.stack([np.interp(x, centres, eye[k]) for k in range(len(centres))], axis=1)


def _dof_rows(skeleton: Skeleton) -> list:
    """(name, [(bone, axis, weight), ...]) of every DOF except the root translation."""
    rows = [('root_yaw', [(0, AXIS_Z, 1.0)]), ('root_pitch', [(0, AXIS_Y, 1.0)]),
            ('root_roll', [(0, AXIS_X, 1.0)])]
    spine = skeleton.indices([f'spine_{i}' for i in range(1, 6)])
    weights = _hat(5, (0.0, 2.0, 4.0))
    for k, tag in enumerate(('1', '3', '5')):
        rows.append((f'spine_yaw_{tag}', [(b, AXIS_Z, w) for b, w in zip(spine, weights[:, k]) if w > 0]))
    rows.append(('spine_pitch', [(b, AXIS_Y, 1.0) for b in spine]))
    neck = skeleton.indices(['neck', 'head'])
    rows.append(('neck_yaw', [(b, AXIS_Z, 0.5) for b in neck]))
    rows.append(('neck_pitch', [(b, AXIS_Y, 0.5) for b in neck]))
    tail = skeleton.indices([f'tail_{i}' for i in range(1, 9)])
    weights = _hat(8, (0.0, 3.5, 7.0))
    for k, tag in enumerate(('base', 'mid', 'tip')):
        rows.append((f'tail_yaw_{tag}', [(b, AXIS_Z, w) for b, w in zip(tail, weights[:, k]) if w > 0]))
    weights = _hat(8, (0.0, 7.0))
    for k, tag in enumerate(('base', 'tip')):
        rows.append((f'tail_pitch_{tag}', [(b, AXIS_Y, w) for b, w in zip(tail, weights[:, k]) if w > 0]))
    for leg in LEGS:
        upper, middle = (('shoulder', 'elbow') if leg[0] == 'f' else ('hip', 'knee'))
        rows.append((f'{upper}_yaw_{leg}', [(skeleton.index(f'{upper}_{leg}'), AXIS_Z, 1.0)]))
        rows.append((f'{upper}_roll_{leg}', [(skeleton.index(f'{upper}_{leg}'), AXIS_X, 1.0)]))
        rows.append((f'{middle}_roll_{leg}', [(skeleton.index(f'{middle}_{leg}'), AXIS_X, 1.0)]))
    return rows


@lru_cache(maxsize=1)
def iguana_active_dofs() -> ActiveDofs:
    """Return the 29 active DOFs of the iguana skeleton, bounded by its joint limits."""
    skeleton = iguana_skeleton()
    rows = _dof_rows(skeleton)
    names = ('root_x', 'root_y', 'root_z') + tuple(r[0] for r in rows)
    n = len(names)
    basis = np.zeros((skeleton.n_bones, 3, n))
    lower = np.full(n, -np.inf)
    upper = np.full(n, np.inf)
    scale = np.ones(n)
    scale[:3] = 0.1  # metres vs radians: markers move ~10x more per metre than per radian
    for d, (name, entries) in enumerate(rows, start=3):
        bound = np.inf
        for bone, axis, weight in entries:
            basis[bone, axis, d] = weight
            if bone != 0:  # the root orientation is free apart from the pitch/roll guard below
                bound = min(bound, skeleton.limits[bone, _LIMIT_COLUMN[axis], 1] / weight)
        if name in ('root_pitch', 'root_roll'):
            bound = np.pi / 2 - 1e-3
        lower[d], upper[d] = -bound, bound
    for arr in (basis, lower, upper, scale):
        arr.setflags(write=False)
    return ActiveDofs(names=names, basis=basis, translation=np.arange(3), lower=lower, upper=upper,
                      scale=scale)


def euler_matrices(angles: np.ndarray) -> np.ndarray:
    """Rotation matrices `(..., 3, 3)` of `Rz(a[...,0]) Ry(a[...,1]) Rx(a[...,2])`."""
    angles = np.asarray(angles, dtype=float)
    cz, cy, cx = np.cos(angles[..., 0]), np.cos(angles[..., 1]), np.cos(angles[..., 2])
    sz, sy, sx = np.sin(angles[..., 0]), np.sin(angles[..., 1]), np.sin(angles[..., 2])
    return np.stack([
        np.stack([cz * cy, cz * sy * sx - sz * cx, cz * sy * cx + sz * sx], axis=-1),
        np.stack([sz * cy, sz * sy * sx + cz * cx, sz * sy * cx - cz * sx], axis=-1),
        np.stack([-sy, cy * sx, cy * cx], axis=-1),
    ], axis=-2)


def euler_quaternions(angles: np.ndarray) -> np.ndarray:
    """Return unit quaternions `(..., 4)` (xyzw) of `Rz Ry Rx` from Euler angles `(..., 3)` (z, y, x slots)."""
    return quat_from_euler(angles, 'ZYX')


def local_rotations(dofs: ActiveDofs, theta: np.ndarray) -> np.ndarray:
    """Skeleton local rotations `(..., n_bones, 4)` (root entry = world root orientation) of `theta (..., n_dof)`."""
    return euler_quaternions(dofs.angles(theta))


def root_positions(dofs: ActiveDofs, theta: np.ndarray) -> np.ndarray:
    """Root (pelvis) positions `(..., 3)` of poses `theta (..., n_dof)`."""
    return np.asarray(theta, dtype=float)[..., dofs.translation]


@dataclass(frozen=True)
class KinematicState:
    """
    World joint positions, rotations and elementary-rotation axes of every bone in every frame.

    The positions are `(F, n_bones, 3)` and the rotations `(F, n_bones, 3, 3)`; the world axes `(F, n_bones, 3, 3)`
    (last axis xyz) are those of each bone's z, y and x elementary rotations.
    """

    positions: np.ndarray
    rotations: np.ndarray
    axes: np.ndarray


def forward_kinematics_dofs(skeleton: Skeleton, dofs: ActiveDofs, theta: np.ndarray) -> KinematicState:
    """Bone transforms and joint axes of poses `theta (F, n_dof)` (compiled kernel over frames and bones)."""
    theta = np.atleast_2d(np.asarray(theta, dtype=float))
    angles = np.ascontiguousarray(dofs.angles(theta))
    translation = np.ascontiguousarray(theta[:, dofs.translation])
    pos, rot, axes = _fk_kernel(np.asarray(skeleton.parents, dtype=np.int64),
                                np.ascontiguousarray(skeleton.offsets), angles, translation)
    return KinematicState(positions=pos, rotations=rot, axes=axes)


@numba.njit(cache=True)
def _fk_kernel(parents: np.ndarray, offsets: np.ndarray, angles: np.ndarray, translation: np.ndarray) -> tuple:
    """Positions `(F, B, 3)`, rotations `(F, B, 3, 3)` and elementary world axes `(F, B, 3, 3)`."""
    n_frames, n_bones = angles.shape[0], angles.shape[1]
    pos = np.empty((n_frames, n_bones, 3))
    rot = np.empty((n_frames, n_bones, 3, 3))
    axes = np.empty((n_frames, n_bones, 3, 3))
    local = np.empty((3, 3))
    after_z = np.empty((3, 3))
    parent_rot = np.empty((3, 3))
    for f in range(n_frames):
        for b in range(n_bones):
            p = parents[b]
            if p < 0:
                for i in range(3):
                    pos[f, b, i] = translation[f, i]
                    for j in range(3):
                        parent_rot[i, j] = 1.0 if i == j else 0.0
            else:
                for i in range(3):
                    pos[f, b, i] = pos[f, p, i]
                    for j in range(3):
                        parent_rot[i, j] = rot[f, p, i, j]
                        pos[f, b, i] += rot[f, p, i, j] * offsets[b, j]
            cz, sz = np.cos(angles[f, b, 0]), np.sin(angles[f, b, 0])
            cy, sy = np.cos(angles[f, b, 1]), np.sin(angles[f, b, 1])
            cx, sx = np.cos(angles[f, b, 2]), np.sin(angles[f, b, 2])
            local[0, 0], local[0, 1], local[0, 2] = cz * cy, cz * sy * sx - sz * cx, cz * sy * cx + sz * sx
            local[1, 0], local[1, 1], local[1, 2] = sz * cy, sz * sy * sx + cz * cx, sz * sy * cx - cz * sx
            local[2, 0], local[2, 1], local[2, 2] = -sy, cy * sx, cy * cx
            for i in range(3):
                # column y of parent @ Rz: parent[:, 0] * (-sz) + parent[:, 1] * cz
                after_z[i, 1] = -parent_rot[i, 0] * sz + parent_rot[i, 1] * cz
                axes[f, b, 0, i] = parent_rot[i, 2]
                axes[f, b, 1, i] = after_z[i, 1]
                for j in range(3):
                    acc = 0.0
                    for k in range(3):
                        acc += parent_rot[i, k] * local[k, j]
                    rot[f, b, i, j] = acc
                axes[f, b, 2, i] = rot[f, b, i, 0]
    return pos, rot, axes


def marker_model(state: KinematicState, markers: MarkerSet) -> np.ndarray:
    """World marker positions `(F, n_markers, 3)` of a kinematic state."""
    return (state.positions[:, markers.bones]
            + np.einsum('fmij,mj->fmi', state.rotations[:, markers.bones], markers.offsets))


def ancestor_mask(skeleton: Skeleton, markers: MarkerSet) -> np.ndarray:
    """`(n_bones, n_markers)` 1.0 where bone b is the marker's bone or one of its ancestors."""
    mask = np.zeros((skeleton.n_bones, len(markers.labels)))
    for m, bone in enumerate(markers.bones):
        b = int(bone)
        while b >= 0:
            mask[b, m] = 1.0
            b = int(skeleton.parents[b])
    mask.setflags(write=False)
    return mask


@dataclass(frozen=True)
class BodyModel:
    """Skeleton, active DOFs, marker set and the bone-to-marker ancestor mask `(n_bones, n_markers)`."""

    skeleton: Skeleton
    dofs: ActiveDofs
    markers: MarkerSet
    mask: np.ndarray

    def state(self, theta: np.ndarray) -> KinematicState:
        """Kinematic state of poses `theta (F, n_dof)`."""
        return forward_kinematics_dofs(self.skeleton, self.dofs, theta)

    def marker_positions(self, theta: np.ndarray) -> np.ndarray:
        """World marker positions `(F, n_markers, 3)` of poses `theta (F, n_dof)`."""
        return marker_model(self.state(theta), self.markers)

    def gradient(self, state: KinematicState, marker_pos: np.ndarray, grad_markers: np.ndarray) -> np.ndarray:
        """Chain rule: dE/dtheta `(F, n_dof)` from dE/d(marker positions) `(F, n_markers, 3)`."""
        moment = np.einsum('bm,fmi->fbi', self.mask, np.cross(marker_pos, grad_markers))
        force = np.einsum('bm,fmi->fbi', self.mask, grad_markers)
        torque = moment - np.cross(state.positions, force)  # sum_m (p_m - j_b) x g_m, per bone
        grad_angles = np.einsum('fbki,fbi->fbk', state.axes, torque)
        grad = np.einsum('fbk,bkd->fd', grad_angles, self.dofs.basis)
        grad[:, self.dofs.translation] += grad_markers.sum(axis=1)
        return grad

    def jacobian(self, state: KinematicState, marker_pos: np.ndarray) -> np.ndarray:
        """d(marker positions)/dtheta `(F, n_markers, 3, n_dof)`."""
        lever = marker_pos[:, None, :, :] - state.positions[:, :, None, :]  # (F, n_bones, n_markers, 3)
        jac_angles = np.cross(state.axes[:, :, :, None, :], lever[:, :, None, :, :])  # (F, b, k, m, 3)
        jac_angles *= self.mask[None, :, None, :, None]
        jac = np.einsum('fbkmi,bkd->fmid', jac_angles, self.dofs.basis)
        jac[..., self.dofs.translation] += np.eye(3)
        return jac


@lru_cache(maxsize=1)
def iguana_body_model() -> BodyModel:
    """Return the iguana's skeleton, 29 active DOFs and 15 markers."""
    skeleton, markers = iguana_skeleton(), iguana_markers()
    return BodyModel(skeleton=skeleton, dofs=iguana_active_dofs(), markers=markers,
                     mask=ancestor_mask(skeleton, markers))
