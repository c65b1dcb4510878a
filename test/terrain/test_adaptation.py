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

"""Terrain adaptation (Section VI): plane fitting, residual fitting, flat-ground no-op, warm starts."""
import dataclasses

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from iguana_ros.body.skeleton import FEET, FOOT_PIVOTS, forward_kinematics, iguana_skeleton
from iguana_ros.errors import InputError
from iguana_ros.geometry import quat_from_rotvec, quat_rotate, quat_to_matrix
from iguana_ros.terrain import adaptation as ad
from iguana_ros.terrain.heightfield import HeightField

N_FRAMES = 12


@pytest.fixture(scope='module')
def skel():
    return iguana_skeleton()


def _clip_pose(skel, frame, seed=0):
    """Return a smooth trot-like clip pose at `frame` (30 Hz): oscillating joints, drooping tail, feet on z >= 0."""
    rng = np.random.default_rng(seed)
    amp = rng.normal(scale=0.15, size=(skel.n_bones, 3))
    amp[0] = 0.0
    phase = rng.uniform(0, 2 * np.pi, size=(skel.n_bones, 3))
    t = frame / 30.0
    rotvec = amp * np.sin(2 * np.pi * 1.5 * t + phase)
    rotvec[skel.index('tail_1'), 1] -= 0.12
    local = quat_from_rotvec(rotvec)
    local[0] = quat_from_rotvec(np.array([0.0, 0.0, 0.3]))
    root = skel.rest_pose()[0] + np.array([0.3 * t, 0.1 * t, 0.0])
    positions = forward_kinematics(skel, root, local)[0]
    root[2] -= positions[skel.indices(list(FEET)), 2].min()
    return root, local


def _stance(skel, clip):
    """Stance flags `(4,)` of a clip pose: feet within 1 cm of the capture floor."""
    return ad.residual_heights_of(skel, *clip)[0] < 0.01


def _check_adapted(skel, terrain, clip, adapted, foot_tol=0.004, depth_tol=1e-4):
    """
    Stance feet (their pivots) as far above the terrain as above the capture floor in the clip, within `foot_tol`.

    No joint deeper than `depth_tol`, but the feet's (the sole alignment turns a stance foot about its pivot, moving the
    foot joint, an end site in the sole, up to 2.6 mm into a 15 deg slope) and the tail's, which a weight-bearing clip
    presses in as deep as its tip's residual height (at most max_tail_press).
    """
    feet_h, tail_h = ad.residual_heights_of(skel, *clip)
    p = adapted.joint_positions
    pivots = skel.indices(list(FOOT_PIVOTS))
    clip_pivots = forward_kinematics(skel, *clip)[0][pivots]
    normal = terrain.normal(p[pivots, :2])
    above = (p[pivots, 2] - terrain.height(p[pivots, :2])) * normal[:, 2]      # distance along the normal
    foot_err = (above - clip_pivots[:, 2])[_stance(skel, clip)]
    assert foot_err.size and np.max(np.abs(foot_err)) < foot_tol
    tail = np.array([name.startswith('tail_') for name in skel.names])
    press = min(0.0, max(tail_h, -ad.AdaptationSettings().max_tail_press))
    depth = p[:, 2] - terrain.height(p[:, :2])
    foot = np.isin(np.arange(skel.n_bones), skel.indices(list(FEET)))
    assert np.min(depth[~tail & ~foot]) > -depth_tol
    assert np.min(depth[foot]) > -0.003
    assert np.min(depth[tail]) > press - 2e-3
    np.testing.assert_allclose(forward_kinematics(skel, adapted.root_position, adapted.local_rotations)[0],
                               p, atol=1e-12)


