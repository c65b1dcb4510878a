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

"""Issue 12 item 6: a scene without goals never reports a goal reached; an empty scene file is an error."""
import json
import math

import numpy as np

from iguana_ros.cli import main
from iguana_ros.metrics import locomotion_metrics
from iguana_ros.run_metrics import scene_goal, walk_frames
from iguana_ros.scene import parse_scene


def _metrics(goal_xy):
    n = 40
    times = (np.arange(n) + 1) / 30.0
    root = np.zeros((n, 3))
    up = np.tile([0.0, 0.0, 1.0], (n, 1))
    landmarks = np.zeros((n, 2, 3))
    landmarks[:, 1, 0] = 0.1
    trunk = np.zeros((n, 3, 3))
    trunk[:, :, 0] = [0.0, 0.1, 0.2]
    return locomotion_metrics(times, root, np.zeros(n), up, goal_xy, 0.15, np.zeros((n, 4, 2)),
                              np.ones((n, 4), bool), 2, trunk, landmarks, landmarks, np.array([[0, 1]]))


def test_no_goal_is_never_reached():
    plain = _metrics(None).as_dict()
    assert plain['reached_goal'] is False and plain['time_to_goal'] is None
    assert plain['final_goal_distance'] is None and plain['stuck'] is False
    assert _metrics(np.array([0.0, 0.0])).reached_goal   # a goal at the start is reached at once
    scene = parse_scene({'model': {'resolution': 'coarse'}})
    assert scene_goal(scene) is None
    times = (np.arange(10) + 1) / 30.0
    assert walk_frames(times, np.zeros((10, 3)), None, 0.15) == (10, False)   # the walk is the whole run


def test_simulate_without_goals_reports_no_goal_reached(tmp_path, capsys):
    scene = tmp_path / 'idle.yaml'
    scene.write_text('name: idle\nmodel: {resolution: coarse}\nterrain: {kind: flat}\nduration: 0.2\n')
    assert main(['simulate', str(scene), '--json']) == 0
    metrics = json.loads(capsys.readouterr().out)
    assert metrics['reached_goal'] is False
    assert metrics['time_to_goal'] is None and metrics['final_goal_distance'] is None
    assert not math.isnan(metrics['path_length'])


def test_simulate_of_an_empty_file_is_one_line(tmp_path, capsys):
    empty = tmp_path / 'empty.yaml'
    empty.write_text('')
    assert main(['simulate', str(empty), '--duration', '0.1', '--json']) == 1
    captured = capsys.readouterr()
    assert captured.out == ''
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and 'empty.yaml' in lines[0] and 'empty' in lines[0]
