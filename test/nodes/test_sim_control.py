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
The simulator's sim/pause, sim/resume, sim/step and sim/reset services drive a real `iguana run` (four node processes).

A lockstep run started paused holds frame 0, `step 30` advances exactly 30 frames whose roots are the library loop's
bit for bit, a pause holds the state bit for bit, reset puts the body back at its start pose (recorded on run_events),
`iguana sim` refuses a bad step in one line; a realtime run pauses and steps the same way.
"""
import subprocess
import time

import numpy as np
import pytest

from iguana_ros.bag.trajectory import read_root_trajectory, read_topics
from iguana_ros.constants import FRAME_RATE
from iguana_ros.errors import IguanaError
from iguana_ros.nodes.commander import IguanaCommander
from iguana_ros.pipeline import run as run_pipeline
from iguana_ros.ros.run_events import EVENT_PAUSED, EVENT_RESET, run_event_from_msg
from iguana_ros.scene import load_scene
from ros_harness import IGUANA, start_scene_run, stop_scene_run, wait_for

pytestmark = [pytest.mark.ros, pytest.mark.slow, pytest.mark.timeout(300)]

FRAMES = 90
SCENE = {'name': 'controlled', 'description': 'a short walk on flat ground, driven by the sim/* services',
         'terrain': {'kind': 'flat'}, 'goals': [{'x': 1.5, 'y': 0.3}], 'duration': FRAMES / FRAME_RATE}


def _start(folder, mode: str) -> tuple:
    """Start `iguana run SCENE --paused` in `mode` with a bag; return (scene path, bag path, process)."""
    run = start_scene_run(folder, SCENE, '--mode', mode, '--paused')
    return run.scene, run.bag, run.process


def _held_for(iguana: IguanaCommander, seconds: float) -> list:
    """Return the simulated times of the iguana_state messages received while spinning `seconds` wall seconds."""
    before = iguana.states_since(0.0)
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        iguana.state(timeout=deadline - time.monotonic())
    return [s.time for s in iguana.states_since(0.0)[len(before):]]


def _newest_time(iguana: IguanaCommander) -> float | None:
    """Return the simulated time of the newest iguana_state (spinning up to 0.5 s for news), None before any."""
    try:
        return iguana.state(timeout=0.5).time
    except IguanaError:
        return None


def _run_events(bag) -> list:
    """Return the RunEvents recorded in `bag`."""
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.serialization import deserialize_message
    return [run_event_from_msg(deserialize_message(data, DiagnosticArray))
            for data in read_topics(bag, ['run_events']).messages['run_events']]


@pytest.fixture(scope='module')
def lockstep(tmp_path_factory):
    """Start a commander, then a paused lockstep run on its domain; stop the run after the module's tests."""
    iguana = IguanaCommander()             # first: its subscription is matched when frame 0 goes out, once
    scene, bag, run = _start(tmp_path_factory.mktemp('lockstep'), 'lockstep')
    try:
        yield scene, bag, run, iguana
    finally:
        iguana.close()
        stop_scene_run(run)


def test_a_paused_start_holds_frame_0_and_step_30_advances_exactly_30_frames(lockstep):
    _, _, run, iguana = lockstep
    # a busy machine may discover the commander after frame 0 went out: a service answered means the simulator's
    # participant knows the commander's, and a reset at frame 0 re-sends the start pose
    assert iguana.pause(timeout=120.0).success and iguana.reset().success
    start = iguana.state(timeout=30.0)
    assert start.time == 0.0, run.output[-2000:]
    assert _held_for(iguana, 1.5) == [], 'a paused simulator published states'
    reply = iguana.step(30)
    assert reply.success and reply.frame == 30 and reply.time == pytest.approx(30 / FRAME_RATE), reply
    assert wait_for(lambda: _newest_time(iguana) == pytest.approx(1.0), 30.0, 0.0)
    frames = [round(s.time * FRAME_RATE) for s in iguana.states_since(0.0)]
    assert [f for f in frames if f > 0] == list(range(1, 31)), frames                    # every frame, once
    held = iguana.state()
    assert _held_for(iguana, 1.5) == [], 'the step did not hold at its last frame'
    again = iguana.state(timeout=0.2)
    assert again is held or (np.array_equal(again.position, held.position) and again.time == held.time)


