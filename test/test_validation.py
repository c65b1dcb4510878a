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
The shared checks of what a node accepts from a topic (iguana_ros.validation) and the per-topic decoders.

The decoders of iguana_ros.ros.messages call the checks; the bounds are derived from the model and the scene, one line
per rejection.
"""
from __future__ import annotations

import numpy as np
import pytest

from iguana_ros import validation as v
from iguana_ros.body.model import build_model
from iguana_ros.body.skeleton import iguana_skeleton
from iguana_ros.constants import (DESIRED_SHRINK_FACTOR, DESIRED_STRETCH_FACTOR, FRAME_RATE, MAX_FRAME_GAP,
                                  MAX_PUSH_BODY_DELTA_V,
                                  MAX_PUSH_REGION_DELTA_V, PUSH_FORCE)
from iguana_ros.errors import InputError
from iguana_ros.geometry import quat_from_yaw
from iguana_ros.nodes.goal_sender import goal_message
from iguana_ros.physics.pushes import push_active, push_active_time, region_masses
from iguana_ros.ros import messages as m
from iguana_ros.scene import PushSpec
from iguana_ros.stages import motion_graph
from iguana_ros.terrain.adaptation import pose_kinematics


@pytest.fixture(scope='module')
def model():
    return build_model('coarse')


def test_goal_off_the_terrain_or_stamped_before_zero_is_rejected_by_the_one_goal_decoder():
    goal = m.goal_from_msg(goal_message(1.0, -2.0, at=3.0), half_extent=5.0)
    assert goal.xy.tolist() == [1.0, -2.0] and goal.at == 3.0 and goal.yaw is None      # all-zero: any heading
    assert m.goal_from_msg(goal_message(1.0, -2.0, yaw_deg=90.0), half_extent=5.0).yaw == pytest.approx(np.pi / 2)
    squashed = goal_message(1.0, 1.0, yaw_deg=0.0)
    squashed.pose.orientation.w = 0.5
    with pytest.raises(InputError, match='goal orientation has norm 0.5; expected a unit quaternion'):
        m.goal_from_msg(squashed, half_extent=5.0)
    with pytest.raises(InputError, match=r'goal \(1e\+09, 0\) is off the terrain \(\|x\|, \|y\| <= 5 m\)'):
        m.goal_from_msg(goal_message(1e9, 0.0), half_extent=5.0)
    early = goal_message(1.0, 1.0)
    early.header.stamp.sec = -3
    with pytest.raises(InputError, match='goal stamp is -3 s; expected a simulated time >= 0'):
        m.goal_from_msg(early, half_extent=5.0)
    twisted = goal_message(1.0, 1.0)
    twisted.pose.orientation.z = float('inf')
    with pytest.raises(InputError, match='goal orientation has 1 non-finite'):
        m.goal_from_msg(twisted, half_extent=5.0)
    with pytest.raises(InputError, match="frame_id 'base_link', expected 'world' or 'map' or 'odom'"):
        m.goal_from_msg(goal_message(1.0, 1.0, frame_id='base_link'), half_extent=5.0)
    for frame in ('map', 'odom'):                  # REP-105 frames that coincide with the world frame
        assert m.goal_from_msg(goal_message(1.0, 1.0, frame_id=frame), half_extent=5.0).xy.tolist() == [1.0, 1.0]


def test_desired_lengths_must_lie_within_the_factor_of_rest(model):
    rest = np.asarray(model.spring_rest_lengths)
    bent = rest.copy()
    bent[::40] *= 2.0      # a few springs far from rest, as a folded leg commands
    bent[5::40] *= 0.2
    assert np.array_equal(v.check_desired_lengths(bent, rest), bent)
    with pytest.raises(InputError, match=r'strain the whole body: RMS \|ln\(length / rest\)\| is 0.693, above 0.3 '
                                         r'\(median length 2 x rest\)'):
        v.check_desired_lengths(rest * 2.0, rest)   # every spring x2 at once: diverges in one frame
    for scale in (1e6 / rest.max(), DESIRED_STRETCH_FACTOR * 1.01, 1.0 / DESIRED_SHRINK_FACTOR / 1.01, 0.0):
        with pytest.raises(InputError, match='lengths outside .* x their rest length'):
            v.check_desired_lengths(rest * scale, rest)
    one = rest.copy()
    one[7] = 1e6
    with pytest.raises(InputError, match=r'1 of \d+ lengths outside .*\(spring 7: 1e\+06 m'):
        v.check_desired_lengths(one, rest)
    data = m.lengths_to_cdr(np.full(len(rest), 1e6), 0)
    assert m.lengths_from_cdr(data, len(rest))[1][0] == 1e6      # the format alone (a recorded bag) is fine
    with pytest.raises(InputError, match='outside'):
        m.lengths_from_cdr(data, len(rest), rest)                 # the simulator's check: rejected


def test_push_force_velocity_change_torque_and_region_are_bounded(model):
    masses = region_masses(model.node_mass, model.node_tags)
    force = v.check_push([0.0, -PUSH_FORCE, 0.0], [0.0, 0.0, 0.0], 'trunk_left', masses, 1.0, 0.1)
    assert force.tolist() == [0.0, -PUSH_FORCE, 0.0]                      # the paper's push
    acting = (PushSpec(at=0.95, force=(0.0, 500.0, 0.0), duration=0.5, region='all'),)
    cases = [([0.0, -1e6, 0.0], [0, 0, 0], 'trunk_left', 0.1, (), r'push force 1e\+06 N is above the 1000 N limit'),
             ([0.0, -600.0, 0.0], [0, 0, 0], 'all', 0.1, acting, r'with the 1 push\(es\) still acting totals 1100 N'),
             ([0.0, -1000.0, 0.0], [0, 0, 0], 'trunk_left', 0.1, (), r'gives trunk_left \(0.6\d+ kg\) 1\d\d m/s, '
              f'above the {MAX_PUSH_REGION_DELTA_V:g} m/s limit'),           # the probe's push
             ([0.0, -30.0, 0.0], [0, 0, 0], 'feet', 0.1, (), 'gives feet'),
             ([0.0, -250.0, 0.0], [0, 0, 0], 'all', 0.1, (), f'gives the body 6.25 m/s, above the '
              f'{MAX_PUSH_BODY_DELTA_V:g} m/s limit'),
             ([0.0, -150.0, 0.0], [0, 0, 0], 'all', 0.1, acting, 'with the pushes still acting gives the body'),
             ([0.0, -700.0, 0.0], [0, 0, 0], 'all', 0.01, (), r'acting 0.03333 s \(whole frames\) gives the body'),
             ([0.0, -40.0, 0.0], [0, 0, 5.0], 'trunk_left', 0.1, (), 'only a force is applied'),
             ([0.0, float('nan'), 0.0], [0, 0, 0], 'trunk_left', 0.1, (), 'push force has 1 non-finite'),
             ([0.0, -40.0, 0.0], [0, 0, 0], 'wing', 0.1, (), "push region 'wing' is not a node tag")]
    for f, t, region, duration, active, message in cases:
        with pytest.raises(InputError, match=message):
            v.check_push(f, t, region, masses, 1.0, duration, active)


def test_a_push_acts_over_whole_frames():
    assert push_active_time(1.0, 0.1) == pytest.approx(3 / FRAME_RATE)
    assert push_active_time(1.0, 0.01) == pytest.approx(1 / FRAME_RATE)      # a frame at least
    assert push_active_time(1.01, 0.01) == 0.0                               # no frame starts within it: no push
    assert push_active_time(0.0, 1.0) == pytest.approx(1.0)
    times = np.arange(200) / FRAME_RATE
    for at, duration in ((0.37, 0.2), (1.0, 0.1), (2.0 / 3.0, 0.5)):          # the rule push_forces applies
        assert push_active_time(at, duration) * FRAME_RATE == sum(push_active(at, duration, t) for t in times)


def test_poses_and_clips_must_fit_the_skeleton_and_the_world():
    from nav_msgs.msg import Odometry
    from rclpy.serialization import deserialize_message, serialize_message
    from trajectory_msgs.msg import MultiDOFJointTrajectory

    skeleton = iguana_skeleton()
    clip = motion_graph().align('forward', np.array([0.5, 0.2]), 0.4)
    joints, rotations = pose_kinematics(skeleton, clip.root_positions[3], clip.local_rotations[3])
    data = m.reference_pose_to_cdr(joints, rotations, 3)
    assert m.reference_pose_from_cdr(data, skeleton.n_bones, skeleton, 15.0)[0] == 3
    far = joints.copy()
    far[5] += 1e9
    with pytest.raises(InputError, match='magnitude 1e\\+09 m; expected within 15 m'):
        m.reference_pose_from_cdr(m.reference_pose_to_cdr(far, rotations, 3), skeleton.n_bones, skeleton, 15.0)
    bent = joints.copy()
    bent[5, 2] += 0.01
    with pytest.raises(InputError, match='does not fit the skeleton: bone '):
        m.reference_pose_from_cdr(m.reference_pose_to_cdr(bent, rotations, 3), skeleton.n_bones, skeleton, 15.0)
    clip_data = m.clip_to_cdr(clip, skeleton, 40)
    assert m.clip_from_cdr(clip_data, skeleton, 15.0)[0] == 40
    clip_msg = deserialize_message(clip_data, MultiDOFJointTrajectory)
    clip_msg.points[2].transforms[4].translation.y = 1e9
    with pytest.raises(InputError, match='differ from the skeleton offsets'):
        m.clip_from_cdr(serialize_message(clip_msg), skeleton, 15.0)
    clip_msg = deserialize_message(clip_data, MultiDOFJointTrajectory)
    clip_msg.points[2].transforms = clip_msg.points[2].transforms[:-1]   # a ragged trajectory: one line
    with pytest.raises(InputError, match='trajectory points hold'):
        m.clip_from_cdr(serialize_message(clip_msg), skeleton, 15.0)
    data = m.state_to_cdr(np.array([0.3, 0.1, 0.07]), quat_from_yaw(0.2), np.zeros(3), np.zeros(3), 9)
    assert m.state_from_cdr(data, 15.0)[0] == 9
    state = deserialize_message(data, Odometry)
    state.pose.pose.orientation.w *= 2.0
    with pytest.raises(InputError, match='expected unit quaternions'):
        m.state_from_cdr(serialize_message(state), 15.0)


def test_frames_far_ahead_are_rejected_stale_and_repeated_ones_classified():
    assert v.check_frame('x', 4, 5) == v.FRAME_STALE
    assert v.check_frame('x', 5, 5) == v.FRAME_REPEAT
    assert v.check_frame('x', 6, 5) == v.FRAME_NEW
    assert v.check_frame('x', MAX_FRAME_GAP, -1) == v.FRAME_NEW
    with pytest.raises(InputError, match=f'expected at most {MAX_FRAME_GAP} ahead'):
        v.check_frame('iguana_state', 5 + MAX_FRAME_GAP + 1, 5)


def test_a_route_is_checked_waypoint_by_waypoint_and_keeps_only_the_last_heading():
    from iguana_ros.nodes.goal_sender import route_message
    route = m.route_from_msg(route_message([(1.0, 0.0), (1.0, 1.0)], yaw_deg=90.0, at=2.0), half_extent=5.0)
    assert route.at == 2.0 and route.waypoints[0] == (1.0, 0.0, None)
    assert route.waypoints[1][:2] == (1.0, 1.0) and route.waypoints[1][2] == pytest.approx(np.pi / 2)
    with pytest.raises(InputError, match=r'goal \(9, 1\) is off the terrain'):
        m.route_from_msg(route_message([(1.0, 0.0), (9.0, 1.0)]), half_extent=5.0)
    with pytest.raises(InputError, match='route has 0 waypoints, expected 1 to'):
        m.route_from_msg(route_message([]), half_extent=5.0)
    with pytest.raises(InputError, match="frame_id 'iguana/head'"):
        m.route_from_msg(route_message([(1.0, 0.0)], frame_id='iguana/head'), half_extent=5.0)
    assert len(m.route_from_msg(route_message([(1.0, 0.0)], frame_id='odom'), half_extent=5.0).waypoints) == 1
