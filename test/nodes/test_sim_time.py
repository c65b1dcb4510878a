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
use_sim_time, set by the standard params file for the node that reads its clock (the planner).

A node's clock follows /clock (here seen in the stamp of the planner's accepted_goals, the one output not stamped with a
frame); with use_sim_time false it is the system clock and /clock is ignored.
"""
from __future__ import annotations

import sys
import time

import pytest

from iguana_ros.config import params_file
from iguana_ros.ros.conversions import time_from_msg, time_to_msg
from ros_harness import NodeProcess, spin_until

pytestmark = [pytest.mark.ros, pytest.mark.timeout(120)]


def _planner(tmp_path, *params: str) -> NodeProcess:
    """Return the planner as `iguana run` and the launch file start it: the standard params file, then `params`."""
    args = [sys.executable, '-m', 'iguana_ros.nodes.planner_node', '--ros-args', '--params-file', str(params_file()),
            '-p', 'scene:=flat_walk']
    for param in params:
        args += ['-p', param]
    return NodeProcess(args, 'planner_node', tmp_path).start(ready='planner ready', timeout=90)


class ClockAndGoals:
    """A test node publishing /clock and goal_pose and collecting accepted_goals."""

    def __init__(self, node, executor) -> None:
        from iguana_ros.ros.endpoints import resolve
        self.executor, self.accepted = executor, []
        executor.add_node(node)
        self.pubs = {}
        for key in ('clock', 'goal_pose'):
            name, cls, qos = resolve(key)
            self.pubs[key] = node.create_publisher(cls, name, qos)
        name, cls, qos = resolve('accepted_goals')
        node.create_subscription(cls, name, self.accepted.append, qos)

    def stamp_after_goal(self, clock_s: float, timeout: float = 20.0) -> float:
        """Send /clock = `clock_s` and a goal until the planner lists one more goal; that list's stamp, s."""
        from rosgraph_msgs.msg import Clock

        from iguana_ros.nodes.goal_sender import goal_message
        before = len(self.accepted[-1].poses) if self.accepted else 0
        deadline = time.monotonic() + timeout
        while not (self.accepted and len(self.accepted[-1].poses) > before):
            assert time.monotonic() < deadline, 'the planner accepted no goal'
            self.pubs['clock'].publish(Clock(clock=time_to_msg(clock_s)))
            spin_until(self.executor, lambda: False, 0.1)  # the /clock first, then the goal it stamps
            if not (self.accepted and len(self.accepted[-1].poses) > before):
                self.pubs['goal_pose'].publish(goal_message(0.5, 0.5))
                spin_until(self.executor, lambda: False, 0.2)
        return time_from_msg(self.accepted[-1].header.stamp)


def test_a_node_with_use_sim_time_follows_clock(tmp_path, make_node, executor):
    probe = ClockAndGoals(make_node('sim_time_probe'), executor)
    with _planner(tmp_path) as planner:
        assert spin_until(executor, lambda: bool(probe.accepted), 30.0), 'no accepted_goals from the planner'
        assert time_from_msg(probe.accepted[0].header.stamp) == 0.0  # simulated time before any /clock
        assert spin_until(executor, lambda: probe.pubs['clock'].get_subscription_count() >= 1, 30.0)
        first = probe.stamp_after_goal(123.4)
        later = probe.stamp_after_goal(200.0)
        assert planner.running
    assert first == pytest.approx(123.4, abs=1e-9) and later == pytest.approx(200.0, abs=1e-9)


def test_a_node_without_use_sim_time_keeps_the_system_clock(tmp_path, make_node, executor):
    probe = ClockAndGoals(make_node('wall_time_probe'), executor)
    with _planner(tmp_path, 'planner_node:use_sim_time:=false'):  # a value for every node loses to the file's section
        assert spin_until(executor, lambda: bool(probe.accepted), 30.0), 'no accepted_goals from the planner'
        assert probe.pubs['clock'].get_subscription_count() == 0  # nobody listens to /clock
        stamp = probe.stamp_after_goal(123.4)
    assert abs(stamp - time.time()) < 60.0
