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

"""The viewer's ROS-free parts: what is drawn at a time (RunView), the terrain click, clip names, the timeline."""
from __future__ import annotations

import math

import numpy as np
import pytest

from iguana_ros.metrics import slip_per_foot
from iguana_ros.render.run import GoalSet
from iguana_ros.view.playback import Playback
from iguana_ros.view.scene import (ARROW_M_PER_N, ARROW_SHOW_S, flank_push, identify_clip, panel_lines,
                                   PATH_MAX_POINTS, path_stride, PushEvent, RunView, Series, terrain_hit)

SQUARE = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, -1, 0], [1, 1, 0], [-1, 1, 0]], float)
"""Two triangles covering the square |x|, |y| <= 1 at z = 0."""


def test_a_ray_hits_the_terrain_where_it_crosses_it():
    hit = terrain_hit([0.3, -0.2, 2.0], [0.0, 0.0, -1.0], SQUARE)
    assert np.allclose(hit, [0.3, -0.2, 0.0])
    slanted = terrain_hit([-1.0, 0.0, 1.0], [2.0, 0.0, -2.0], SQUARE + [0, 0, 0.5])   # raised to z = 0.5
    assert np.allclose(slanted, [-0.5, 0.0, 0.5])
    assert terrain_hit([3.0, 0.0, 2.0], [0.0, 0.0, -1.0], SQUARE) is None       # beside it
    assert terrain_hit([0.0, 0.0, 2.0], [0.0, 0.0, 1.0], SQUARE) is None        # looking up
    assert terrain_hit([0.0, 0.0, 2.0], [0.0, 0.0, 0.0], SQUARE) is None        # no direction
    assert terrain_hit([0.0, 0.0, 2.0], [0.0, 0.0, -1.0], np.zeros((0, 3))) is None


def test_the_nearest_of_two_layers_is_hit():
    two = np.concatenate([SQUARE, SQUARE + [0, 0, 0.4]])
    assert np.allclose(terrain_hit([0.1, 0.1, 3.0], [0.0, 0.0, -1.0], two), [0.1, 0.1, 0.4])


def test_series_keeps_time_order_a_resent_row_replaces_an_older_one_is_dropped():
    s = Series((2,), capacity=2)
    for t, v in ((0.0, [1, 1]), (0.1, [2, 2]), (0.1, [3, 3]), (0.05, [9, 9]), (0.2, [4, 4])):
        s.append(t, v)
    assert s.times.tolist() == [0.0, 0.1, 0.2]
    assert s.values[:, 0].tolist() == [1, 3, 4]
    assert s.index_at(0.15) == 1 and s.index_at(-1.0) == -1 and s.index_at(5.0) == 2


def _walk(view: RunView, n: int = 61, rate: float = 30.0, wall_per_sim: float = 0.5) -> None:
    """States along +x at 0.3 m/s; feet slide 1 mm per frame while in contact; received at half the sim time."""
    for k in range(n):
        t = k / rate
        view.add_state(t, [0.3 * t, 0.0, 0.07], 0.0, 0.3, wall=100.0 + wall_per_sim * t)
        feet = np.array([[0.2 + 0.001 * k, 0.05, 0.0], [0.2, -0.05, 0.0], [-0.1, 0.05, 0.0], [-0.1, -0.05, 0.0]])
        view.add_feet(t, positions=feet)
        view.add_feet(t, contact=[True, False, k % 2 == 0, False])


def test_frame_at_a_time_gathers_path_contacts_speed_slip_and_realtime_factor():
    view = RunView()
    _walk(view)
    frame = view.frame(1.0)
    assert frame.time == 1.0
    assert np.allclose(frame.root, [0.3, 0.0, 0.07])
    assert len(frame.path) == 31 and np.allclose(frame.path[-1], frame.root)
    assert np.allclose(frame.contacts, [[0.23, 0.05, 0.0], [-0.1, 0.05, 0.0]])          # frame 30: fl and hl
    assert frame.speed == pytest.approx(0.3)
    assert frame.realtime_factor == pytest.approx(2.0)                                  # received at half speed
    rows = view.feet.values[0:31]                                                        # the last second
    expected = slip_per_foot(rows[:, :, :2], rows[:, :, 3] == 1.0, 1).sum() / 1.0
    assert frame.slip == pytest.approx(expected) and frame.slip == pytest.approx(0.030, abs=1e-9)
    assert view.frame().time == pytest.approx(2.0)                                       # latest


def test_a_push_arrow_points_along_the_force_at_the_root_and_outlasts_a_short_push():
    view = RunView()
    _walk(view)
    view.add_push(PushEvent(0.5, np.array([0.0, -40.0, 0.0]), 'trunk_left', 0.1))
    assert len(view.frame(0.4).arrows) == 0
    arrow = view.frame(0.55).arrows[0]
    assert np.allclose(arrow[1] - arrow[0], [0.0, -40.0 * ARROW_M_PER_N, 0.0])
    assert np.allclose(arrow[1][:2], view.frame(0.55).root[:2])
    assert len(view.frame(0.5 + ARROW_SHOW_S - 0.01).arrows) == 1
    assert len(view.frame(0.5 + ARROW_SHOW_S + 0.01).arrows) == 0


