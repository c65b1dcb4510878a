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
Finite but absurd input at the node boundary (issue 12, items 7 and 8), with real node processes.

A goal far off the terrain is rejected by the simulator as by the planner (test/cli/test_goal.py) and not drawn, 1e6 m
spring lengths and a 1e6 N push are rejected, and the lockstep simulator keeps running and never simulates the bad
frame.
"""
from __future__ import annotations

import numpy as np
import pytest

from iguana_ros.body.model import build_model
from ros_harness import spin_until
from test_nodes import _lockstep_peers, _node, _scene, _state, Probe

pytestmark = [pytest.mark.ros, pytest.mark.timeout(150)]


def test_the_simulator_rejects_what_is_absurd_and_never_simulates_it(tmp_path, make_node, executor):
    """
    A goal at x = 1e9 (the planner's rule: test/cli/test_goal.py), lengths of 1e6 m, a 1e6 N push.

    Each is logged as rejected; the goal is not drawn, and frame 0 is simulated with the good lengths sent after.
    """
    from geometry_msgs.msg import WrenchStamped

    from iguana_ros.nodes.goal_sender import goal_message
    from iguana_ros.ros.messages import lengths_to_cdr, state_from_cdr
    from iguana_ros.stages import SimulatorStage
    from iguana_ros.terrain.heightfield import HeightField
    model = build_model('coarse')
    rest = np.array(model.spring_rest_lengths)
    probe = _lockstep_peers(make_node, executor)
    probe.listen('iguana_state')
    probe.listen('scene_markers')
    probe.listen('diagnostics')
    lengths_pub, push_pub, goal_pub = probe.pub('spring_rest_lengths'), probe.pub('push'), probe.pub('goal_pose')

    def drawn():
        return [(mk.pose.position.x, mk.pose.position.y) for msg in probe.got['scene_markers']
                for mk in msg.markers if mk.ns == 'goal']
    with _node('simulator_node', _scene(tmp_path), tmp_path, lockstep_timeout=1.0, lockstep_max_timeouts=100) as sim:
        probe.wait_matched('goal_pose')
        goal_pub.publish(goal_message(1e9, 0.0))
        goal_pub.publish(goal_message(0.5, 1.0))
        assert spin_until(executor, lambda: (0.5, 1.0) in drawn(), 30), sim.output
        probe.wait('iguana_state', 1, timeout=60)
        probe.wait_matched('push')
        push = WrenchStamped()
        push.header.frame_id = 'trunk_left'
        push.wrench.force.y = -1e6
        push_pub.publish(push)
        lengths_pub.publish(lengths_to_cdr(np.full(len(rest), 1e6), 0))
        # the watchdog names the rejection: the frame waits for lengths it can simulate
        assert sim.wait_for_output('last rejected: frame 0: spring_rest_lengths has', 30), sim.output
        assert all(state_from_cdr(s)[0] == 0 for s in probe.got['iguana_state'])
        lengths_pub.publish(lengths_to_cdr(rest, 0))
        assert spin_until(executor, lambda: any(state_from_cdr(s)[0] == 1 for s in probe.got['iguana_state']), 30)
        assert sim.running
        assert spin_until(executor, lambda: _reported_frames(probe.got['diagnostics']) >= 1, 10)   # 1 Hz reports
    assert drawn() == [(0.5, 1.0)]  # the 1e9 goal was never drawn
    assert 'rejected goal_pose: goal (1e+09, 0) is off the terrain (|x|, |y| <= 5 m)' in sim.output
    after = next(s for s in probe.got['iguana_state'] if state_from_cdr(s)[0] == 1)
    stage = SimulatorStage(model, HeightField.flat(), 'balanced')   # the same frame simulated in-process
    stage.advance(rest)
    assert np.array_equal(state_from_cdr(after)[1], stage.root_pose()[0])
    assert 'rejected push: push force 1e+06 N is above the 1000 N limit' in sim.output
    assert 'rejected spring_rest_lengths: spring_rest_lengths has' in sim.output
    assert 'x their rest length' in sim.output
    _check_diagnostics(probe.got['diagnostics'])


def _values(status) -> dict:
    """Return the key/value pairs of a DiagnosticStatus."""
    return {kv.key: kv.value for kv in status.values}


def _reported_frames(messages: list) -> int:
    """Return the frames the simulator's latest /diagnostics status counts (0 before any)."""
    statuses = [s for msg in messages for s in msg.status if s.name == '/simulator_node']
    return int(_values(statuses[-1])['frames']) if statuses else 0


def _check_diagnostics(messages: list) -> None:
    """/diagnostics named the three rejections (WARN, with the count and the last reason) and the frame simulated."""
    from diagnostic_msgs.msg import DiagnosticStatus
    statuses = [s for msg in messages for s in msg.status if s.name == '/simulator_node']
    assert statuses and all(s.hardware_id == 'iguana_ros' for s in statuses)
    warned = [s for s in statuses if s.level == DiagnosticStatus.WARN]
    assert warned and 'rejected' in warned[0].message
    last = _values(statuses[-1])
    assert int(last['rejected_inputs']) == 3 and int(last['frames']) >= 1
    assert 'push force 1e+06 N' in last['last_rejected'] or 'spring_rest_lengths' in last['last_rejected']
    assert float(last['simulated_s']) == pytest.approx(1 / 30, abs=5e-4) and float(last['realtime_factor']) >= 0.0


def test_a_burst_of_bad_clips_does_not_push_the_planners_clip_out(tmp_path, make_node, executor):
    """
    motion_clip is latched with depth 1.

    A reader that deep lost the planner's clip when another publisher's messages came right after it while the node was
    busy (found by `iguana bench faults topics`: the lockstep run stalled at that stride).
    """
    from rclpy.serialization import deserialize_message, serialize_message
    from trajectory_msgs.msg import MultiDOFJointTrajectory

    from iguana_ros.body.skeleton import iguana_skeleton
    from iguana_ros.ros.messages import clip_to_cdr, reference_pose_from_cdr
    from iguana_ros.stages import motion_graph
    skeleton = iguana_skeleton()
    graph = motion_graph()
    first = graph.align('forward', np.array([0.0, 0.0]), 0.0)
    second = graph.align('forward', first.root_positions[-1, :2], 0.0, previous=first)
    bad = deserialize_message(clip_to_cdr(second, skeleton, 20), MultiDOFJointTrajectory)
    bad.header.frame_id = 'map'
    bad = serialize_message(bad)
    probe = Probe(make_node('probe'), executor)
    probe.listen('reference_pose')
    clip_pub, state_pub = probe.pub('motion_clip'), probe.pub('iguana_state')
    bad_pub = probe.pub('motion_clip')     # another writer (a writer keeps only its own last sample)
    scene = _scene(tmp_path, terrain={'kind': 'tilted', 'slope_deg': 10.0})   # adaptation on: a busy node
    with _node('terrain_adaptation_node', scene, tmp_path) as node:
        probe.wait_matched('iguana_state')
        assert spin_until(executor, lambda: clip_pub.get_subscription_count() >= 1
                          and bad_pub.get_subscription_count() >= 1, 30)
        probe.deliver(bad_pub, bad)                              # each writer and the node see each other
        probe.deliver(clip_pub, clip_to_cdr(first, skeleton, 0))
        probe.deliver(state_pub, _state(0))
        assert spin_until(executor, lambda: len(probe.got['reference_pose']) >= 1, 30), node.output
        state_pub.publish(_state(1))                             # the node adapts frame 1 ...
        clip_pub.publish(clip_to_cdr(second, skeleton, 20))      # ... while the next clip and a burst arrive
        for _ in range(8):
            bad_pub.publish(bad)
        assert spin_until(executor, lambda: len(probe.got['reference_pose']) >= 2, 30), node.output
        state_pub.publish(_state(20, xy=tuple(second.root_positions[0, :2])))
        assert spin_until(executor, lambda: any(reference_pose_from_cdr(p, skeleton.n_bones)[0] == 20
                                                for p in probe.got['reference_pose']), 20), node.output
        assert spin_until(executor, lambda: "rejected motion_clip: motion_clip has frame_id 'map'" in node.output,
                          10), node.output
        assert node.running
