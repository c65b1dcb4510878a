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
Implicit body surface of the iguana around its rest skeleton: trunk, wedge head, tapering tail, four limbs.

The body is the set `{p : body_field(p) < 0}` with `body_field` an approximate signed distance (m): the
smooth union of a main generalised cylinder (snout to tail tip along the spine, elliptic cross-sections from
a profile table) and four limb chains (tapered elliptic capsules shoulder/hip -> elbow/knee -> wrist/ankle
-> foot -> toe tip), intersected with the half-space z >= 0 so the soles are flat on the ground.
Axes: x forward, y left, z up; rest pose only (the mesh is built there).
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numba
import numpy as np

from iguana_ros.body.skeleton import iguana_skeleton, rest_joint_positions, Skeleton

# Main body profile: (x station m, half-width ry m, half-height rz m, centre height above the spine line m).
# Fitted to the marker offsets: BACK_1..3 on the dorsal midline, SIDE_* on the flanks, HEAD on the crown,
# TAIL_1..3 on the top of the tail; the snout tip and tail tip end where the skeleton's end sites are.
MAIN_PROFILE = (
    (0.300, 0.006, 0.005, 0.002),   # snout tip (cap adds ~5 mm: surface ends at the snout end site)
    (0.285, 0.012, 0.012, 0.006),
    (0.265, 0.019, 0.021, 0.009),   # crown (HEAD marker)
    (0.240, 0.023, 0.024, 0.004),   # head joint, jaw
    (0.212, 0.025, 0.026, 0.002),   # neck
    (0.185, 0.038, 0.036, 0.004),   # shoulder girdle (BACK_1)
    (0.148, 0.046, 0.040, 0.005),   # SIDE_F*
    (0.111, 0.048, 0.040, 0.005),   # mid trunk (BACK_2)
    (0.037, 0.044, 0.037, 0.004),   # SIDE_H*
    (0.000, 0.039, 0.034, 0.004),   # pelvis (BACK_3)
    (-0.020, 0.032, 0.030, 0.001),  # vent, tail base
    (-0.115, 0.020, 0.024, 0.000),  # TAIL_1 (laterally compressed tail)
    (-0.344, 0.011, 0.014, 0.000),  # TAIL_2
    (-0.530, 0.0055, 0.007, 0.000),  # TAIL_3
    (-0.5425, 0.0025, 0.003, 0.000),  # tail tip (a few mm)
)

# Limb chains: joint names from girdle to foot, then the toe-tip offset from the foot joint (m) and
# (half-width, half-height) radii at each chain point (girdle joint, elbow/knee, wrist/ankle, foot, toe tip).
LIMB_TABLE = {
    'fl': (('shoulder_fl', 'elbow_fl', 'wrist_fl', 'foot_fl'), (0.022, 0.012, 0.0),
           ((0.012, 0.012), (0.009, 0.009), (0.007, 0.007), (0.010, 0.0048), (0.006, 0.003))),
    'fr': (('shoulder_fr', 'elbow_fr', 'wrist_fr', 'foot_fr'), (0.022, -0.012, 0.0),
           ((0.012, 0.012), (0.009, 0.009), (0.007, 0.007), (0.010, 0.0048), (0.006, 0.003))),
    'hl': (('hip_hl', 'knee_hl', 'ankle_hl', 'foot_hl'), (0.030, 0.014, 0.0),
           ((0.014, 0.014), (0.010, 0.010), (0.0075, 0.0075), (0.011, 0.005), (0.006, 0.003))),
    'hr': (('hip_hr', 'knee_hr', 'ankle_hr', 'foot_hr'), (0.030, -0.014, 0.0),
           ((0.014, 0.014), (0.010, 0.010), (0.0075, 0.0075), (0.011, 0.005), (0.006, 0.003))),
}
LIMBS = ('fl', 'fr', 'hl', 'hr')

SMOOTH_UNION = 0.006
"""Blend radius of the smooth union of limbs and trunk (shoulder/hip fillets), m."""


@dataclass(frozen=True)
class LimbChain:
    """One limb: chain points `(5, 3)` (girdle, elbow/knee, wrist/ankle, foot, toe tip), radii `(5, 2)`."""

    name: str
    points: np.ndarray
    radii: np.ndarray
    bones: tuple


@dataclass(frozen=True)
class BodyShape:
    """Main profile `(n_stations, 4)` ascending in x with spine heights `(n_stations,)`, and the limbs."""

    profile: np.ndarray
    spine_z: np.ndarray
    limbs: tuple
    skeleton: Skeleton

    @property
    def x_range(self) -> tuple:
        """(tail-tip station x, snout station x) of the main body, m."""
        return float(self.profile[0, 0]), float(self.profile[-1, 0])


