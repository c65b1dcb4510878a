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

"""Simulator physics checks with known answers: free fall, conservation, friction on slopes, pushes, errors."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from iguana_ros.constants import GRAVITY
from iguana_ros.errors import InputError
from iguana_ros.physics.errors import SimulationDiverged
from iguana_ros.physics.meshes import box_mesh
from iguana_ros.physics.simulator import SoftBodySimulator
from iguana_ros.terrain.heightfield import HeightField

NO_DAMPING = {'rayleigh_alpha': 0.0, 'rayleigh_beta': 0.0}


@pytest.fixture(scope='module')
def block():
    """Return a 10 × 6 × 4 cm block of 12 cubes (72 tets), 0.5 kg, E = 1e5 Pa."""
    return box_mesh(size=(0.1, 0.06, 0.04), cells=(3, 2, 1), total_mass=0.5, youngs_modulus=1e5,
                    spring_stiffness=100.0)


def test_free_fall_matches_g(block):
    sim = SoftBodySimulator(block, terrain=None, fidelity='balanced', dt=1 / 1200, cg_tol=1e-10, **NO_DAMPING)
    z0 = sim.center_of_mass()[2]
    sim.advance(0.5)
    v = sim.velocities
    t = sim.time
    assert t == pytest.approx(0.5)
    com_velocity = block.node_mass @ v / block.node_mass.sum()
    np.testing.assert_allclose(com_velocity, [0, 0, -GRAVITY * t], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(v[:, 2], -GRAVITY * t, rtol=1e-5)     # nodes: up to the CG tolerance
    # backward Euler: z_n = z0 − g h² n(n+1)/2, i.e. g t²/2 plus g h t / 2
    drop = z0 - sim.center_of_mass()[2]
    assert drop == pytest.approx(0.5 * GRAVITY * t ** 2 + 0.5 * GRAVITY * sim.fidelity.dt * t, rel=1e-6)


def test_momentum_conserved_without_ground_and_damping(block):
    sim = SoftBodySimulator(block, terrain=None, gravity=0.0, fidelity='accurate', dt=1 / 1200, **NO_DAMPING)
    x0 = block.rest_positions * [1.03, 1.0, 0.98]                     # stretched: it will vibrate
    omega = np.array([0.0, 2.0, 5.0])                                  # and spin
    com = block.node_mass @ x0 / block.node_mass.sum()
    v0 = np.cross(omega, x0 - com) + [0.3, -0.1, 0.2]
    sim.reset(x0, v0)
    m = block.node_mass[:, None]

    def momenta():
        x, v = sim.positions, sim.velocities
        return (m * v).sum(axis=0), (np.cross(x, m * v)).sum(axis=0)

    p0, l0 = momenta()
    desired = block.spring_rest_lengths * 1.05     # active springs too: internal forces only
    for _ in range(30):
        sim.advance_frame(desired)
    p1, l1 = momenta()
    # linear momentum: exact up to the CG residual. Angular momentum: the internal forces are torque-free
    # (test_forces), but backward Euler's numerical damping of the vibration is not; measured 0.28 % after 1 s.
    np.testing.assert_allclose(p1, p0, atol=1e-9 * np.linalg.norm(p0))
    np.testing.assert_allclose(l1, l0, atol=5e-3 * np.linalg.norm(l0))
    assert np.linalg.norm(sim.velocities - v0) > 0.5   # it did deform and vibrate


def _block_on_slope(block, slope_deg, friction=None, seconds=2.0):
    """Block placed on a plane rising along +x at `slope_deg`; returns (simulator, downhill travel of the COM)."""
    terrain = HeightField.tilted_plane(slope_deg, (1.0, 0.0))
    rot = Rotation.from_rotvec([0.0, -np.radians(slope_deg), 0.0]).as_matrix()   # tilt the block onto the plane
    x0 = block.rest_positions @ rot.T + [0, 0, 1e-4]
    sim = SoftBodySimulator(block, terrain=terrain, friction=friction)
    sim.reset(x0)
    sim.advance(0.2)                                 # touch down and settle
    start = sim.center_of_mass()
    sim.advance(seconds)
    downhill = np.array([-np.cos(np.radians(slope_deg)), 0.0, -np.sin(np.radians(slope_deg))])
    return sim, float((sim.center_of_mass() - start) @ downhill)


def test_block_rests_on_30_degree_slope_with_mu_1(block):
    sim, travel = _block_on_slope(block, 30.0)
    assert abs(travel) < 1e-3
    assert np.abs(sim.velocities).max() < 1e-3 and sim.in_contact.sum() >= 4
    depth = HeightField.tilted_plane(30.0).height(sim.positions[:, :2]) - sim.positions[:, 2]
    assert depth.max() < 0.01


def test_block_slides_on_50_degree_slope_with_mu_1(block):
    _, travel = _block_on_slope(block, 50.0, seconds=1.0)
    # Coulomb sliding: a = g (sin θ − μ cos θ) = 1.21 m/s², 0.6 m in 1 s (plus speed gained while settling)
    a = GRAVITY * (np.sin(np.radians(50)) - np.cos(np.radians(50)))
    assert 0.5 * a * 0.8 < travel < 0.5 * a * 1.0 + 0.2 * a * 1.5


def test_per_region_friction(block):
    t = 0.5
    _, travel = _block_on_slope(block, 30.0, friction={'bottom': 0.2}, seconds=t)
    a = GRAVITY * (np.sin(np.radians(30)) - 0.2 * np.cos(np.radians(30)))
    assert travel > 0.8 * 0.5 * a * t ** 2                   # slides with μ = 0.2 (≥ 80 % of the Coulomb answer)


def test_block_rests_on_flat_ground_without_sinking(block):
    sim = SoftBodySimulator(block, HeightField.flat())
    sim.reset(block.rest_positions + [0, 0, 0.05])          # dropped from 5 cm
    sim.advance(1.0)
    assert sim.positions[:, 2].min() > -0.01 and np.abs(sim.velocities).max() < 1e-3
    assert sim.in_contact.sum() == block.node_tags['bottom'].sum()
    assert abs(sim.center_of_mass()[2] - 0.02) < 1e-3       # resting at its rest height within 1 mm


def test_push_impulse_gives_momentum(block):
    sim = SoftBodySimulator(block, terrain=None, gravity=0.0, cg_tol=1e-9, **NO_DAMPING)
    push = np.zeros_like(block.rest_positions)
    left = block.node_tags['left']
    push[left] = [0.0, -40.0, 0.0] / left.sum()              # 40 N to the right, for 0.1 s
    sim.advance(0.1, external_forces=push)
    momentum = block.node_mass @ sim.velocities
    np.testing.assert_allclose(momentum, [0.0, -4.0, 0.0], atol=1e-6)


def test_deterministic_and_solvers_agree(block):
    def run(**kw):
        sim = SoftBodySimulator(block, HeightField.hills(amplitude=0.01, wavelength=0.2, seed=1, extent=1.0), **kw)
        sim.reset(block.rest_positions + [0, 0, 0.02])
        bend = block.spring_rest_lengths * (1 + 0.05 * np.sign(block.rest_positions[block.springs[:, 0], 1]))
        for _ in range(10):
            sim.advance_frame(bend)
        return sim.positions

    a, b = run(), run()
    assert np.array_equal(a, b)
    direct = run(fidelity='accurate', dt=1 / 1200, solver='direct')
    cg = run(fidelity='accurate', dt=1 / 1200, cg_tol=1e-10)
    np.testing.assert_allclose(direct, cg, atol=1e-7)


def test_divergence_is_reported_not_returned(block):
    sim = SoftBodySimulator(block, terrain=None, max_speed=1.0)
    with pytest.raises(SimulationDiverged, match='m/s, above the 1 m/s bound') as info:
        sim.advance(1.0)
    assert info.value.cause == 'speed' and 0.09 < info.value.time < 0.12
    with pytest.raises(SimulationDiverged):              # stays failed until reset
        sim.advance_frame()
    sim.reset()
    sim.advance_frame()


def test_solver_failure_is_named(block):
    stiff = box_mesh(size=(0.1, 0.06, 0.04), cells=(3, 2, 1), total_mass=0.5, youngs_modulus=1e9)
    sim = SoftBodySimulator(stiff, terrain=None, dt=1 / 60, cg_max_iter=1, cg_tol=1e-8, jacobian_every=1,
                            preconditioner='jacobi', cg_fallback=False)     # 1 block-Jacobi iteration cannot do
    sim.reset(stiff.rest_positions * [1.2, 1.0, 1.0])
    with pytest.raises(SimulationDiverged, match='CG linear solver failed') as info:
        sim.advance_frame()
    assert info.value.cause == 'solver'
    rescued = SoftBodySimulator(stiff, terrain=None, dt=1 / 60, cg_max_iter=1, cg_tol=1e-8, jacobian_every=1,
                                preconditioner='jacobi')
    rescued.reset(stiff.rest_positions * [1.2, 1.0, 1.0])
    rescued.advance_frame()
    assert rescued.stats['direct_fallback_steps'] >= 1 and np.isfinite(rescued.positions).all()


@pytest.mark.parametrize('kwargs, words', [
    ({'fidelity': 'turbo'}, 'unknown preset'),
    ({'dt': 0.0}, 'dt must be'),
    ({'solver': 'gauss'}, 'solver must be'),
    ({'friction': {'nose': 0.5}}, 'unknown node tag'),
])
def test_bad_settings_raise_input_error(block, kwargs, words):
    with pytest.raises(InputError, match=words):
        SoftBodySimulator(block, **kwargs)


def test_bad_frame_inputs_raise_input_error(block):
    sim = SoftBodySimulator(block)
    with pytest.raises(InputError, match='desired_lengths'):
        sim.advance_frame(np.full(3, 0.1))
    with pytest.raises(InputError, match='external_forces'):
        sim.advance_frame(None, np.full((len(block.rest_positions), 3), np.nan))


def test_free_fall_with_the_default_mass_damping_follows_the_damped_solution(block):
    """
    α = 0.2 /s damps absolute motion (docs/METHODS.md, "Forces").

    The drop in 1.5 s is (g/α)(t − (1 − e^(−αt))/α) = 10.0 m, not g t²/2 = 11.0 m; β K does not act on a rigid
    translation.
    """
    sim = SoftBodySimulator(block, terrain=None, fidelity='balanced', cg_tol=1e-10)
    z0 = sim.center_of_mass()[2]
    sim.advance(1.5)
    alpha, t = 0.2, sim.time
    expected = GRAVITY / alpha * (t - (1.0 - np.exp(-alpha * t)) / alpha)
    assert z0 - sim.center_of_mass()[2] == pytest.approx(expected, rel=2e-3)
    assert expected == pytest.approx(10.0, abs=0.01) and 0.5 * GRAVITY * t ** 2 == pytest.approx(11.03, abs=0.01)
