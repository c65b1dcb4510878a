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
The three scripts in examples/ run as a new user would run them (short scenes, coarse mesh).

The library loop with metrics and a plot; driving a real `iguana run` with IguanaCommander; reading its bag with mcap.
"""
from __future__ import annotations

import re
import subprocess
import sys

import pytest
import yaml

from ros_harness import IGUANA, NodeProcess, REPO, wait_for

EXAMPLES = REPO / 'examples'

DRIVEN_SCENE = {'name': 'driven', 'description': 'flat ground, no goals of its own: the example sends one',
                'terrain': {'kind': 'flat'}, 'model': {'resolution': 'coarse'}, 'duration': 10.0}


def example(name: str, *args, timeout: float = 180.0) -> subprocess.CompletedProcess:
    """Run examples/<name> with the test interpreter from the repository root."""
    return subprocess.run([sys.executable, str(EXAMPLES / name), *map(str, args)], cwd=REPO, capture_output=True,
                          text=True, timeout=timeout)


@pytest.mark.timeout(300)
def test_library_loop_prints_metrics_and_saves_a_plot(tmp_path):
    plot = tmp_path / 'walk.png'
    done = example('library_loop.py', 'flat_walk', '--duration', '1.5', '--mesh', 'coarse', '-o', plot)
    assert done.returncode == 0, done.stdout + done.stderr
    assert re.search(r'^simulated 1\.50 s in [\d.]+ s wall', done.stdout, re.MULTILINE), done.stdout
    assert re.search(r'^goal not reached, \d\.\d\d m short; walked 0\.\d\d m at 0\.\d+ m/s over \d strides',
                     done.stdout, re.MULTILINE), done.stdout
    assert plot.read_bytes()[:8] == b'\x89PNG\r\n\x1a\n' and plot.stat().st_size > 10_000


@pytest.fixture(scope='module')
def driven(tmp_path_factory):
    """
    Yield a realtime `iguana run` of a goal-less flat scene, driven by examples/drive_running_system.py.

    Yields (run output, example result, bag) once both have finished. Realtime, as the example's docstring runs it:
    in lockstep a fast machine simulates the 10 s in ~2.5 s of wall time, less than the example's discovery, goal
    and push handshakes can take on a loaded one (the run ended before the push was answered).
    """
    folder = tmp_path_factory.mktemp('driven')
    scene = folder / 'driven.yaml'
    scene.write_text(yaml.safe_dump(DRIVEN_SCENE))
    bag = folder / 'bag'
    run = NodeProcess([*IGUANA, 'run', str(scene), '--mode', 'realtime', '--record', str(bag), '--progress-every',
                       '1'], 'iguana_run', folder)
    with run.start():
        drive = example('drive_running_system.py', '--ahead', '0.25', '--timeout', '120', '--push', '40',
                        timeout=200)
        wait_for(lambda: not run.running, 120.0, 0.2)
    yield run.output, drive, run.proc.returncode, bag


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.long
@pytest.mark.timeout(300)
def test_drive_example_sends_a_goal_waits_for_it_and_pushes(driven):
    output, drive, code, _bag = driven
    assert drive.returncode == 0, drive.stdout + drive.stderr + output[-3000:]
    lines = drive.stdout.splitlines()
    assert re.fullmatch(r't=\d+\.\d\d s: root at \(-?\d\.\d\d, -?\d\.\d\d\) m, heading -?\d+ deg', lines[0]), lines
    assert re.fullmatch(r'goal \(\d\.\d\d, -?\d\.\d\d\) accepted by the planner', lines[1]), lines
    assert re.fullmatch(r't=\d+\.\d\d s: reached, 0\.\d{3} m from the goal', lines[2]), lines
    assert re.fullmatch(r'pushed 40 N for 0\.1 s: peak sideways speed \d\.\d{3} m/s', lines[3]), lines
    assert code == 0, output[-3000:]


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.long
def test_read_bag_example_reads_the_driven_run(driven, tmp_path):
    _output, _drive, code, bag = driven
    assert code == 0
    csv = tmp_path / 'root.csv'
    done = example('read_bag.py', bag, '--csv', csv, '-o', tmp_path / 'run.npz')
    assert done.returncode == 0, done.stdout + done.stderr
    assert re.search(r'^301 states from t=0\.00 to 10\.00 s; root moved \d\.\d\d m', done.stdout, re.MULTILINE), \
        done.stdout
    fraction = r'[01]\.\d\d'                         # a foot may stand the whole run (1.00)
    assert re.search(rf'^301 foot frames; fraction in contact: fl {fraction} fr {fraction} hl {fraction} '
                     rf'hr {fraction}$', done.stdout, re.MULTILINE), done.stdout
    assert re.search(r'^goal 0: \(\d\.\d\d, -?\d\.\d\d\)', done.stdout, re.MULTILINE), done.stdout  # the example's
    header, *rows = csv.read_text().splitlines()
    assert header.startswith('t,x,y,z,vx,vy,vz,height_fl') and len(rows) == 301
    import numpy as np
    arrays = np.load(tmp_path / 'run.npz')
    assert arrays['position'].shape == (301, 3) and arrays['foot_position'].shape == (301, 4, 3)
    assert np.all(np.isfinite(arrays['position']))


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.long
def test_the_driven_run_named_its_phases_and_showed_its_progress(driven):
    """
    `iguana run` with stdout not a terminal.

    Each start-up phase as it begins and ends, then a progress line every second (simulated time, realtime factor,
    distance to the goal the commander sent, clip), and the phases' durations in the summary; all from messages
    (run_events, iguana_state, accepted_goals).
    """
    output, _drive, code, _bag = driven
    assert code == 0, output[-3000:]
    lines = output.splitlines()
    phases = ('launching nodes', 'loading the model', 'DDS discovery', 'compiling kernels')
    ended = [next(i for i, line in enumerate(lines) if re.fullmatch(rf'\[start-up\] {p}: \d+\.\d\d s( \(.*\))?', line))
             for p in phases]
    assert ended == sorted(ended), lines[:12]
    assert lines[0] == '[start-up] launching nodes ...'
    shown = re.compile(r'\[progress\] \d+\.\d\d of 10\.00 s simulated \(\d+ %\).*')
    progress = [line for line in lines if shown.fullmatch(line)]
    assert progress and all(ended[-1] < lines.index(line) for line in progress), lines
    assert any(re.search(r', realtime factor \d+\.\d\d, \d+\.\d\d m to the goal, clip \'\w+\'$', line)
               for line in progress), progress
    assert lines.index(progress[-1]) < lines.index('run completed: 10.00 of 10.00 s simulated')
    startup = next(line for line in lines if line.startswith('start-up: '))
    assert re.fullmatch(r'start-up: launching nodes \d+\.\d\d s, loading the model \d+\.\d\d s '
                        r'\(model (from cache|built)\), DDS discovery \d+\.\d\d s, compiling kernels \d+\.\d\d s '
                        r'\(kernel cache [\w ()]+\)', startup), startup
