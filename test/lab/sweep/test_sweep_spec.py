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

"""Sweep specs: the shipped specs, expansion order and identity of tasks, stable keys, and one-line errors."""
import textwrap

import pytest

from iguana_lab.bench.sim import TRADEOFF_SETTINGS
from iguana_lab.bench.stability import SCENARIOS
from iguana_lab.locomotion_bench import benchmark_tasks, random_scenes, run_task
from iguana_lab.sweep.scene_task import run_scene, RunOptions
from iguana_lab.sweep.spec import load_sweep, MAX_TASKS, parse_sweep, SweepError
from iguana_ros.errors import InputError
from iguana_ros.scene import load_scene, SceneError


def _write(tmp_path, text: str, name: str = 'spec.yaml'):
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def test_shipped_specs_expand_to_the_benchmarks_tasks():
    loco = load_sweep('locomotion')
    assert (loco.kind, loco.summary, len(loco.plan.tasks)) == ('scenes', 'locomotion', 16)
    bench = benchmark_tasks(random_scenes(8, 0, 40.0, 'medium'))            # what `iguana bench locomotion` runs
    assert [t.identity for t in loco.plan.tasks] == [t.identity for t in bench]
    scene, options, _ = loco.plan.tasks[1].args
    assert (scene.adaptation, options) == (False, RunOptions(stop_after_goal=2.0))
    stab = load_sweep('stability')
    assert [t.identity['scenario'] for t in stab.plan.tasks] == list(SCENARIOS)
    trade = load_sweep('tradeoff')
    assert len(trade.plan.tasks) == 1 + len(TRADEOFF_SETTINGS) + 1 + 3 and trade.plan.timing
    tune = load_sweep('stiffness_friction')
    assert len(tune.plan.tasks) == 2 * 2 * 3 * 2 and len(tune.plots) == 2


def test_grid_and_cases_expand_in_order_with_their_columns(tmp_path):
    spec = load_sweep(str(_write(tmp_path, """
        name: order
        scenes: [flat_walk, hills]
        grid:
          fidelity.dt: [1/600, 0.001]
          friction: [0.5, {default: 1.0, foot_fl: 0.4}]
        cases:
          - {model.resolution: coarse, duration: 0.5}
          - {model.stiffness: softer, model.resolution: coarse, adaptation: false}
        """)))
    tasks = spec.plan.tasks
    assert len(tasks) == 2 * 2 * 2 * 2 and spec.name == 'order'
    first = tasks[0].identity
    assert (first['scene'], first['duration'], first['resolution'], first['fidelity.dt'], first['friction']) == \
        ('flat_walk', 0.5, 'coarse', pytest.approx(1 / 600), 0.5)
    assert 'model.resolution' not in first and first['mode'] == 'adapt'      # shown once, as `resolution`
    assert [t.identity['friction'] for t in tasks[:2]] == [0.5, {'default': 1.0, 'foot_fl': 0.4}]
    assert [t.identity['fidelity.dt'] for t in tasks[:4:2]] == [pytest.approx(1 / 600), 0.001]
    fifth = tasks[4]
    assert (fifth.identity['model.stiffness'], fifth.identity['adaptation'], fifth.identity['duration']) == \
        ('softer', False, load_scene('flat_walk').duration)                # the second case keeps the scene's
    scene, options, _ = tasks[1].args
    assert options.simulator_options() == {'dt': pytest.approx(1 / 600), 'friction': {'default': 1.0, 'foot_fl': 0.4}}
    assert tasks[8].identity['scene'] == 'hills'
    assert len({t.key for t in tasks}) == len(tasks)
    again = load_sweep(str(_write(tmp_path, 'scenes: [flat_walk]\ngrid: {fidelity.dt: [0.001]}\n'
                                  'cases: [{duration: 0.5, model.resolution: coarse, friction: 0.5}]\n', 'b.yaml')))
    assert again.plan.tasks[0].key == tasks[2].key                         # keys follow the inputs, not the file


