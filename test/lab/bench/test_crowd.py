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

"""`iguana bench crowd` and `iguana bench crossing`: figures from their runs, seeded scenes, one-line errors."""
import json
import math

import numpy as np
import pytest

from iguana_lab.bench.crowd import crossing_scene, crowd_scene, format_crowd, MEDIANS, NODE_MEDIANS
from iguana_ros.cli import main


@pytest.mark.slow
@pytest.mark.timeout(300)
def test_bench_crowd_json_is_the_medians_of_its_runs(capsys):
    assert main(['bench', 'crowd', '--iguanas', '1', '2', '--mesh', 'coarse', '--seconds', '0.3', '--repeats', '1',
                 '--json']) == 0
    result = json.loads(capsys.readouterr().out)
    one, two = result['rows']
    assert (one['iguanas'], two['iguanas']) == (1, 2) and one['cpu_per_character_vs_one'] == 1.0
    for row in (one, two):
        [run] = row['runs']
        for key in MEDIANS:
            assert row[key] == pytest.approx(run[key]), key
        assert run['realtime_factor'] == pytest.approx(run['simulated_s'] / run['wall_s'])
        assert run['simulated_s'] == pytest.approx(0.3) and run['body_contact_frames'] == 0
        assert run['peak_rss_mb'] >= run['baseline_rss_mb'] > 0
    assert two['cpu_per_character_vs_one'] == pytest.approx(two['cpu_s_per_character_s'] / one['cpu_s_per_character_s'])


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.timeout(400)
def test_bench_crowd_nodes_runs_each_crowd_as_iguana_run_too(capsys):
    """1 and 2 coarse iguanas for 0.5 s as nodes: every figure finite and positive, in the JSON and the table."""
    assert main(['bench', 'crowd', '--iguanas', '1', '2', '--mesh', 'coarse', '--seconds', '0.5', '--repeats', '1',
                 '--nodes', '--json']) == 0
    result = json.loads(capsys.readouterr().out)
    assert 'iguana run' in result['nodes_loop']
    one, two = result['rows']
    assert one['nodes']['cpu_per_character_vs_one'] == 1.0 and 'realtime_factor' in one   # the library's stay
    assert two['nodes']['cpu_per_character_vs_one'] == pytest.approx(
        two['nodes']['cpu_s_per_character_s'] / one['nodes']['cpu_s_per_character_s'])
    for row in (one, two):
        nodes = row['nodes']
        [run] = nodes['runs']
        characters = {f'iguana{i + 1}' for i in range(row['iguanas'])}
        for key in NODE_MEDIANS:
            assert math.isfinite(nodes[key]) and nodes[key] > 0 and nodes[key] == pytest.approx(run[key]), key
        assert run['simulated_s'] == pytest.approx(0.5) and run['outcome'] == 'completed'
        assert set(run['cpu_ms_per_frame_by_process']) >= {'simulator_node', 'recorder', 'iguana run', *characters}
        # the recorder's and iguana run's CPU are added (in 0.5 s they may round to no clock tick: >=, not >)
        assert run['cpu_s_per_character_s_all'] >= run['cpu_s_per_character_s']
        assert set(run['peak_rss_mb_by_process']) >= {'simulator_node', *characters}
        assert run['peak_rss_mb'] == pytest.approx(sum(mb for name, mb in run['peak_rss_mb_by_process'].items()
                                                       if name != 'recorder'))
        assert run['total_wall_s'] > run['wall_s'] == pytest.approx(run['simulated_s'] / run['realtime_factor'])
    table = format_crowd(result).splitlines()
    assert len(table) == 8 and all(line.count(' | ') == 1 for line in table[4:])


def test_the_crowd_stands_apart_and_the_crossings_are_seeded():
    crowd = crowd_scene(8, 'coarse', 1.0)
    starts = np.array([[c.start.x, c.start.y] for c in crowd.characters])
    assert len(starts) == 8 and np.min(np.diff(starts[:, 1])) == pytest.approx(1.5)
    assert max(abs(c.goals[0].y) for c in crowd.characters) < crowd.terrain.extent / 2
    assert crossing_scene(7) == crossing_scene(7) and crossing_scene(7) != crossing_scene(8)
    assert {len(crossing_scene(seed).characters) for seed in range(1, 30)} == {2, 3, 4}


@pytest.mark.parametrize('argv, line', [
    (['bench', 'crowd', '--iguanas', '0'], '--iguanas: expected an integer >= 1'),
    (['bench', 'crossing', '--seconds', '-1'], '--seconds: seconds must be a positive number'),
])
def test_bad_arguments_are_one_line(cli, argv, line):
    status, out, err = cli(argv)
    assert status == 1 and out == '' and line in err and err.strip().count('\n') == 0, err