def test_goals_and_unknown_figures_before_anything_arrived():
    view = RunView()
    frame = view.frame()
    assert frame.root is None and frame.mesh is None and frame.goals is None and len(frame.path) == 0
    assert panel_lines(frame) == ['simulated time 0.00 s', 'realtime factor –', 'clip –', 'speed –',
                                  'foot slip –']
    first = GoalSet(0.0, np.zeros((1, 3)), np.array([0.05]), np.ones((1, 4)))
    second = GoalSet(2.0, np.ones((2, 3)), np.array([0.05, 0.05]), np.ones((2, 4)))
    view.add_goals(second)
    view.add_goals(first)
    assert view.frame(1.0).goals is first and view.frame(2.5).goals is second


def test_a_placed_clip_is_named_after_its_library_clip():
    from iguana_ros.motion.clips import load_clip_library
    from iguana_ros.stages import motion_graph
    library = load_clip_library()
    graph = motion_graph(library)
    previous = graph.align('forward', np.array([0.4, -0.2]), 0.3)
    for name in ('turn_left', 'forward', 'idle', 'turn_right'):
        placed = graph.align(name, np.array([1.0, 2.0]), 1.2, previous=previous)   # turned, moved, blended
        assert identify_clip(placed.local_rotations, library) == name
        previous = placed
    other = placed.local_rotations.copy()
    other[-1, 5] = [0.0, 0.0, math.sin(0.2), math.cos(0.2)]
    assert identify_clip(other, library) == ''
    assert identify_clip(other[:5], library) == ''


def test_a_left_flank_push_points_to_the_bodys_right():
    force, region = flank_push(0.0, 40.0, 'left')
    assert region == 'trunk_left' and np.allclose(force, [0.0, -40.0, 0.0])       # as the push_normal scene
    force, region = flank_push(math.pi / 2, 10.0, 'right')
    assert region == 'trunk_right' and np.allclose(force, [-10.0, 0.0, 0.0])


def test_playback_plays_pauses_scrubs_loops_and_stops_at_the_end():
    pb = Playback(1.0, 5.0, speed=2.0)
    assert pb.time == 1.0 and pb.playing
    assert pb.advance(0.5) == pytest.approx(2.0)
    pb.toggle()
    assert pb.advance(10.0) == pytest.approx(2.0)                 # paused
    assert pb.seek(4.5) == 4.5 and pb.seek(-3.0) == 1.0 and pb.seek(9.0) == 5.0
    pb.toggle()                                                    # playing at the end: from the start
    assert pb.time == 1.0 and pb.playing
    assert pb.advance(3.0) == 5.0 and not pb.playing               # stops at the end
    looping = Playback(0.0, 4.0, loop=True)
    assert looping.advance(5.0) == pytest.approx(1.0) and looping.playing


def test_a_long_path_is_thinned_and_only_grows_between_doublings_of_its_stride():
    """
    A long path is thinned and only grows between doublings of its stride.

    The defect: the path was thinned evenly to 2000 points, so past 2000 states (67 s) its length stayed 2000 and the
    page, which redrew it when its length changed, froze it; thinned evenly it also changed everywhere at each state.
    """
    view = RunView()
    for k in range(PATH_MAX_POINTS * 2 + 500):
        view.add_state(k / 30.0, [0.01 * k, 0.0, 0.07], 0.0, 0.3)
    paths = {k: view.frame(k / 30.0).path for k in (100, PATH_MAX_POINTS + 300, PATH_MAX_POINTS + 301,
                                                    PATH_MAX_POINTS * 2 + 499)}
    assert len(paths[100]) == 101                                             # short: every state
    for k, path in paths.items():
        assert len(path) <= PATH_MAX_POINTS + 1 and np.allclose(path[-1], [0.01 * k, 0.0, 0.07])   # ends at the root
        assert np.allclose(path[0], [0.0, 0.0, 0.07])
    assert path_stride(PATH_MAX_POINTS + 300) == 2 and path_stride(PATH_MAX_POINTS * 2 + 499) == 4
    a, b = paths[PATH_MAX_POINTS + 300], paths[PATH_MAX_POINTS + 301]
    assert len(b) >= len(a) and np.array_equal(b[:len(a) - 1], a[:-1])       # later: the same points, and more


def test_a_growing_path_resends_only_its_last_piece():
    from iguana_ros.view.server import PATH_PIECE, ViewerPage
    server = ViewerPage(RunView(), port=0)
    try:
        path = np.column_stack([np.arange(2 * PATH_PIECE + 10) * 0.01, np.zeros(2 * PATH_PIECE + 10),
                                np.zeros(2 * PATH_PIECE + 10)])
        server._draw_path(path[:2 * PATH_PIECE + 5])
        first = {name: server.handles[name] for name in ('path/0', 'path/1', 'path/2')}
        server._draw_path(path)                                           # five more points
        assert [server.handles[n] is first[n] for n in ('path/0', 'path/1', 'path/2')] == [True, True, False]
        server._draw_path(path[:PATH_PIECE // 2])                         # scrubbed back: one short piece
        assert sorted(n for n in server.handles if n.startswith('path/')) == ['path/0']
        assert len(server.drawn.path_pieces) == 1
    finally:
        server.close()
