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

"""The randomized locomotion benchmark: its scenes, error rows, run order, summary figures and the CLI."""
import dataclasses
import json
import math
from pathlib import Path
import subprocess
import sys

import pytest

from iguana_lab.cli import bench_locomotion
from iguana_lab.locomotion_bench import (BENCH_KINDS, random_scenes, run_benchmark, run_task, summarize)
from iguana_ros.cli import main
from iguana_ros.errors import InputError
from iguana_ros.scene import TerrainSpec


def test_random_scenes_deterministic_cycling_kinds_with_goals_3m_away():
    scenes = random_scenes(12, seed=5, duration=25.0, resolution='coarse')
    assert scenes == random_scenes(12, seed=5, duration=25.0, resolution='coarse')
    assert scenes[:4] == random_scenes(4, seed=5, duration=25.0, resolution='coarse')   # prefix-stable
    assert scenes != random_scenes(12, seed=6, duration=25.0, resolution='coarse')
    assert [s.terrain.kind for s in scenes] == list(BENCH_KINDS) * 3
    assert [s.name for s in scenes[:3]] == ['bench_hills_000', 'bench_tilted_001', 'bench_steps_002']
    headings = []
    for s in scenes:
        assert len(s.goals) == 1 and s.goal_radius == 0.2 and s.duration == 25.0 and s.fidelity == 'balanced'
        assert s.model.resolution == 'coarse' and s.terrain.extent == 10.0 and (s.start.x, s.start.y) == (0, 0)
        assert math.hypot(s.goals[0].x, s.goals[0].y) == pytest.approx(3.0, abs=1e-3)
        headings.append(math.atan2(s.goals[0].y, s.goals[0].x))
        t = s.terrain
        if t.kind == 'hills':
            assert 0.03 <= t.amplitude <= 0.12 and 0.5 <= t.wavelength <= 1.4
        elif t.kind == 'tilted':
            assert 5.0 <= t.slope_deg <= 15.0 and 0.0 <= t.direction_deg <= 360.0
        elif t.kind == 'steps':
            assert (t.block_size, t.step_min, t.step_max) == (0.3, 0.03, 0.05)
        else:
            assert 0.03 <= t.amplitude <= 0.10 and 0.4 <= t.wavelength <= 1.2
    assert len({s.terrain.seed for s in scenes if s.terrain.kind != 'tilted'}) == 9
    assert any(abs(h) > math.pi / 2 for h in headings)            # some goals lie behind the iguana


def test_random_scenes_kinds_and_bad_arguments():
    assert [s.terrain.kind for s in random_scenes(3, 0, kinds=('noise',))] == ['noise'] * 3
    for kwargs, words in [({'kinds': ('lava',)}, 'terrain kinds'), ({'resolution': 'ultra'}, 'mesh'),
                          ({'seed': -1}, 'seed'), ({'duration': 0.0}, 'duration')]:
        with pytest.raises(InputError, match=words):
            random_scenes(**{'n_terrains': 2, 'seed': 0, **kwargs})


def _missing_map_scene(name: str):
    """Return a scene whose terrain file is missing: its run fails at once (no simulation)."""
    scene = random_scenes(1, 0)[0]
    return dataclasses.replace(scene, name=name, terrain=TerrainSpec(kind='heightmap', file=f'/nonexistent/{name}.npy'))


@pytest.mark.long
def test_failing_runs_become_error_rows_in_a_fixed_order():
    row = run_task(_missing_map_scene('a'), True)
    assert row['error_type'] == 'InputError' and 'does not exist' in row['error'] and '\n' not in row['error']
    assert (row['scene'], row['mode'], row['adaptation']) == ('a', 'adapt', True)
    seen = []
    rows = run_benchmark([_missing_map_scene(n) for n in 'abc'], workers=2,
                         progress=lambda r, done, total: seen.append((done, total)))
    assert [(r['scene'], r['mode']) for r in rows] == [(n, m) for n in 'abc' for m in ('adapt', 'no_adapt')]
    assert all(r['error'] for r in rows) and seen == [(k, 6) for k in range(1, 7)]
    assert summarize(rows)['modes']['adapt']['all']['errors'] == 3


