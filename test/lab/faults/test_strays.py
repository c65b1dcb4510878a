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
Strangers on the graph at start-up (issue 30, item 3).

A subscriber on goal_pose (what `ros2 topic echo`, Foxglove or a plotter does) made 2 of 6 runs of the probe wait 60 s
(the scene goal went out once three readers matched, the stranger's among them, before the simulator's) and 1 fail
(`simulator_node exited with status 0` after a complete run). The long suite: `iguana bench faults strays --trials 50`.
"""
from __future__ import annotations

import pytest

from iguana_lab.faults.strays import run_trial, stray_suite

pytestmark = [pytest.mark.ros, pytest.mark.slow, pytest.mark.timeout(600)]


@pytest.mark.parametrize('mode,qos,moment', [('readers', 'table', -1.0), ('readers', 'deep', 0.8),
                                             ('inputs', 'transient_local', -1.0)])
def test_a_run_with_strangers_on_every_topic_completes_as_alone(tmp_path, mode, qos, moment):
    trial = run_trial(0, mode, qos, moment, tmp_path)
    assert trial.survived, trial
    assert trial.exit_code == 0 and trial.frames == 61 and trial.goals_recorded == 1


@pytest.mark.long
@pytest.mark.timeout(3600)
def test_fifty_runs_with_strangers_at_random_moments(tmp_path):
    result = stray_suite(50, 0, tmp_path)
    print({k: v for k, v in result.items() if k != 'rows'})
    failed = [row for row in result['rows'] if row['problems']]
    lines = [f"trial {row['index']} ({row['mode']}, {row['qos']}, at {row['moment_s']} s): {'; '.join(row['problems'])}"
             for row in failed]              # in full: pytest cuts a dict short
    assert not failed, '\n'.join(lines)


def test_a_refusal_before_the_run_started_anything_is_one_line_without_a_bag(tmp_path):
    """Strays up before the run's domain check ended (a slow start): refused at once, nothing to finalise."""
    from iguana_lab.faults.strays import _check, StrayTrial
    line = 'iguana run: error: ROS_DOMAIN_ID 120 is in use: publishers of /clock (stray_1); stop them or ...'
    trial = StrayTrial(37, 'outputs', 'best_effort', 1.79, exit_code=1)
    _check(trial, line, tmp_path / 'bag')
    assert trial.survived, trial.problems
    (tmp_path / 'bag').mkdir()                                   # a bag was started: it must say it was finalised
    late = StrayTrial(37, 'outputs', 'best_effort', 1.79, exit_code=1)
    _check(late, line, tmp_path / 'bag')
    assert late.problems and 'not in one line' in late.problems[0]
