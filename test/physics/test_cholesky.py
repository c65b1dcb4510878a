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

"""Block Cholesky preconditioner: exact factor of the system matrix, simulator runs equal the direct LU's."""
import numpy as np
import pytest

from iguana_ros.physics.cholesky import block_cholesky, cholesky_solve, CholeskyPattern
from iguana_ros.physics.meshes import box_mesh
from iguana_ros.physics.simulator import SoftBodySimulator
from iguana_ros.terrain.heightfield import HeightField


@pytest.fixture(scope='module')
def bar():
    """Return a 30 × 6 × 4 cm bar of 10 cubes (60 tets), 0.5 kg, stiff springs (1e5 N/m) as on the iguana's legs."""
    return box_mesh(size=(0.3, 0.06, 0.04), cells=(10, 1, 1), total_mass=0.5, youngs_modulus=1e4,
                    spring_stiffness=1e5)


def _spd_system(bar, seed=0):
    """Return the bar's pattern with random SPD block values: (pattern, blocks, dense matrix)."""
    sim = SoftBodySimulator(bar, terrain=None)
    pat = sim.pattern
    rng = np.random.default_rng(seed)
    n = pat.n_nodes
    dense = np.zeros((3 * n, 3 * n))
    rows = pat.rows
    for r, c in zip(rows, pat.cols):                 # symmetric, on the pattern, made diagonally dominant
        if r < c:
            blk = rng.normal(size=(3, 3))
            dense[3 * r:3 * r + 3, 3 * c:3 * c + 3] = blk
            dense[3 * c:3 * c + 3, 3 * r:3 * r + 3] = blk.T
    dense += np.diag(np.abs(dense).sum(axis=1) + 1.0)
    blocks = np.stack([dense[3 * r:3 * r + 3, 3 * c:3 * c + 3] for r, c in zip(rows, pat.cols)])
    return pat, blocks, dense


def test_factor_solves_the_block_system(bar):
    pat, blocks, dense = _spd_system(bar)
    chol = CholeskyPattern.build(pat.row_ptr, pat.cols)
    assert sorted(chol.perm.tolist()) == list(range(pat.n_nodes))
    values, diag_inv = np.zeros((chol.n_factor_blocks, 3, 3)), np.zeros((pat.n_nodes, 3, 3))
    assert block_cholesky(chol.arrays(), blocks, values, diag_inv)
    rhs = np.random.default_rng(1).normal(size=(pat.n_nodes, 3))
    z, work = np.zeros_like(rhs), np.zeros_like(rhs)
    cholesky_solve(chol.arrays(), values, diag_inv, rhs, z, work)
    np.testing.assert_allclose(z.ravel(), np.linalg.solve(dense, rhs.ravel()), rtol=1e-10, atol=1e-12)


def test_indefinite_matrix_is_reported(bar):
    pat, blocks, _ = _spd_system(bar)
    blocks[pat.diag[3]] *= -1.0                      # a negative pivot
    chol = CholeskyPattern.build(pat.row_ptr, pat.cols)
    values, diag_inv = np.zeros((chol.n_factor_blocks, 3, 3)), np.zeros((pat.n_nodes, 3, 3))
    assert not block_cholesky(chol.arrays(), blocks, values, diag_inv)


def _drop_bent_bar(bar, **kwargs) -> SoftBodySimulator:
    """
    Return the bar dropped 5 cm onto hills with its springs shortened 3 %, run for 0.3 s.

    The run covers the fall, touch-down and friction.
    """
    terrain = HeightField.hills(amplitude=0.02, wavelength=0.3, seed=1, extent=1.0)
    sim = SoftBodySimulator(bar, terrain, 'balanced', **kwargs)
    sim.reset(np.asarray(bar.rest_positions) + [0.0, 0.0, 0.05])
    bent = np.asarray(bar.spring_rest_lengths) * 0.97
    for _ in range(9):
        sim.advance_frame(bent)
    return sim


