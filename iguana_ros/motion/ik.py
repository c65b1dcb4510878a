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
Full-body IK (Section IV): sparse markers -> root pose and active joint angles for every frame.

One nonlinear least-squares problem over the whole take, solved with L-BFGS-B (the paper's L-BFGS, with the
joint limits as bounds): marker misfit of the visible markers (a gap, NaN, drops out; foot-marker gaps are
bridged in world space at a lower weight, a planted foot stays put), a temporal
smoothness prior on joint accelerations, and a weak pull toward the rest pose. The gradient is analytic
(`BodyModel.gradient`), the forward kinematics vectorised over frames.

L-BFGS alone converges slowly on this stiff problem, so it starts from a per-frame fit: a rigid fit of the
trunk markers gives the root, then bounded Levenberg-Marquardt steps (batched over frames, analytic
Jacobian) fit each frame; a DOF none of whose markers is visible in a frame is interpolated across the gap.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize

from iguana_ros.errors import InputError
from iguana_ros.geometry import rigid_fit
from iguana_ros.motion.dofs import BodyModel, iguana_body_model, marker_model

FOOT_MARKERS = ('FOOT_FL', 'FOOT_FR', 'FOOT_HL', 'FOOT_HR')
"""End-effector markers whose gaps are bridged in world space before the fit."""
TRUNK_MARKERS = ('BACK_1', 'BACK_2', 'BACK_3', 'SIDE_FL', 'SIDE_HL', 'SIDE_FR', 'SIDE_HR')
"""Markers of the rigid trunk fit that starts the IK."""


@dataclass(frozen=True)
class IKSettings:
    """Weights (as standard deviations) and stopping rule of the IK objective."""

    marker_std: float = 0.002
    """Expected marker misfit, m."""
    accel_std: float = 0.2
    """Expected joint acceleration, rad per frame^2 (translation: x 0.1 m/rad)."""
    rest_std: float = 1.0
    """Spread of joint angles about the rest pose, rad (a weak prior for barely observed directions)."""
    max_iterations: int = 300
    frame_iterations: int = 25
    """Levenberg-Marquardt iterations of the per-frame start."""
    fill_feet: bool = True
    """Bridge foot-marker gaps by interpolating the marker in the world (a planted foot stays put), weighted
    as a sample `filled_std_factor` times less certain."""
    filled_std_factor: float = 3.0


@dataclass(frozen=True)
class IKResult:
    """Poses `theta (F, n_dof)`, per-sample marker residual `(F, n_markers)` m (NaN where missing)."""

    theta: np.ndarray
    residual: np.ndarray
    iterations: int
    converged: bool

    @property
    def marker_rms_mm(self) -> float:
        """RMS marker residual over the visible samples, mm."""
        return float(np.sqrt(np.nanmean(self.residual ** 2)) * 1e3)

    def per_marker_rms_mm(self) -> np.ndarray:
        """RMS residual of each marker `(n_markers,)`, mm."""
        return np.sqrt(np.nanmean(self.residual ** 2, axis=0)) * 1e3


def _frame_fits(reference: np.ndarray, observed: np.ndarray, weight: np.ndarray, valid: np.ndarray) -> tuple:
    """
    Rotations `(F, 3, 3)` and translations `(F, 3)` with observed ~ R @ reference + t (weighted), frame by frame.

    Frames not `valid (F,)` get the identity (the caller interpolates them).
    """
    rot = np.tile(np.eye(3), (len(observed), 1, 1))
    trans = np.zeros((len(observed), 3))
    for f in np.flatnonzero(valid):              # one 3x3 SVD per frame of a take
        rot[f], trans[f] = rigid_fit(reference, observed[f], weight[f])
    return rot, trans


