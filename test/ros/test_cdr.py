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

"""The one CDR codec (iguana_ros/ros/cdr.py) against rclpy's serializer and mcap-ros2-support's decoder."""
import numpy as np
import pytest

pytest.importorskip('rclpy')
from mcap.records import Schema  # noqa: E402, I100
from mcap_ros2.decoder import DecoderFactory  # noqa: E402
from rclpy.serialization import deserialize_message, serialize_message  # noqa: E402
from visualization_msgs.msg import Marker, MarkerArray, UVCoordinate  # noqa: E402

from iguana_ros.bag.schema import message_definition  # noqa: E402
from iguana_ros.errors import InputError  # noqa: E402
from iguana_ros.ros import cdr  # noqa: E402
from iguana_ros.ros.conversions import frame_stamp, triangle_list_marker, triangle_soup  # noqa: E402


@pytest.fixture
def rng():
    return np.random.default_rng(7)


def _mesh(rng, n_v=9, n_t=5):
    return rng.normal(size=(n_v, 3)), rng.integers(0, n_v, size=(n_t, 3)), rng.uniform(size=(n_v, 4))


def _decoder(type_name: str):
    """mcap-ros2-support's decoder of `type_name` (from the definition a recorded bag's schema holds)."""
    schema = Schema(id=1, name=type_name, encoding='ros2msg', data=message_definition(type_name).encode())
    return DecoderFactory().decoder_for('cdr', schema)


def _full_marker(rng, n_points: int) -> tuple[Marker, dict]:
    """
    Return a Marker with every field set to something other than its default.

    It also returns the same values as a layout dict.
    """
    points = rng.normal(size=(n_points, 3))
    colors = rng.uniform(size=(n_points, 4)).astype(np.float32)
    uv = rng.uniform(size=(2, 2)).astype(np.float32)
    values = {'stamp': (12, 345_000_000), 'frame_id': 'world', 'ns': 'terrain-ns', 'id': -7, 'type': 11,
              'action': 2, 'pose': (1.5, -2.0, 0.25, 0.0, 0.0, 0.6, 0.8), 'scale': (2.0, 3.0, 4.0),
              'color': (0.25, 0.5, 0.75, 1.0), 'lifetime': (3, 7), 'frame_locked': (True,), 'points': points,
              'colors': colors, 'texture_resource': 'file:///t.png', 'texture_stamp': (1, 2),
              'texture_frame_id': 'cam', 'texture_format': 'png', 'texture_data': np.arange(5, dtype=np.uint8),
              'uv_coordinates': uv, 'text': 'héllo', 'mesh_resource': 'package://m.dae',
              'mesh_file_filename': 'm.stl', 'mesh_file_data': np.arange(3, dtype=np.uint8),
              'mesh_use_embedded_materials': (True,)}
    m = Marker(ns=values['ns'], id=values['id'], type=values['type'], action=values['action'],
               frame_locked=True, texture_resource=values['texture_resource'], text=values['text'],
               mesh_resource=values['mesh_resource'], mesh_use_embedded_materials=True)
    m.header.stamp.sec, m.header.stamp.nanosec = values['stamp']
    m.header.frame_id = values['frame_id']
    p, o = m.pose.position, m.pose.orientation
    p.x, p.y, p.z, o.x, o.y, o.z, o.w = values['pose']
    m.scale.x, m.scale.y, m.scale.z = values['scale']
    m.color.r, m.color.g, m.color.b, m.color.a = values['color']
    m.lifetime.sec, m.lifetime.nanosec = values['lifetime']
    m.points = [type(m.pose.position)(x=x, y=y, z=z) for x, y, z in points.tolist()]
    m.colors = [type(m.color)(r=r, g=g, b=b, a=a) for r, g, b, a in colors.tolist()]
    m.texture.header.stamp.sec, m.texture.header.stamp.nanosec = values['texture_stamp']
    m.texture.header.frame_id, m.texture.format = values['texture_frame_id'], values['texture_format']
    m.texture.data = values['texture_data'].tolist()
    m.uv_coordinates = [UVCoordinate(u=u, v=v) for u, v in uv.tolist()]
    m.mesh_file.filename, m.mesh_file.data = values['mesh_file_filename'], values['mesh_file_data'].tolist()
    return m, values


