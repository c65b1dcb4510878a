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

"""The corotated Cholesky preconditioner: node clusters, their rotations, the turned solve, and runs with it."""
import numpy as np
import pytest
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial.transform import Rotation

from iguana_lab.bench.workload import walk_on_hills
from iguana_ros.body.model import build_model
from iguana_ros.errors import InputError
from iguana_ros.physics.cholesky import block_cholesky, cholesky_solve, CholeskyPattern, F_ROTATED
from iguana_ros.physics.factor_rotation import cluster_rotations, MIN_CLUSTER_SIZE, node_clusters
from iguana_ros.physics.factor_thread import FactorThread
from iguana_ros.physics.fidelity import get_fidelity
from iguana_ros.physics.simulator import SoftBodySimulator
from iguana_ros.terrain.heightfield import HeightField


@pytest.fixture(scope='module')
def medium():
    return build_model('medium', 'normal')


def test_the_clusters_cover_every_node_once_each_connected_over_the_springs(medium):
    ptr, nodes = node_clusters(medium.rest_positions, medium.springs)
    n = len(medium.rest_positions)
    assert sorted(nodes.tolist()) == list(range(n))
    sizes = np.diff(ptr)
    assert sizes.min() >= MIN_CLUSTER_SIZE and 15 <= np.median(sizes) <= 16
    springs = np.asarray(medium.springs)
    graph = csr_matrix((np.ones(len(springs)), (springs[:, 0], springs[:, 1])), shape=(n, n))
    for k in range(len(sizes)):
        members = nodes[ptr[k]:ptr[k + 1]]
        assert connected_components(graph[members][:, members], directed=False)[0] == 1
    again = node_clusters(medium.rest_positions, medium.springs)
    np.testing.assert_array_equal(again[0], ptr)     # deterministic
    np.testing.assert_array_equal(again[1], nodes)


def test_a_body_turned_rigidly_gives_every_node_that_rotation(medium):
    ptr, nodes = node_clusters(medium.rest_positions, medium.springs)
    rest = np.ascontiguousarray(medium.rest_positions, dtype=np.float64)
    turn = Rotation.from_rotvec([0.3, -0.5, 0.2]).as_matrix()
    moved = rest @ turn.T + [0.4, -0.1, 0.05]
    quats = np.tile([0.0, 0.0, 0.0, 1.0], (len(ptr) - 1, 1))
    rotations = np.zeros((len(rest), 3, 3))
    cluster_rotations(moved, rest, ptr, nodes, quats, rotations, 300)   # from I; elongated clusters converge slowly
    np.testing.assert_allclose(rotations, np.broadcast_to(turn, rotations.shape), atol=1e-6)
    cluster_rotations(rest, rest, ptr, nodes, quats, rotations, 300)    # back, warm-started from the turn
    np.testing.assert_allclose(rotations, np.broadcast_to(np.eye(3), rotations.shape), atol=1e-6)


def test_the_turned_solve_applies_r_a_inverse_r_transposed():
    """On a random SPD block system: z = R A⁻¹ Rᵀ r with node rotations, and exactly A⁻¹ r with identities."""
    rng = np.random.default_rng(3)
    n = 12
    rows = [(i, j) for i in range(n) for j in range(i, n) if j - i in (0, 1, 3)]
    row_ptr = np.searchsorted([r for r, _ in rows], np.arange(n + 1)).astype(np.int64)
    cols = np.array([c for _, c in rows], dtype=np.int64)
    dense = np.zeros((3 * n, 3 * n))
    for r, c in rows:
        if r < c:
            blk = rng.normal(size=(3, 3))
            dense[3 * r:3 * r + 3, 3 * c:3 * c + 3] = blk
            dense[3 * c:3 * c + 3, 3 * r:3 * r + 3] = blk.T
    dense += np.diag(np.abs(dense).sum(axis=1) + 1.0)
    blocks = np.stack([dense[3 * r:3 * r + 3, 3 * c:3 * c + 3] for r, c in rows])
    pattern = CholeskyPattern.build(row_ptr, cols)
    values, diag_inv = np.zeros((pattern.n_factor_blocks, 3, 3)), np.zeros((n, 3, 3))
    assert block_cholesky(pattern.arrays(), blocks, values, diag_inv)
    r = rng.normal(size=(n, 3))
    rotations = Rotation.random(n, random_state=4).as_matrix()
    turned = np.zeros((3 * n, 3 * n))
    for i in range(n):
        turned[3 * i:3 * i + 3, 3 * i:3 * i + 3] = rotations[i]
    z, plain, work = np.zeros_like(r), np.zeros_like(r), np.zeros_like(r)
    cholesky_solve(pattern.arrays(), values, diag_inv, r, z, work, rotations)
    expected = turned @ np.linalg.solve(dense, turned.T @ r.ravel())
    np.testing.assert_allclose(z.ravel(), expected, rtol=1e-10, atol=1e-12)
    cholesky_solve(pattern.arrays(), values, diag_inv, r, plain, work)
    cholesky_solve(pattern.arrays(), values, diag_inv, r, z, work, np.tile(np.eye(3), (n, 1, 1)))
    np.testing.assert_array_equal(z, plain)


def test_a_turned_factor_needs_fewer_iterations_and_factorisations_for_the_same_motion(medium):
    """The gait with and without turning the factor: the same motion to the CG tolerance, less solver work."""
    assert get_fidelity('balanced').factor_rotation_every > 0
    turned, plain = walk_on_hills(medium, 15), walk_on_hills(medium, 15, factor_rotation_every=0)
    assert turned.stats['factor_rotation_every'] == 4 and plain.stats['factor_rotation_every'] == 0
    assert np.abs(turned.positions - plain.positions).max() < 2e-3
    work = [s.stats['cg_iterations'] + s.refactor_budget * s.stats['factorisations'] for s in (turned, plain)]
    assert work[0] < 0.97 * work[1], work                # in CG iterations' worth


def test_a_turned_factor_from_the_factor_thread_starts_from_its_snapshot(medium, monkeypatch):
    """With the factor thread, a swapped-in factor's rotations start afresh at its snapshot's positions."""
    swaps = []
    original = FactorThread.swap

    def checked(self, chol, counters):
        new = original(self, chol, counters)
        if new.values is not chol.values:            # the worker's factor went in
            swaps.append(np.array_equal(new.anchor, new.snapshot_anchor) and new.state[F_ROTATED] == 0
                         and np.all(new.cluster_quats == [0.0, 0.0, 0.0, 1.0]))
        return new
    monkeypatch.setattr(FactorThread, 'swap', checked)
    sim = walk_on_hills(medium, 10, factor_thread='on')
    sim.close()
    assert len(swaps) >= 3 and all(swaps)


def test_without_the_cholesky_preconditioner_there_is_nothing_to_turn(medium):
    sim = SoftBodySimulator(medium, HeightField.flat(), 'balanced', preconditioner='jacobi')
    assert sim.stats['factor_rotation_every'] == 0 and len(sim._model.cluster_nodes) == 0
    with pytest.raises(InputError, match='factor_rotation_every'):
        get_fidelity('balanced', factor_rotation_every=-1)
