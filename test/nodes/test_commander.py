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
IguanaCommander drives a real `iguana run` (four node processes over DDS).

A goal the planner adopts and the body reaches, a push with its duration that moves the body sideways, and refusals as
one clear error.
"""

import numpy as np
import pytest

from iguana_ros.errors import IguanaError
from iguana_ros.nodes.commander import IguanaCommander
from ros_harness import start_scene_run, stop_scene_run, wait_for

pytestmark = [pytest.mark.ros, pytest.mark.slow, pytest.mark.timeout(300)]

SCENE = {'name': 'commanded', 'description': 'no goals of its own: the commander sends them',
         'terrain': {'kind': 'flat'}, 'duration': 120.0}


@pytest.fixture(scope='module')
def running(tmp_path_factory):
    """
    `iguana run` of a goal-less flat scene, stopped with SIGTERM after the module's tests.

    Realtime, as a commander drives a running system: in lockstep a fast machine walked the 2 m of the first test in
    ~2.5 s of wall time, before a loaded one had delivered the goal's acceptance to `go_to`.
    """
    run = start_scene_run(tmp_path_factory.mktemp('commander'), SCENE, '--mode', 'realtime').process
    commander = IguanaCommander()
    try:
        yield run, commander
    finally:
        commander.close()
        stop_scene_run(run)


def test_go_to_is_adopted_and_reached(running):
    run, iguana = running
    start = iguana.state(timeout=90.0)
    assert np.all(np.isfinite(start.position)) and start.time >= 0.0
    # far enough that the walk is not over once go_to returns: 2 m is ~10 s of walking (realtime: of wall time)
    goal = start.position[:2] + [2.0, 0.0]
    iguana.go_to(*goal, yaw=0.0, timeout=30.0)
    assert iguana.distance_to_goal() > iguana.goal_radius
    assert iguana.wait_until_reached(timeout=90.0), (iguana.distance_to_goal(), run.output[-2000:])
    reached = iguana.state()
    assert reached.time > start.time and np.hypot(*(reached.position[:2] - goal)) < iguana.goal_radius


def test_push_with_a_duration_moves_the_body_sideways(running):
    _, iguana = running
    calm = [iguana.state().linear_velocity[1] for _ in range(15)]
    sent = iguana.push('trunk_left', (0.0, -60.0, 0.0), duration=0.2)
    # period 0, no sleep: each poll spins for the next state (those received while waiting for the ack are kept too)
    assert wait_for(lambda: iguana.state().time >= sent + 1.5, 60.0, period=0.0), iguana.state().time
    lateral = iguana.states_since(sent)
    assert len(lateral) >= 45, [s.time for s in lateral]   # no state lost from the 1.5 s after the push
    pushed = min(s.linear_velocity[1] for s in lateral)
    assert pushed < -0.1 and pushed < 3 * -max(abs(v) for v in calm), (pushed, calm)   # toward -y, beyond sway


def test_follow_waypoints_passes_them_in_order_with_feedback(running):
    run, iguana = running
    start = iguana.state().position[:2]
    points = [start + [1.0, 0.0], start + [1.0, 0.7]]    # the first leg several strides long: its feedback is seen
    iguana.follow_waypoints(points, yaw=np.pi / 2, timeout=30.0)
    heading_for = []
    for _ in range(1200):
        if iguana.wait_until_reached(timeout=0.1):
            break
        heading_for.append(iguana.feedback().waypoint)
    done = iguana.feedback()
    assert done.state == 'arrived' and done.waypoints == 2 and done.waypoint == 1, (done, run.output[-2000:])
    assert heading_for == sorted(heading_for) and heading_for[0] == 0, heading_for    # in order, the first first
    end = iguana.state()
    assert np.hypot(*(end.position[:2] - points[-1])) < iguana.goal_radius + 0.05
    assert abs(np.angle(np.exp(1j * (end.yaw - np.pi / 2)))) < np.radians(35.0), end.yaw


def test_refusals_are_one_clear_error(running):
    _, iguana = running
    with pytest.raises(IguanaError, match='push_duration'):
        iguana.push('trunk_left', (0.0, -10.0, 0.0), duration=100.0)   # outside its declared [0.001, 10] s
    with pytest.raises(IguanaError, match=r'refused: goal \(500, 0\) is off the terrain'):
        iguana.go_to(500.0, 0.0, timeout=5.0)   # off the terrain: the planner refuses it with the reason
    with pytest.raises(IguanaError, match='not finite'):
        iguana.go_to(float('nan'), 0.0)
    with pytest.raises(IguanaError, match='did not accept'):
        iguana.follow_waypoints([(0.5, 0.0), (500.0, 0.0)], timeout=5.0)   # a waypoint off the terrain
    with pytest.raises(IguanaError, match='finite waypoints'):
        iguana.follow_waypoints([])
