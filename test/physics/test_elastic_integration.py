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

"""The FEM force evaluated explicitly where the springs carry the stiffness (`Fidelity.elastic_integration`)."""
import dataclasses

import numpy as np
import pytest
import scipy.linalg

from iguana_lab.bench.workload import gait_for
from iguana_ros.body.model import build_model
from iguana_ros.errors import InputError
from iguana_ros.physics.errors import SimulationDiverged
from iguana_ros.physics.fidelity import EXPLICIT_ELASTIC_LIMIT, get_fidelity, HELD_ELASTIC_LIMIT, MAX_ELASTIC_EVERY
from iguana_ros.physics.meshes import box_mesh
from iguana_ros.physics.simulator import elastic_stiffness_ratio, SoftBodySimulator
from iguana_ros.terrain.heightfield import HeightField


@pytest.fixture(scope='module')
def medium():
    return build_model('medium', 'normal')


def _stiff_fem(model, factor):
    """Return `model` with its Young's modulus times `factor` (the springs unchanged)."""
    return dataclasses.replace(model, youngs_modulus=np.asarray(model.youngs_modulus) * factor)


def test_auto_is_explicit_only_where_the_fem_is_negligible(medium):
    """Medium: explicit, held (h²λ ~1e-3); coarse (a mode only its FEM holds): explicit each step; E x1e4: implicit."""
    sim = SoftBodySimulator(medium, None, 'balanced')
    assert sim.elastic_ratio < 0.2 * EXPLICIT_ELASTIC_LIMIT and not sim.elastic_implicit
    assert sim.stats['elastic_integration'] == 'explicit'
    every = sim.elastic_every                 # held (its few fast tets every step; the bound: test_elastic_rates)
    assert every >= 2 and sim.elastic_fast_tets < 0.05 * len(medium.tets)
    assert every == MAX_ELASTIC_EVERY or (every + 1) ** 2 * sim.elastic_ratio > HELD_ELASTIC_LIMIT
    coarse = SoftBodySimulator(build_model('coarse', 'normal'), None, 'balanced')
    assert HELD_ELASTIC_LIMIT < coarse.elastic_ratio <= EXPLICIT_ELASTIC_LIMIT and not coarse.elastic_implicit
    assert coarse.elastic_every >= 2 and 0 < coarse.elastic_fast_tets < 0.25 * len(coarse.model.tets)  # elastic_rates
    assert SoftBodySimulator(build_model('coarse', 'normal'), None, 'fast').elastic_implicit   # h²λ = 12 at 1/200
    stiff = SoftBodySimulator(_stiff_fem(medium, 1e4), None, 'balanced')
    assert stiff.elastic_ratio == pytest.approx(1e4 * sim.elastic_ratio, rel=1e-6) and stiff.elastic_implicit
    forced = SoftBodySimulator(medium, None, 'balanced', elastic_integration='implicit')
    assert forced.elastic_implicit and forced.elastic_ratio is None and forced.elastic_every == 1


def test_elastic_stiffness_ratio_is_the_largest_generalized_eigenvalue():
    """The sparse estimate equals a dense generalized eigensolve of (K_e, A) on a small block."""
    block = box_mesh(size=(0.1, 0.06, 0.04), cells=(3, 2, 1), total_mass=0.5, youngs_modulus=1e4,
                     spring_stiffness=1e4)
    sim = SoftBodySimulator(block, None, 'balanced', elastic_integration='implicit')
    h, alpha, beta = sim.fidelity.dt, sim._fp[1], sim._fp[2]
    ratio = elastic_stiffness_ratio(sim._model, sim.pattern, sim.rest_positions, sim.desired_lengths_rest, h, alpha,
                                    beta)
    with_fem = SoftBodySimulator(block, None, 'balanced', elastic_integration='implicit', rayleigh_beta=0.0)
    without = SoftBodySimulator(block, None, 'balanced', elastic_integration='explicit', rayleigh_beta=0.0)
    k_e = _stiffness_matrix(with_fem) - _stiffness_matrix(without)     # the FEM's share of h² K
    a = _system_matrix(sim, explicit=True)
    dense = scipy.linalg.eigh(k_e, a, eigvals_only=True)[-1]
    assert ratio == pytest.approx(dense, rel=1e-6)


def _stiffness_matrix(sim):
    """Return h² K of an unstepped simulator's first system matrix (full, dense), its mass part removed."""
    sim.advance_frame(n_steps=1)
    full = sim.pattern.to_scipy(sim._state.matrix_blocks).toarray()
    mass = np.repeat(sim._model.mass * (1.0 + sim.fidelity.dt * sim._fp[1]), 3)
    return full - np.diag(mass)