def test_flat_ground_is_an_exact_no_op(skel):
    root, local = _clip_pose(skel, 5)
    out = ad.adapt_pose(skel, HeightField.flat(), root, local)
    assert np.array_equal(out.root_position, root) and np.array_equal(out.local_rotations, local)
    raised = ad.adapt_pose(skel, HeightField.flat(0.25), root, local)
    np.testing.assert_allclose(raised.root_position - root, [0.0, 0.0, 0.25], atol=1e-15)
    assert np.array_equal(raised.local_rotations, local)
    # the plane fit itself is the identity on flat ground
    feet_h, _ = ad.residual_heights_of(skel, root, local)
    fit = ad.plane_fit(skel, HeightField.flat(), root, local, feet_h)
    np.testing.assert_allclose(fit.rotation, np.eye(3), atol=1e-9)
    np.testing.assert_allclose(fit.root_position, root, atol=1e-9)
    np.testing.assert_allclose(fit.local_rotations, local, atol=1e-9)


@pytest.mark.parametrize('slope_deg', [12.0, -15.0])
def test_tilted_plane_feet_on_targets_and_body_tilted(skel, slope_deg):
    terrain = HeightField.tilted_plane(slope_deg, direction=(1.0, 0.3))
    state = ad.AdaptationState()
    up = np.array([0.0, 0.0, 1.0])
    normal = terrain.normal(np.zeros(2))
    for frame in range(0, N_FRAMES, 3):
        clip = _clip_pose(skel, frame)
        out = ad.adapt_pose(skel, terrain, *clip, stance=_stance(skel, clip), state=state)
        _check_adapted(skel, terrain, clip, out)
        feet_h, _ = ad.residual_heights_of(skel, *clip)
        fit = ad.plane_fit(skel, terrain, *clip, feet_h)
        tilted_up = fit.rotation @ up
        assert np.degrees(np.arccos(tilted_up @ normal)) < 3.0  # plane fit follows the slope


def test_hills_feet_tail_and_no_penetration(skel):
    terrain = HeightField.hills(amplitude=0.03, wavelength=0.9, seed=7, extent=10.0)  # gentler than the hills scene
    state = ad.AdaptationState()
    tail = skel.index(ad.TAIL_TIP_BONE)
    for frame in range(N_FRAMES):
        clip = _clip_pose(skel, frame)
        stance = _stance(skel, clip)
        out = ad.adapt_pose(skel, terrain, *clip, stance=stance, state=state)
        _check_adapted(skel, terrain, clip, out)
        tip = out.joint_positions[tail]
        assert abs(tip[2] - terrain.height(tip[:2]) - ad.residual_heights_of(skel, *clip)[1]) < 0.002
        assert np.linalg.norm(tip - out.tail_target) < 0.005
        feet_h, tail_h = ad.residual_heights_of(skel, *clip)
        fit = ad.plane_fit(skel, terrain, *clip, feet_h)
        fitted = ad.residual_fit(skel, terrain, fit.root_position, fit.local_rotations, feet_h, tail_h,
                                 stance=stance)
        feet = fitted.joint_positions[skel.indices(list(FEET))]      # residual fitting's effectors
        np.testing.assert_allclose(feet[stance], fitted.foot_targets[stance], atol=0.002)


def test_residual_fit_lifts_a_penetrating_tail_and_respects_joint_limits(skel):
    terrain = HeightField.hills(amplitude=0.06, wavelength=0.6, seed=1, extent=5.0)
    root, local = _clip_pose(skel, 0, seed=2)
    local[skel.index('tail_2')] = quat_from_rotvec(np.array([0.0, -0.35, 0.0]))  # tail dug into the ground
    feet_h, tail_h = ad.residual_heights_of(skel, root, local)
    fit = ad.plane_fit(skel, terrain, root, local, feet_h)
    before = forward_kinematics(skel, fit.root_position, fit.local_rotations)[0]
    assert np.min(before[:, 2] - terrain.height(before[:, :2])) < -0.01
    out = ad.residual_fit(skel, terrain, fit.root_position, fit.local_rotations, feet_h, tail_h,
                          stance=_stance(skel, (root, local)))
    _check_adapted(skel, terrain, (root, local), out)
    moved = ad.ik_bones(skel)
    rotvec = Rotation.from_quat(out.local_rotations[moved]).as_rotvec()
    start = Rotation.from_quat(fit.local_rotations[moved]).as_rotvec()
    lo = np.minimum(skel.limits[moved, :, 0], start) - 1e-9
    hi = np.maximum(skel.limits[moved, :, 1], start) + 1e-9
    assert np.all((rotvec >= lo) & (rotvec <= hi))
    untouched = np.setdiff1d(np.arange(1, skel.n_bones), moved)
    np.testing.assert_array_equal(out.local_rotations[untouched], fit.local_rotations[untouched])