@pytest.mark.parametrize('n_points', [0, 1, 4])
def test_marker_layout_writes_what_rclpy_serializes(rng, n_points):
    message, values = _full_marker(rng, n_points)
    writer = cdr.CdrWriter()
    writer.write(cdr.MARKER, values)
    data = writer.to_bytes()     # rclpy leaves its padding bytes as they were: same length, same message
    assert len(data) == len(serialize_message(message)) and deserialize_message(data, Marker) == message


@pytest.mark.parametrize('n_points', [0, 1, 4])
def test_marker_layout_reads_what_rclpy_serializes(rng, n_points):
    message, values = _full_marker(rng, n_points)
    data = serialize_message(message)
    reader = cdr.CdrReader(data)
    fields = reader.read(cdr.MARKER)
    assert 4 + reader.pos == len(data)                     # every byte read, nothing left over
    for name, kind in cdr.MARKER:
        if isinstance(kind, cdr.Sequence):
            np.testing.assert_array_equal(fields[name], np.asarray(values[name]).reshape(-1, kind.width))
        elif kind == cdr.STRING:
            assert fields[name] == values[name]
        else:
            assert fields[name] == tuple(np.atleast_1d(values[name]).tolist())


def test_mcap_ros2_decodes_what_the_writer_builds(rng):
    _, values = _full_marker(rng, 4)
    writer = cdr.CdrWriter()
    writer.write(cdr.MARKER, values)
    decoded = _decoder('visualization_msgs/msg/Marker')(writer.to_bytes())
    assert (decoded.ns, decoded.id, decoded.text, decoded.mesh_file.filename) == ('terrain-ns', -7, 'héllo', 'm.stl')
    assert (decoded.header.stamp.sec, decoded.header.stamp.nanosec, decoded.lifetime.sec) == (12, 345_000_000, 3)
    assert decoded.frame_locked and decoded.mesh_use_embedded_materials
    assert [(p.x, p.y, p.z) for p in decoded.points] == [tuple(p) for p in values['points'].tolist()]
    assert (list(decoded.texture.data) == [0, 1, 2, 3, 4]
            and decoded.uv_coordinates[1].v == values['uv_coordinates'][1, 1])


@pytest.mark.parametrize('n_t', [0, 1, 70])
def test_mesh_marker_bytes_are_rclpys_and_read_back(rng, n_t):
    verts, tris, rgba = _mesh(rng, n_t=n_t)
    kwargs = {'stamp': 12.5, 'frame_id': 'world', 'ns': 'body', 'marker_id': 4}
    data = cdr.triangle_list_marker_cdr(verts, tris, rgba, **kwargs)
    message = triangle_list_marker(verts, tris, rgba, **kwargs)
    assert len(data) == len(serialize_message(message)) and deserialize_message(data, Marker) == message
    decoded = _decoder('visualization_msgs/msg/Marker')(data)
    assert len(decoded.points) == 3 * n_t and decoded.ns == 'body' and decoded.header.stamp.nanosec == 500_000_000
    points, colors = cdr.triangle_list_from_cdr(data)
    np.testing.assert_array_equal(points, verts[tris.reshape(-1)])
    np.testing.assert_array_equal(colors, rgba[tris.reshape(-1)].astype(np.float32))
    assert cdr.header_stamp_ns(data) == 12_500_000_000


def test_marker_array_reader_reads_rclpy_and_every_cut_is_an_input_error(rng):
    full, values = _full_marker(rng, 3)
    verts, tris, rgba = _mesh(rng, n_t=2)
    data = serialize_message(MarkerArray(markers=[full, triangle_list_marker(verts, tris, rgba, ns='x'), Marker()]))
    markers = cdr.marker_array_from_cdr(data)
    assert [m.ns for m in markers] == ['terrain-ns', 'x', ''] and [m.action for m in markers] == [2, 0, 0]
    np.testing.assert_array_equal(markers[0].points, values['points'])
    np.testing.assert_array_equal(markers[0].orientation, values['pose'][3:])
    np.testing.assert_array_equal(markers[1].points, verts[tris.reshape(-1)])
    for cut in range(len(data)):
        with pytest.raises(InputError, match='not little-endian CDR|truncated or not a MarkerArray'):
            cdr.marker_array_from_cdr(data[:cut])