def _row(scene, kind, adapt, reached, time, slip, speed, fell=False, stuck=False, **extra):
    """Return a hand-made finished row."""
    return {'scene': scene, 'kind': kind, 'terrain': {'seed': 1}, 'goal': [3.0, 0.0], 'adaptation': adapt,
            'mode': 'adapt' if adapt else 'no_adapt', 'reached_goal': reached, 'time_to_goal': time,
            'foot_slip_per_stride': slip, 'speed_fraction': speed, 'fell': fell, 'stuck': stuck, **extra}


ROWS = [
    _row('s1', 'hills', True, True, 10.0, 0.1, 0.8, path_length=3.0, per_foot=[0.1, 0.2]),
    _row('s2', 'hills', True, False, None, 0.3, 0.4, stuck=True, path_length=1.0),
    {'scene': 's3', 'kind': 'steps', 'adaptation': True, 'mode': 'adapt', 'error': 'SimulationDiverged: nan',
     'error_type': 'SimulationDiverged', 'wall_s': 1.0},
    _row('s1', 'hills', False, True, 15.0, 0.2, 0.6),
    _row('s2', 'hills', False, True, 30.0, 0.5, 0.5, stuck=True),
    _row('s3', 'steps', False, False, None, 0.6, 0.1, fell=True, stuck=True),
]


def test_summarize_exact_figures_and_ratios():
    s = summarize(ROWS)
    assert s['speed_key'] == 'speed_fraction' and s['kinds'] == ['hills', 'steps']
    a, n = s['modes']['adapt'], s['modes']['no_adapt']
    assert {k: v for k, v in a['all'].items() if k != 'medians'} == {
        'n': 3, 'reached': 1, 'reach_rate': pytest.approx(1 / 3), 'time_to_goal_median': 10.0,
        'foot_slip_per_stride_median': pytest.approx(0.2), 'foot_slip_per_stride_mean': pytest.approx(0.2),
        'speed_median': pytest.approx(0.6), 'fell': 0, 'stuck': 1, 'errors': 1}
    assert a['all']['medians'] == {'foot_slip_per_stride': pytest.approx(0.2), 'path_length': 2.0,
                                   'speed_fraction': pytest.approx(0.6), 'time_to_goal': 10.0}   # no list 'per_foot'
    assert a['steps'] == {'n': 1, 'reached': 0, 'reach_rate': 0.0, 'time_to_goal_median': None,
                          'foot_slip_per_stride_median': None, 'foot_slip_per_stride_mean': None,
                          'speed_median': None, 'fell': 0, 'stuck': 0, 'errors': 1, 'medians': {}}
    assert (n['all']['reached'], n['all']['time_to_goal_median'], n['all']['foot_slip_per_stride_median']) == \
        (2, 22.5, 0.5)
    assert n['all']['foot_slip_per_stride_mean'] == pytest.approx(1.3 / 3)
    assert (n['all']['fell'], n['all']['stuck'], n['all']['errors']) == (1, 1, 0)   # s2 reached: not stuck
    r = s['ratios']
    assert r['all'] == {'reach_rate_with_over_without': pytest.approx(0.5), 'slip_without_over_with':
                        pytest.approx(2.5), 'time_without_over_with': 1.5, 'both_reached': 1}
    assert r['hills']['slip_without_over_with'] == pytest.approx(1.75) and r['hills']['time_without_over_with'] == 1.5
    assert r['steps'] == {'reach_rate_with_over_without': None, 'slip_without_over_with': None,
                          'time_without_over_with': None, 'both_reached': 0}
    assert 'adapt' in bench_locomotion.format_summary(s)


def test_summarize_without_speed_fraction_or_other_mode():
    rows = [{**{k: v for k, v in r.items() if k != 'speed_fraction'}, 'mean_forward_speed': 0.2}
            for r in ROWS if not r['adaptation']]
    s = summarize(rows)
    assert s['speed_key'] == 'mean_forward_speed' and s['modes']['no_adapt']['all']['speed_median'] == 0.2
    assert list(s['modes']) == ['no_adapt'] and s['ratios'] == {}
    assert summarize([]) == {'speed_key': 'mean_forward_speed', 'kinds': [], 'modes': {}, 'ratios': {}}


