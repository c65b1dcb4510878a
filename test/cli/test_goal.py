"""`iguana goal`: a real subscriber receives the PoseStamped; bad numbers and no subscriber exit 1."""
import math

import numpy as np
import pytest
from ros_harness import IGUANA, NodeProcess, spin_until

from iguana_ros.cli import main


@pytest.mark.parametrize('argv, message', [
    (['goal', 'nan', '1'], 'goal x is nan; expected a finite number'),
    (['goal', '1', 'inf'], 'goal y is inf; expected a finite number'),
    (['goal', '1', '2', '--yaw', 'nan'], 'goal yaw is nan'),
    (['goal', '1', '2', '--timeout', '0'], '--timeout is 0.0'),
])
def test_non_finite_goal_is_one_line_exit_1(capsys, argv, message):
    assert main(argv) == 1
    err = capsys.readouterr().err.strip()
    assert message in err and len(err.splitlines()) == 1


@pytest.mark.ros
def test_no_subscriber_times_out_with_clear_message(capsys):
    assert main(['goal', '1', '2', '--timeout', '0.5']) == 1
    assert capsys.readouterr().err.strip() == 'iguana goal: error: no subscriber on /goal_pose within 0.5 s'


@pytest.mark.ros
def test_goal_reaches_a_real_subscriber(tmp_path, make_node, executor):
    from iguana_ros.nodes.conversions import pose_stamped_to_numpy
    from iguana_ros.nodes.ros_topics import resolve
    name, cls, qos = resolve('goal_pose')
    node = make_node('goal_listener')
    executor.add_node(node)
    received = []
    node.create_subscription(cls, name, received.append, qos)
    goal = NodeProcess([*IGUANA, 'goal', '1.5', '-2', '--yaw', '90', '--frame', 'map',
                        '--timeout', '20'], 'goal', tmp_path).start()
    with goal:
        assert spin_until(executor, lambda: bool(received), 25), goal.output
        assert goal.wait(10) == 0, goal.output
    assert 'goal sent on /goal_pose' in goal.output
    pos, quat = pose_stamped_to_numpy(received[0])
    np.testing.assert_allclose(pos, [1.5, -2.0, 0.0])
    np.testing.assert_allclose(quat, [0, 0, math.sqrt(0.5), math.sqrt(0.5)])
    assert received[0].header.frame_id == 'map'
    stamp = received[0].header.stamp
    assert stamp.sec == 0 and stamp.nanosec == 0  # 0 = adopt at once (--at schedules in sim time)
