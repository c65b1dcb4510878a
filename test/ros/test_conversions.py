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

"""numpy <-> message conversions round-trip exactly; bad arrays raise InputError naming the field."""
import numpy as np
import pytest

pytest.importorskip('rclpy')
from rclpy.serialization import deserialize_message, serialize_message  # noqa: E402
from visualization_msgs.msg import Marker  # noqa: E402

from iguana_ros.errors import InputError  # noqa: E402
from iguana_ros.geometry import quat_from_yaw  # noqa: E402
from iguana_ros.ros import cdr  # noqa: E402
from iguana_ros.ros import conversions as cv  # noqa: E402


@pytest.fixture
def rng():
    return np.random.default_rng(7)


def _unit_quats(rng, n):
    q = rng.normal(size=(n, 4))
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def test_time_round_trip_and_split():
    msg = cv.time_to_msg(12.000000007)
    assert (msg.sec, msg.nanosec) == (12, 7)
    assert cv.time_from_msg(msg) == pytest.approx(12.000000007, abs=1e-12)
    with pytest.raises(InputError, match='negative'):
        cv.time_to_msg(-1.0)


def test_yaw_quaternion_rotates_x_to_y():
    q = quat_from_yaw(np.pi / 2)
    np.testing.assert_allclose(q, [0, 0, np.sqrt(0.5), np.sqrt(0.5)])


def test_pose_array_round_trip(rng):
    pos, quat = rng.normal(size=(17, 3)), _unit_quats(rng, 17)
    msg = cv.pose_array_msg(pos, quat, stamp=3.5, frame_id='world')
    assert msg.header.frame_id == 'world' and msg.header.stamp.sec == 3
    back_pos, back_quat = cv.pose_array_to_numpy(deserialize_message(serialize_message(msg), type(msg)))
    np.testing.assert_array_equal(back_pos, pos)
    np.testing.assert_array_equal(back_quat, quat)


def test_empty_pose_list_keeps_shapes():
    pos, quat = cv.poses_from_msgs([])
    assert pos.shape == (0, 3) and quat.shape == (0, 4)


def test_pose_stamped_round_trip():
    msg = cv.pose_stamped_msg([1.0, -2.0, 0.5], quat_from_yaw(0.3), stamp=1.25)
    pos, quat = cv.pose_stamped_to_numpy(msg)
    np.testing.assert_array_equal(pos, [1.0, -2.0, 0.5])
    np.testing.assert_allclose(quat, quat_from_yaw(0.3))
    assert msg.header.frame_id == 'world'


def test_joint_state_round_trip_with_names(rng):
    values = rng.random(1234)
    msg = cv.joint_state_msg(values, stamp=2.0, names=[f's{i}' for i in range(1234)])
    np.testing.assert_array_equal(cv.joint_state_positions(msg), values)
    assert msg.name[5] == 's5'
    with pytest.raises(InputError, match='names has 2 entries, expected 3'):
        cv.joint_state_msg([1.0, 2.0, 3.0], names=['a', 'b'])


def test_odometry_round_trip(rng):
    pos, quat, lin, ang = rng.random(3), _unit_quats(rng, 1)[0], rng.random(3), rng.random(3)
    msg = cv.odometry_msg(pos, quat, lin, ang, stamp=4.0)
    assert msg.child_frame_id == 'base_link'
    for got, want in zip(cv.odometry_to_numpy(msg), (pos, quat, lin, ang)):
        np.testing.assert_array_equal(got, want)


def test_multi_dof_trajectory_round_trip(rng):
    n_frames, names = 9, ['root', 'spine', 'tail']
    times = np.arange(n_frames) / 30.0
    trans, rot = rng.normal(size=(n_frames, 3, 3)), _unit_quats(rng, n_frames * 3).reshape(n_frames, 3, 4)
    msg = cv.multi_dof_trajectory_msg(times, names, trans, rot)
    t2, n2, tr2, r2 = cv.multi_dof_trajectory_to_numpy(deserialize_message(serialize_message(msg),
                                                                           type(msg)))
    np.testing.assert_allclose(t2, times, atol=1e-9)
    assert n2 == names
    np.testing.assert_array_equal(tr2, trans)
    np.testing.assert_array_equal(r2, rot)
    assert msg.points[3].time_from_start.nanosec == 100_000_000


def _mesh(rng, n_v=40, n_t=70):
    return rng.random((n_v, 3)), rng.integers(0, n_v, (n_t, 3)), rng.random((n_v, 4))


def test_triangle_list_marker_layout(rng):
    verts, tris, rgba = _mesh(rng)
    msg = cv.triangle_list_marker(verts, tris, rgba, stamp=1.0)
    assert msg.type == Marker.TRIANGLE_LIST and msg.action == Marker.ADD
    assert len(msg.points) == len(msg.colors) == 3 * 70
    assert msg.color.a == 1.0 and msg.pose.orientation.w == 1.0
    assert (msg.scale.x, msg.scale.y, msg.scale.z) == (1.0, 1.0, 1.0)
    points, colors = cv.triangle_list_from_marker(msg)
    np.testing.assert_array_equal(points, verts[tris.reshape(-1)])
    np.testing.assert_allclose(colors, rgba[tris.reshape(-1)], atol=1e-7)  # float32 in the message