@pytest.mark.parametrize('text, words', [
    ('scenes: [flat_walk]\ncolour: red\n', "field 'colour': unknown field"),
    ('scenes: [flat_walk]\ngrid: {model.stiffness: [hard]}\n', "field 'model.stiffness': expected one of normal"),
    ('scenes: [flat_walk]\ngrid: {model.wings: [2]}\n', "field 'grid.model.wings': unknown override"),
    ('scenes: [flat_walk]\ngrid: {duration: 5}\n', "field 'grid.duration': expected a non-empty list"),
    ('scenes: [flat_walk]\ngrid: {duration: [5]}\ncases: [{duration: 2}]\n', 'also a grid key'),
    ('scenes: [flat_walk]\ngrid: {duration: [-1]}\n', "field 'duration': expected a positive number"),
    ('scenes: [flat_walk]\ngrid: {fidelity.cg_tol: [2]}\n', 'cg_tol must be a relative tolerance'),
    ('scenes: [flat_walk]\ngrid: {fidelity.dt: [1/0]}\n', 'fidelity.dt: expected a number or a fraction'),
    ('scenes: [flat_walk]\ngrid: {friction: [-1]}\n', 'friction: expected a number >= 0'),
    ('scenes: [nowhere]\n', "no scene 'nowhere'"),
    ('scenes: [flat_walk]\nstability: {}\n', 'a sweep names what it runs'),
    ('description: nothing\n', 'a sweep names what it runs'),
    ('stability: {mesh: coarse}\ngrid: {duration: [1]}\n', "field 'grid': applies to scene sweeps only"),
    ('stability: {scenarios: [meteor]}\n', "field 'stability.scenarios': expected names among baseline"),
    ('tradeoff: {mesh: huge}\n', "field 'tradeoff.mesh': expected one of coarse"),
    ('random_terrains: {count: 0}\n', "field 'random_terrains.count': expected a number >= 1"),
    ('random_terrains: {count: 2, kinds: [lava]}\n', "field 'random_terrains.kinds'"),
    (f'random_terrains: {{count: {MAX_TASKS}}}\ngrid: {{adaptation: [true, false]}}\n', 'tasks, at most'),
    ('scenes: [flat_walk]\nsummary: poetry\n', "field 'summary': expected one of locomotion"),
    ('scenes: [flat_walk]\nplots: [{x: duration}]\n', "field 'plots[0].y': expected a column name"),
    ('name: ../up\nscenes: [flat_walk]\n', "field 'name'"),
    ('- just\n- a list\n', 'a sweep spec is a YAML mapping'),
    ('scenes: [flat_walk\n', 'not a readable YAML sweep spec'),
])
def test_bad_specs_fail_in_one_line_naming_file_and_field(tmp_path, text, words):
    path = _write(tmp_path, text)
    with pytest.raises(InputError) as exc:
        load_sweep(str(path))
    message = str(exc.value)
    assert words in message and '\n' not in message
    assert str(path) in message or words.startswith('no scene')


def test_scene_overrides_are_checked_as_scene_files_are(tmp_path):
    path = _write(tmp_path, 'scenes: [hills]\ngrid: {terrain.extent: [2.0]}\n')
    with pytest.raises(SceneError, match=r"scene hills, terrain.extent=2.0\): field 'goals\[0\]': goal \(3, 0\) is "
                                         r'off the terrain'):
        load_sweep(str(path))
    with pytest.raises(SweepError, match='no sweep'):
        load_sweep('no_such_sweep')


def test_scene_task_row_and_run_time_failure():
    """
    A scene task's row holds what ran and the metrics.

    A run-time error (an unknown friction tag) raises for the engine to record, and locomotion's run_task records it
    itself.
    """
    spec = parse_sweep({'scenes': ['flat_walk'], 'cases': [{'duration': 0.2, 'model.resolution': 'coarse'},
                                                           {'friction': {'wings': 0.2}, 'duration': 0.2}]})
    ok, bad = spec.plan.tasks
    row = run_scene(*ok.args)
    assert {k: row[k] for k in ('scene', 'kind', 'resolution', 'duration', 'mode')} == \
        {'scene': 'flat_walk', 'kind': 'flat', 'resolution': 'coarse', 'duration': 0.2, 'mode': 'adapt'}
    assert row['simulated_s'] == pytest.approx(0.2) and row['strides'] >= 1 and 'error' not in row
    with pytest.raises(InputError, match="unknown node tag 'wings'"):
        run_scene(*bad.args)
    assert run_task(ok.args[0], True)['simulated_s'] == pytest.approx(0.2)


def test_cli_bad_arguments_fail_before_anything_runs(tmp_path, capsys):
    """`iguana sweep` refuses bad options and specs with one line and exit 1 (2 for argparse), writing nothing."""
    from iguana_ros.cli import main

    good = _write(tmp_path, 'scenes: [flat_walk]\n', 'good.yaml')
    for argv, code, words in [
            (['--workers', '0'], 2, '--workers'),
            (['--workers', '2', '--scheduler', 'tcp://127.0.0.1:1'], 2, 'not allowed with'),
            (['--memory-limit', 'lots'], 1, '--memory-limit: expected a size')]:
        if code == 2:
            with pytest.raises(SystemExit) as exc:
                main(['sweep', str(good), '-o', str(tmp_path / 'out')] + argv)
            assert exc.value.code == 2
        else:
            assert main(['sweep', str(good), '-o', str(tmp_path / 'out')] + argv) == 1
        err = capsys.readouterr().err
        assert words in err and 'Traceback' not in err
    bad = _write(tmp_path, 'scenes: [flat_walk]\ngrid: {model.stiffness: [hard]}\n', 'bad.yaml')
    assert main(['sweep', str(bad), '-o', str(tmp_path / 'out')]) == 1
    err = capsys.readouterr().err
    assert err.count('\n') == 1 and err.startswith('iguana sweep: error: ') and 'model.stiffness' in err
    assert not (tmp_path / 'out').exists()