def _system_matrix(sim, explicit):
    """Return A = M(1 + hα) + (hβ + h²) K_springs of a fresh simulator's first step (dense)."""
    fresh = SoftBodySimulator(sim.model, None, 'balanced', elastic_integration='explicit' if explicit else 'implicit')
    fresh.advance_frame(n_steps=1)
    return fresh.pattern.to_scipy(fresh._state.matrix_blocks).toarray()


def test_explicit_fem_walks_like_the_implicit_step(medium):
    """
    Explicit FEM, every step and held as 'auto' holds it, stays within 0.5 mm of the implicit step.

    0.5 s of the bench gait on hills; the dt 1/1200 error is ~17 mm. CG to 1e-3, so that the schemes' own difference
    (~0.03 mm) is compared, not the solver's: at `balanced`'s 1e-2 each run lands 0.1–0.8 mm from its tight solve,
    by how well its preconditioner fits (with the turned factor, explicit 0.14 and implicit 0.79 mm).
    """
    from iguana_ros.physics import integrator as itg
    terrain = HeightField.hills(amplitude=0.03, wavelength=0.6, seed=0, extent=3.0)
    gait = gait_for(medium)
    runs = {}
    for name, scheme in (('implicit', 'implicit'), ('explicit', 'explicit'), ('held', 'auto')):
        sim = SoftBodySimulator(medium, terrain, 'balanced', elastic_integration=scheme, cg_tol=1e-3)
        assert name != 'held' or sim._ip[itg.IP_ELASTIC_EVERY] >= 2
        start = sim.rest_positions + [0.0, 0.0, 0.05]
        sim.reset(start)
        for _ in range(15):
            sim.advance_frame(gait.desired_lengths(sim.time))
        runs[name] = sim.positions
        moved = np.sqrt(np.mean(np.sum((sim.positions - start) ** 2, axis=1)))
    for name in ('explicit', 'held'):
        gap = np.sqrt(np.mean(np.sum((runs[name] - runs['implicit']) ** 2, axis=1)))
        assert moved > 0.01 and gap < 5e-4, name


def _squashed_second(model, **overrides):
    """Return whether 1 s from a 5 % squashed rest shape without gravity stays finite (`overrides` of `balanced`)."""
    sim = SoftBodySimulator(model, None, 'balanced', gravity=0.0, **overrides)
    sim.reset(model.rest_positions * [1.05, 1.0, 0.95])
    try:
        for _ in range(30):
            sim.advance_frame()
    except SimulationDiverged:
        return False
    return bool(np.all(np.isfinite(sim.positions)))


def test_the_explicit_limit_keeps_a_wide_margin(medium):
    """
    At dt 1/1200 the explicit FEM is stable to h²λ ≈ 3–4 as the limit's rule says: 2.3 holds, 11.6 diverges.

    So the bodies 'auto' makes explicit (h²λ <= EXPLICIT_ELASTIC_LIMIT = 0.4) are ~8x inside it (measured: 2.9
    holds, 3.5 diverges); one at the limit (E x300, h²λ 0.35) is explicit and stable.
    """
    at_limit = SoftBodySimulator(_stiff_fem(medium, 300.0), None, 'balanced')
    assert 0.3 < at_limit.elastic_ratio <= EXPLICIT_ELASTIC_LIMIT and not at_limit.elastic_implicit
    assert _squashed_second(_stiff_fem(medium, 300.0))
    assert _squashed_second(_stiff_fem(medium, 2000.0), elastic_integration='explicit')
    assert not _squashed_second(_stiff_fem(medium, 1e4), elastic_integration='explicit')


def test_a_stiff_fem_forced_explicit_diverges_where_auto_stays_stable(medium):
    """The rule matters: E x1e4 explicit at dt 1/300 blows up within a frame; auto keeps it implicit and stable."""
    stiff = _stiff_fem(medium, 1e4)
    start = medium.rest_positions * [1.02, 1.0, 0.98]
    forced = SoftBodySimulator(stiff, None, 'fast', elastic_integration='explicit', gravity=0.0)
    forced.reset(start)
    with pytest.raises(SimulationDiverged):
        for _ in range(10):
            forced.advance_frame()
    auto = SoftBodySimulator(stiff, None, 'fast', gravity=0.0)
    auto.reset(start)
    for _ in range(10):
        auto.advance_frame()
    assert auto.elastic_implicit and np.all(np.isfinite(auto.positions))


def test_a_bad_elastic_integration_is_one_clear_error():
    with pytest.raises(InputError, match='elastic_integration'):
        get_fidelity('balanced', elastic_integration='sometimes')