def test_warm_start_needs_fewer_evaluations(skel):
    """A pose slid slowly over hills (the paper's Figure 10) converges faster from last frame's solution."""
    terrain = HeightField.hills(amplitude=0.03, wavelength=0.9, seed=7, extent=10.0)
    root, local = _clip_pose(skel, 4)
    warm_state, warm, cold = ad.AdaptationState(), 0, 0
    for frame in range(N_FRAMES):
        clip = (root + np.array([0.005, 0.002, 0.0]) * frame, local)
        ad.adapt_pose(skel, terrain, *clip, state=warm_state)
        cold_state = ad.AdaptationState()
        ad.adapt_pose(skel, terrain, *clip, state=cold_state)
        if frame:
            warm += warm_state.evaluations
            cold += cold_state.evaluations
    assert warm < 0.7 * cold


def test_objective_gradient_matches_finite_differences(skel):
    terrain = HeightField.hills(amplitude=0.05, wavelength=0.6, seed=2, extent=5.0)
    root, local = _clip_pose(skel, 3)
    targets = np.random.default_rng(0).normal(scale=0.02, size=(5, 3)) + \
        forward_kinematics(skel, root, local)[0][skel.indices(list(FEET) + [ad.TAIL_TIP_BONE])]
    problem = ad._ResidualProblem(skel, terrain, root, local, targets, np.ones(5),
                                  np.full(skel.n_bones, 0.05), ad.AdaptationSettings())
    x = problem.x_ref + np.random.default_rng(1).normal(scale=0.1, size=problem.x_ref.shape)
    f, grad = problem(x)
    assert f > 0 and np.max(np.abs(grad)) > 1.0
    eps = 1e-6
    numeric = np.array([(problem(x + eps * e)[0] - problem(x - eps * e)[0]) / (2 * eps)
                        for e in np.eye(len(x))])
    np.testing.assert_allclose(grad, numeric, rtol=1e-5, atol=1e-4 * np.max(np.abs(grad)))
    problem(x)
    np.testing.assert_allclose(problem.positions, forward_kinematics(skel, *problem.pose(x, root, local))[0],
                               atol=1e-12)


def test_compiled_kinematics_match_skeleton_fk(skel):
    root, local = _clip_pose(skel, 7)
    p, q = ad.pose_kinematics(skel, root, local)
    p_ref, q_ref = forward_kinematics(skel, root, local)
    np.testing.assert_allclose(p, p_ref, atol=1e-14)
    np.testing.assert_allclose(quat_to_matrix(q), quat_to_matrix(q_ref), atol=1e-14)


def test_bad_input_raises_input_error(skel):
    root, local = _clip_pose(skel, 0)
    terrain = HeightField.tilted_plane(10.0)
    with pytest.raises(InputError, match='local_rotations'):
        ad.adapt_pose(skel, terrain, root, local[:5])
    with pytest.raises(InputError, match='NaN'):
        ad.adapt_pose(skel, terrain, root * np.nan, local)
    with pytest.raises(InputError, match='foot_residual_heights'):
        ad.adapt_pose(skel, terrain, root, local, foot_residual_heights=np.zeros(3))


