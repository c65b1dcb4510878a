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
Vectorised rigid-body geometry.

Quaternions (x, y, z, w order, as ROS and scipy), rotation vectors, rotation matrices, intrinsic Euler angles and the
rigid (Kabsch) fit of two point sets.

The package's one rotation toolkit: code outside numba kernels rotates with these functions (the kernels inline
the few products they need). Every quaternion function broadcasts over leading axes: a quaternion array has shape
`(..., 4)`, a vector `(..., 3)`, a matrix `(..., 3, 3)`.
"""
from __future__ import annotations

import math

import numpy as np

_EPS = 1e-12


def quat_identity(shape: tuple = ()) -> np.ndarray:
    """Identity quaternions of shape `shape + (4,)`."""
    q = np.zeros(tuple(shape) + (4,))
    q[..., 3] = 1.0
    return q


def quat_normalize(q: np.ndarray) -> np.ndarray:
    """Return unit quaternions `(..., 4)`; a zero quaternion becomes the identity."""
    q = np.asarray(q, dtype=float)
    norm = np.linalg.norm(q, axis=-1, keepdims=True)
    out = np.where(norm > _EPS, q / np.maximum(norm, _EPS), 0.0)
    out[..., 3] = np.where(norm[..., 0] > _EPS, out[..., 3], 1.0)
    return out


def quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product a * b of quaternions `(..., 4)` (apply b first, then a)."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    ax, ay, az, aw = a[..., 0], a[..., 1], a[..., 2], a[..., 3]
    bx, by, bz, bw = b[..., 0], b[..., 1], b[..., 2], b[..., 3]
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = aw * bx + ax * bw + ay * bz - az * by
    out[..., 1] = aw * by - ax * bz + ay * bw + az * bx
    out[..., 2] = aw * bz + ax * by - ay * bx + az * bw
    out[..., 3] = aw * bw - ax * bx - ay * by - az * bz
    return out


def quat_conjugate(q: np.ndarray) -> np.ndarray:
    """Conjugate (the inverse of a unit quaternion) `(..., 4)`."""
    q = np.array(q, dtype=float)
    q[..., :3] *= -1.0
    return q


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross products `(..., 3)` of vectors `(..., 3)` (broadcast): np.cross's arithmetic, without its overhead."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def quat_rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate vectors `v (..., 3)` by unit quaternions `q (..., 4)`."""
    q = np.asarray(q, dtype=float)
    v = np.asarray(v, dtype=float)
    u = q[..., :3]
    w = q[..., 3:4]
    t = 2.0 * cross(u, v)
    return v + w * t + cross(u, t)


def quat_from_rotvec(rotvec: np.ndarray) -> np.ndarray:
    """Return unit quaternions `(..., 4)` from rotation vectors `(..., 3)` (axis times angle, rad)."""
    rotvec = np.asarray(rotvec, dtype=float)
    angle = np.linalg.norm(rotvec, axis=-1, keepdims=True)
    half = 0.5 * angle
    # sin(half)/angle with its Taylor series near zero
    small = angle < 1e-6
    scale = np.where(small, 0.5 - angle ** 2 / 48.0, np.sin(half) / np.where(small, 1.0, angle))
    return np.concatenate([rotvec * scale, np.cos(half)], axis=-1)


