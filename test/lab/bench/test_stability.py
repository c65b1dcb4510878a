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

"""Stability sweep: every extreme scenario stays finite and bounded, or stops with a named SimulationDiverged."""
import numpy as np
import pytest

from iguana_lab.bench.stability import inverted_start, REST_DEPTH_LIMIT, run_scenario, SCENARIOS
from iguana_ros.constants import MAX_NODE_SPEED
from iguana_ros.physics.meshes import box_mesh


@pytest.fixture(scope='module')
def body():
    """Return a 4 kg, 30 × 10 × 6 cm block of 60 tets: the iguana's mass on a mesh small enough for a quick sweep."""
    return box_mesh(size=(0.3, 0.1, 0.06), cells=(5, 2, 1), total_mass=4.0)


@pytest.mark.parametrize('name', list(SCENARIOS))
def test_scenario_is_stable(body, name):
    """
    Every scenario stays stable on the block (docs/RESULTS.md's table).

    Finite, below the speed bound, no tet inverted through the last 0.2 s (a sliver of the 1 kPa body may flip in
    and out while resting, `PERSIST_FRAMES`), resting on the ground. A divergence fails the test, naming its cause;
    that a divergence is reported clearly is test_simulator.py's.
    """
    result = run_scenario(body, name, seconds=1.0)
    assert result['outcome'] == 'stable', f"{name}: diverged ({result['cause']}): {result['message']}"
    assert result['finite'] and result['max_speed'] < MAX_NODE_SPEED
    assert result['inverted_tets_persisting'] == 0, result
    if 'push' not in name:                                   # the 1 kN push throws the block into the air
        assert result['final_max_depth'] < REST_DEPTH_LIMIT  # no node 1 cm inside the ground at the end


def test_inverted_start_really_inverts(body):
    from iguana_ros.physics.meshes import tet_volumes

    x = inverted_start(body)
    assert np.sum(tet_volumes(x, body.tets) <= 0) >= 3