def test_the_matrix_free_operator_is_the_scattered_matrix(medium):
    """
    With the FEM explicit every off-diagonal block is one spring's: the matrix-free step equals the scattered blocks.

    Its forces, its products K v and A x, and the blocks it assembles for a factorisation.
    """
    from iguana_ros.physics import integrator as itg
    from iguana_ros.physics.assembly import block_matvec
    from iguana_ros.physics.forces import (assemble_spring_matrix, spring_forces, spring_forces_operator,
                                           spring_operator_matvec)
    sim = SoftBodySimulator(medium, None, 'balanced')
    assert sim._ip[itg.IP_MATRIX_FREE] and not SoftBodySimulator(_stiff_fem(medium, 1e4), None)._ip[
        itg.IP_MATRIX_FREE]                   # a stiff FEM stays implicit: its tets write blocks too
    assert not SoftBodySimulator(medium, None, 'balanced', preconditioner='jacobi')._ip[itg.IP_MATRIX_FREE]
    m = sim._model
    rng = np.random.default_rng(0)
    n = len(sim.rest_positions)
    x = sim.rest_positions + rng.normal(scale=2e-3, size=(n, 3))
    v, dv, probe = rng.normal(size=(3, n, 3))
    lengths = sim.desired_lengths_rest * rng.uniform(0.9, 1.1, len(sim.desired_lengths_rest))
    node_matrix = np.zeros((n, 3, 3))
    node_matrix[:] = np.eye(3) * m.mass[:, None, None]
    node_matrix[:5] += rng.normal(size=(5, 3, 3)) * 1e-3      # contact terms on a few nodes (symmetrised below)
    node_matrix[:5] += node_matrix[:5].transpose(0, 2, 1)
    scattered, assembled = np.zeros((2, sim.pattern.n_blocks, 3, 3))
    assembled[:] = np.nan                     # every block is written, none is read
    forces = np.zeros((2, n, 3))
    spring_forces(x, m.springs, m.spring_stiffness, lengths, forces[0], scattered, m.spring_blocks, 1e-6)
    coef, work, node_work = np.zeros((5, len(m.springs))), np.zeros((9, len(m.springs))), np.zeros((n, 9))
    rhs, kdv, ax = np.zeros((3, n, 3))
    h = 1e-3
    spring_forces_operator(x, v, dv, m.springs, m.spring_stiffness, lengths, coef, node_work, work, h, rhs, kdv,
                           1e-6)
    held = np.zeros((2, n, 3))                # between Jacobian refreshes (scale 0) the same coefficients apply
    spring_forces_operator(x, v, dv, m.springs, m.spring_stiffness, lengths, coef, node_work, work, h, *held, 0.0)
    assert np.array_equal(held, [rhs, kdv])
    tol = 1e-12 * np.abs(scattered).max()
    kv = np.zeros((n, 3))
    block_matvec(m.row_ptr, m.cols, scattered, v, kv)
    np.testing.assert_allclose(rhs, h * forces[0] - kv, rtol=0, atol=1e-12 * h * np.abs(forces[0]).max()
                               + tol * np.abs(v).max() * 50)
    expected = np.zeros((n, 3))
    block_matvec(m.row_ptr, m.cols, scattered, dv, expected)
    np.testing.assert_allclose(kdv, expected, rtol=0, atol=tol * np.abs(dv).max() * 50)
    scattered[m.diag] += node_matrix
    assemble_spring_matrix(coef, node_matrix, m.diag, m.spring_blocks, m.node_spring_ptr, m.node_springs, assembled)
    np.testing.assert_allclose(assembled, scattered, rtol=0, atol=tol)
    expected = np.zeros((n, 3))
    block_matvec(m.row_ptr, m.cols, scattered, probe, expected)
    spring_operator_matvec(m.springs, coef, node_matrix, probe, ax)
    np.testing.assert_allclose(ax, expected, rtol=0, atol=tol * np.abs(probe).max() * 50)


def test_matrix_free_steps_follow_the_assembled_ones(medium):
    """0.5 s of the bench gait on hills: the matrix-free step stays within 0.1 mm of the step on assembled blocks."""
    from iguana_ros.physics import integrator as itg
    terrain = HeightField.hills(amplitude=0.03, wavelength=0.6, seed=0, extent=3.0)
    gait = gait_for(medium)
    runs = []
    for matrix_free in (1, 0):
        sim = SoftBodySimulator(medium, terrain, 'balanced')
        sim._ip[itg.IP_MATRIX_FREE] = matrix_free
        start = sim.rest_positions + [0.0, 0.0, 0.05]
        sim.reset(start)
        for _ in range(15):
            sim.advance_frame(gait.desired_lengths(sim.time))
        runs.append(sim.positions)
        assert sim.stats['cg_iterations_per_step'] < 2.0
    assert np.sqrt(np.mean(np.sum((runs[0] - start) ** 2, axis=1))) > 0.01
    assert np.sqrt(np.mean(np.sum((runs[0] - runs[1]) ** 2, axis=1))) < 1e-4