def test_cdr_reader_reads_rclpy_serialized_marker(rng):
    verts, tris, rgba = _mesh(rng)
    data = serialize_message(cv.triangle_list_marker(verts, tris, rgba, ns='a-longer-namespace'))
    np.testing.assert_array_equal(cdr.triangle_list_from_cdr(data)[0], verts[tris.reshape(-1)])
    with pytest.raises(InputError, match='truncated'):
        cdr.triangle_list_from_cdr(data[:200])


def test_marker_array_with_delete_all():
    arr = cv.marker_array_msg([Marker(id=1)], delete_all_first=True)
    assert [m.action for m in arr.markers] == [Marker.DELETEALL, Marker.ADD]


@pytest.mark.parametrize('call, message', [
    (lambda: cv.poses_to_msgs(np.zeros((3, 3)), np.zeros((2, 4))),
     r'quaternions has shape \(2, 4\), expected \(3, 4\)'),
    (lambda: cv.pose_stamped_msg([np.nan, 0, 0], [0, 0, 0, 1]), 'position has 1 non-finite'),
    (lambda: cv.joint_state_msg([[1.0]]), r'values has shape \(1, 1\), expected \(n\)'),
    (lambda: cv.odometry_msg([0, 0, 0], [0, 0, 0, 1], [np.inf, 0, 0], [0, 0, 0]), 'linear_velocity'),
    (lambda: cv.triangle_list_marker(np.zeros((3, 3)), np.array([[0, 1, 3]]), np.ones((3, 4))),
     'outside 0..2'),
    (lambda: cdr.triangle_list_marker_cdr(np.zeros((3, 3)), np.zeros((1, 3)), np.ones((3, 4))),
     'integer'),
    (lambda: cv.multi_dof_trajectory_msg([0.0], ['a'], np.zeros((1, 2, 3)), np.zeros((1, 2, 4))),
     'translations has shape'),
    (lambda: cv.validate_array('thing', 'abc', (3,)), 'thing must be numeric'),
])
def test_bad_arrays_raise_input_error(call, message):
    with pytest.raises(InputError, match=message):
        call()


def test_foot_probe_messages_round_trip_exactly(rng):
    from geometry_msgs.msg import PoseArray
    from sensor_msgs.msg import JointState

    from iguana_ros.ros import messages as m
    heights, contact, soles = rng.normal(size=4) * 0.01, np.array([True, False, False, True]), rng.normal(size=(4, 3))
    state = deserialize_message(m.foot_state_to_cdr(heights, contact, 17), JointState)
    assert list(state.name) == ['foot_fl', 'foot_fr', 'foot_hl', 'foot_hr'] and len(state.velocity) == 0
    frame, h, c = m.foot_state_from_cdr(serialize_message(state))
    assert frame == 17 and np.array_equal(h, heights) and np.array_equal(c, contact)
    positions = deserialize_message(m.foot_positions_to_cdr(soles, 4), PoseArray)
    assert [(p.orientation.x, p.orientation.w) for p in positions.poses] == [(0.0, 1.0)] * 4
    assert m.foot_positions_from_cdr(serialize_message(positions))[0] == 4
    assert np.array_equal(m.foot_positions_from_cdr(m.foot_positions_to_cdr(soles, 4))[1], soles)
    stance = deserialize_message(m.reference_stance_to_cdr(contact, 3), JointState)
    assert len(stance.position) == 0 and list(stance.effort) == [1.0, 0.0, 0.0, 1.0]
    assert m.reference_stance_from_cdr(serialize_message(stance))[0] == 3
    assert np.array_equal(m.reference_stance_from_cdr(serialize_message(stance))[1], contact)


def test_bad_foot_probe_messages_raise_input_error():
    from sensor_msgs.msg import JointState

    from iguana_ros.ros import messages as m
    msg = deserialize_message(m.foot_state_to_cdr(np.zeros(4), np.ones(4, bool), 1), JointState)
    msg.name = ['a', 'b', 'c', 'd']
    with pytest.raises(InputError, match='foot_state names'):
        m.foot_state_from_cdr(serialize_message(msg))
    msg = deserialize_message(m.reference_stance_to_cdr(np.ones(4, bool), 1), JointState)
    msg.effort = [1.0, 0.5, 0.0, 1.0]
    with pytest.raises(InputError, match='expected flags 0.0 or 1.0'):
        m.reference_stance_from_cdr(serialize_message(msg))
    with pytest.raises(InputError, match=r'foot positions has shape \(3, 3\)'):
        m.foot_positions_to_cdr(np.zeros((3, 3)), 0)
    msg = deserialize_message(m.foot_state_to_cdr(np.zeros(4), np.ones(4, bool), 1), JointState)
    msg.position = [0.0, float('nan'), 0.0, 0.0]
    with pytest.raises(InputError, match='non-finite'):
        m.foot_state_from_cdr(serialize_message(msg))
