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

"""Upper-triangle block storage of the symmetric system matrix: pattern, matrix–vector product, preconditioners."""
import numpy as np
import pytest

from iguana_ros.physics.assembly import block_matvec, BlockPattern
from iguana_ros.physics.integrator import invert_diagonal
from iguana_ros.physics.meshes import box_mesh
from iguana_ros.physics.solver import block_jacobi_pcg


@pytest.fixture(scope='module')
def system():
    """Return a 2×2×1-cube box's pattern with random symmetric, diagonally dominant values: (pattern, blocks, dense)."""
    mesh = box_mesh(size=(0.2, 0.2, 0.1), cells=(2, 2, 1), total_mass=1.0, youngs_modulus=1e4, spring_stiffness=1e3)
    pat = BlockPattern.build(len(mesh.rest_positions), mesh.tets, mesh.springs)
    rng = np.random.default_rng(3)
    blocks = rng.normal(size=(pat.n_blocks, 3, 3))
    blocks[pat.diag] = blocks[pat.diag] + np.transpose(blocks[pat.diag], (0, 2, 1))
    dense = pat.to_scipy(blocks).toarray()
    blocks[pat.diag] += np.eye(3) * (np.abs(dense).sum(axis=1).max() + 1.0)
    return pat, blocks, pat.to_scipy(blocks).toarray()


def test_pattern_stores_each_node_pair_once_in_the_upper_triangle(system):
    pat, _, _ = system
    rows = pat.rows
    assert np.all(pat.cols >= rows)
    assert np.array_equal(pat.cols[pat.diag], np.arange(pat.n_nodes))
    assert np.array_equal(pat.diag, pat.row_ptr[:-1])             # the diagonal block leads its row
    assert len(set(zip(rows.tolist(), pat.cols.tolist()))) == pat.n_blocks


def test_full_matrix_is_symmetric_and_matvec_matches_it(system):
    pat, blocks, dense = system
    np.testing.assert_array_equal(dense, dense.T)
    x = np.random.default_rng(4).normal(size=(pat.n_nodes, 3))
    out = np.full_like(x, np.nan)                                  # stale contents must not leak in
    block_matvec(pat.row_ptr, pat.cols, blocks, x, out)
    np.testing.assert_allclose(out.ravel(), dense @ x.ravel(), rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize('ssor', [False, True])
def test_preconditioned_cg_solves_the_stored_system(system, ssor):
    pat, blocks, dense = system
    b = np.random.default_rng(5).normal(size=(pat.n_nodes, 3))
    pinv = np.zeros((pat.n_nodes, 3, 3))
    invert_diagonal(pat.diag, blocks, pinv)
    x = np.zeros_like(b)
    iters, res, _ = block_jacobi_pcg(pat.row_ptr, pat.cols, blocks, pinv, b, x, 1e-12, 0.0, 500,
                                     np.zeros((4, pat.n_nodes, 3)), ssor)
    assert 0 < iters < 500
    np.testing.assert_allclose(x.ravel(), np.linalg.solve(dense, b.ravel()), rtol=1e-8, atol=1e-10)