def quat_to_rotvec(q: np.ndarray) -> np.ndarray:
    """Rotation vectors `(..., 3)` (angle in [0, pi]) from unit quaternions `(..., 4)`."""
    q = quat_normalize(q)
    q = np.where(q[..., 3:4] < 0.0, -q, q)
    sin_half = np.linalg.norm(q[..., :3], axis=-1, keepdims=True)
    angle = 2.0 * np.arctan2(sin_half, q[..., 3:4])
    small = sin_half < 1e-6
    scale = np.where(small, 2.0 + angle ** 2 / 12.0, angle / np.where(small, 1.0, sin_half))
    return q[..., :3] * scale


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrices `(..., 3, 3)` from unit quaternions `(..., 4)`."""
    q = quat_normalize(q)
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    m = np.empty(q.shape[:-1] + (3, 3))
    m[..., 0, 0], m[..., 0, 1], m[..., 0, 2] = 1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)
    m[..., 1, 0], m[..., 1, 1], m[..., 1, 2] = 2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)
    m[..., 2, 0], m[..., 2, 1], m[..., 2, 2] = 2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)
    return m


def matrix_to_quat(m: np.ndarray) -> np.ndarray:
    """
    Return unit quaternions `(..., 4)` (w >= 0) from rotation matrices `(..., 3, 3)` (Markley 2008).

    The largest of (m00, m11, m22, trace) picks the best-conditioned component; the arithmetic is scipy's
    `Rotation.from_matrix` for orthogonal matrices, operation for operation, so the results equal it bitwise.
    """
    m = np.asarray(m, dtype=float)
    if m.shape == (3, 3):
        return _matrix_to_quat_one(m.tolist())
    flat = m.reshape(-1, 3, 3)
    trace = flat[:, 0, 0] + flat[:, 1, 1] + flat[:, 2, 2]
    choice = np.argmax(np.stack([flat[:, 0, 0], flat[:, 1, 1], flat[:, 2, 2], trace], axis=-1), axis=-1)
    q = np.empty((len(flat), 4))
    for i in range(3):
        rows = choice == i
        j, k = (i + 1) % 3, (i + 2) % 3
        r = flat[rows]
        q[rows, i] = 1.0 - trace[rows] + 2.0 * r[:, i, i]
        q[rows, j] = r[:, j, i] + r[:, i, j]
        q[rows, k] = r[:, k, i] + r[:, i, k]
        q[rows, 3] = r[:, k, j] - r[:, j, k]
    rows = choice == 3
    r = flat[rows]
    q[rows, 0] = r[:, 2, 1] - r[:, 1, 2]
    q[rows, 1] = r[:, 0, 2] - r[:, 2, 0]
    q[rows, 2] = r[:, 1, 0] - r[:, 0, 1]
    q[rows, 3] = 1.0 + trace[rows]
    norm = np.sqrt(q[:, 0] * q[:, 0] + q[:, 1] * q[:, 1] + q[:, 2] * q[:, 2] + q[:, 3] * q[:, 3])
    q /= norm[:, None]
    q = np.where(q[:, 3:4] < 0.0, -q, q)
    return q.reshape(m.shape[:-2] + (4,))


def _matrix_to_quat_one(r: list) -> np.ndarray:
    """`matrix_to_quat` of one matrix (nested lists): the batch's operations on Python floats, so the same bits."""
    trace = r[0][0] + r[1][1] + r[2][2]
    diagonal = (r[0][0], r[1][1], r[2][2], trace)
    i = max(range(4), key=diagonal.__getitem__)      # the first largest, as np.argmax
    if i < 3:
        j, k = (i + 1) % 3, (i + 2) % 3
        q = [0.0] * 4
        q[i] = 1.0 - trace + 2.0 * r[i][i]
        q[j] = r[j][i] + r[i][j]
        q[k] = r[k][i] + r[i][k]
        q[3] = r[k][j] - r[j][k]
    else:
        q = [r[2][1] - r[1][2], r[0][2] - r[2][0], r[1][0] - r[0][1], 1.0 + trace]
    norm = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    q = [v / norm for v in q]
    return np.array([-v for v in q] if q[3] < 0.0 else q)


_AXES = {'X': 0, 'Y': 1, 'Z': 2}


def _tait_bryan(order: str) -> tuple:
    """Axis indices (i, j, k) of an intrinsic Tait-Bryan `order` such as 'ZXY'; ValueError otherwise."""
    if len(order) != 3 or set(order) != set(_AXES):
        raise ValueError(f'Euler order must be an intrinsic Tait-Bryan sequence of X, Y, Z (e.g. ZXY), got {order!r}')
    return tuple(_AXES[a] for a in order)


