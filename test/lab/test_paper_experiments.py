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
The paper's experiments as measured effects that must not vanish.

Terrain adaptation on hills (Figure 11) and 40 N pushes on the walking trunk at six stride phases, normal vs softer
model (Section VIII-D, Figure 12). Medium mesh, as in the tables of docs/RESULTS.md; the runs take ~40 s of wall time on
two cores.
"""

import pytest

from iguana_lab.push_experiment import PushSettings, run_push_experiment
from iguana_ros.pipeline import run
from iguana_ros.run_metrics import metrics_of_run
from iguana_ros.scene import load_scene

pytestmark = pytest.mark.long


@pytest.fixture(scope='module')
def hills_runs():
    """Return the default hills scene (goal 3 m ahead over hills up to 8 cm) with and without adaptation."""
    scene = load_scene('hills')
    out = {}
    for adapt in (True, False):
        result = run(scene, adaptation=adapt, stop_after_goal=1.0)
        out[adapt] = metrics_of_run(result, scene)
    return out


def test_figure_11_adaptation_gets_over_the_hills_without_slipping(hills_runs):
    """
    With terrain adaptation the iguana gets over the hills without slipping (Figure 11).

    Measured: with adaptation the goal at 14.2 s, slip 0.079 m per stride (4 feet), 91 % of swings clear; without it the
    iguana gets stuck 1.6 m short, slip 0.31 m per stride, its hind feet dragged or hanging.
    """
    adapted, plain = hills_runs[True], hills_runs[False]
    assert adapted.reached_goal and not adapted.fell
    assert adapted.foot_slip_per_stride < 0.12
    assert plain.foot_slip_per_stride > 1.5 * adapted.foot_slip_per_stride
    assert (not plain.reached_goal) or plain.time_to_goal > 1.2 * adapted.time_to_goal


@pytest.fixture(scope='module')
def pushes():
    """Six push phases per model, a shortened recovery window (docs/RESULTS.md uses 2 s)."""
    return run_push_experiment(settings=PushSettings(phases=6, recovery=1.0), workers=2)['models']


def test_pushes_displace_both_models_and_both_walk_on(pushes):
    """
    Every 40 N, 0.1 s push moves the trunk sideways by more than 1 cm, and nobody falls.

    The body walks on at (nearly) its unpushed speed; docs/RESULTS.md "Pushes" gives the measured figures.
    """
    for name, model in pushes.items():
        assert model['fell'] == 0, name
        assert model['peak_lateral_min_m'] > 0.01, name
        assert model['peak_lateral_max_m'] < 0.15, name
        assert model['recovered_speed_fraction_median'] > 0.8, name


def test_pushes_the_response_depends_on_the_stride_phase(pushes):
    """
    Which feet are in stance when the push lands decides how far it moves the trunk.

    The stance decides more than the model's stiffness does: measured normal 1.7-5.1 cm, softer 1.5-4.5 cm over six
    phases (medians 2.9 and 3.1 cm). The paper's "softer model is pushed less" (Figure 12) is not reproduced, see
    docs/RESULTS.md "Pushes".
    """
    for name, model in pushes.items():
        assert model['peak_lateral_max_m'] > 1.5 * model['peak_lateral_min_m'], name
    normal, softer = (pushes[k]['peak_lateral_median_m'] for k in ('normal', 'softer'))
    assert abs(normal - softer) < 0.5 * min(normal, softer)