def test_mesh_reader_refuses_cut_or_foreign_bytes(rng):
    data = cdr.triangle_list_marker_cdr(*_mesh(rng, n_t=3))
    reader = cdr.CdrReader(data)
    reader.read(cdr.MARKER, until='colors')
    for cut in range(4 + reader.pos):                      # up to the colours: the part the reader needs
        with pytest.raises(InputError, match='marker'):
            cdr.triangle_list_from_cdr(data[:cut])
    with pytest.raises(InputError, match='not little-endian CDR'):
        cdr.triangle_list_from_cdr(b'\x00\x00' + data[2:])


@pytest.fixture(scope='module')
def placed_clip():
    from iguana_ros.body.skeleton import iguana_skeleton
    from iguana_ros.stages import motion_graph
    skeleton = iguana_skeleton()
    return skeleton, motion_graph().align('turn_left', np.array([0.3, -1.2]), 0.7)


# The oracle: each topic's message built with rclpy's own classes (ros/conversions.py), for rclpy to serialize and
# deserialize; the bytes the nodes write must be those, and what the nodes read from rclpy's bytes must be the values.

def _clip_msg(clip, skeleton, frame: int):
    """motion_clip of a placed clip as a MultiDOFJointTrajectory object: bone 0 the root, the others their offsets."""
    from iguana_ros.constants import FRAME_RATE
    from iguana_ros.ros.conversions import multi_dof_trajectory_msg
    n = len(clip.root_positions)
    translations = np.broadcast_to(skeleton.offsets, (n,) + skeleton.offsets.shape).copy()
    translations[:, 0] = clip.root_positions
    return multi_dof_trajectory_msg(np.arange(n) / FRAME_RATE, skeleton.names, translations, clip.local_rotations,
                                    stamp=frame_stamp(frame), frame_id='world')


def _pose_msg(positions, rotations, frame: int):
    """reference_pose / foot_positions as a PoseArray object in the world frame."""
    from iguana_ros.ros.conversions import pose_array_msg
    return pose_array_msg(positions, rotations, stamp=frame_stamp(frame), frame_id='world')


def _lengths_msg(lengths, frame: int):
    """spring_rest_lengths as a JointState object."""
    from iguana_ros.ros.conversions import joint_state_msg
    return joint_state_msg(lengths, stamp=frame_stamp(frame))


def _state_msg(root, orientation, linear, angular, frame: int):
    """iguana_state as an Odometry object (world, base_link)."""
    from iguana_ros.ros.conversions import odometry_msg
    return odometry_msg(root, orientation, linear, angular, stamp=frame_stamp(frame))


def _feet_msg(values, flags, frame: int):
    """foot_state / reference_stance as a JointState object named by foot: position = values, effort = flags."""
    import array

    from iguana_ros.ros.conversions import joint_state_msg
    from iguana_ros.body.skeleton import FEET
    msg = joint_state_msg(np.zeros(0) if values is None else values, stamp=frame_stamp(frame))
    msg.name = list(FEET)
    msg.effort = array.array('d', np.asarray(flags, float).tobytes())
    return msg


def _identity(n: int = 4) -> np.ndarray:
    quats = np.zeros((n, 4))
    quats[:, 3] = 1.0
    return quats


@pytest.mark.parametrize('frame', [0, 17, 12345])
def test_clip_bytes_are_the_message_rclpy_serializes(placed_clip, frame):
    """`clip_to_cdr` (how the planner publishes) writes what rclpy serializes for the clip's message."""
    from trajectory_msgs.msg import MultiDOFJointTrajectory

    from iguana_ros.ros.messages import clip_to_cdr
    skeleton, clip = placed_clip
    message, data = _clip_msg(clip, skeleton, frame), clip_to_cdr(clip, skeleton, frame)
    assert len(data) == len(serialize_message(message))
    assert deserialize_message(data, MultiDOFJointTrajectory) == message


