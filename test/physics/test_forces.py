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

"""Force kernels against analytic values: single-tet elasticity, rigid motions, springs, Jacobians."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from iguana_ros.physics.assembly import BlockPattern
from iguana_ros.physics.forces import (
    corotated_elastic_forces, extract_rotation, lame_parameters, shape_gradients, spring_forces)
from iguana_ros.physics.meshes import box_mesh, single_tet, tet_volumes

E, NU = 1.0e5, 0.3


def _fem(mesh, x, polar_iters=100, scale=0.0):
    """Elastic forces (n, 3) and (if scale) the dense stiffness (3n, 3n) of `mesh` at positions `x`."""
    grads, vol = shape_gradients(mesh.rest_positions, mesh.tets)
    mu, lam = lame_parameters(mesh.youngs_modulus, mesh.poisson_ratio)
    pattern = BlockPattern.build(len(x), mesh.tets, mesh.springs)
    blocks = np.zeros((pattern.n_blocks, 3, 3))
    quats = np.tile([0.0, 0.0, 0.0, 1.0], (len(mesh.tets), 1))
    forces = np.zeros_like(x)
    corotated_elastic_forces(np.ascontiguousarray(x), mesh.tets, grads, vol, mu, lam, quats, polar_iters, forces,
                             blocks, pattern.tet_blocks, scale)
    return forces, pattern.to_scipy(blocks).toarray(), quats


def test_single_tet_uniaxial_stretch_matches_analytic():
    edge, delta = 0.1, 0.002
    mesh = single_tet(edge=edge, youngs_modulus=E, poisson_ratio=NU)
    x = mesh.rest_positions.copy()
    x[1, 0] += delta                                  # F = diag(1 + δ/L, 1, 1): ε_xx = δ/L, R = I
    f, _, _ = _fem(mesh, x)
    mu, lam = lame_parameters(np.array([E]), NU)
    # f_a = −V σ ∇φ_a with V = L³/6, σ = diag((λ+2μ)ε, λε, λε), ∇φ_1 = x̂/L, ∇φ_2 = ŷ/L, ∇φ_3 = ẑ/L
    eps = delta / edge
    v = edge ** 3 / 6.0
    expected = np.zeros((4, 3))
    expected[1] = [-v * (lam[0] + 2 * mu[0]) * eps / edge, 0, 0]
    expected[2] = [0, -v * lam[0] * eps / edge, 0]
    expected[3] = [0, 0, -v * lam[0] * eps / edge]
    expected[0] = -expected[1:].sum(axis=0)
    np.testing.assert_allclose(f, expected, rtol=1e-12, atol=1e-12)
    assert f[1, 0] == pytest.approx(-(edge / 6) * (lam[0] + 2 * mu[0]) * delta, rel=1e-12)


def test_elastic_force_is_frame_indifferent():
    mesh = single_tet(edge=0.1, youngs_modulus=E, poisson_ratio=NU)
    x = mesh.rest_positions.copy()
    x[1, 0] += 0.003
    x[3] += [0.001, -0.002, 0.0]
    f, _, _ = _fem(mesh, x)
    rot = Rotation.from_rotvec([0.4, -1.1, 2.0]).as_matrix()
    f_rot, _, _ = _fem(mesh, x @ rot.T + [1.0, 2.0, -0.5])
    np.testing.assert_allclose(f_rot, f @ rot.T, atol=1e-6 * np.abs(f).max())  # rotation converged to 1e-8 rad


def test_rigid_motion_produces_no_elastic_force():
    mesh = box_mesh(cells=(3, 2, 2), youngs_modulus=E)
    rot = Rotation.from_rotvec([2.0, 0.5, -1.3]).as_matrix()
    f, _, _ = _fem(mesh, mesh.rest_positions @ rot.T + [0.3, -4.0, 1.0])
    stretched, _, _ = _fem(mesh, mesh.rest_positions * [1.01, 1.0, 1.0])
    assert np.abs(f).max() < 1e-9 * np.abs(stretched).max()


def test_internal_forces_are_torque_free_when_deformed():
    mesh = box_mesh(size=(0.1, 0.06, 0.04), cells=(3, 2, 1), youngs_modulus=E)
    x = mesh.rest_positions + np.random.default_rng(0).normal(scale=0.003, size=mesh.rest_positions.shape)
    f, _, _ = _fem(mesh, x)
    fs, _ = _springs(mesh, x, mesh.spring_rest_lengths * 1.1)
    for force in (f, fs):
        assert np.abs(force.sum(axis=0)).max() < 1e-10 * np.abs(force).max()
        assert np.abs(np.cross(x, force).sum(axis=0)).max() < 1e-9 * np.abs(force).max()


def test_stiffness_matches_finite_differences_at_rest():
    mesh = box_mesh(size=(0.1, 0.05, 0.05), cells=(2, 1, 1), youngs_modulus=E)
    _, k, _ = _fem(mesh, mesh.rest_positions, scale=1.0)
    rng = np.random.default_rng(0)
    for _ in range(3):
        dx = rng.normal(size=mesh.rest_positions.shape) * 1e-7
        f_plus, _, _ = _fem(mesh, mesh.rest_positions + dx)
        np.testing.assert_allclose(f_plus.ravel(), -k @ dx.ravel(), rtol=1e-4, atol=1e-4 * np.abs(f_plus).max())
    assert np.allclose(k, k.T) and np.linalg.eigvalsh(k).min() > -1e-6 * np.abs(k).max()


def test_rotation_extraction_is_proper_for_flat_and_inverted_elements():
    rng = np.random.default_rng(2)
    r = np.empty((3, 3))
    cases = [np.diag([1.0, 1.0, -0.5]),                # inverted
             np.diag([1.0, 1.0, 0.0]),                 # flat
             np.zeros((3, 3)),                         # collapsed to a point
             rng.normal(size=(3, 3))]
    for a in cases:
        q = np.array([0.0, 0.0, 0.0, 1.0])
        extract_rotation(a, q, r, 100)
        np.testing.assert_allclose(r @ r.T, np.eye(3), atol=1e-12)
        assert np.linalg.det(r) == pytest.approx(1.0)
    # a rotated inverted tet: the elastic force does positive work toward restoring positive volume
    mesh = single_tet(edge=0.1, youngs_modulus=E, poisson_ratio=NU)
    x = mesh.rest_positions.copy()
    x[3, 2] = -0.03                                   # node 3 pushed through the opposite face
    assert tet_volumes(x, mesh.tets)[0] < 0
    f, _, _ = _fem(mesh, x)
    assert f[3, 2] > 0 and np.isfinite(f).all()
    assert tet_volumes(x + 1e-4 * f / np.abs(f).max(), mesh.tets)[0] > tet_volumes(x, mesh.tets)[0]


def _springs(mesh, x, desired, scale=0.0):
    pattern = BlockPattern.build(len(x), mesh.tets, mesh.springs)
    blocks = np.zeros((pattern.n_blocks, 3, 3))
    forces = np.zeros_like(x)
    spring_forces(x, mesh.springs, mesh.spring_stiffness, desired, forces, blocks, pattern.spring_blocks, scale)
    return forces, pattern.to_scipy(blocks).toarray()


def test_spring_with_desired_equal_current_length_exerts_nothing():
    mesh = box_mesh(cells=(2, 1, 1), spring_stiffness=500.0)
    rng = np.random.default_rng(3)
    x = mesh.rest_positions + rng.normal(scale=0.01, size=mesh.rest_positions.shape)
    current = np.linalg.norm(x[mesh.springs[:, 1]] - x[mesh.springs[:, 0]], axis=1)
    f, _ = _springs(mesh, x, current)
    assert np.abs(f).max() < 1e-12


def test_spring_force_magnitude_direction_and_jacobian():
    mesh = single_tet(edge=0.1, spring_stiffness=300.0)
    x = mesh.rest_positions.copy()
    desired = mesh.spring_rest_lengths * 0.9           # every spring wants to be 10 % shorter
    f, k = _springs(mesh, x, desired, scale=1.0)
    s = int(np.flatnonzero((mesh.springs == [0, 1]).all(axis=1))[0])
    # node 1 pulled toward node 0 by a(l − l_d) = 300 × 0.01 = 3 N from spring (0, 1) plus the others
    single = np.zeros_like(x)
    only = np.zeros(len(mesh.springs), dtype=bool)
    only[s] = True
    spring_forces(x, mesh.springs[only], mesh.spring_stiffness[only], desired[only], single,
                  np.zeros((1, 3, 3)), np.zeros((1, 4), dtype=np.int64), 0.0)
    np.testing.assert_allclose(single[1], [-3.0, 0, 0], atol=1e-12)
    np.testing.assert_allclose(single[0], [3.0, 0, 0], atol=1e-12)
    assert np.abs(f.sum(axis=0)).max() < 1e-12
    dx = np.random.default_rng(4).normal(size=x.shape) * 1e-7   # stretched springs: no clamping, exact Jacobian
    f_plus, _ = _springs(mesh, x + dx, desired)
    np.testing.assert_allclose((f_plus - f).ravel(), -k @ dx.ravel(), rtol=1e-5, atol=1e-9)


def test_relabelled_tets_give_the_same_forces_and_stiffness():
    """The simulator sorts each tet's nodes (with their gradients) for its upper-triangle storage: same physics."""
    from iguana_ros.physics.simulator import _ascending_nodes

    mesh = box_mesh(size=(0.1, 0.05, 0.05), cells=(2, 1, 1), youngs_modulus=E)
    x = mesh.rest_positions + np.random.default_rng(2).normal(scale=0.002, size=mesh.rest_positions.shape)
    grads, vol = shape_gradients(mesh.rest_positions, mesh.tets)
    mu, lam = lame_parameters(mesh.youngs_modulus, mesh.poisson_ratio)
    results = []
    for tets, g in ((mesh.tets, grads), _ascending_nodes(mesh.tets, grads)):
        pattern = BlockPattern.build(len(x), tets, mesh.springs)
        blocks, forces = np.zeros((pattern.n_blocks, 3, 3)), np.zeros_like(x)
        quats = np.tile([0.0, 0.0, 0.0, 1.0], (len(tets), 1))
        corotated_elastic_forces(x, np.ascontiguousarray(tets), g, vol, mu, lam, quats, 50, forces, blocks,
                                 pattern.tet_blocks, 1.0)
        results.append((forces, pattern.to_scipy(blocks).toarray()))
    assert not np.array_equal(mesh.tets, np.sort(mesh.tets, axis=1))      # the relabelling does something
    np.testing.assert_allclose(results[0][0], results[1][0], rtol=1e-12, atol=1e-12 * np.abs(results[0][0]).max())
    np.testing.assert_allclose(results[0][1], results[1][1], rtol=1e-12, atol=1e-12 * np.abs(results[0][1]).max())
