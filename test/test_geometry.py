"""Quaternion helpers agree with scipy and with each other."""
import numpy as np
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