def _fill_frames(values: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Linear interpolation over frames `(F, k)` where `valid (F,)` is False."""
    frames = np.arange(len(values))
    out = values.copy()
    for k in range(values.shape[1]):
        out[:, k] = np.interp(frames, frames[valid], values[valid, k])
    return out


def initial_guess(model: BodyModel, observed: np.ndarray) -> np.ndarray:
    """Poses `(F, n_dof)`: root from a rigid fit of the trunk markers, joints at rest."""
    d = model.dofs
    idx = np.array([model.markers.index(label) for label in TRUNK_MARKERS])
    rest = np.zeros((1, d.n_dof))
    rest[0, :3] = model.skeleton.offsets[0]
    reference = model.marker_positions(rest)[0, idx]
    obs = observed[:, idx]
    visible = ~np.isnan(obs).any(axis=-1)
    valid = visible.sum(axis=1) >= 3
    if valid.sum() < 1:
        raise InputError('IK needs at least 3 visible trunk markers in some frame '
                         f'({", ".join(TRUNK_MARKERS)})')
    rot, trans = _frame_fits(reference, np.nan_to_num(obs), visible.astype(float), valid)
    yaw = np.unwrap(np.arctan2(rot[:, 1, 0], rot[:, 0, 0]))
    pitch = -np.arcsin(np.clip(rot[:, 2, 0], -1.0, 1.0))
    roll = np.arctan2(rot[:, 2, 1], rot[:, 2, 2])
    root = trans + np.einsum('fij,j->fi', rot, rest[0, :3])
    pose = _fill_frames(np.column_stack([root, yaw, pitch, roll]), valid)
    pose[:, 3] = _fill_frames(np.unwrap(pose[:, 3])[:, None], np.ones(len(pose), bool))[:, 0]
    theta = np.zeros((observed.shape[0], d.n_dof))
    theta[:, :6] = pose  # root_x, root_y, root_z, root_yaw, root_pitch, root_roll
    return theta


def _bridge_gaps(track: np.ndarray) -> tuple:
    """Marker track `(F, 3)` with inner NaN runs linearly interpolated, and the `(F,)` mask of filled samples."""
    seen = ~np.isnan(track).any(axis=-1)
    if seen.sum() < 2:
        return track, np.zeros(len(track), dtype=bool)
    frames = np.arange(len(track))
    inner = (frames > frames[seen][0]) & (frames < frames[seen][-1]) & ~seen
    out = track.copy()
    for k in range(3):
        out[inner, k] = np.interp(frames[inner], frames[seen], track[seen, k])
    return out, inner


def observation_weights(model: BodyModel, observed: np.ndarray, settings: IKSettings) -> tuple:
    """(targets `(F, n_markers, 3)` without NaN, weights `(F, n_markers)` in 1/m^2; 0 = not observed)."""
    target = np.array(observed, dtype=float, copy=True)
    weight = (~np.isnan(target).any(axis=-1)) / settings.marker_std ** 2
    if settings.fill_feet:
        for label in FOOT_MARKERS:
            m = model.markers.index(label)
            target[:, m], filled = _bridge_gaps(target[:, m])
            weight[filled, m] = 1.0 / (settings.filled_std_factor * settings.marker_std) ** 2
    return np.nan_to_num(target), weight


def _influence(model: BodyModel) -> np.ndarray:
    """`(n_dof, n_markers)` True where a DOF moves a marker."""
    moves = np.einsum('bkd,bm->dm', np.abs(model.dofs.basis), model.mask) > 0
    moves[model.dofs.translation] = True
    return moves


def fill_unobserved(model: BodyModel, theta: np.ndarray, visible: np.ndarray) -> np.ndarray:
    """Poses `(F, n_dof)` with each DOF interpolated over the frames where none of its markers is visible."""
    seen = (visible.astype(float) @ _influence(model).T.astype(float)) > 0  # (F, n_dof)
    out = theta.copy()
    frames = np.arange(len(theta))
    for k in np.flatnonzero(~seen.all(axis=0) & seen.any(axis=0)):
        out[:, k] = np.interp(frames, frames[seen[:, k]], theta[seen[:, k], k])
    return out


def fit_frames(model: BodyModel, target: np.ndarray, weight: np.ndarray, theta: np.ndarray,
               settings: IKSettings) -> np.ndarray:
    """
    Return the per-frame bounded Levenberg-Marquardt fit `(F, n_dof)` of marker targets `(F, n_markers, 3)`.

    The targets have weights `(F, n_markers)` (see `observation_weights`).
    """
    d = model.dofs
    visible = weight > 0
    root_w = np.sqrt(weight)
    w_rest = np.ones(d.n_dof) / settings.rest_std ** 2
    w_rest[:6] = 0.0
    n_frames = len(theta)

    def cost(th: np.ndarray) -> tuple:
        state = model.state(th)
        pos = marker_model(state, model.markers)
        diff = root_w[..., None] * (pos - target)
        value = 0.5 * (np.sum(diff ** 2, axis=(1, 2)) + np.sum(w_rest * th ** 2, axis=1))
        return value, state, pos, diff

    damping = np.full(n_frames, 1e-3)
    current, state, pos, diff = cost(theta)
    for _ in range(settings.frame_iterations):
        jac = (model.jacobian(state, pos) * root_w[..., None, None]).reshape(n_frames, -1, d.n_dof)
        hess = np.einsum('fri,frj->fij', jac, jac) + np.diag(w_rest)
        grad = np.einsum('fri,fr->fi', jac, diff.reshape(n_frames, -1)) + w_rest * theta
        diag = np.einsum('fii->fi', hess)
        system = hess + damping[:, None, None] * np.eye(d.n_dof) * (diag[:, None, :] + 1e-9)
        step = np.linalg.solve(system, -grad[..., None])[..., 0]
        trial = np.clip(theta + step, d.lower, d.upper)
        value, trial_state, trial_pos, trial_diff = cost(trial)
        better = value <= current
        theta = np.where(better[:, None], trial, theta)
        current = np.where(better, value, current)
        damping = np.clip(np.where(better, damping * 0.3, damping * 10.0), 1e-9, 1e9)
        state, pos, diff = cost(theta)[1:]
    return fill_unobserved(model, theta, visible)


def _second_difference(x: np.ndarray) -> np.ndarray:
    """Second differences along frames `(F-2, n)`."""
    return x[2:] - 2.0 * x[1:-1] + x[:-2]


def _second_difference_adjoint(a: np.ndarray, n_frames: int) -> np.ndarray:
    """Adjoint of `_second_difference`: `(F, n)` from `(F-2, n)`."""
    out = np.zeros((n_frames, a.shape[1]))
    out[2:] += a
    out[1:-1] -= 2.0 * a
    out[:-2] += a
    return out


def solve_ik(observed: np.ndarray, model: BodyModel | None = None, settings: IKSettings = IKSettings(),
             init: np.ndarray | None = None) -> IKResult:
    """Fit the active DOFs to markers `observed (F, n_markers, 3)` (m, NaN = missing) over the whole take."""
    model = model or iguana_body_model()
    d = model.dofs
    observed = np.asarray(observed, dtype=float)
    if observed.ndim != 3 or observed.shape[1:] != (len(model.markers.labels), 3):
        raise InputError(f'IK needs markers of shape (frames, {len(model.markers.labels)}, 3), '
                         f'got {observed.shape}')
    n_frames = observed.shape[0]
    target, weight = observation_weights(model, observed, settings)
    if init is None:
        theta0 = fit_frames(model, target, weight, initial_guess(model, observed), settings)
    else:
        theta0 = np.asarray(init, dtype=float)
    joints = np.ones(d.n_dof, dtype=bool)
    joints[:6] = False
    w_marker = weight[..., None]
    w_accel = 1.0 / (settings.accel_std * d.scale) ** 2
    w_rest = joints / settings.rest_std ** 2

    def objective(x: np.ndarray) -> tuple:
        theta = x.reshape(n_frames, d.n_dof) * d.scale
        state = model.state(theta)
        pos = marker_model(state, model.markers)
        diff = pos - target
        g_markers = w_marker * diff
        acc = _second_difference(theta)
        energy = 0.5 * (np.sum(g_markers * diff) + np.sum(w_accel * acc ** 2) + np.sum(w_rest * theta ** 2))
        grad = (model.gradient(state, pos, g_markers)
                + _second_difference_adjoint(w_accel * acc, n_frames) + w_rest * theta)
        return energy, (grad * d.scale).ravel()

    lower = np.tile(np.where(np.isfinite(d.lower), d.lower / d.scale, -np.inf), n_frames)
    upper = np.tile(np.where(np.isfinite(d.upper), d.upper / d.scale, np.inf), n_frames)
    bounds = [(lo if np.isfinite(lo) else None, hi if np.isfinite(hi) else None) for lo, hi in zip(lower, upper)]
    x0 = np.clip((theta0 / d.scale).ravel(), lower, upper)
    result = minimize(objective, x0, jac=True, method='L-BFGS-B', bounds=bounds,
                      options={'maxiter': settings.max_iterations, 'maxfun': 2 * settings.max_iterations,
                               'ftol': 1e-13, 'gtol': 1e-7, 'maxcor': 20})
    theta = result.x.reshape(n_frames, d.n_dof) * d.scale
    if not np.all(np.isfinite(theta)):
        raise InputError('IK diverged (non-finite pose); check the marker data for outliers')
    residual = np.linalg.norm(model.marker_positions(theta) - observed, axis=-1)
    return IKResult(theta=theta, residual=residual, iterations=int(result.nit), converged=bool(result.success))
