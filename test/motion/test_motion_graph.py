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

"""Motion graph: complete graph, goal-seeking clip choice, root alignment and blending."""
from types import SimpleNamespace

import numpy as np
import pytest

from iguana_ros.geometry import quat_from_yaw, quat_identity, yaw_of
from iguana_ros.motion.motion_graph import MotionGraph

N_BONES = 3


def _clip(name, dx, turn, n=10):
    """Return a synthetic stride: root moves dx along a circular arc turning by `turn` rad."""
    t = np.linspace(0.0, 1.0, n)
    yaw = turn * t
    root = np.zeros((n, 3))
    root[:, 0] = dx * t * np.cos(yaw / 2)
    root[:, 1] = dx * t * np.sin(yaw / 2)
    root[:, 2] = 0.075
    local = quat_identity((n, N_BONES))
    local[:, 0] = quat_from_yaw(yaw)
    local[:, 1] = quat_from_yaw(0.2 * np.sin(2 * np.pi * t))
    return SimpleNamespace(name=name, root_positions=root, local_rotations=local,
                           contacts=np.ones((n, 4), bool),
                           root_displacement=root[-1, :2], heading_change=turn)


@pytest.fixture
def graph():
    lib = {'forward': _clip('forward', 0.2, 0.0), 'turn_left': _clip('turn_left', 0.15, 0.35),
           'turn_right': _clip('turn_right', 0.15, -0.35), 'idle': _clip('idle', 0.0, 0.0)}
    return MotionGraph(lib, blend_frames=3)


def test_complete_graph(graph):
    assert len(graph.edges()) == len(graph.names) ** 2
    assert {(a, b) for a in graph.names for b in graph.names} == set(graph.edges())


def test_gaits_decide_the_edges():
    walk = SimpleNamespace(**vars(_clip('walk', 0.1, 0.0)), entry_gait='walk', exit_gait='walk')
    start = SimpleNamespace(**vars(_clip('start', 0.05, 0.0)), entry_gait='stand', exit_gait='walk')
    idle = SimpleNamespace(**vars(_clip('idle', 0.0, 0.0)), entry_gait='stand', exit_gait='stand')
    graph = MotionGraph({'walk': walk, 'start': start, 'idle': idle}, blend_frames=3)
    assert set(graph.edges()) == {('walk', 'walk'), ('start', 'walk'), ('idle', 'start'), ('idle', 'idle')}


def test_align_places_clip_at_body_pose(graph):
    aligned = graph.align('turn_left', np.array([1.0, 2.0]), 0.7)
    assert np.allclose(aligned.root_positions[0, :2], [1.0, 2.0])
    assert yaw_of(aligned.local_rotations[0, 0]) == pytest.approx(0.7)
    assert yaw_of(aligned.local_rotations[-1, 0]) == pytest.approx(0.7 + 0.35)
    step = aligned.root_positions[-1, :2] - aligned.root_positions[0, :2]
    src = graph.clips['turn_left'].root_displacement
    assert np.linalg.norm(step) == pytest.approx(np.linalg.norm(src))
    # non-root bones keep their local rotations
    assert np.allclose(aligned.local_rotations[:, 1], graph.clips['turn_left'].local_rotations[:, 1])


def test_blend_starts_at_previous_pose_and_fades(graph):
    first = graph.align('forward', np.zeros(2), 0.0)
    first.local_rotations[-1, 1] = quat_from_yaw(0.3)  # previous clip ended bent
    second = graph.align('forward', np.zeros(2), 0.0, previous=first)
    plain = graph.align('forward', np.zeros(2), 0.0)
    bend = yaw_of(second.local_rotations[:, 1])
    assert abs(bend[0] - 0.3) < abs(yaw_of(plain.local_rotations[0, 1]) - 0.3)
    assert np.allclose(second.local_rotations[3:], plain.local_rotations[3:])