@pytest.mark.parametrize('slope_deg', [12.0, -15.0])
def test_stance_soles_lie_parallel_to_the_terrain(skel, slope_deg):
    """
    align_soles turns each stance foot's pivot bone so its up axis is the terrain normal.

    Every joint but the feet stays where residual fitting put it.
    """
    terrain = HeightField.tilted_plane(slope_deg, direction=(1.0, 0.3))
    clip = _clip_pose(skel, 0)
    stance = _stance(skel, clip)
    out = ad.adapt_pose(skel, terrain, *clip, stance=stance)
    pivots = skel.indices(list(FOOT_PIVOTS))
    up = quat_rotate(out.joint_rotations[pivots], np.array([0.0, 0.0, 1.0]))
    normal = terrain.normal(out.joint_positions[pivots, :2])
    angle = np.degrees(np.arccos(np.clip(np.sum(up * normal, axis=1), -1.0, 1.0)))
    assert stance.any() and np.all(angle[stance] < 0.5)
    feet_h, tail_h = ad.residual_heights_of(skel, *clip)
    fit = ad.plane_fit(skel, terrain, *clip, feet_h)
    fitted = ad.residual_fit(skel, terrain, fit.root_position, fit.local_rotations, feet_h, tail_h, stance=stance)
    others = np.setdiff1d(np.arange(skel.n_bones), skel.indices(list(FEET)))
    np.testing.assert_allclose(out.joint_positions[others], fitted.joint_positions[others], atol=1e-12)


def _random_problem(skel, seed):
    """Return a residual-fitting problem on rough hills with targets off the clip pose (some joints below ground)."""
    rng = np.random.default_rng(seed)
    terrain = HeightField.hills(amplitude=0.06, wavelength=0.5, seed=seed, extent=5.0)
    root, local = _clip_pose(skel, seed % 20, seed=seed)
    points = forward_kinematics(skel, root, local)[0][skel.indices(list(FEET) + [ad.TAIL_TIP_BONE])]
    targets = points + rng.normal(scale=0.02, size=(5, 3))
    return ad._ResidualProblem(skel, terrain, root, local, targets, rng.uniform(0.3, 1.0, 5),
                               np.full(skel.n_bones, 0.003), ad.AdaptationSettings())


@pytest.mark.parametrize('seed', range(6))
def test_bounded_gauss_newton_beats_lbfgsb_and_reaches_its_tight_minimum(skel, seed):
    """
    The compiled solver stays in the box and ends as low as scipy's L-BFGS-B at the same settings (0.2 % slack).

    L-BFGS-B is what it replaced. The targets lie off the clip pose and some joints start below ground, so the
    residuals stay large: harder than a trot frame, where it needs 3-4 evaluations. Run to a tight tolerance it
    reaches the minimum a tight L-BFGS-B reaches (a kink of the bilinear terrain under a pressed joint can keep the
    projected gradient from vanishing).
    """
    from scipy.optimize import Bounds, minimize

    problem = _random_problem(skel, seed)
    settings = ad.AdaptationSettings()
    x0 = problem.start(None)
    lo, hi = problem.bounds
    x, iterations, evaluations = problem.solve(x0, settings)
    assert np.all((x >= lo) & (x <= hi)) and 1 <= iterations <= evaluations
    reference = minimize(problem, x0, jac=True, method='L-BFGS-B', bounds=Bounds(lo, hi),
                         options={'maxiter': settings.max_iterations, 'gtol': settings.gradient_tolerance,
                                  'ftol': settings.function_tolerance})
    assert problem(x)[0] <= reference.fun * 1.002
    x, _, _ = problem.solve(x0, dataclasses.replace(settings, max_iterations=10000, function_tolerance=1e-14))
    tight = minimize(problem, x0, jac=True, method='L-BFGS-B', bounds=Bounds(lo, hi),
                     options={'maxiter': 10000, 'gtol': 1e-10, 'ftol': 1e-14})
    assert problem(x)[0] <= tight.fun + 1e-5 * (1.0 + tight.fun)
