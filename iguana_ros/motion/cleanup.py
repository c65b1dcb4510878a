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
Footskate cleanup of a stride clip, after Kovar, Schreiner and Gleicher 2002.

As in "Footskate cleanup for motion capture editing", every stance foot is planted at one place on the capture floor
with its sole flat, swings are re-joined to the planted ends and lifted to a minimum clearance, and the legs are
re-solved by IK.

Planting works on the foot's pivot, the wrist or ankle joint: the leg IK (three DOFs per leg) puts the pivot
on its planted target, and `flat_soles` then turns the wrist/ankle bone so the sole lies flat with one fixed
heading through the stance. The pivot's position does not depend on that bone's own rotation, so the
flattening keeps it planted, and the whole foot (skinned to wrist/ankle and foot bones) stands still. Without
it the sole tilts with the leg (only one or two of a foot's 7-10 sole nodes touched the ground in simulation)
and the foot rolls and slides on that point, as the paper observes of its stiffer model (Section VIII-D).

A sparse, noisy capture (Section IV) leaves the reference's stance feet skating (measured on the shipped
clips: 1.4-3.1 cm per stance) and a few millimetres above or below the floor, each foot by its own offset.
A soft body that tracks such a reference is told to slide its stance feet and to stand on legs of unequal
length; a stiff one then rests on three feet (the fourth hangs) and slides the rest. The cleanup works on a
cyclic clip (frame N = frame 0 moved by the stride), so a stance or swing that runs across the seam is
treated as one.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from iguana_ros.body.skeleton import FOOT_PIVOTS, forward_kinematics, Skeleton
from iguana_ros.geometry import (quat_conjugate, quat_from_rotvec, quat_from_yaw, quat_mul, quat_normalize,
                                 quat_to_rotvec, yaw_of)
from iguana_ros.motion.dofs import BodyModel
from iguana_ros.motion.gait import leg_ik


MIN_SWING_CLEARANCE = 0.02
"""Least peak height (m) of a swinging foot pivot above its planted height (the synthetic gait lifts 2 cm)."""

STANCE_TOLERANCE = 0.002
"""Largest distance (m) between a planted target and the foot pivot the leg IK reaches (joint limits)."""

TAIL_TIP_HEIGHT = -0.01
"""Height (m) of the tail-tip joint over the floor in every frame of a cleaned clip: the tail rests on the
ground and is pressed into it (its lower surface ~5 mm below the joint), so it bears weight. The model's
centre of mass lies ~4.7 cm behind each diagonal support line of the trot (docs/RESULTS.md, "Why the hind feet did not
lift"); a tail that carries ~4 N closes the support triangle so the swing hind foot carries nothing."""

PIVOT_TAIL_TIP_HEIGHT = 0.02
"""Height (m) of the tail-tip joint over the floor in a turn on the spot: the tail is held just off the ground, so it
does not catch on a step edge as it sweeps sideways. Measured over 5 + 3 pivots of the medium body (2 Hz, balanced):
on level ground -38 / +33 deg per stride at -0.01 m and at +0.02 m (-28 / +27 at +0.04 m); on a field of 3-5 cm steps
-16..+12 deg (the tail caught, some strides turned the wrong way) at -0.01 m, -12..-33 / +30..+36 at +0.02 m."""

TRIM_ROUNDS = 4
"""Frames a stance may lose at each end where the leg cannot reach its planted point."""


@dataclass(frozen=True)
class StrideTransform:
    """The planar rigid motion of one stride: a point p of frame 0 is at `target + R (p - origin)` in frame N."""

    origin: np.ndarray      # (2,) m, root xy of frame 0
    target: np.ndarray      # (2,) m, root xy of frame N
    turn: float             # rad, heading change

    def apply(self, points: np.ndarray, times: int = 1) -> np.ndarray:
        """Points `(..., 3)` moved by the stride `times` times (negative = backwards); z unchanged."""
        out = np.array(points, dtype=float, copy=True)
        for _ in range(abs(times)):
            c, s = np.cos(self.turn), np.sin(self.turn)
            if times > 0:
                d = out[..., :2] - self.origin
                out[..., 0], out[..., 1] = (self.target[0] + c * d[..., 0] - s * d[..., 1],
                                            self.target[1] + s * d[..., 0] + c * d[..., 1])
            else:
                d = out[..., :2] - self.target
                out[..., 0], out[..., 1] = (self.origin[0] + c * d[..., 0] + s * d[..., 1],
                                            self.origin[1] - s * d[..., 0] + c * d[..., 1])
        return out


