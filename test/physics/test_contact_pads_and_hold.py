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

"""Sole pads (per-node contact offset), ground reaction forces, and the first-order hold of desired lengths."""
import dataclasses

import numpy as np
import pytest

from iguana_ros.constants import GRAVITY
from iguana_ros.errors import InputError
from iguana_ros.physics.meshes import box_mesh
from iguana_ros.physics.simulator import SoftBodySimulator
from iguana_ros.terrain.heightfield import HeightField


@pytest.fixture(scope='module')
def block():
    """Return a 10 × 6 × 4 cm block of 12 cubes, 0.5 kg, resting on its bottom face (z = 0)."""
    return box_mesh(size=(0.1, 0.06, 0.04), cells=(3, 2, 1), total_mass=0.5, youngs_modulus=1e5,
                    spring_stiffness=100.0)


def _settled(model, seconds=1.0):
    """Return the block after `seconds` on flat ground from its rest pose."""
    sim = SoftBodySimulator(model, HeightField.flat(), 'balanced')
    sim.advance(seconds)
    return sim


def test_ground_forces_carry_the_weight_at_rest(block):
    sim = _settled(block)
    forces = sim.ground_forces()
    total = forces.sum(axis=0)
    assert total[2] == pytest.approx(block.node_mass.sum() * GRAVITY, rel=1e-3)
    assert np.hypot(*total[:2]) < 1e-3 * total[2]
    assert np.all(forces[~sim.in_contact] == 0.0)


def test_a_contact_offset_lifts_its_nodes_by_that_much(block):
    """
    Nodes with offset d touch the ground d above it.

    A block whose bottom nodes all have offset 5 mm rests 5 mm higher (to the penalty sink of ~0.01 mm).
    """
    bottom = block.rest_positions[:, 2] < 1e-9
    padded = dataclasses.replace(block, contact_offset=np.where(bottom, 0.005, 0.0))
    plain, lifted = _settled(block), _settled(padded)
    rise = lifted.positions[bottom, 2].mean() - plain.positions[bottom, 2].mean()
    assert rise == pytest.approx(0.005, abs=2e-4)
    assert lifted.in_contact[bottom].all()


def test_bad_contact_offset_is_an_input_error(block):
    with pytest.raises(InputError, match='contact_offset'):
        SoftBodySimulator(dataclasses.replace(block, contact_offset=-np.ones(len(block.rest_positions))),
                          HeightField.flat())


def _weightless(block, hold):
    """Return a weightless block at rest under its rest lengths, after one step."""
    sim = SoftBodySimulator(block, None, 'balanced', gravity=0.0, length_hold=hold, cg_tol=1e-10)
    sim.advance_frame(block.spring_rest_lengths, n_steps=1)
    return sim


def test_first_order_hold_ramps_the_desired_lengths_within_a_call(block):
    """
    With the linear hold, one call of n steps toward new lengths ends exactly where n one-step calls along the ramp end.

    The zero hold applies the new lengths from the first step and ends elsewhere.
    """
    rest, n = block.spring_rest_lengths, 8
    target = rest * 1.1
    ramped = _weightless(block, 'linear')
    ramped.advance_frame(target, n_steps=n)
    stepwise = _weightless(block, 'zero')
    for k in range(n):
        stepwise.advance_frame(rest + (target - rest) * (k + 1) / n, n_steps=1)
    np.testing.assert_allclose(ramped.positions, stepwise.positions, atol=1e-9)
    held = _weightless(block, 'zero')
    held.advance_frame(target, n_steps=n)
    assert np.abs(held.positions - ramped.positions).max() > 1e-5
    with pytest.raises(InputError, match='length_hold'):
        SoftBodySimulator(block, None, length_hold='cubic')


def test_the_block_maximum_test_changes_no_contact(block):
    """Nodes above their terrain block's highest height skip the interpolation: the run is bitwise the same."""
    from iguana_ros.physics.kernel_data import kernel_constant
    terrain = HeightField.hills(amplitude=0.01, wavelength=0.6, seed=3, extent=1.0)
    runs = []
    for skip in (True, False):
        sim = SoftBodySimulator(block, terrain, 'balanced')
        if not skip:
            sim._model = sim._model._replace(height_bounds=kernel_constant(np.full(sim._model.height_bounds.shape,
                                                                                   np.inf)))
        sim.reset(sim.rest_positions + [0.3, 0.2, 0.03])
        sim.advance(0.4, external_forces=np.tile([0.3, 0.0, 0.0], (len(sim.rest_positions), 1)))
        runs.append((sim.positions, sim.in_contact, sim.ground_forces()))
        assert 0 < sim.in_contact.sum() < len(sim.rest_positions)
        sim.reset()
        assert not sim._state.contact_stiffness.any() and not sim._state.contact_damping.any()
    for a, b in zip(*runs):
        assert np.array_equal(a, b)
