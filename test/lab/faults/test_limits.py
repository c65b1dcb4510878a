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

"""
Pushes and desired spring lengths drawn at random within what the nodes accept (issue 30).

None diverges, and the run's outcome is what its root trajectory shows (no run called completed whose body left the
terrain or fell).
"""
from __future__ import annotations

import numpy as np
import pytest

from iguana_lab.faults.limits import draw_trials, limits_suite, push_spec, trajectory_outcome
from iguana_ros.physics.pushes import region_masses
from iguana_ros.terrain.heightfield import HeightField
from iguana_ros.validation import check_push


def test_drawn_pushes_reach_the_limits_and_are_accepted():
    from iguana_ros.body.model import build_model
    from iguana_ros.constants import BODY_MASS, MAX_PUSH_BODY_DELTA_V, MAX_PUSH_REGION_DELTA_V
    models = {r: build_model(r) for r in ('coarse', 'medium', 'fine')}
    near_limit = 0
    for trial in draw_trials('push', 200, seed=5):
        masses = region_masses(models[trial.resolution].node_mass, models[trial.resolution].node_tags)
        push = push_spec(trial, masses)
        check_push(push.force, np.zeros(3), push.region, masses, push.at, push.duration)
        impulse = np.linalg.norm(push.force) * push.duration
        limit = min(masses[push.region] * MAX_PUSH_REGION_DELTA_V, BODY_MASS * MAX_PUSH_BODY_DELTA_V)
        near_limit += impulse > 0.9 * limit
    assert near_limit > 60                         # biased to the limit, not a sample of gentle pushes


def test_the_trajectory_reading_sees_a_body_off_the_terrain_and_a_fall():
    terrain = HeightField.flat(extent=5.0)
    n = 60
    roots, upright = np.zeros((n, 3)), np.tile([0.0, 0.0, 0.0, 1.0], (n, 1))
    assert trajectory_outcome(roots, upright, terrain) == 'completed'
    off = roots.copy()
    off[40:, 0] = 5.2
    assert trajectory_outcome(off, upright, terrain) == 'left_terrain'
    on_back = upright.copy()
    on_back[10:] = [1.0, 0.0, 0.0, 0.0]                     # rolled 180°, from frame 10 on
    assert trajectory_outcome(roots, on_back, terrain) == 'fell'
    assert trajectory_outcome(roots[:40], on_back[:40], terrain) == 'completed'      # 30 frames tilted: not yet


def test_a_sample_of_the_suite_neither_diverges_nor_misreports():
    result = limits_suite(pushes=10, lengths=10, seed=11, workers=2)
    assert result['ok'], result
    assert result['push']['accepted'] == 10 and result['lengths']['accepted'] == 10


@pytest.mark.long
def test_five_hundred_pushes_and_five_hundred_length_runs_within_the_limits():
    """`iguana bench faults limits --pushes 500 --lengths 500 --seed 0`: the figures are in the closing note."""
    result = limits_suite(pushes=500, lengths=500, seed=0, workers=2)
    print({k: {f: v for f, v in row.items() if f != 'failures'} if isinstance(row, dict) else row
           for k, row in result.items()})
    assert result['ok'], {k: row['failures'][:5] for k, row in result.items() if isinstance(row, dict)}
    assert result['push']['diverged'] == 0 == result['lengths']['diverged']
    assert result['push']['accepted'] == 500 == result['lengths']['accepted']