def test_cli_kinds_match_the_library_and_bad_arguments_fail(capsys):
    assert bench_locomotion.KINDS == BENCH_KINDS
    for argv, words in [(['--terrains', '0'], '--terrains'), (['--kinds', 'hills,lava'], '--kinds'),
                        (['--duration', 'nan'], '--duration'), (['--workers', 'two'], '--workers'),
                        (['--modes', 'sometimes'], '--modes')]:
        with pytest.raises(SystemExit) as exc:
            main(['bench', 'locomotion'] + argv)
        assert exc.value.code == 2 and words in capsys.readouterr().err
    assert main(['bench', 'locomotion', '--terrains', '1', '-o', '/nonexistent/rows.json']) == 1
    assert 'cannot write the rows' in capsys.readouterr().err


@pytest.mark.slow
@pytest.mark.long
def test_cli_end_to_end_two_terrains(tmp_path):
    """A real run: 2 terrains x 2 modes on 2 workers; JSON on stdout, one progress line per run on stderr."""
    iguana = Path(sys.executable).with_name('iguana')
    out = tmp_path / 'rows.json'
    proc = subprocess.run([str(iguana), 'bench', 'locomotion', '--suite', 'terrains', '--terrains', '2', '--duration',
                           '1.5', '--mesh', 'coarse', '--workers', '2', '--json', '-o', str(out)],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    result = json.loads(proc.stdout)
    assert set(result) == {'config', 'summary', 'rows', 'wall_s'}
    rows = result['rows']
    assert [(r['scene'], r['mode']) for r in rows] == [
        ('bench_hills_000', 'adapt'), ('bench_hills_000', 'no_adapt'),
        ('bench_tilted_001', 'adapt'), ('bench_tilted_001', 'no_adapt')]
    assert json.loads(out.read_text()) == rows
    for r in rows:
        assert 'error' not in r, r
        assert r['simulated_s'] == pytest.approx(1.5) and r['realtime_factor'] > 0 and r['strides'] >= 1
        assert isinstance(r['reached_goal'], bool) and r['foot_slip_per_stride'] >= 0
    assert rows[0]['terrain'] == rows[1]['terrain'] and 'amplitude' in rows[0]['terrain']
    summary = result['summary']
    assert set(summary['modes']) == {'adapt', 'no_adapt'} and summary['kinds'] == ['hills', 'tilted']
    assert summary['modes']['adapt']['all']['n'] == 2 and summary['modes']['no_adapt']['all']['errors'] == 0
    assert set(summary['ratios']) == {'all', 'hills', 'tilted'}
    assert sum(line.startswith('[') for line in proc.stderr.splitlines()) == 4


@pytest.mark.slow
@pytest.mark.long
def test_cli_steering_suite_end_to_end(tmp_path):
    """A real run of the steering suite: two near goals on the coarse body; the table, then JSON rows with figures."""
    iguana = Path(sys.executable).with_name('iguana')
    common = [str(iguana), 'bench', 'locomotion', '--scenes', '2', '--categories', 'near', '--mesh', 'coarse',
              '--workers', '2', '--seed', '4']
    proc = subprocess.run([*common, '--json'], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    result = json.loads(proc.stdout)
    rows = result['rows']
    assert [r['scene'] for r in rows] == ['steer_near_000', 'steer_near_001']
    assert result['config']['suite'] == 'steering'
    for r in rows:
        assert 'error' not in r, r
        assert r['category'] == 'near' and r['straight_distance'] <= 1.2 and r['plan_ms_median'] > 0
        assert r['reached_goal'] is True and r['circling_strides'] == 0, r
    near = result['summary']['groups']['near']
    assert near['n'] == 2 and near['reached'] == 2 and result['summary']['near_goals'] == 2
    assert sum(line.startswith('[') for line in proc.stderr.splitlines()) == 2
    table = subprocess.run(common, capture_output=True, text=True, timeout=300)
    assert table.returncode == 0 and 'behind / ahead time' in table.stdout and 'near ' in table.stdout
