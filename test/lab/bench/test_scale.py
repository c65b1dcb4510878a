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

"""`iguana bench scale`: its figures are the medians and ratios of the runs it lists; bad arguments fail in one line."""
import json
import math

import numpy as np
import pytest

from iguana_lab.bench.scale import bench_scale, format_scale
from iguana_ros.cli import main

MEDIANS = ('ms_per_step', 'cpu_ms_per_step', 'realtime_factor', 'realtime_factor_cpu', 'cpu_s_per_character_s',
           'peak_rss_mb')


def _check_medians(row: dict) -> None:
    """Assert each median figure of `row` is the median of its listed runs."""
    for key in MEDIANS:
        assert row[key] == pytest.approx(np.median([r[key] for r in row['runs']])), key


@pytest.mark.slow
@pytest.mark.timeout(300)
def test_bench_scale_json_is_computed_from_its_runs(capsys):
    """Coarse mesh, 1 and 2 bodies, 0.2 s, one run each in a fresh process: fields, per-node cost, steps, ratios."""
    argv = ['bench', 'scale', '--meshes', 'coarse', '--bodies', '1', '2', '--bodies-mesh', 'coarse',
            '--seconds', '0.2', '--repeats', '1', '--json']
    assert main(argv) == 0
    result = json.loads(capsys.readouterr().out)
    [mesh] = result['meshes']
    assert mesh['mesh'] == 'coarse' and mesh['nodes'] > 50 and mesh['springs'] > mesh['nodes']
    assert mesh['tets'] > 0 and len(mesh['runs']) == 1 and result['mesh_growth'] == []
    _check_medians(mesh)
    assert mesh['us_per_node_step'] == pytest.approx(1e3 * mesh['ms_per_step'] / mesh['nodes'])
    assert mesh['us_per_spring_step'] == pytest.approx(1e3 * mesh['ms_per_step'] / mesh['springs'])
    one, two = result['bodies']
    assert (one['bodies'], two['bodies']) == (1, 2) and one['steps'] == mesh['steps'] == 240
    assert two['steps'] == 2 * one['steps'] and two['steps_per_body'] == one['steps_per_body']
    for row in (one, two):
        _check_medians(row)
        [run] = row['runs']
        assert row['realtime_factor'] == pytest.approx(row['simulated_s'] / run['wall_s'])
        assert row['realtime_factor_cpu'] == pytest.approx(row['simulated_s'] / run['cpu_s'])
        assert row['cpu_s_per_character_s'] == pytest.approx(run['cpu_s'] / (row['bodies'] * row['simulated_s']))
        assert run['peak_rss_mb'] >= run['baseline_rss_mb'] > 0
    assert two['ms_per_character_step'] == pytest.approx(two['ms_per_step'] / 2)
    assert two['cost_per_character_vs_1'] == pytest.approx(two['ms_per_step'] / 2 / one['ms_per_step'])
    assert two['cpu_cost_per_character_vs_1'] == pytest.approx(two['cpu_ms_per_step'] / 2 / one['cpu_ms_per_step'])
    assert 'independent' in result['bodies_note'] and result['cpus_available'] >= 1


def _fake_run(calls: list):
    """Return a stand-in for `in_fresh_process` whose runs take 1 ms per 100 nodes per body, plus the run's index."""
    nodes = {'coarse': 100, 'medium': 400}

    def run(fn, mesh, bodies, seconds, preset):
        calls.append((mesh, bodies))
        ms = nodes[mesh] / 100 * bodies + len(calls)
        steps = int(round(seconds * 1200))
        return {'model': mesh, 'nodes': nodes[mesh], 'tets': 2 * nodes[mesh], 'springs': 6 * nodes[mesh],
                'dt': 1 / 1200, 'bodies': bodies, 'simulated_s': seconds, 'steps_per_body': steps,
                'steps': bodies * steps, 'wall_s': ms * steps / 1e3, 'cpu_s': ms * steps / 1e3, 'ms_per_step': ms,
                'cpu_ms_per_step': ms / 2, 'realtime_factor': seconds / (ms * steps / 1e3),
                'realtime_factor_cpu': seconds / (ms * steps / 2e3),
                'cpu_s_per_character_s': ms * steps / 1e3 / (bodies * seconds), 'peak_rss_mb': 100.0 + len(calls),
                'baseline_rss_mb': 90.0, 'compile_s': 0.0, 'model_build_s': 0.0}
    return run


def test_bench_scale_medians_and_growth_are_the_runs_own():
    """Runs interleave, the shared 1-body run serves both tables; medians and ratios recomputed from the runs."""
    calls = []
    result = bench_scale(('coarse', 'medium'), (1, 2), 'medium', seconds=0.1, repeats=3, run=_fake_run(calls))
    assert calls == [('coarse', 1), ('medium', 1), ('medium', 2)] * 3
    coarse, medium = result['meshes']
    for row in result['meshes'] + result['bodies']:
        assert len(row['runs']) == 3
        _check_medians(row)
    assert medium['runs'] == result['bodies'][0]['runs']
    [growth] = result['mesh_growth']
    ms_ratio = medium['ms_per_step'] / coarse['ms_per_step']
    assert growth['ms_per_step_ratio'] == pytest.approx(ms_ratio)
    assert (growth['node_ratio'], growth['tet_ratio'], growth['spring_ratio']) == (4.0, 4.0, 4.0)
    assert growth['exponent_in_nodes'] == pytest.approx(math.log(ms_ratio) / math.log(4.0))
    two = result['bodies'][1]
    assert two['cost_per_character_vs_1'] == pytest.approx(two['ms_per_step'] / 2 / medium['ms_per_step'])
    assert two['cpu_cost_per_character_vs_1'] == pytest.approx(two['cpu_ms_per_step'] / 2 / medium['cpu_ms_per_step'])
    text = format_scale(result)
    assert 'coarse -> medium' in text and 'independent' in text


@pytest.mark.parametrize('argv, words', [
    (['--meshes', 'huge'], "unknown mesh 'huge'"),
    (['--bodies-mesh', 'huge'], "unknown mesh 'huge'"),
    (['--bodies', '1', '0'], '--bodies: expected an integer >= 1'),
    (['--bodies', 'two'], '--bodies: expected an integer'),
    (['--seconds', '-1'], '--seconds: seconds must be a positive number'),
    (['--seconds', 'nan'], '--seconds: seconds must be a positive number'),
    (['--repeats', '0'], '--repeats: expected an integer >= 1'),
])
def test_bench_scale_bad_argument_is_one_line_and_exit_1(capsys, argv, words):
    """A bad value stops the command before any run, with one line on stderr and exit status 1."""
    assert main(['bench', 'scale'] + argv) == 1
    captured = capsys.readouterr()
    assert captured.out == '' and captured.err.count('\n') == 1
    assert captured.err.startswith('iguana bench: error: ') and words in captured.err
