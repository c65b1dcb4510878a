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
The progress display's parts without ROS.

The tests cover start-up milestones into phases, the active goal, the windowed realtime factor, the progress line, and
the display on a pipe (lines) and on a terminal (a tqdm bar).
"""
from __future__ import annotations

import io
import math

import pytest

from iguana_ros.ros.run_events import EVENT_LOADED, EVENT_UP, RunEvent
from iguana_ros.supervisor.progress_display import (active_goal, EVENTS_GRACE_S, PhaseTime, ProgressDisplay,
                                                    RateWindow, RunStatus, startup_line, StartupClock)

NODES = ('planner_node', 'simulator_node')


def test_phases_follow_the_milestones_of_every_node():
    clock = StartupClock(NODES, launched=100.0)
    assert clock.current() == 'launching nodes' and clock.finished() == ()
    clock.note(RunEvent('planner_node', EVENT_UP, 101.0))
    clock.note(RunEvent('stranger', EVENT_UP, 150.0))               # not one of the run's nodes: ignored
    assert clock.current() == 'launching nodes'
    clock.note(RunEvent('simulator_node', EVENT_UP, 102.5))
    clock.note(RunEvent('simulator_node', EVENT_LOADED, 104.0, detail='model from cache'))
    assert [p.label for p in clock.finished()] == ['launching nodes'] and clock.current() == 'loading the model'
    clock.note(RunEvent('planner_node', EVENT_LOADED, 103.0))
    clock.note_frame(0, 105.0)
    clock.note_frame(1, 107.25)
    clock.note_frame(2, 107.3)
    assert clock.finished() == (PhaseTime('launching nodes', 2.5),
                                PhaseTime('loading the model', 1.5, 'model from cache'),
                                PhaseTime('DDS discovery', 1.0), PhaseTime('compiling kernels', 2.25))
    assert clock.current() == ''
    assert startup_line(clock.finished()) == ('start-up: launching nodes 2.50 s, loading the model 1.50 s (model from '
                                              'cache), DDS discovery 1.00 s, compiling kernels 2.25 s')


def test_a_phase_that_ends_early_counts_zero_and_nothing_before_the_launch():
    clock = StartupClock(NODES)
    clock.note_frame(1, 5.0)
    assert clock.current() == '' and clock.finished() == ()
    clock.launched = 1.0
    for node in NODES:
        clock.note(RunEvent(node, EVENT_UP, 2.0))
        clock.note(RunEvent(node, EVENT_LOADED, 6.0))           # built after frame 0 was out (frame 0 = frame 1 here)
    assert [p.seconds for p in clock.finished()] == [1.0, 4.0, 0.0, 0.0]


def test_start_up_is_over_once_every_phase_ended_or_events_are_overdue():
    clock = StartupClock(NODES, launched=1.0)
    clock.note_frame(0, 5.0)
    clock.note_frame(1, 5.1)                                    # frame 1 heard before any node's events
    assert not clock.over(5.2) and not clock.over(5.1 + EVENTS_GRACE_S)
    for node in NODES:
        clock.note(RunEvent(node, EVENT_UP, 2.0))
        clock.note(RunEvent(node, EVENT_LOADED, 3.0))
    assert clock.over(5.2)
    late = StartupClock(NODES, launched=1.0)
    assert not late.over(100.0)                                 # no frame 1: never over
    late.note_frame(1, 5.0)
    assert late.over(5.01 + EVENTS_GRACE_S)                     # events never came: progress shows anyway


def test_active_goal_is_the_last_due_one():
    goals = [(1.0, 0.0, 0.0), (2.0, 0.0, 5.0), (3.0, 1.0, 1.7e9)]   # the last stamped with the wall clock
    assert active_goal([], 1.0, 3600.0) is None
    assert active_goal(goals[:2], 1.0, 3600.0) == (1.0, 0.0)
    assert active_goal(goals[:2], 5.0, 3600.0) == (2.0, 0.0)
    assert active_goal(goals, 1.0, 3600.0) == (3.0, 1.0)


def test_rate_window_measures_recent_speed():
    rate = RateWindow(window_s=2.0)
    assert math.isnan(rate.factor())
    for k in range(11):                                          # 1 s simulated per wall second, then 3
        rate.add(float(k), float(k))
    for k in range(1, 6):
        rate.add(10.0 + k, 10.0 + 3 * k)
    assert rate.factor() == pytest.approx(3.0)


def test_status_line_names_only_what_is_known():
    assert RunStatus(3.4, 25.0).line() == '3.40 of 25.00 s simulated (14 %)'
    full = RunStatus(3.4, 25.0, 1.314, 2.1, 'walk_3')
    assert full.line() == "3.40 of 25.00 s simulated (14 %), realtime factor 1.31, 2.10 m to the goal, clip 'walk_3'"


def test_display_on_a_pipe_writes_phases_and_a_line_per_period():
    out = io.StringIO()
    display = ProgressDisplay(out, period_s=3600.0)
    assert not display.use_bar
    display.phases((), 'launching nodes')
    display.phases((PhaseTime('launching nodes', 2.0),), 'loading the model')
    display.update(RunStatus(1.0, 10.0))
    display.update(RunStatus(2.0, 10.0))                         # within the period: no second line
    display.close()
    assert out.getvalue().splitlines() == ['[start-up] launching nodes ...', '[start-up] launching nodes: 2.00 s',
                                           '[start-up] loading the model ...',
                                           '[progress] 1.00 of 10.00 s simulated (10 %)']


def test_display_on_a_terminal_draws_a_bar():
    out = io.StringIO()
    display = ProgressDisplay(out, bar=True)
    display.phases((PhaseTime('compiling kernels', 0.5),), '')
    display.update(RunStatus(2.5, 10.0, 1.2, 0.8, 'turn_left'))
    display.close()
    text = out.getvalue()
    assert '[start-up] compiling kernels: 0.50 s' in text
    assert '\r' in text and '[progress] simulated 2.50/10.00 s |' in text, text
    assert "realtime factor 1.20, 0.80 m to the goal, clip 'turn_left'" in text
