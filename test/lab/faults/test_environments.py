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
Environment faults (issue 30): the doctor names each broken environment's cause, `iguana goal` stops with one line.

The whole table is `long` (`make test-long`, about a minute); three rows run through `iguana bench faults environments`
in the quick suite.
"""
import json
import os

import pytest

from iguana_lab.faults.environments import environment_suite, FAULTS, suite_lines
from iguana_ros.cli import main

pytestmark = [pytest.mark.ros, pytest.mark.timeout(400)]


@pytest.mark.slow
@pytest.mark.long
def test_every_broken_environment_is_named_by_the_doctor_and_stops_goal_with_one_line():
    result = environment_suite(domain_id=os.environ['ROS_DOMAIN_ID'])
    print('\n'.join(suite_lines(result)))
    failed = [row for row in result['rows'] if row['problems']]
    assert not failed, [(row['name'], row['problems']) for row in failed]
    assert result['trials'] == result['survived'] == result['named_by_doctor'] == len(FAULTS)
    assert result['goal_named_the_cause'] + result['goal_found_no_planner'] == len(FAULTS)
    assert {'ROS domain id', 'rclpy log directory', 'rclpy and RMW', 'discovery range', 'static peers',
            'model cache', 'kernel cache'} <= set(result['by_check'])


def test_the_bench_command_runs_chosen_rows_and_prints_counts(capsys):
    rows = ['domain-huge', 'rmw-missing', 'home-through-a-file']
    assert main(['bench', 'faults', 'environments', *rows, '--domain', os.environ['ROS_DOMAIN_ID'], '--json']) == 0
    captured = capsys.readouterr()
    result = json.loads(captured.out)
    assert result['trials'] == result['survived'] == 3, result['rows']
    assert [row['name'] for row in result['rows']] == rows
    assert result['rows'][1]['goal_line'].startswith('iguana goal: error: ✗ rclpy and RMW: '
                                                     'RMW_IMPLEMENTATION=rmw_missing_xyz cannot be used')
    assert [line.split()[0] for line in captured.err.splitlines()] == ['ok', 'ok', 'ok']


def test_an_unknown_row_is_one_line(capsys):
    assert main(['bench', 'faults', 'environments', 'no-such-row']) == 1
    err = capsys.readouterr().err
    assert err.startswith('iguana bench: error: no environment fault no-such-row; known: domain-huge, '), err
