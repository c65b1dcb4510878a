"""Footskate cleanup of a stride clip (after Kovar, Schreiner and Gleicher 2002, "Footskate cleanup for
motion capture editing"): every stance foot planted at one place on the capture floor, swings re-joined to
the planted ends and lifted to a minimum clearance, legs re-solved by IK.

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

from iguana_ros.motion.dofs import BodyModel
from iguana_ros.motion.gait import leg_ik

MIN_SWING_CLEARANCE = 0.02
"""Least peak height (m) of a swinging foot marker above its planted height (the synthetic gait lifts 2 cm)."""

STANCE_TOLERANCE = 0.003
"""Largest distance (m) between a planted target and the foot marker the leg IK reaches (joint limits)."""


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
    """The stride motion of a cyclic clip `theta (N+1, n_dof)` (frame N = frame 0 moved by it)."""
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


def planted_foot_targets(feet: np.ndarray, contacts: np.ndarray, floor: np.ndarray, stride: StrideTransform,
                         min_clearance: float = MIN_SWING_CLEARANCE) -> np.ndarray:
    """Cleaned foot-marker targets `(N+1, n_feet, 3)` of a cyclic clip from its foot markers `(N+1, n_feet, 3)`,
    stance flags `(N+1, n_feet)` and each foot's marker height on the floor `(n_feet,)` m.

    Each stance is planted at its mean horizontal position, at floor height; each swing keeps its shape,
    offset smoothly from the correction at lift-off to the one at touch-down, and is raised (by a sine bump)
    to peak at least `min_clearance` above the floor. A foot that never leaves the ground stays planted.
    """
    n = len(feet) - 1
    # three strides unrolled (previous, this, next), so runs across the seam are whole
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
    peak = float(np.max(swing[:, 2])) - floor
    if peak < min_clearance:
        swing[:, 2] += (min_clearance - peak) * np.sin(np.pi * s)
    targets[lift + 1:down, k] = swing


def floor_marker_heights(model: BodyModel) -> np.ndarray:
    """Height (m) of each foot marker `(4,)` above the floor in the rest pose (soles flat on z = 0)."""
    rest_root, _ = model.skeleton.rest_pose()
    rest = np.zeros((1, model.dofs.n_dof))
    rest[0, :3] = rest_root
    return model.marker_positions(rest)[0, :4, 2]


def clean_footskate(theta: np.ndarray, contacts: np.ndarray, model: BodyModel,
                    min_clearance: float = MIN_SWING_CLEARANCE) -> np.ndarray:
    """Poses `(N+1, n_dof)` of the cyclic clip `theta (N+1, n_dof)` with its legs re-solved so that the foot
    markers follow `planted_foot_targets` (stance flags `contacts (N+1, 4)`); the trunk is unchanged."""
    theta = np.asarray(theta, dtype=float)
    contacts = np.asarray(contacts, dtype=bool)
    feet = model.marker_positions(theta)[:, :4]
    targets = planted_foot_targets(feet, contacts, floor_marker_heights(model),
                                   stride_transform(theta, model.dofs), min_clearance)
    return leg_ik(model, theta, targets, contacts, tolerance=STANCE_TOLERANCE)
