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
A body off its terrain or fallen ends the run with that outcome.

Issue 30: a 1 kN push threw the iguana 20 m and `iguana simulate` exited 0; a realtime run 718 m off its terrain ended
`run completed`.
"""
from __future__ import annotations

from pathlib import Path
import subprocess
import sys

import numpy as np
import pytest
import yaml

from iguana_ros.constants import FALL_HOLD, FRAME_RATE
from iguana_ros.geometry import quat_from_rotvec
from iguana_ros.physics.body_watch import BODY_LOST_EXIT_CODES, BodyWatch, FELL, LEFT_TERRAIN
from iguana_ros.terrain.heightfield import HeightField

UPRIGHT = np.array([0.0, 0.0, 0.0, 1.0])


def test_the_watch_sees_the_root_leave_the_terrain_sideways_or_upwards():
    watch = BodyWatch(HeightField.flat(extent=5.0))
    assert watch.check(np.array([4.9, -4.9, 0.1]), UPRIGHT, 1.0) is None
    lost = watch.check(np.array([5.01, 0.0, 0.1]), UPRIGHT, 1.1)
    assert lost.cause == LEFT_TERRAIN and lost.time == 1.1 and '(5.01, 0.00)' in lost.message
    assert watch.check(np.zeros(3), UPRIGHT, 1.2) is lost                 # lost stays lost
    high = BodyWatch(HeightField.flat(extent=5.0)).check(np.array([0.0, 0.0, 5.5]), UPRIGHT, 0.5)
    assert high.cause == LEFT_TERRAIN and '5.50 m high' in high.message


def test_the_watch_calls_a_fall_only_after_the_tilt_lasted_fall_hold():
    watch = BodyWatch(HeightField.flat(extent=5.0))
    on_side = quat_from_rotvec(np.array([np.radians(80.0), 0.0, 0.0]))
    frames = int(round(FALL_HOLD * FRAME_RATE))
    for f in range(frames // 2):                                          # tipped briefly: not a fall
        assert watch.check(np.zeros(3), on_side, f / FRAME_RATE) is None
    assert watch.check(np.zeros(3), UPRIGHT, 0.5) is None
    start = 1.0
    for f in range(frames):
        assert watch.check(np.zeros(3), on_side, start + f / FRAME_RATE) is None
    lost = watch.check(np.zeros(3), on_side, start + frames / FRAME_RATE)
    assert lost.cause == FELL and 'tilted 80 deg' in lost.message and 'since t=1.00 s' in lost.message


def _scene(tmp_path: Path, **fields) -> Path:
    raw = {'model': {'resolution': 'coarse'}, 'terrain': {'kind': 'flat'}, 'duration': 3.0,
           'goals': [{'x': 1.0, 'y': 0.0}], **fields}
    path = tmp_path / 'scene.yaml'
    path.write_text(yaml.safe_dump(raw))
    return path


def _simulate(scene: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, '-m', 'iguana_ros.cli', 'simulate', str(scene), '--json'],
                          capture_output=True, text=True, timeout=600)


def test_the_probes_push_is_refused_in_one_line_before_anything_runs(tmp_path):
    push = {'at': 1.0, 'force': [0.0, -1000.0, 0.0], 'duration': 0.1, 'region': 'trunk_left'}
    done = _simulate(_scene(tmp_path, pushes=[push]))
    assert done.returncode == 1 and done.stdout == ''
    lines = [line for line in done.stderr.splitlines() if 'Warning' not in line]
    assert len(lines) == 1 and 'pushes[0]' in lines[0] and 'm/s limit' in lines[0], done.stderr


def test_a_push_within_the_limits_that_throws_the_iguana_off_ends_the_run_as_left_terrain(tmp_path):
    from iguana_ros.pipeline import run
    from iguana_ros.scene import load_scene
    push = {'at': 0.5, 'force': [140.0, 0.0, 140.0], 'duration': 0.1, 'region': 'all'}   # 4.95 m/s, 45° up
    scene_file = _scene(tmp_path, start={'x': 4.3, 'y': 0.0}, goals=[{'x': 4.0, 'y': 0.0}], pushes=[push])
    result = run(load_scene(str(scene_file)))
    assert result.outcome == LEFT_TERRAIN and result.lost.time < 2.0
    assert len(result.times) == round(result.lost.time * FRAME_RATE) < 3.0 * FRAME_RATE     # ended there
    done = _simulate(scene_file)
    assert done.returncode == BODY_LOST_EXIT_CODES[LEFT_TERRAIN]
    assert '"outcome": "left_terrain"' in done.stdout
    assert 'run ended at t=' in done.stderr and 'the iguana left the terrain' in done.stderr


@pytest.mark.parametrize('resolution', ['coarse', 'medium'])
def test_lengths_at_the_limits_from_the_first_frame_do_not_diverge(resolution):
    """The probe's case, within today's limits: the first frame ramps from rest instead of jumping."""
    from iguana_ros.body.model import build_model
    from iguana_ros.constants import DESIRED_STRAIN_RMS, DESIRED_STRETCH_FACTOR
    from iguana_ros.stages import SimulatorStage
    from iguana_ros.validation import check_desired_lengths
    model = build_model(resolution)
    rest = np.asarray(model.spring_rest_lengths)
    n = int(DESIRED_STRAIN_RMS ** 2 * len(rest) / np.log(DESIRED_STRETCH_FACTOR) ** 2)
    rng = np.random.default_rng(3)
    for fidelity in ('fast', 'balanced'):
        for _ in range(5):
            ratio = np.ones(len(rest))
            ratio[rng.choice(len(rest), n, replace=False)] = DESIRED_STRETCH_FACTOR * 0.999
            lengths = check_desired_lengths(rest * ratio, rest)
            stage = SimulatorStage(model, HeightField.flat(), fidelity)
            for _ in range(10):
                stage.advance(lengths)                      # raises SimulationDiverged if it diverges
            assert np.all(np.isfinite(stage.sim.positions))