def test_reused_factor_needs_few_iterations_and_tracks_direct_solve(bar):
    """A factor reused for up to 4 steps: far fewer factorisations, ≤ 3 CG iterations a step, same motion."""
    lagged = _drop_bent_bar(bar, factor_every=4, refactor_iters=2)
    direct = _drop_bent_bar(bar, solver='direct')
    steps = lagged.stats['steps']
    assert steps // 4 <= lagged.stats['factorisations'] < steps // 2
    assert 1.0 < lagged.stats['cg_iterations_per_step'] <= 3.0
    assert lagged.stats['direct_fallback_steps'] == 0
    diff = np.abs(lagged.positions - direct.positions).max()
    assert diff < 1e-3, f'{diff:.3g} m from the direct solve'


def test_stale_factor_that_fails_is_refactorised_not_given_up(bar):
    """With one CG iteration allowed, a stale factor cannot converge: the step refactorises and solves again."""
    sim = _drop_bent_bar(bar, factor_every=1000, refactor_iters=1000, cg_max_iter=1)
    assert sim.stats['direct_fallback_steps'] == 0
    assert sim.stats['factorisations'] > 1
    assert sim.stats['cg_iterations_per_step'] > 1.0


def test_cholesky_cg_run_equals_direct_lu(bar):
    """A dropped, bent bar landing on hills: CG with a fresh factor each step tracks the direct solve to round-off."""
    runs = {name: _drop_bent_bar(bar, **kwargs) for name, kwargs in (
        ('cholesky', {'preconditioner': 'cholesky', 'factor_every': 1}), ('direct', {'solver': 'direct'}),
        ('jacobi', {'preconditioner': 'jacobi'}))}
    assert runs['cholesky'].stats['cholesky_failures'] == 0
    assert runs['cholesky'].stats['nodes_in_contact'] > 0
    assert runs['cholesky'].stats['cg_iterations_per_step'] == pytest.approx(1.0)
    assert runs['jacobi'].stats['cg_iterations_per_step'] > 3
    diff = np.abs(runs['cholesky'].positions - runs['direct'].positions).max()
    assert diff < 1e-9


def test_amortised_rule_refactorises_once_the_extra_iterations_cost_a_factorisation(bar):
    """
    Step by step under the 'amortised' rule alone, a factorisation comes exactly at the budget.

    That is, when the CG iterations beyond one per solve since the last factorisation have reached it, never before.
    """
    from iguana_ros.physics import integrator as itg

    terrain = HeightField.hills(amplitude=0.02, wavelength=0.3, seed=1, extent=1.0)
    sim = SoftBodySimulator(bar, terrain, 'balanced', factor_every=1000, refactor_iters=1000,
                            refactor_rule='amortised')
    assert 1.0 < sim.refactor_budget < 50.0 and sim.stats['refactor_budget'] == sim.refactor_budget
    sim.reset(np.asarray(bar.rest_positions) + [0.0, 0.0, 0.05])
    bent = np.asarray(bar.spring_rest_lengths) * 0.97
    by_budget = 0
    for step in range(400):
        extra, factorisations = int(sim._chol.state[itg.F_EXTRA_ITERS]), sim.stats['factorisations']
        sim.advance_frame(bent, n_steps=1)
        refactorised = sim.stats['factorisations'] > factorisations
        if step > 0:
            assert refactorised == (extra >= sim.refactor_budget), (step, extra)
            by_budget += refactorised
        if refactorised:
            assert sim._chol.state[itg.F_EXTRA_ITERS] == sim._chol.state[itg.F_LAST_ITERS] - 1
    assert by_budget >= 3 and sim.stats['cholesky_failures'] == 0


def test_age_rule_has_no_budget_and_a_bigger_body_a_larger_one(bar):
    """'age' leaves the budget out; a factorisation costs more CG iterations on a body with more fill per node."""
    assert SoftBodySimulator(bar, None, 'balanced', refactor_rule='age').refactor_budget is None
    thick = box_mesh(size=(0.3, 0.12, 0.08), cells=(10, 2, 2), total_mass=0.5, youngs_modulus=1e4,
                     spring_stiffness=1e5)
    budgets = [SoftBodySimulator(body, None, 'balanced').refactor_budget for body in (bar, thick)]
    assert 1.0 < budgets[0] < budgets[1]