@lru_cache(maxsize=1)
def iguana_shape() -> BodyShape:
    """Return the iguana body shape around the rest skeleton."""
    skeleton = iguana_skeleton()
    joints = rest_joint_positions(skeleton)
    profile = np.array(MAIN_PROFILE[::-1])  # ascending x for np.interp
    spine = _spine_polyline(skeleton, joints)
    spine_z = np.interp(profile[:, 0], spine[:, 0], spine[:, 1])
    limbs = []
    for name in LIMBS:
        bones, toe, radii = LIMB_TABLE[name]
        pts = joints[skeleton.indices(list(bones))]
        pts = np.vstack([pts, pts[-1] + np.asarray(toe)])
        limbs.append(LimbChain(name=name, points=pts, radii=np.array(radii), bones=bones))
    for arr in (profile, spine_z):
        arr.setflags(write=False)
    return BodyShape(profile=profile, spine_z=spine_z, limbs=tuple(limbs), skeleton=skeleton)


def _spine_polyline(skeleton: Skeleton, joints: np.ndarray) -> np.ndarray:
    """(x, z) `(n, 2)` of the snout-to-tail-tip joint chain, ascending x."""
    names = ['tail_tip'] + [f'tail_{i}' for i in range(8, 0, -1)] + ['pelvis'] + \
        [f'spine_{i}' for i in range(1, 6)] + ['neck', 'head', 'snout']
    pts = joints[skeleton.indices(names)]
    return pts[:, [0, 2]]


def main_cross_section(shape: BodyShape, x: np.ndarray) -> tuple:
    """Centre height, half-width and half-height `(n,)` each of the main body at stations `x (n,)`."""
    prof = shape.profile
    zc = np.interp(x, prof[:, 0], shape.spine_z + prof[:, 3])
    ry = np.interp(x, prof[:, 0], prof[:, 1])
    rz = np.interp(x, prof[:, 0], prof[:, 2])
    return zc, ry, rz


def main_field(shape: BodyShape, p: np.ndarray) -> np.ndarray:
    """Approximate signed distance `(n,)` (m) of points `p (n, 3)` to the main body (head, trunk, tail)."""
    x0, x1 = shape.x_range
    xc = np.clip(p[:, 0], x0, x1)
    zc, ry, rz = main_cross_section(shape, xc)
    rmin = np.minimum(ry, rz)
    u = (p[:, 0] - xc) / rmin  # end caps: ellipsoids of axial semi-axis min(ry, rz)
    r = np.sqrt((p[:, 1] / ry) ** 2 + ((p[:, 2] - zc) / rz) ** 2 + u ** 2)
    return (r - 1.0) * rmin


def segment_frames(a: np.ndarray, b: np.ndarray) -> tuple:
    """Return unit axis, lateral and up vectors `(n, 3)` each of segments a -> b `(n, 3)`."""
    d = b - a
    d = d / np.linalg.norm(d, axis=-1, keepdims=True)
    ref = np.where(np.abs(d[:, 2:3]) > 0.9, np.array([[1.0, 0.0, 0.0]]), np.array([[0.0, 0.0, 1.0]]))
    lat = np.cross(ref, d)
    lat /= np.linalg.norm(lat, axis=-1, keepdims=True)
    up = np.cross(d, lat)
    return d, lat, up


def limb_field(limb: LimbChain, p: np.ndarray) -> np.ndarray:
    """Approximate signed distance `(n,)` of points `p (n, 3)` to one limb (union of tapered capsules)."""
    a, b = limb.points[:-1], limb.points[1:]
    d, lat, up = segment_frames(a, b)
    length = np.linalg.norm(b - a, axis=-1)
    q = p[:, None, :] - a[None]                                   # (n, s, 3)
    t = np.clip(np.einsum('nsk,sk->ns', q, d) / length, 0.0, 1.0)
    ry = limb.radii[:-1, 0] + t * (limb.radii[1:, 0] - limb.radii[:-1, 0])
    rz = limb.radii[:-1, 1] + t * (limb.radii[1:, 1] - limb.radii[:-1, 1])
    rel = q - t[..., None] * (b - a)[None]
    rmin = np.minimum(ry, rz)
    r = np.sqrt((np.einsum('nsk,sk->ns', rel, lat) / ry) ** 2
                + (np.einsum('nsk,sk->ns', rel, up) / rz) ** 2
                + (np.einsum('nsk,sk->ns', rel, d) / rmin) ** 2)
    return np.min((r - 1.0) * rmin, axis=1)


def smooth_min(a: np.ndarray, b: np.ndarray, k: float) -> np.ndarray:
    """Polynomial smooth minimum of two fields (blend width `k`)."""
    h = np.maximum(k - np.abs(a - b), 0.0) / k
    return np.minimum(a, b) - h * h * k * 0.25


def body_field(shape: BodyShape, p: np.ndarray) -> np.ndarray:
    """Approximate signed distance `(n,)` (m, negative inside) of points `p (n, 3)` to the body surface."""
    p = np.ascontiguousarray(np.atleast_2d(np.asarray(p, dtype=float)))
    prof = shape.profile
    zc = np.ascontiguousarray(shape.spine_z + prof[:, 3])
    segs = _limb_segments(shape)
    return _field_kernel(p, np.ascontiguousarray(prof[:, 0]), zc, np.ascontiguousarray(prof[:, 1]),
                         np.ascontiguousarray(prof[:, 2]), *segs, SMOOTH_UNION)


