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
The planner's go_to_pose action on a real `iguana run` (four node processes over DDS).

Through IguanaCommander, GoToPoseClient and `iguana goal`.

A refused goal has its reason within 1 s; a goal is reached with SUCCEEDED and feedback at stride ends; a newer goal
replaces an older one; a cancelled goal stops the iguana.
"""
import math
import time

import numpy as np
import pytest

from iguana_ros.errors import IguanaError
from iguana_ros.nodes.commander import IguanaCommander
from iguana_ros.nodes.go_to_pose import goal_request, GoToPoseClient
from iguana_ros.nodes.goal_sender import goal_message
from ros_harness import IGUANA, NodeProcess, start_scene_run, stop_scene_run, wait_for

pytestmark = [pytest.mark.ros, pytest.mark.slow, pytest.mark.timeout(300)]

SCENE = {'name': 'go_to_pose', 'description': 'no goals of its own: the tests send them', 'terrain': {'kind': 'flat'},
         'model': {'resolution': 'coarse'}, 'duration': 200.0}


@pytest.fixture(scope='module')
def running(tmp_path_factory):
    """`iguana run` of a goal-less flat scene (realtime), a commander and a second action client on its node."""
    run = start_scene_run(tmp_path_factory.mktemp('go_to_pose'), SCENE, '--mode', 'realtime').process
    commander = IguanaCommander()
    try:
        commander.state(timeout=120.0)
        yield run, commander, GoToPoseClient(commander.node)
    finally:
        commander.close()
        stop_scene_run(run)


def _nan_goal():
    msg = goal_message(1.0, 0.0)
    msg.pose.position.y = math.nan
    return msg


@pytest.mark.parametrize('pose, reason', [
    (goal_message(1.0, 0.0, frame_id='base_link'), "goal_pose has frame_id 'base_link', expected 'world'"),
    (goal_message(50.0, 0.0), 'goal (50, 0) is off the terrain'),
    (_nan_goal(), 'goal position has 1 non-finite value(s)'),
])
def test_a_refused_goal_has_its_reason_within_a_second(running, pose, reason):
    _, _, client = running
    client.wait_for_server(30.0)
    start = time.monotonic()
    with pytest.raises(IguanaError, match='refused: ') as refused:
        client.send(goal_request(pose), timeout=10.0)
    latency = time.monotonic() - start
    print(f'refusal latency {latency * 1000:.0f} ms')
    assert latency < 1.0 and reason in str(refused.value), (latency, refused.value)
    result = client.result(1.0)
    assert not result.reached and result.outcome == 'refused' and result.code == 1


def test_a_goal_is_reached_with_feedback_at_stride_ends(running):
    run, iguana, _ = running
    start = iguana.state().position[:2]
    iguana.go_to(*(start + [0.8, 0.0]), position_tolerance=0.2, timeout=30.0)
    while not iguana.is_task_complete():
        iguana.feedback()
    seen = iguana.feedback_history()           # feedback() is the latest: a busy machine may skip one between calls
    result = iguana.result(1.0)
    assert result.reached and result.outcome == 'succeeded' and result.distance_remaining <= 0.2, (
        result, run.output[-2000:])
    strides = [fb.strides for fb in seen]
    assert strides[0] == 0 and strides == sorted(strides) and strides[-1] >= 3, strides
    assert all(math.isfinite(fb.distance_remaining) and fb.status for fb in seen)
    assert 0.0 < result.time_elapsed and seen[-1].distance_remaining < seen[0].distance_remaining


def test_a_newer_goal_replaces_the_older_one(running):
    _, iguana, client = running
    start = iguana.state().position[:2]
    iguana.go_to(*(start + [0.0, 2.0]), timeout=30.0)
    client.send(goal_request(goal_message(*(start + [0.0, -0.5]))), timeout=30.0)
    replaced = iguana.result(30.0)
    assert not replaced.reached and replaced.outcome == 'replaced' and replaced.code == 3, replaced
    assert client.cancel(30.0).outcome == 'canceled'


def _travel(states) -> float:
    """Return the horizontal distance m between the first and the last of `states`."""
    return float(np.hypot(*(states[-1].position[:2] - states[0].position[:2])))


def test_a_cancelled_goal_stops_the_iguana(running):
    _, iguana, _ = running
    start = iguana.state().position[:2]
    goal = start + [-2.0, 0.0]
    iguana.go_to(*goal, timeout=30.0)
    assert wait_for(lambda: iguana.feedback().strides >= 4, 30.0, period=0.0)
    walked_from = iguana.state().time
    assert wait_for(lambda: iguana.state().time > walked_from + 1.0, 30.0, period=0.0)
    walking = _travel(iguana.states_since(walked_from))
    result = iguana.cancel()
    assert result.outcome == 'canceled' and not result.reached and result.code == 2, result
    stopped_at = iguana.state().time
    assert wait_for(lambda: iguana.state().time > stopped_at + 4.0, 30.0, period=0.0)
    resting = _travel(iguana.states_since(stopped_at + 3.0))       # over the 4th second after the cancel
    assert walking > 0.05 and resting < 0.02, (walking, resting)   # measured: 0.085 m and 0.001 m
    assert np.hypot(*(iguana.state().position[:2] - goal)) > 1.0


def test_iguana_goal_refused_accepted_wait_and_cancel(running, tmp_path):
    _, iguana, _ = running
    x, y = iguana.state().position[:2]

    def goal(*args: str) -> NodeProcess:
        proc = NodeProcess([*IGUANA, 'goal', *args], 'goal', tmp_path).start()
        proc.wait(60)
        return proc
    refused = goal('100', '0')
    assert refused.proc.returncode == 1 and refused.output.strip() == (
        'iguana goal: error: refused: goal (100, 0) is off the terrain (|x|, |y| <= 5 m)')
    waited = goal(f'{x + 0.5:g}', f'{y:g}', '--tolerance', '0.25', '--wait', '--timeout', '30')
    lines = waited.output.strip().splitlines()
    assert waited.proc.returncode == 0 and lines[0].startswith('goal accepted by the planner on go_to_pose'), lines
    assert lines[-1].startswith('reached (succeeded): goal') and any('strides=1 ' in line for line in lines), lines
    far = goal(f'{x - 2:g}', f'{y:g}', '--timeout', '30')
    assert far.proc.returncode == 0 and 'goal accepted' in far.output
    cancel = goal('--cancel')
    assert cancel.proc.returncode == 0 and cancel.output.strip() == 'cancelled 1 goal', cancel.output
