"""Vectorised rigid-body geometry: quaternions (x, y, z, w order, as ROS and scipy) and rotation vectors.

Every function broadcasts over leading axes: a quaternion array has shape `(..., 4)`, a vector `(..., 3)`.
"""
from __future__ import annotations

import numpy as np

_EPS = 1e-12


def quat_identity(shape: tuple = ()) -> np.ndarray:
    """Identity quaternions of shape `shape + (4,)`."""
    q = np.zeros(tuple(shape) + (4,))
    q[..., 3] = 1.0
    return q


def quat_normalize(q: np.ndarray) -> np.ndarray:
    """Unit quaternions `(..., 4)`; a zero quaternion becomes the identity."""
    q = np.asarray(q, dtype=float)
    norm = np.linalg.norm(q, axis=-1, keepdims=True)
    out = np.where(norm > _EPS, q / np.maximum(norm, _EPS), 0.0)
    out[..., 3] = np.where(norm[..., 0] > _EPS, out[..., 3], 1.0)
    return out


def quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product a * b of quaternions `(..., 4)` (apply b first, then a)."""
    ax, ay, az, aw = np.moveaxis(np.asarray(a, dtype=float), -1, 0)
    bx, by, bz, bw = np.moveaxis(np.asarray(b, dtype=float), -1, 0)
    return np.stack([
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    ], axis=-1)


def quat_conjugate(q: np.ndarray) -> np.ndarray:
    """Conjugate (the inverse of a unit quaternion) `(..., 4)`."""
    q = np.array(q, dtype=float)
    q[..., :3] *= -1.0
    return q


def quat_rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate vectors `v (..., 3)` by unit quaternions `q (..., 4)`."""
    q = np.asarray(q, dtype=float)
    v = np.asarray(v, dtype=float)
    u = q[..., :3]
    w = q[..., 3:4]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def quat_from_rotvec(rotvec: np.ndarray) -> np.ndarray:
    """Unit quaternions `(..., 4)` from rotation vectors `(..., 3)` (axis times angle, rad)."""
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
    x, y, z, w = np.moveaxis(quat_normalize(q), -1, 0)
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], axis=-1),
        np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], axis=-1),
        np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], axis=-1),
    ], axis=-2)


def matrix_to_quat(m: np.ndarray) -> np.ndarray:
    """Unit quaternions `(..., 4)` (w >= 0) from rotation matrices `(..., 3, 3)`."""
    from scipy.spatial.transform import Rotation

    m = np.asarray(m, dtype=float)
    flat = Rotation.from_matrix(m.reshape(-1, 3, 3)).as_quat()
    flat = np.where(flat[:, 3:4] < 0.0, -flat, flat)
    return flat.reshape(m.shape[:-2] + (4,))


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