def stride_transform(theta: np.ndarray, dofs) -> StrideTransform:
    """Return the stride motion of a cyclic clip `theta (N+1, n_dof)` (frame N = frame 0 moved by it)."""
    ix, iy, iyaw = dofs.index('root_x'), dofs.index('root_y'), dofs.index('root_yaw')
    return StrideTransform(origin=theta[0, [ix, iy]].astype(float), target=theta[-1, [ix, iy]].astype(float),
                           turn=float(theta[-1, iyaw] - theta[0, iyaw]))


def _runs(flags: np.ndarray) -> list[tuple[int, int]]:
    """(first, last) index of every run of True in `flags (n,)`."""
    edges = np.diff(np.concatenate([[0], flags.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1))


def _smoothstep(s: np.ndarray) -> np.ndarray:
    """3s² − 2s³ on [0, 1]."""
    return s * s * (3.0 - 2.0 * s)


def planted_foot_targets(feet: np.ndarray, contacts: np.ndarray, floor: np.ndarray, stride: StrideTransform | None,
                         min_clearance: float = MIN_SWING_CLEARANCE) -> np.ndarray:
    """
    Return cleaned foot-marker targets `(N+1, n_feet, 3)` of a clip from its markers, stance flags and floor heights.

    The inputs are the foot markers `(N+1, n_feet, 3)`, the stance flags `(N+1, n_feet)` and each foot's marker height
    on the floor `(n_feet,)` m; `stride` is the motion of a cyclic clip (None: a window of a take, whose first and last
    stance and swing are cut by its ends).

    Each stance is planted at its mean horizontal position, at floor height; each swing keeps its shape,
    offset smoothly from the correction at lift-off to the one at touch-down, kept above the floor, and raised
    (by the smallest sine bump that does it) to peak at `min_clearance` above the floor if it is lower. A foot
    that never leaves the ground stays planted.
    """
    n = len(feet) - 1
    if stride is None:
        ext, flags = np.array(feet, dtype=float), np.asarray(contacts, bool)
    else:  # three strides unrolled (previous, this, next), so runs across the seam are whole
        ext = np.concatenate([stride.apply(feet[:n], -1), feet[:n], stride.apply(feet[:n], 1)])
        flags = np.concatenate([contacts[:n]] * 3)
    targets = ext.copy()
    for k in range(feet.shape[1]):
        stance_runs = _runs(flags[:, k])
        for a, b in stance_runs:
            targets[a:b + 1, k, :2] = ext[a:b + 1, k, :2].mean(axis=0)
            targets[a:b + 1, k, 2] = floor[k]
        for (_, lift), (down, _) in zip(stance_runs[:-1], stance_runs[1:]):
            _clean_swing(ext, targets, k, lift, down, floor[k], min_clearance)
    if stride is None:
        return targets
    middle = targets[n:2 * n + 1]
    return np.concatenate([middle[:n], stride.apply(middle[:1], 1)])


def _clean_swing(ext: np.ndarray, targets: np.ndarray, k: int, lift: int, down: int, floor: float,
                 min_clearance: float) -> None:
    """Re-join swing frames lift+1..down-1 of foot `k` to the planted ends and lift it to `min_clearance`."""
    if down - lift < 2:
        return
    s = (np.arange(lift + 1, down) - lift) / (down - lift)
    e = _smoothstep(s)[:, None]
    start_fix = targets[lift, k] - ext[lift, k]
    end_fix = targets[down, k] - ext[down, k]
    swing = ext[lift + 1:down, k] + (1.0 - e) * start_fix + e * end_fix
    swing[:, 2] = np.maximum(swing[:, 2], floor)            # a re-joined swing never dips below the floor
    lift_above = swing[:, 2] - floor
    if np.max(lift_above) < min_clearance:                  # the smallest sine bump that peaks at the minimum
        bump = np.sin(np.pi * s)
        swing[:, 2] += np.min((min_clearance - lift_above) / bump) * bump
    targets[lift + 1:down, k] = swing


def foot_pivots(model: BodyModel, theta: np.ndarray) -> np.ndarray:
    """World positions `(F, 4, 3)` of the wrist/ankle joints (FOOT_PIVOTS) of poses `theta (F, n_dof)`."""
    return model.state(theta).positions[:, model.skeleton.indices(list(FOOT_PIVOTS))]


def floor_pivot_heights(model: BodyModel) -> np.ndarray:
    """Height (m) of each foot pivot `(4,)` above the floor in the rest pose (soles flat on z = 0)."""
    rest_root, _ = model.skeleton.rest_pose()
    rest = np.zeros((1, model.dofs.n_dof))
    rest[0, :3] = rest_root
    return foot_pivots(model, rest)[0, :, 2]


def clean_footskate(theta: np.ndarray, contacts: np.ndarray, model: BodyModel,
                    min_clearance: float = MIN_SWING_CLEARANCE, cyclic: bool = True) -> tuple:
    """
    Return (poses `(N+1, n_dof)`, stance flags `(N+1, 4)`) of the clip `theta (N+1, n_dof)` with its legs re-solved.

    The legs are re-solved so that the foot pivots follow `planted_foot_targets` of `contacts (N+1, 4)`; the trunk is
    unchanged. A cyclic clip (frame N = frame 0 moved by the stride) is cleaned across its seam; otherwise (`cyclic`
    False) the poses are a window of a take whose ends the caller crops off.

    A stance frame at the start or end of a stance in which the leg cannot reach the planted point (a leg
    stretched to lift-off: the captured foot rolled there) becomes a swing frame, up to TRIM_ROUNDS times.
    """
    theta = np.asarray(theta, dtype=float)
    contacts = np.array(contacts, dtype=bool, copy=True)
    floor = floor_pivot_heights(model)
    stride = stride_transform(theta, model.dofs) if cyclic else None
    pivots = foot_pivots(model, theta)
    for _ in range(TRIM_ROUNDS):
        targets = planted_foot_targets(pivots, contacts, floor, stride, min_clearance)
        solved = leg_ik(model, theta, targets, contacts, tolerance=np.inf, effectors=foot_pivots)
        miss = contacts & (np.linalg.norm(targets - foot_pivots(model, solved), axis=-1) > STANCE_TOLERANCE)
        ends = miss & _stance_ends(contacts, cyclic)
        if not ends.any():
            break
        contacts[ends] = False
        if cyclic:
            contacts[-1] = contacts[0]
    solved = leg_ik(model, theta, planted_foot_targets(pivots, contacts, floor, stride, min_clearance), contacts,
                    tolerance=STANCE_TOLERANCE, effectors=foot_pivots)
    return solved, contacts


def _stance_ends(contacts: np.ndarray, cyclic: bool = True) -> np.ndarray:
    """Return flags `(N+1, n_feet)` of the first and last frame of every stance of a clip (seam-aware if `cyclic`)."""
    if not cyclic:
        padded = np.pad(contacts, ((1, 1), (0, 0)), mode='edge')
        return contacts & ~(padded[:-2] & padded[2:])
    body = contacts[:-1]
    before = np.roll(body, 1, axis=0)
    after = np.roll(body, -1, axis=0)
    ends = body & ~(before & after)
    return np.concatenate([ends, ends[:1]])


def support_tail(theta: np.ndarray, model: BodyModel, tip_height: float = TAIL_TIP_HEIGHT,
                 iterations: int = 8) -> np.ndarray:
    """
    Return poses `(F, n_dof)` with `tail_pitch_base` set per frame so the tail-tip joint is at `tip_height` m.

    Secant iterations on the one DOF find it; the tail's sway and the rest of the pose are unchanged.
    """
    theta = np.array(theta, dtype=float, copy=True)
    dof, tip = model.dofs.index('tail_pitch_base'), model.skeleton.index('tail_tip')

    def error(th):
        return model.state(th).positions[:, tip, 2] - tip_height
    eps = 1e-4
    for _ in range(iterations):
        e = error(theta)
        bumped = theta.copy()
        bumped[:, dof] += eps
        slope = (error(bumped) - e) / eps
        theta[:, dof] -= np.where(np.abs(slope) > 1e-6, e / np.where(slope == 0, 1.0, slope), 0.0)
    lo, hi = model.dofs.lower[dof], model.dofs.upper[dof]
    theta[:, dof] = np.clip(theta[:, dof], lo, hi)
    return theta


def _slerp(a: np.ndarray, b: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Rotations `(n, 4)` from `a (4,)` to `b (4,)` at fractions `t (n,)`."""
    delta = quat_mul(quat_conjugate(a), b)
    delta = np.where(delta[3] < 0.0, -delta, delta)
    return quat_normalize(quat_mul(a, quat_from_rotvec(quat_to_rotvec(delta)[None, :] * t[:, None])))


def flat_sole_rotations(world: np.ndarray, contacts: np.ndarray, turn: float | None) -> np.ndarray:
    """
    World rotations `(N+1, 4)` of one foot's pivot bone in a clip.

    Flat (heading only, the stance's mean heading) in stance, and in swing the original rotations `world (N+1, 4)`
    corrected by a rotation eased from the lift-off correction to the touch-down one. `contacts (N+1,)`, `turn` the
    stride's heading change (rad) of a cyclic clip, None for a clip that is not (a transition: its first and last
    stance are flattened as far as the clip holds them).
    """
    n = len(world) - 1
    if turn is None:
        ext, flags = np.array(world, dtype=float), np.asarray(contacts, bool)
    else:
        spin = [quat_from_yaw(np.full(n, k * turn)) for k in (-1, 0, 1)]
        ext = np.concatenate([quat_mul(spin[k], world[:n]) for k in range(3)])
        flags = np.concatenate([contacts[:n]] * 3)
    out = ext.copy()
    runs = _runs(flags)
    for a, b in runs:
        heading = np.unwrap(yaw_of(ext[a:b + 1]))
        out[a:b + 1] = quat_from_yaw(np.full(b - a + 1, heading.mean()))
    for (_, lift), (down, _) in zip(runs[:-1], runs[1:]):
        if down - lift < 2:
            continue
        fix_lift = quat_mul(out[lift], quat_conjugate(ext[lift]))
        fix_down = quat_mul(out[down], quat_conjugate(ext[down]))
        s = _smoothstep((np.arange(lift + 1, down) - lift) / (down - lift))
        out[lift + 1:down] = quat_mul(_slerp(fix_lift, fix_down, s), ext[lift + 1:down])
    if turn is None:
        return out
    middle = out[n:2 * n]
    return np.concatenate([middle, quat_mul(quat_from_yaw(turn), middle[:1])])


def flat_soles(skeleton: Skeleton, root_positions: np.ndarray, local_rotations: np.ndarray,
               contacts: np.ndarray, turn: float | None) -> np.ndarray:
    """
    Return local rotations `(N+1, n_bones, 4)` of a clip with every stance sole flat on the floor.

    See `flat_sole_rotations` (`turn` None for a clip that is not cyclic). Only the FOOT_PIVOTS bones change, so no
    joint position moves but the feet's.
    """
    local = np.array(local_rotations, dtype=float, copy=True)
    contacts = np.asarray(contacts, dtype=bool)
    _, world = forward_kinematics(skeleton, root_positions, local)
    for k, bone in enumerate(skeleton.indices(list(FOOT_PIVOTS))):
        if not contacts[:, k].any():
            continue
        flat = flat_sole_rotations(world[:, bone], contacts[:, k], turn)
        parent = skeleton.parents[bone]
        local[:, bone] = quat_normalize(quat_mul(quat_conjugate(world[:, parent]), flat))
    return local