def quat_from_euler(angles: np.ndarray, order: str) -> np.ndarray:
    """
    Return unit quaternions `(..., 4)` of intrinsic Euler angles `(..., 3)` rad.

    R = R_order[0] R_order[1] R_order[2].
    """
    angles = np.asarray(angles, dtype=float)
    half = 0.5 * angles
    zeros = np.zeros(angles.shape[:-1])
    q = None
    for slot, axis in enumerate(_tait_bryan(order)):
        comps = [zeros, zeros, zeros]
        comps[axis] = np.sin(half[..., slot])
        factor = np.stack(comps + [np.cos(half[..., slot])], axis=-1)
        q = factor if q is None else quat_mul(q, factor)
    return q


def matrix_to_euler(m: np.ndarray, order: str) -> np.ndarray:
    """
    Intrinsic Euler angles `(..., 3)` rad of rotation matrices `(..., 3, 3)`.

    R = R_order[0] R_order[1] R_order[2], the middle angle in [-pi/2, pi/2]; at gimbal lock (|middle| = pi/2) the last
    angle is 0.
    """
    i, j, k = _tait_bryan(order)
    m = np.asarray(m, dtype=float)
    sign = 1.0 if (j - i) % 3 == 1 else -1.0             # +1 for a cyclic order (XYZ, YZX, ZXY)
    locked = np.abs(m[..., i, k]) > 1.0 - 1e-12
    middle = np.where(locked, np.copysign(np.pi / 2, sign * m[..., i, k]),
                      np.arcsin(np.clip(sign * m[..., i, k], -1.0, 1.0)))
    first = np.where(locked, np.arctan2(sign * m[..., k, j], m[..., j, j]),
                     np.arctan2(-sign * m[..., j, k], m[..., k, k]))
    last = np.where(locked, 0.0, np.arctan2(-sign * m[..., i, j], m[..., i, i]))
    return np.stack([first, middle, last], axis=-1)


def quat_from_yaw(yaw: np.ndarray) -> np.ndarray:
    """Quaternions `(..., 4)` of rotations by `yaw` (rad) about +z."""
    yaw = np.asarray(yaw, dtype=float)
    return np.stack([np.zeros_like(yaw), np.zeros_like(yaw), np.sin(0.5 * yaw), np.cos(0.5 * yaw)],
                    axis=-1)


def yaw_of(q: np.ndarray) -> np.ndarray:
    """Heading angle (rad) about +z of the body x axis rotated by `q (..., 4)`."""
    x_axis = quat_rotate(q, np.array([1.0, 0.0, 0.0]))
    return np.arctan2(x_axis[..., 1], x_axis[..., 0])


def wrap_angle(angle: np.ndarray) -> np.ndarray:
    """Angles wrapped to [-pi, pi)."""
    return (np.asarray(angle) + np.pi) % (2.0 * np.pi) - np.pi


def planar_compose(pose: np.ndarray, delta: np.ndarray) -> np.ndarray:
    """Return planar poses `(..., 3)` (x, y, yaw) moved from `pose (..., 3)` by `delta (..., 3)` in its own frame."""
    pose, delta = np.asarray(pose, dtype=float), np.asarray(delta, dtype=float)
    c, s = np.cos(pose[..., 2]), np.sin(pose[..., 2])
    return np.stack([pose[..., 0] + c * delta[..., 0] - s * delta[..., 1],
                     pose[..., 1] + s * delta[..., 0] + c * delta[..., 1],
                     pose[..., 2] + delta[..., 2]], axis=-1)


def planar_relative(pose: np.ndarray, other: np.ndarray) -> np.ndarray:
    """Planar poses `(..., 3)` of `other (..., 3)` in the frame of `pose (..., 3)` (yaw difference wrapped)."""
    pose, other = np.asarray(pose, dtype=float), np.asarray(other, dtype=float)
    c, s = np.cos(pose[..., 2]), np.sin(pose[..., 2])
    dx, dy = other[..., 0] - pose[..., 0], other[..., 1] - pose[..., 1]
    return np.stack([c * dx + s * dy, -s * dx + c * dy, wrap_angle(other[..., 2] - pose[..., 2])], axis=-1)


def quat_between(a: np.ndarray, b: np.ndarray, min_angle: float = 1e-9) -> np.ndarray | None:
    """
    Return the smallest rotation `(4,)` taking unit vector `a (3,)` to unit vector `b (3,)`.

    None when they are less than `min_angle` rad apart (opposite vectors turn about an axis perpendicular to `a`).
    """
    q, turned = quats_between(np.asarray(a, dtype=float)[None], np.asarray(b, dtype=float)[None], min_angle)
    return q[0] if turned[0] else None