def _limb_segments(shape: BodyShape) -> tuple:
    """Packed limb segments: starts, ends, axis, lateral, up `(s, 3)`, radii at both ends `(s, 4)`, limb `(s,)`."""
    a = np.vstack([limb.points[:-1] for limb in shape.limbs])
    b = np.vstack([limb.points[1:] for limb in shape.limbs])
    d, lat, up = segment_frames(a, b)
    radii = np.vstack([np.hstack([limb.radii[:-1], limb.radii[1:]]) for limb in shape.limbs])
    limb_id = np.concatenate([np.full(len(limb.points) - 1, i) for i, limb in enumerate(shape.limbs)])
    return a, b, d, lat, up, radii, limb_id.astype(np.int64)


@numba.njit(cache=True)
def _interp1(x: float, xs: np.ndarray, ys: np.ndarray) -> float:
    """Linear interpolation of ys over ascending xs at x (clamped)."""
    if x <= xs[0]:
        return ys[0]
    n = xs.shape[0]
    if x >= xs[n - 1]:
        return ys[n - 1]
    i = np.searchsorted(xs, x) - 1
    w = (x - xs[i]) / (xs[i + 1] - xs[i])
    return ys[i] + w * (ys[i + 1] - ys[i])


@numba.njit(cache=True)
def _field_kernel(p, px, pzc, pry, prz, sa, sb, sd, slat, sup, srad, slimb, k):  # pragma: no cover
    """Compiled body field: main cylinder, smooth union with each limb's capsules, ground cut."""
    n = p.shape[0]
    out = np.empty(n)
    n_limbs = slimb.max() + 1 if slimb.shape[0] > 0 else 0
    for i in range(n):
        x = min(max(p[i, 0], px[0]), px[px.shape[0] - 1])
        zc = _interp1(x, px, pzc)
        ry = _interp1(x, px, pry)
        rz = _interp1(x, px, prz)
        rmin = min(ry, rz)
        u = (p[i, 0] - x) / rmin
        f = (np.sqrt((p[i, 1] / ry) ** 2 + ((p[i, 2] - zc) / rz) ** 2 + u * u) - 1.0) * rmin
        for limb in range(n_limbs):
            g = 1e9
            for s in range(slimb.shape[0]):
                if slimb[s] != limb:
                    continue
                q0 = p[i, 0] - sa[s, 0]
                q1 = p[i, 1] - sa[s, 1]
                q2 = p[i, 2] - sa[s, 2]
                e0 = sb[s, 0] - sa[s, 0]
                e1 = sb[s, 1] - sa[s, 1]
                e2 = sb[s, 2] - sa[s, 2]
                length2 = e0 * e0 + e1 * e1 + e2 * e2
                t = min(max((q0 * e0 + q1 * e1 + q2 * e2) / length2, 0.0), 1.0)
                r0 = q0 - t * e0
                r1 = q1 - t * e1
                r2 = q2 - t * e2
                sry = srad[s, 0] + t * (srad[s, 2] - srad[s, 0])
                srz = srad[s, 1] + t * (srad[s, 3] - srad[s, 1])
                smin = min(sry, srz)
                cl = r0 * slat[s, 0] + r1 * slat[s, 1] + r2 * slat[s, 2]
                cu = r0 * sup[s, 0] + r1 * sup[s, 1] + r2 * sup[s, 2]
                cd = r0 * sd[s, 0] + r1 * sd[s, 1] + r2 * sd[s, 2]
                v = (np.sqrt((cl / sry) ** 2 + (cu / srz) ** 2 + (cd / smin) ** 2) - 1.0) * smin
                g = min(g, v)
            h = max(k - abs(f - g), 0.0) / k
            f = min(f, g) - h * h * k * 0.25
        out[i] = max(f, -p[i, 2])
    return out


def body_gradient(shape: BodyShape, p: np.ndarray, h: float = 1e-5) -> np.ndarray:
    """Central-difference gradient `(n, 3)` of `body_field` at points `p (n, 3)`."""
    grad = np.empty_like(p)
    for k in range(3):
        e = np.zeros(3)
        e[k] = h
        grad[:, k] = (body_field(shape, p + e) - body_field(shape, p - e)) / (2 * h)
    return grad


def project_to_surface(shape: BodyShape, p: np.ndarray, iterations: int = 6) -> np.ndarray:
    """Points `(n, 3)` moved onto the body surface by Newton steps along the field gradient."""
    p = np.array(p, dtype=float)
    for _ in range(iterations):
        f = body_field(shape, p)
        g = body_gradient(shape, p)
        p -= (f / np.maximum(np.einsum('nk,nk->n', g, g), 1e-12))[:, None] * g
    p[:, 2] = np.maximum(p[:, 2], 0.0)
    return p
