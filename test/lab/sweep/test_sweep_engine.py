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
The sweep engine on real Dask clusters.

Local clusters of 1 and 2 worker processes give the same table; a scheduler and two workers started as separate
processes (as a cluster user starts them) give it too, and run the benchmark specs; a failing task is a row, an
out-of-memory worker is a row, --resume runs only what is missing, and no process is left running.
"""
import json
from pathlib import Path
import sys
import textwrap
import time

import cloudpickle
import numpy as np
import psutil
import pytest

from iguana_lab.bench.sim import TRADEOFF_SETTINGS
from iguana_lab.bench.stability import run_scenario
from iguana_lab.bench.workload import bench_model
from iguana_lab.locomotion_bench import random_scenes, run_task
from iguana_lab.sweep.engine import Cluster, run_tasks, Task
from iguana_lab.sweep.scene_task import TIMING_COLUMNS
from iguana_ros.cli import main
from iguana_ros.supervisor.process import stop_all
from ros_harness import IGUANA, NodeProcess, wait_for

pytestmark = [pytest.mark.slow, pytest.mark.long, pytest.mark.timeout(400)]   # a hung cluster fails, not the suite

SPEC = """
name: engine_test
scenes: [flat_walk, hills]
grid:
  fidelity.cg_tol: [0.01, 0.001]
cases:
  - {model.resolution: coarse, duration: 0.4}
  - {model.resolution: coarse, duration: 0.4, friction: {wings: 0.1}}
plots:
  - {x: fidelity.cg_tol, y: path_length, by: scene}