def quats_between(a: np.ndarray, b: np.ndarray, min_angle: float = 1e-9) -> tuple:
    """
    Smallest rotations `(n, 4)` taking unit vectors `a (n, 3)` to `b (n, 3)`, and whether each turns `(n,)` bool.

    A pair less than `min_angle` rad apart does not turn (its rotation is the identity); opposite vectors turn about
    an axis perpendicular to `a`.
    """
    a = np.asarray(a, dtype=float)
    axis = cross(a, b)
    sin = np.sqrt(np.einsum('ij,ij->i', axis, axis))
    angle = np.arctan2(sin, np.einsum('ij,ij->i', a, b))
    turned = angle >= min_angle
    opposite = turned & ~(sin > 0.0)
    if np.any(opposite):                                 # any axis perpendicular to a
        axis[opposite] = cross(a[opposite], np.eye(3)[np.argmin(np.abs(a[opposite]), axis=1)])
        sin[opposite] = np.sqrt(np.einsum('ij,ij->i', axis[opposite], axis[opposite]))
    q = quat_identity((len(a),))
    q[turned] = quat_from_rotvec(axis[turned] / sin[turned, None] * angle[turned, None])
    return q, turned


COLLINEAR_RATIO = 1e-6
"""`rigid_fit` takes a point set as collinear when the second singular value of its cross-covariance is at most
this fraction of the first: the roll about the line is then not determined by the points."""


def rigid_fit(source: np.ndarray, target: np.ndarray, weights: np.ndarray | None = None,
              identity_bias: float = 0.0) -> tuple:
    """
    Rotation `(3, 3)` and translation `(3,)` minimising Σ w‖R s + t − t'‖² over points `(n, 3)` (Kabsch).

    `weights (n,)` >= 0 with a positive sum (None = equal, plain means). Only proper rotations (det +1): a mirrored
    set gets the best rotation, a planar set (singular cross-covariance, det 0) its exact one, a collinear set
    (COLLINEAR_RATIO) the smallest rotation taking the source line onto the target line, coincident points the
    identity. `identity_bias` > 0 adds that fraction of the cross-covariance's norm (+1e-15) to its diagonal: a
    pull toward the identity (the terrain plane fit's 1e-6 moves its rotations by < 1e-6 rad).
    """
    source = np.asarray(source, dtype=float)
    target = np.asarray(target, dtype=float)
    if source.ndim != 2 or source.shape[1] != 3 or target.shape != source.shape or len(source) == 0:
        raise ValueError(f'rigid_fit needs two (n, 3) point sets of one shape, got {source.shape} and {target.shape}')
    if weights is None:
        cs, ct = source.mean(axis=0), target.mean(axis=0)
        cov = (target - ct).T @ (source - cs)                  # Σ (t' − mean)(s − mean)ᵀ
    else:
        w = np.asarray(weights, dtype=float)
        if w.shape != (len(source),) or np.any(w < 0.0) or not w.sum() > 0.0:
            raise ValueError(f'rigid_fit weights must be ({len(source)},) values >= 0 with a positive sum')
        w = w / w.sum()
        cs, ct = w @ source, w @ target
        cov = ((target - ct) * w[:, None]).T @ (source - cs)
    if identity_bias > 0.0:
        cov = cov + (identity_bias * np.linalg.norm(cov) + 1e-15) * np.eye(3)
    u, singular, vt = np.linalg.svd(cov)
    if singular[1] <= COLLINEAR_RATIO * singular[0]:           # collinear or coincident: the roll is free
        turn = quat_between(vt[0], u[:, 0]) if singular[0] > 0.0 else None
        rot = np.eye(3) if turn is None else quat_to_matrix(turn)
    else:
        d = -1.0 if np.linalg.det(u @ vt) < 0.0 else 1.0
        rot = u @ np.diag([1.0, 1.0, d]) @ vt
    return rot, ct - rot @ cs