def test_pause_while_stepping_refuses_a_step_past_the_end_and_reset_returns_to_the_start(lockstep):
    _, _, _, iguana = lockstep
    first = iguana.states_since(0.0)[0]
    assert iguana.pause().success
    with pytest.raises(IguanaError, match='between 1 and 60'):
        iguana.step(61)                              # 30 of the scene's 90 frames simulated
    reply = iguana.reset()
    assert reply.success and 'frame 30' in reply.message, reply
    assert wait_for(lambda: np.array_equal(iguana.state(timeout=0.5).position, first.position), 30.0, 0.0)
    reset = iguana.state()
    assert reset.time == pytest.approx(1.0)          # simulated time goes on
    assert np.array_equal(reset.orientation, first.orientation)
    assert np.allclose(reset.linear_velocity, 0.0) and np.allclose(reset.angular_velocity, 0.0)


def test_iguana_sim_steps_refuses_in_one_line_and_resumes_to_the_end(lockstep, walk_library_run):
    scene, bag, run, iguana = lockstep
    done = subprocess.run([*IGUANA, 'sim', 'step', '5'], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0 and 'stepped to frame 35' in done.stdout, done.stdout + done.stderr
    bad = subprocess.run([*IGUANA, 'sim', 'step', '0'], capture_output=True, text=True, timeout=120)
    assert bad.returncode != 0 and bad.stderr.strip().count('\n') == 0 and '1 to' in bad.stderr, bad.stderr
    late = subprocess.run([*IGUANA, 'sim', 'step', '500'], capture_output=True, text=True, timeout=120)
    assert late.returncode == 1 and late.stderr.startswith('error: cannot step 500 frames'), late.stderr
    resumed = subprocess.run([*IGUANA, 'sim', 'resume'], capture_output=True, text=True, timeout=120)
    assert resumed.returncode == 0 and 'resumed at frame 35' in resumed.stdout, resumed.stdout + resumed.stderr
    assert wait_for(lambda: not run.running, 120.0, 0.2), run.output[-2000:]
    assert run.proc.returncode == 0, run.output[-3000:]
    assert 's of it paused; realtime factor' in run.output, run.output[-3000:]   # paused time left out of it
    times, roots = read_root_trajectory(bag)
    assert np.allclose(times, np.arange(FRAMES + 1) / FRAME_RATE)
    # frames 1-29: the library loop's, bit for bit (a paused start and a step change nothing in lockstep)
    assert np.array_equal(roots[1:30], walk_library_run.root_positions[:29])
    assert np.array_equal(roots[30], roots[0])       # frame 30 re-sent after the reset: the start pose
    kinds = [(e.kind, e.frame) for e in _run_events(bag) if e.node == 'simulator_node']
    assert (EVENT_PAUSED, 30) in kinds and (EVENT_RESET, 30) in kinds, kinds


@pytest.fixture(scope='module')
def walk_library_run(lockstep):
    scene = lockstep[0]
    return run_pipeline(load_scene(str(scene)), n_frames=29)


def test_a_realtime_run_pauses_steps_and_resumes(tmp_path):
    with IguanaCommander() as iguana:      # first: its subscription is matched when frame 0 goes out, once
        _, _, run = _start(tmp_path, 'realtime')
        try:
            assert iguana.step(30, timeout=120.0).frame == 30     # answered once frame 30 is simulated
            assert wait_for(lambda: _newest_time(iguana) == pytest.approx(1.0), 30.0, 0.0), run.output[-2000:]
            assert _held_for(iguana, 1.0) == []
            held = iguana.state()
            assert held.time == pytest.approx(1.0)
            assert iguana.resume().success
            assert wait_for(lambda: iguana.state(timeout=0.5).time > 1.5, 30.0, 0.0)
            paused = iguana.pause()
            assert paused.success
            iguana.state(timeout=0.3)                # a state in flight when the pause arrived
            frozen = iguana.state()
            assert _held_for(iguana, 1.0) == [] and f'frame {round(frozen.time * FRAME_RATE)}' in paused.message
        finally:
            stop_scene_run(run)
