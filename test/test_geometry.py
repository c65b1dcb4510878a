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

"""Quaternion helpers agree with scipy and with each other."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from iguana_ros import geometry as g


def _random_quats(n, seed=0):
    return Rotation.random(n, random_state=seed).as_quat()


def test_mul_rotate_matrix_match_scipy():
    a, b = _random_quats(50, 1), _random_quats(50, 2)
    v = np.random.default_rng(3).normal(size=(50, 3))
    ab = g.quat_mul(a, b)
    expected = (Rotation.from_quat(a) * Rotation.from_quat(b)).as_quat()
    assert np.allclose(np.abs(np.sum(ab * expected, axis=1)), 1.0)
    assert np.allclose(g.quat_rotate(a, v), Rotation.from_quat(a).apply(v))
    assert np.allclose(g.quat_to_matrix(a), Rotation.from_quat(a).as_matrix())
    back = g.matrix_to_quat(g.quat_to_matrix(a))
    assert np.allclose(np.abs(np.sum(back * a, axis=1)), 1.0)


def test_rotvec_round_trip_including_tiny_angles():
    rv = np.concatenate([np.random.default_rng(4).normal(size=(20, 3)), np.full((1, 3), 1e-9),
                         np.zeros((1, 3))])
    rv[:20] = rv[:20] / np.linalg.norm(rv[:20], axis=1, keepdims=True) * 2.5
    q = g.quat_from_rotvec(rv)
    assert np.allclose(q, Rotation.from_rotvec(rv).as_quat())
    assert np.allclose(g.quat_to_rotvec(q), rv, atol=1e-12)


def test_conjugate_inverts_and_yaw_round_trips():
    q = _random_quats(10, 5)
    assert np.allclose(g.quat_mul(q, g.quat_conjugate(q)), g.quat_identity((10,)))
    yaw = np.linspace(-3.0, 3.0, 7)
    assert np.allclose(g.yaw_of(g.quat_from_yaw(yaw)), yaw)
    assert np.allclose(g.wrap_angle(np.array([3 * np.pi, -3 * np.pi + 0.1])), [-np.pi, -np.pi + 0.1])


def test_normalize_zero_is_identity():
    assert np.allclose(g.quat_normalize(np.zeros((2, 4))), g.quat_identity((2,)))


def test_matrix_to_quat_equals_scipy_bitwise():
    """The toolkit's own conversion does scipy's arithmetic (each of the four Markley branches is hit)."""
    mats = np.concatenate([Rotation.random(2000, random_state=6).as_matrix(),
                           Rotation.from_rotvec(np.pi * np.eye(3)).as_matrix(), np.eye(3)[None]])
    expected = Rotation.from_matrix(mats).as_quat()
    expected = np.where(expected[:, 3:4] < 0.0, -expected, expected)
    np.testing.assert_array_equal(g.matrix_to_quat(mats), expected)
    assert g.matrix_to_quat(mats[0]).shape == (4,)


def test_euler_round_trips_and_matches_scipy_intrinsic_sequences():
    rng = np.random.default_rng(7)
    angles = np.column_stack([rng.uniform(-3, 3, 50), rng.uniform(-1.5, 1.5, 50), rng.uniform(-3, 3, 50)])
    for order in ('ZXY', 'ZYX', 'XYZ', 'YXZ', 'XZY', 'YZX'):
        q = g.quat_from_euler(angles, order)
        np.testing.assert_allclose(np.abs(np.sum(q * Rotation.from_euler(order, angles).as_quat(), axis=1)), 1.0)
        np.testing.assert_allclose(g.matrix_to_euler(g.quat_to_matrix(q), order), angles, atol=1e-12)
    locked = Rotation.from_euler('ZXY', [0.3, np.pi / 2, 0.0]).as_matrix()   # gimbal lock: last angle 0
    np.testing.assert_allclose(g.matrix_to_euler(locked, 'ZXY'), [0.3, np.pi / 2, 0.0], atol=1e-12)


def test_quat_between_is_the_smallest_rotation():
    q = g.quat_between(np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]))
    np.testing.assert_allclose(q, [0.0, 0.0, np.sin(np.pi / 4), np.cos(np.pi / 4)], atol=1e-15)
    assert g.quat_between(np.array([0.0, 0.0, 1.0]), np.array([0.0, 0.0, 1.0])) is None
    flip = g.quat_between(np.array([0.0, 0.0, 1.0]), np.array([0.0, 0.0, -1.0]))   # opposite: a half turn
    np.testing.assert_allclose(g.quat_rotate(flip, [0.0, 0.0, 1.0]), [0.0, 0.0, -1.0], atol=1e-15)


def _rot_y(angle):
    """Rotation matrix about +y by `angle` rad."""
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def test_rigid_fit_recovers_a_rigid_transform_also_of_planar_sets():
    """
    On exact data the fit is the transform itself, also for 3 and 4 coplanar points.

    The cross-covariance of those coplanar sets is singular (det 0).
    """
    rng = np.random.default_rng(0)
    rot = Rotation.random(random_state=1).as_matrix()
    for src in (rng.normal(size=(20, 3)), rng.normal(size=(3, 3)),
                np.column_stack([rng.normal(size=(4, 2)), np.zeros(4)])):
        target = src @ rot.T + [1.0, 2.0, 3.0]
        r, t = g.rigid_fit(src, target, rng.uniform(0.5, 2.0, len(src)))
        np.testing.assert_allclose(r, rot, atol=1e-12)
        np.testing.assert_allclose(t, [1.0, 2.0, 3.0], atol=1e-12)
    planar = np.column_stack([rng.normal(size=(4, 2)), np.zeros(4)])
    assert abs(np.linalg.det(planar.T @ planar)) < 1e-20


def test_rigid_fit_never_reflects_and_weights_select_points():
    """
    A set mirrored across its thinnest axis.

    The best proper rotation is the identity (analytic: the cross-covariance is diag(c1, c2, -c3)).
    """
    box = np.array([[sx * 0.3, sy * 0.2, sz * 0.1] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    r, t = g.rigid_fit(box, box * [1.0, 1.0, -1.0])
    np.testing.assert_allclose(r, np.eye(3), atol=1e-15)
    np.testing.assert_allclose(t, 0.0, atol=1e-15)
    moved = box @ _rot_y(0.4).T
    outlier = np.vstack([moved, [[50.0, -20.0, 9.0]]])
    r, t = g.rigid_fit(np.vstack([box, [[0.0, 0.0, 0.0]]]), outlier, np.append(np.ones(8), 0.0))
    np.testing.assert_allclose(r, _rot_y(0.4), atol=1e-14)


def test_rigid_fit_of_degenerate_sets():
    """
    The rigid fit of degenerate sets: collinear points, coincident points, no positive weight.

    Collinear points give the smallest rotation taking the line onto the target line (here 0.2 rad about y, no roll);
    coincident points give the identity and the offset; no positive weight gives an error.
    """
    line = np.outer([0.0, 0.1, 0.2, 0.3], [1.0, 0.0, 0.0])
    target = np.outer([0.0, 0.1, 0.2, 0.3], [np.cos(0.2), 0.0, np.sin(0.2)]) + [0.5, 0.0, 0.0]
    r, t = g.rigid_fit(line, target)
    np.testing.assert_allclose(r, _rot_y(-0.2), atol=1e-15)
    np.testing.assert_allclose(line @ r.T + t, target, atol=1e-15)
    r, _ = g.rigid_fit(line, target, identity_bias=1e-6)     # the plane fit's pull toward the identity
    np.testing.assert_allclose(r, _rot_y(-0.2), atol=1e-6)
    r, t = g.rigid_fit(np.ones((3, 3)), np.full((3, 3), 2.0))
    np.testing.assert_array_equal(r, np.eye(3))
    np.testing.assert_array_equal(t, [1.0, 1.0, 1.0])
    with pytest.raises(ValueError, match='positive sum'):
        g.rigid_fit(line, target, np.zeros(4))


def test_matrix_to_quat_of_one_matrix_equals_the_batch_bitwise():
    """The one-matrix path (Python floats, ~30x faster) gives the batch's bits, on every branch of the choice."""
    from scipy.spatial.transform import Rotation
    from iguana_ros.geometry import matrix_to_quat
    mats = np.concatenate([Rotation.random(4000, random_state=3).as_matrix(),
                           [np.eye(3), np.diag([1.0, -1.0, -1.0]), np.diag([-1.0, 1.0, -1.0]),
                            np.diag([-1.0, -1.0, 1.0])]])
    batch = matrix_to_quat(mats)
    one = np.array([matrix_to_quat(m) for m in mats])
    trace = np.trace(mats, axis1=1, axis2=2)
    branches = np.argmax(np.stack([mats[:, 0, 0], mats[:, 1, 1], mats[:, 2, 2], trace], axis=-1), axis=-1)
    assert set(branches.tolist()) == {0, 1, 2, 3}
    assert np.array_equal(batch.view(np.uint64), one.view(np.uint64))
    assert matrix_to_quat(np.eye(3)).shape == (4,)