"""
DASK = str(Path(sys.executable).with_name('dask'))


def _children() -> set:
    """
    Return the pids of this process's living descendants except multiprocessing's resource tracker.

    The tracker lives as long as this process by design.
    """
    pids = set()
    for p in psutil.Process().children(recursive=True):
        try:
            if p.status() != psutil.STATUS_ZOMBIE and 'resource_tracker' not in ' '.join(p.cmdline()):
                pids.add(p.pid)
        except psutil.NoSuchProcess:
            continue
    return pids


def _rows(out: Path) -> list[dict]:
    """Return the rows of a results.json."""
    return json.loads((out / 'results.json').read_text())['rows']


def _table(out: Path, timing: tuple = TIMING_COLUMNS) -> list[dict]:
    """Return the rows of a results.json without the timing columns."""
    return [{k: v for k, v in row.items() if k not in timing} for row in _rows(out)]


def _spec(tmp_path: Path, text: str, name: str) -> Path:
    path = tmp_path / f'{name}.yaml'
    path.write_text(textwrap.dedent(text))
    return path


@pytest.fixture(scope='module')
def spec_file(tmp_path_factory):
    return _spec(tmp_path_factory.mktemp('spec'), SPEC, 'engine_test')


@pytest.fixture(scope='module')
def local_tables(spec_file, tmp_path_factory):
    """Return the sweep run by `iguana sweep` on local clusters of 1 and 2 workers: {workers: results folder}."""
    root = tmp_path_factory.mktemp('local')
    before = _children()
    for workers in (1, 2):
        assert main(['sweep', str(spec_file), '-o', str(root / str(workers)), '--workers', str(workers)]) == 0
    assert wait_for(lambda: _children() <= before, timeout=20), 'worker processes left running'
    return {workers: root / str(workers) for workers in (1, 2)}


@pytest.fixture(scope='module')
def scheduler(tmp_path_factory):
    """
    Yield a `dask scheduler` and two `dask worker` processes on localhost, each in its own process group.

    All of them (and their children) stopped and checked gone at teardown, also when a test fails. Yields the address.
    """
    tmp = tmp_path_factory.mktemp('cluster')
    scheduler_file = tmp / 'scheduler.json'
    procs = []
    try:
        procs.append(NodeProcess([DASK, 'scheduler', '--host', '127.0.0.1', '--port', '0', '--no-dashboard',
                                  '--scheduler-file', scheduler_file], 'scheduler', tmp).start())
        assert wait_for(lambda: scheduler_file.exists() and scheduler_file.stat().st_size > 0, timeout=60), \
            procs[0].tail()
        address = json.loads(scheduler_file.read_text())['address']
        workers = [NodeProcess([DASK, 'worker', address, '--nworkers', '1', '--nthreads', '1', '--memory-limit',
                                '2GiB', '--no-dashboard', '--local-directory', tmp / f'w{k}', '--name', f'w{k}'],
                               f'worker{k}', tmp) for k in range(2)]
        procs += [w.start() for w in workers]
        for w in workers:
            assert w.wait_for_output('Registered to', timeout=60), w.tail()
        yield address
    finally:
        tree = set()
        for proc in (p for p in procs if p.running):
            try:
                tree |= {proc.pid} | {c.pid for c in psutil.Process(proc.pid).children(recursive=True)}
            except psutil.NoSuchProcess:
                pass
        stop_all(procs, timeout=3)
        assert wait_for(lambda: not any(psutil.pid_exists(pid) and psutil.Process(pid).status() != 'zombie'
                                        for pid in tree), timeout=20), 'dask processes left running'


def test_same_table_with_one_and_two_workers_failures_as_rows(local_tables):
    one, two = _table(local_tables[1]), _table(local_tables[2])
    assert one == two and len(one) == 8
    assert [(r['scene'], r['fidelity.cg_tol']) for r in one[:4]] == [('flat_walk', 0.01), ('flat_walk', 0.001)] * 2
    failed = [r for r in one if r.get('error')]
    assert len(failed) == 4 and all("unknown node tag 'wings'" in r['error'] for r in failed)
    assert all(r['error_type'] == 'InputError' and r['friction'] == {'wings': 0.1} for r in failed)
    for row in (r for r in one if not r.get('error')):
        assert row['simulated_s'] == pytest.approx(0.4) and row['strides'] >= 1 and row['resolution'] == 'coarse'
    assert (local_tables[2] / 'plot_path-length_vs_fidelity.cg-tol_by_scene.png').stat().st_size > 5000
    lines = (local_tables[2] / 'results.csv').read_text().splitlines()
    assert len(lines) == 9 and lines[0].startswith('scene,kind,terrain,goal,resolution,duration,adaptation,mode,')


def test_scheduler_and_workers_as_separate_processes_resume(scheduler, spec_file, local_tables, tmp_path, capsys):
    """
    `iguana sweep --scheduler ADDRESS` in a process of its own runs on the two `dask worker` processes.

    The same table; with the log cut short, --resume runs only the two missing tasks.
    """
    out = tmp_path / 'cluster'
    iguana = NodeProcess(IGUANA + ['sweep', spec_file, '-o', out, '--scheduler', scheduler], 'iguana', tmp_path)
    assert iguana.start().wait(timeout=240) == 0, iguana.tail()
    assert f'8 to run on scheduler {scheduler}' in iguana.output and '8/8 [' in iguana.output   # progress bar
    assert _table(out) == _table(local_tables[1])
    log = out / 'rows.jsonl'
    log.write_text('\n'.join(log.read_text().splitlines()[:-2]) + '\n')   # the last two tasks never finished
    assert main(['sweep', str(spec_file), '-o', str(out), '--scheduler', scheduler]) == 1
    assert 'pass --resume' in capsys.readouterr().err                    # refused: the folder holds a sweep
    assert main(['sweep', str(spec_file), '-o', str(out), '--scheduler', scheduler, '--resume']) == 0
    assert '8 tasks, 6 done before, 2 to run' in capsys.readouterr().err
    assert _table(out) == _table(local_tables[1]) and len(log.read_text().splitlines()) == 8


def test_the_benchmarks_run_through_iguana_sweep(scheduler, tmp_path, capsys):
    """The locomotion, stability and tradeoff benchmarks as specs: the rows the benchmarks compute."""
    loco = _spec(tmp_path, """
        random_terrains: {count: 1, seed: 3, kinds: [hills], duration: 1.0, mesh: coarse}
        grid: {adaptation: [true, false]}
        stop_after_goal: 2.0
        summary: locomotion
        plots: [{x: kind, y: foot_slip_per_stride, by: mode}]""", 'loco')
    assert main(['sweep', str(loco), '-o', str(tmp_path / 'loco'), '--scheduler', scheduler]) == 0
    assert 'with / without adaptation' in capsys.readouterr().out       # the benchmark's summary table
    scene = random_scenes(1, 3, 1.0, 'coarse', ('hills',))[0]
    direct = [{k: v for k, v in run_task(scene, mode).items() if k not in TIMING_COLUMNS} for mode in (True, False)]
    assert _table(tmp_path / 'loco') == direct
    assert json.loads((tmp_path / 'loco' / 'results.json').read_text())['summary']['modes']['adapt']['all']['n'] == 1

    stab = _spec(tmp_path, 'stability: {mesh: coarse, seconds: 0.2, scenarios: [baseline, dt 1/60]}', 'stab')
    assert main(['sweep', str(stab), '-o', str(tmp_path / 'stab'), '--scheduler', scheduler]) == 0
    model, _ = bench_model('coarse')
    assert _rows(tmp_path / 'stab') == json.loads(json.dumps([run_scenario(model, n, 0.2)
                                                              for n in ('baseline', 'dt 1/60')]))

    trade = _spec(tmp_path, 'tradeoff: {mesh: coarse, seconds: 0.05, meshes: [coarse], groups: [solver]}', 'trade')
    assert main(['sweep', str(trade), '-o', str(tmp_path / 'trade'), '--scheduler', scheduler]) == 0
    rows = _rows(tmp_path / 'trade')
    assert [r['label'] for r in rows] == [label for g, label, _ in TRADEOFF_SETTINGS if g == 'solver'] + ['mesh=coarse']
    assert all(r['node_rms_m'] is not None and r['com_error_m'] >= 0 for r in rows[:-1] if not r['diverged'])
    assert (tmp_path / 'trade' / 'tradeoff.png').stat().st_size > 5000


def _hold_memory(megabytes: int, seconds: float) -> int:
    """Allocate and touch `megabytes` MB and hold them for `seconds` (a task beyond its worker's memory limit)."""
    block = np.ones(megabytes * 125_000)
    time.sleep(seconds)
    return int(block.size)


def test_out_of_memory_worker_gives_an_error_row():
    """
    A task that outgrows its worker's 1 GiB is stopped by Dask and becomes a KilledWorker row.

    The worker is restarted and the task retried once; the next task runs.
    """
    cloudpickle.register_pickle_by_value(sys.modules[__name__])          # _hold_memory runs on the workers
    before = _children()
    tasks = [Task('hog', _hold_memory, (1500, 30.0), {'task': 'hog'}, 'hog'),
             Task('sum', sum, ([1, 2, 3],), {'task': 'sum'}, 'sum')]
    rows = run_tasks(tasks, Cluster(workers=1, memory_limit='1GiB'))
    assert rows[1] == 6
    assert rows[0]['task'] == 'hog' and rows[0]['error_type'] == 'KilledWorker', rows[0]
    assert wait_for(lambda: _children() <= before, timeout=20), 'worker processes left running'
