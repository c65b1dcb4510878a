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
`iguana goal`.

The planner (a real node process) accepts the goal through its go_to_pose action and the command says so; bad numbers,
no planner and a goal the planner refuses exit 1 with one line (a refusal with its reason).
"""
import sys

import pytest

from iguana_ros.cli import main
from ros_harness import IGUANA, NodeProcess, spin_until


@pytest.mark.parametrize('argv, message', [
    (['goal', 'nan', '1'], 'goal x is nan; expected a finite number'),
    (['goal', '1', 'inf'], 'goal y is inf; expected a finite number'),
    (['goal', '1', '2', '--yaw', 'nan'], 'goal yaw is nan'),
    (['goal', '1', '2', '--timeout', '0'], '--timeout is 0.0'),
    (['goal', '1'], 'expected X and Y'),
    (['goal', '1', '2', '--cancel'], 'expected X and Y, or --cancel without them'),
])
def test_non_finite_goal_is_one_line_exit_1(capsys, argv, message):
    assert main(argv) == 1
    err = capsys.readouterr().err.strip()
    assert message in err and len(err.splitlines()) == 1


@pytest.mark.ros
def test_no_planner_times_out_with_clear_message(capsys):
    assert main(['goal', '1', '2', '--timeout', '0.5']) == 1
    assert capsys.readouterr().err.strip() == (
        'iguana goal: error: no planner answers the go_to_pose action within 0.5 s; '
        'is planner_node running on this ROS_DOMAIN_ID?')


def _planner(tmp_path) -> NodeProcess:
    """Return a planner process on a small flat scene (10 m terrain), not started."""
    scene = tmp_path / 'scene.yaml'
    scene.write_text('model: {resolution: coarse}\nterrain: {kind: flat}\nduration: 2.0\n')
    return NodeProcess([sys.executable, '-m', 'iguana_ros.nodes.planner_node', '--ros-args', '-p', f'scene:={scene}'],
                       'planner_node', tmp_path)


def _listener(make_node, executor) -> tuple[list, object]:
    """
    Return (messages, subscription) of a second subscriber on goal_pose (a recorder, a viewer).

    It must not stand in for the planner.
    """
    from iguana_ros.ros.endpoints import resolve
    name, cls, qos = resolve('goal_pose')
    node = make_node('goal_listener')
    executor.add_node(node)
    received = []
    sub = node.create_subscription(cls, name, received.append, qos)
    return received, sub


@pytest.mark.ros
def test_another_subscriber_without_a_planner_is_not_a_sent_goal(tmp_path, make_node, executor):
    received, _ = _listener(make_node, executor)
    goal = NodeProcess([*IGUANA, 'goal', '1.5', '-2', '--timeout', '2'], 'goal', tmp_path).start()
    with goal:
        assert spin_until(executor, lambda: not goal.running, 20)
    assert goal.proc.returncode == 1, goal.output
    assert goal.output.strip().splitlines() == [
        'iguana goal: error: no planner answers the go_to_pose action within 2 s; '
        'is planner_node running on this ROS_DOMAIN_ID?']
    assert received == []  # nothing went out: the goal was not sent to a listener in the planner's place


@pytest.mark.ros
@pytest.mark.long
@pytest.mark.timeout(150)
def test_goal_waits_for_a_planner_that_starts_later(tmp_path):
    """
    `iguana goal` waits for a planner that starts after it, through the go_to_pose action.

    A goal the planner refuses exits 1 with the reason; a goal stamped in simulated time is scheduled for then.
    """
    goal = NodeProcess([*IGUANA, 'goal', '1.5', '-2', '--yaw', '90', '--timeout', '90'], 'goal', tmp_path).start()
    with goal:
        with _planner(tmp_path).start() as planner:
            assert goal.wait(100) == 0, goal.output + planner.output
            assert 'go_to_pose goal (1.50, -2.00), heading 1.57 rad scheduled for t=0.000 s' in planner.output
            rejected = NodeProcess([*IGUANA, 'goal', '1e9', '0', '--timeout', '8'], 'rejected', tmp_path).start()
            assert rejected.wait(30) == 1
            later = NodeProcess([*IGUANA, 'goal', '1', '0.5', '--at', '2', '--timeout', '30'], 'later', tmp_path)
            later.start()
            assert later.wait(40) == 0, later.output
            assert planner.running
    assert 'goal accepted by the planner on go_to_pose: x=1.5 y=-2 yaw=90 deg frame=world' in goal.output
    assert rejected.output.strip() == ('iguana goal: error: refused: goal (1e+09, 0) is off the terrain '
                                       '(|x|, |y| <= 5 m)')
    assert 'go_to_pose goal refused: goal (1e+09, 0) is off the terrain' in planner.output
    assert 'go_to_pose goal (1.00, 0.50), any heading scheduled for t=2.000 s' in planner.output


@pytest.mark.ros
@pytest.mark.long
@pytest.mark.timeout(300)
def test_every_goal_the_planner_accepted_during_a_recorded_run_is_in_the_bag(tmp_path):
    """
    Issue 30, item 4: 6 goals sent with `iguana goal` during `iguana run --record` each exited 0, 2 reached the bag.

    `iguana goal` exited before the recorder had matched its short-lived publisher. Goals now go through the
    go_to_pose action; the planner lists each one it accepted on the latched accepted_goals, which the bag records.
    """
    import yaml
    from iguana_ros.bag.storage import BagReader
    scene = tmp_path / 'goals.yaml'
    scene.write_text(yaml.safe_dump({'model': {'resolution': 'coarse'}, 'terrain': {'kind': 'flat'},
                                     'goals': [{'x': 1.0, 'y': 0.0}], 'duration': 300.0}))   # stopped below
    bag = tmp_path / 'bag'
    run = NodeProcess([*IGUANA, 'run', str(scene), '--mode', 'realtime', '--record', str(bag)], 'run', tmp_path)
    with run.start():
        assert run.wait_for_output('simulated', 120), run.output          # the progress lines: under way
        for k in range(6):
            goal = NodeProcess([*IGUANA, 'goal', f'{0.5 + 0.2 * k:g}', '-0.4', '--timeout', '30'], f'goal{k}',
                               tmp_path).start()
            assert goal.wait(60) == 0, goal.output
        run.stop()
    from nav_msgs.msg import Path
    from rclpy.serialization import deserialize_message
    lists = [m for m in BagReader(bag).messages() if m.topic == '/accepted_goals']
    accepted = deserialize_message(lists[-1].data, Path).poses
    assert len(accepted) == 7, f'{len(accepted)} accepted goals in the bag, expected the scene goal and 6 sent'
