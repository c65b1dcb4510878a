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

"""Body-body contact against hand-computed cases: a node at a known depth in a box, at rest and sliding."""
import numpy as np
import pytest

from iguana_ros.physics.body_contact import (BodyContactParams, contact_forces, ContactBody, penetration_depths,
                                             STABLE_OMEGA_DT)
from iguana_ros.physics.meshes import box_mesh, single_tet

BLOCK = 1.0 / 1200


def _tet_with_tip_in_box(depth: float):
    """Return (tet body, box body, tet positions, box positions): the tet's apex `depth` m under the box's top."""
    box, tet = box_mesh(size=(0.3, 0.3, 0.1), cells=(3, 3, 1)), single_tet(edge=0.05)
    tip = np.array([0.01, 0.02, 0.1 - depth])
    tet_x = tet.rest_positions - tet.rest_positions[3] + tip       # node 3 is the apex (0, 0, edge)
    tet_x[:3, 2] = tet_x[3, 2] + 0.05 + 0.02                       # the base well above the box
    return ContactBody.of_model(tet), ContactBody.of_model(box), tet_x, box.rest_positions.copy()


@pytest.mark.parametrize('depth', [0.001, 0.004])
def test_a_node_at_rest_at_a_known_depth_is_pushed_straight_out_by_stiffness_times_depth(depth):
    tet, box, xa, xb = _tet_with_tip_in_box(depth)
    params = BodyContactParams()
    forces, pairs = contact_forces([tet, box], [xa, xb], [np.zeros_like(xa), np.zeros_like(xb)], params, BLOCK)
    k = params.stiffness_for(tet, BLOCK)
    assert k == min(params.stiffness, (STABLE_OMEGA_DT / BLOCK) ** 2 * tet.mean_node_mass)
    np.testing.assert_allclose(forces[0][3], [0.0, 0.0, k * depth], rtol=1e-9, atol=1e-12)
    assert not forces[0][:3].any()                                  # the other nodes are outside
    np.testing.assert_allclose(forces[1].sum(axis=0), -forces[0].sum(axis=0), rtol=1e-12)
    [pair] = pairs
    assert (pair.a, pair.b, pair.nodes) == (0, 1, 1) and pair.max_depth == pytest.approx(depth)
    assert penetration_depths(box, xa, xb)[3] == pytest.approx(depth) and penetration_depths(box, xa, xb)[:3].max() == 0


@pytest.mark.parametrize('speed', [0.1, 10.0])
def test_sliding_is_resisted_viscously_up_to_the_friction_coefficient_times_the_normal_force(speed):
    tet, box, xa, xb = _tet_with_tip_in_box(0.004)
    va = np.zeros_like(xa)
    va[3] = [speed, 0.0, 0.0]
    params = BodyContactParams()
    forces, _ = contact_forces([tet, box], [xa, xb], [va, np.zeros_like(xb)], params, BLOCK)
    fx, fz = forces[0][3, 0], forces[0][3, 2]
    k = params.stiffness_for(tet, BLOCK)
    damping = 2.0 * params.damping_ratio * np.sqrt(k * tet.mean_node_mass)
    assert fz == pytest.approx(k * 0.004)                          # no normal velocity: no normal damping
    assert fx == pytest.approx(-min(params.friction * fz, damping * speed))
    assert (fx == pytest.approx(-params.friction * fz)) == (speed == 10.0)    # slow: viscous; fast: Coulomb
    np.testing.assert_allclose(forces[1].sum(axis=0), -forces[0].sum(axis=0), rtol=1e-12)