def test_clip_from_cdr_reads_and_checks_what_rclpy_serializes(placed_clip):
    """The terrain adaptation node's numpy reading of motion_clip: the clip's values, its checks, one-line errors."""
    from geometry_msgs.msg import Twist

    from iguana_ros.ros.messages import clip_from_cdr
    skeleton, clip = placed_clip
    message = _clip_msg(clip, skeleton, 40)
    message.points[3].velocities = [Twist()] * 2            # twists (not used) are skipped
    start, read = clip_from_cdr(serialize_message(message), skeleton)
    assert start == 40
    assert np.array_equal(read.root_positions, clip.root_positions)
    assert np.array_equal(read.local_rotations, clip.local_rotations)
    wrong = _clip_msg(clip, skeleton, 40)
    wrong.header.frame_id = 'map'
    with pytest.raises(InputError, match="frame_id 'map'"):
        clip_from_cdr(serialize_message(wrong), skeleton)
    short = _clip_msg(clip, skeleton, 40)
    short.points[2].transforms = short.points[2].transforms[:5]
    with pytest.raises(InputError, match='hold 5 transforms, expected 34'):
        clip_from_cdr(serialize_message(short), skeleton)
    data = serialize_message(message)
    for cut in (3, 40, len(data) // 2, len(data) - 3):
        with pytest.raises(InputError, match='truncated or not a MultiDOFJointTrajectory|not little-endian CDR'):
            clip_from_cdr(data[:cut], skeleton)


def test_stride_from_cdr_reads_a_clip_without_a_skeleton(placed_clip):
    """The gait summary's reading of motion_clip: start frame, frames, root displacement and first heading."""
    from iguana_ros.geometry import yaw_of
    from iguana_ros.ros.messages import stride_from_cdr
    skeleton, clip = placed_clip
    start, stride = stride_from_cdr(serialize_message(_clip_msg(clip, skeleton, 60)))
    assert start == stride.start == 60 and stride.n_frames == len(clip.root_positions) - 1
    assert np.array_equal(stride.displacement, clip.root_positions[-1, :2] - clip.root_positions[0, :2])
    assert stride.heading == float(yaw_of(clip.local_rotations[0, 0]))
    wrong = _clip_msg(clip, skeleton, 60)
    wrong.header.frame_id = 'map'
    one = _clip_msg(clip, skeleton, 60)
    one.points = one.points[:1]
    for bad, match in ((wrong, "frame_id 'map'"), (one, 'has 1 points, expected at least 2')):
        with pytest.raises(InputError, match=match):
            stride_from_cdr(serialize_message(bad))


def test_reference_pose_bytes_and_reading_match_rclpy(rng, placed_clip):
    """`reference_pose_to_cdr` writes what rclpy serializes; `reference_pose_from_cdr` reads and checks its values."""
    from geometry_msgs.msg import PoseArray

    from iguana_ros.ros.messages import reference_pose_from_cdr, reference_pose_to_cdr
    from iguana_ros.terrain.adaptation import pose_kinematics
    skeleton, clip = placed_clip
    joints, rotations = pose_kinematics(skeleton, clip.root_positions[4], clip.local_rotations[4])
    message, data = _pose_msg(joints, rotations, 77), reference_pose_to_cdr(joints, rotations, 77)
    assert len(data) == len(serialize_message(message)) and deserialize_message(data, PoseArray) == message
    read = reference_pose_from_cdr(serialize_message(message), skeleton.n_bones, skeleton)
    assert read[0] == 77
    assert np.array_equal(read[1], joints) and np.array_equal(read[2], rotations)
    bent = _pose_msg(joints + rng.normal(scale=0.01, size=joints.shape), rotations, 77)
    with pytest.raises(InputError, match='reference_pose'):
        reference_pose_from_cdr(serialize_message(bent), skeleton.n_bones, skeleton)      # bone lengths do not fit
    with pytest.raises(InputError, match='truncated or not a PoseArray'):
        reference_pose_from_cdr(data[:-9], skeleton.n_bones, skeleton)


def test_iguana_state_reading_matches_rclpy(rng):
    """`state_from_cdr` reads what rclpy serializes (pose; with `state_twist_from_cdr` the twist), with its checks."""
    from iguana_ros.ros.messages import state_from_cdr, state_twist_from_cdr
    quat = rng.normal(size=4)
    quat /= np.linalg.norm(quat)
    root, linear, angular = np.array([1.0, -2.0, 0.3]), rng.normal(size=3), rng.normal(size=3)
    message = _state_msg(root, quat, linear, angular, 123)
    message.pose.covariance[7] = 0.5                  # covariances are skipped, whatever they hold
    read = state_from_cdr(serialize_message(message), 15.0)
    assert len(read) == 3 and read[0] == 123
    assert np.array_equal(read[1], root) and np.array_equal(read[2], quat)
    full = state_twist_from_cdr(serialize_message(message), 15.0)
    assert full[0] == 123 and np.array_equal(full[3], np.concatenate([linear, angular]))
    far = _state_msg(np.array([20.0, 0.0, 0.0]), np.array([0.0, 0.0, 0.0, 1.0]), np.zeros(3), np.zeros(3), 1)
    with pytest.raises(InputError, match='iguana_state'):
        state_from_cdr(serialize_message(far), 15.0)
    spinning = _state_msg(np.zeros(3), np.array([0.0, 0.0, 0.0, 1.0]), np.zeros(3), np.zeros(3), 1)
    spinning.twist.twist.angular.y = float('nan')
    with pytest.raises(InputError, match='iguana_state twist'):
        state_from_cdr(serialize_message(spinning))
    data = serialize_message(message)
    for cut in (3, 30, len(data) // 2, len(data) - 8):
        with pytest.raises(InputError, match='truncated or not an Odometry|not little-endian CDR'):
            state_from_cdr(data[:cut])


def test_another_types_bytes_on_iguana_state_are_an_input_error(rng):
    """A Marker's bytes recorded on iguana_state (a wrong-type payload in a sound bag) fail the node's checks."""
    from iguana_ros.ros.messages import state_from_cdr
    verts, tris, rgba = _mesh(rng)
    with pytest.raises(InputError, match='iguana_state'):
        state_from_cdr(cdr.triangle_list_marker_cdr(verts, tris, rgba))


@pytest.mark.parametrize('frame', [0, 1, 29, 12345])
def test_per_frame_bytes_are_the_messages_rclpy_serializes(rng, frame):
    """
    The nodes publish these per frame as bytes built from numpy.

    rclpy reads each back as the message built with its own classes, and mcap-ros2-support decodes the same values.
    """
    from geometry_msgs.msg import PoseArray
    from nav_msgs.msg import Odometry
    from rosgraph_msgs.msg import Clock
    from sensor_msgs.msg import JointState

    from iguana_ros.ros import messages as m
    from iguana_ros.ros.conversions import frame_stamp
    quat = rng.normal(size=4)
    state = (rng.normal(size=3), quat / np.linalg.norm(quat), rng.normal(size=3), rng.normal(size=3), frame)
    heights, flags, soles = rng.normal(size=4), rng.uniform(size=4) > 0.5, rng.normal(size=(4, 3))
    lengths = rng.uniform(size=2553)
    cases = [(_lengths_msg(lengths, frame), m.lengths_to_cdr(lengths, frame), JointState),
             (_state_msg(*state), m.state_to_cdr(*state), Odometry),
             (_feet_msg(heights, flags, frame), m.foot_state_to_cdr(heights, flags, frame), JointState),
             (_feet_msg(None, flags, frame), m.reference_stance_to_cdr(flags, frame), JointState),
             (_pose_msg(soles, _identity(), frame), m.foot_positions_to_cdr(soles, frame), PoseArray),
             (Clock(clock=frame_stamp(frame)), m.clock_to_cdr(frame), Clock)]
    for message, data, cls in cases:
        assert deserialize_message(data, cls) == message, cls.__name__
        type_name = {'JointState': 'sensor_msgs/msg/JointState', 'Odometry': 'nav_msgs/msg/Odometry',
                     'PoseArray': 'geometry_msgs/msg/PoseArray', 'Clock': 'rosgraph_msgs/msg/Clock'}[cls.__name__]
        decoded = _decoder(type_name)(data)
        stamp = decoded.clock if cls is Clock else decoded.header.stamp
        assert (stamp.sec, stamp.nanosec) == (frame_stamp(frame).sec, frame_stamp(frame).nanosec)
    assert np.array_equal(_decoder('sensor_msgs/msg/JointState')(cases[0][1]).position, lengths)
    assert _decoder('sensor_msgs/msg/JointState')(cases[2][1]).effort == flags.astype(float).tolist()
    assert m.clock_frame_from_cdr(serialize_message(cases[-1][0])) == frame


@pytest.mark.parametrize('frame', [0, 17, 12345])
def test_feet_readings_match_rclpy(rng, frame):
    """foot_state, reference_stance and foot_positions read from rclpy's bytes give the values they were built of."""
    from iguana_ros.ros import messages as m
    heights, flags, soles = rng.normal(size=4), rng.uniform(size=4) > 0.5, rng.normal(size=(4, 3))
    got, h, c = m.foot_state_from_cdr(serialize_message(_feet_msg(heights, flags, frame)))
    assert got == frame and np.array_equal(h, heights) and np.array_equal(c, flags) and c.dtype == bool
    got, stance = m.reference_stance_from_cdr(serialize_message(_feet_msg(None, flags, frame)))
    assert got == frame and np.array_equal(stance, flags)
    got, read = m.foot_positions_from_cdr(serialize_message(_pose_msg(soles, _identity(), frame)))
    assert got == frame and np.array_equal(read, soles)


def test_feet_readings_reject_what_does_not_fit(rng):
    """Wrong names, non-flag efforts, missing heights, three feet or another frame_id are InputErrors."""
    from iguana_ros.ros import messages as m
    renamed = _feet_msg(np.zeros(4), np.ones(4, bool), 1)
    renamed.name = ['a', 'b', 'c', 'd']
    halfway = _feet_msg(np.zeros(4), np.ones(4, bool), 1)
    halfway.effort[2] = 0.5
    heightless = _feet_msg(None, np.ones(4, bool), 1)
    for bad, match in ((renamed, 'names are'), (halfway, 'flags 0.0 or 1.0'), (heightless, r'position.*shape')):
        with pytest.raises(InputError, match=match):
            m.foot_state_from_cdr(serialize_message(bad))
    with pytest.raises(InputError, match='names are'):
        m.reference_stance_from_cdr(serialize_message(renamed))
    three = _pose_msg(np.zeros((3, 3)), _identity(3), 12)
    elsewhere = _pose_msg(np.zeros((4, 3)), _identity(), 12)
    elsewhere.header.frame_id = 'map'
    for bad, match in ((three, r'foot_positions.*shape'), (elsewhere, "frame_id 'map'")):
        with pytest.raises(InputError, match=match):
            m.foot_positions_from_cdr(serialize_message(bad))
    with pytest.raises(InputError, match='truncated or not a JointState'):
        m.foot_state_from_cdr(serialize_message(_feet_msg(np.zeros(4), np.ones(4, bool), 1))[:30])


def test_push_from_cdr_reads_what_rclpy_serializes_with_the_simulators_checks():
    """The simulator node's reading of push: force, torque, the region ('' is trunk_left), finite or InputError."""
    from iguana_ros.ros.conversions import push_msg
    from iguana_ros.ros.messages import push_from_cdr
    message = push_msg([1.0, -40.0, 0.5], 'trunk_right', stamp=2.5)
    message.wrench.torque.z = 0.25
    request = push_from_cdr(serialize_message(message))
    assert np.array_equal(request.force, [1.0, -40.0, 0.5]) and np.array_equal(request.torque, [0.0, 0.0, 0.25])
    assert request.region == 'trunk_right'
    assert push_from_cdr(serialize_message(push_msg([0.0, 1.0, 0.0], ''))).region == 'trunk_left'
    message.wrench.torque.x = float('nan')
    with pytest.raises(InputError, match='push torque'):
        push_from_cdr(serialize_message(message))
    with pytest.raises(InputError, match='truncated or not a WrenchStamped'):
        push_from_cdr(serialize_message(push_msg([0.0, 1.0, 0.0], 'trunk_left'))[:40])


def test_lengths_reading_matches_rclpy(rng):
    """`lengths_from_cdr` (the simulator node's read) gives the lengths rclpy serialized, with its checks."""
    from iguana_ros.ros.messages import frame_of_cdr, lengths_from_cdr
    rest = rng.uniform(0.05, 0.2, size=40)
    message = _lengths_msg(rest * 1.1, 77)
    read = lengths_from_cdr(serialize_message(message), 40, rest)
    assert read[0] == 77 and np.array_equal(read[1], rest * 1.1)
    for bad, match in ((_lengths_msg(rest[:-1], 1), r'shape \(39,\)'), (_lengths_msg(-rest, 1), 'negative'),
                       (_lengths_msg(rest * 1e3, 1), 'spring_rest_lengths')):
        with pytest.raises(InputError, match=match):
            lengths_from_cdr(serialize_message(bad), 40, rest)
    data = serialize_message(message)
    for cut in (3, 10, 30, len(data) // 2):
        with pytest.raises(InputError, match='truncated or not a JointState|not little-endian CDR'):
            lengths_from_cdr(data[:cut], 40, rest)
    assert frame_of_cdr(data) == 77 and frame_of_cdr(data[:6]) == '?'


def test_defaults_of_unset_fields_are_shared_and_read_only():
    """A field a writer is not given takes one cached default: nothing a message does can change the next one."""
    first = cdr.joint_state_cdr((1, 2), 'world', ['a', 'b'], np.zeros(2))
    empty = cdr._default(cdr.VALUES)
    assert cdr._default(cdr.VALUES) is empty and empty.shape == (0, 1)
    assert not empty.flags.writeable
    with pytest.raises(ValueError, match='read-only'):
        empty[...] = 1.0
    assert cdr._default(cdr.STRINGS) == () and cdr._default('36d') == (0,) * 36
    assert cdr.joint_state_cdr((1, 2), 'world', ['a', 'b'], np.zeros(2)) == first
    assert cdr.joint_state_from_cdr(first)['velocity'].shape == (0,)


@pytest.mark.parametrize('ns', ['', 'a', 'ab', 'abc', 'abcd', 'abcde', 'abcdef', 'abcdefg', 'iguana'])
def test_a_reused_marker_writer_gives_rclpys_bytes_every_frame_whatever_the_padding(rng, ns):
    """
    Strings of every length mod 8 move the points' 8-byte alignment; bad vertices fail and leave later frames whole.

    (rclpy's serializer leaves its padding bytes unset, so its bytes are compared by what they decode to.)
    """
    verts, tris, rgba = _mesh(rng, n_t=9)
    writer = cdr.TriangleListMarkerWriter(tris, len(verts), frame_id='world', ns=ns, marker_id=2)
    template = bytes(writer.template)
    for frame in range(3):
        moved = verts + 0.01 * frame
        stamp = frame_stamp(frame + 7)
        data = writer.write(moved, rgba, stamp)
        message = triangle_list_marker(moved, tris, rgba, stamp=stamp, frame_id='world', ns=ns, marker_id=2)
        assert len(data) == len(serialize_message(message)) and deserialize_message(data, Marker) == message
        points, colors = triangle_soup(moved, tris, rgba)
        assert data == cdr.write_layout(cdr.MARKER, {
            'stamp': (stamp.sec, stamp.nanosec), 'frame_id': 'world', 'ns': ns, 'id': 2, 'type': Marker.TRIANGLE_LIST,
            'pose': (0.0,) * 6 + (1.0,), 'scale': (1.0,) * 3, 'color': (1.0,) * 4, 'points': points, 'colors': colors})
        with pytest.raises(InputError, match='vertices has 1 non-finite'):
            writer.write(np.where(np.arange(len(verts))[:, None] == 1, [np.nan, 0.0, 0.0], moved), rgba, stamp)
    assert bytes(writer.template) == template
