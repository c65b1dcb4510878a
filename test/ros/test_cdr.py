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


@pytest.mark.parametrize('frame', [0, 17, 12345])
def test_clip_bytes_are_the_message_rclpy_serializes(placed_clip, frame):
    """`clip_to_cdr` (how the planner publishes) writes what rclpy serializes for `clip_to_msg`'s message."""
    from trajectory_msgs.msg import MultiDOFJointTrajectory

    from iguana_ros.ros.messages import clip_to_cdr, clip_to_msg
    skeleton, clip = placed_clip
    message, data = clip_to_msg(clip, skeleton, frame), clip_to_cdr(clip, skeleton, frame)
    assert len(data) == len(serialize_message(message))
    assert deserialize_message(data, MultiDOFJointTrajectory) == message


def test_clip_from_cdr_reads_and_checks_as_clip_from_msg(placed_clip):
    """The terrain adaptation node's numpy reading of motion_clip: same clip, same checks, one-line errors."""
    from geometry_msgs.msg import Twist

    from iguana_ros.ros.messages import clip_from_cdr, clip_from_msg, clip_to_msg
    skeleton, clip = placed_clip
    message = clip_to_msg(clip, skeleton, 40)
    message.points[3].velocities = [Twist()] * 2            # twists (not used) are skipped
    start, read = clip_from_cdr(serialize_message(message), skeleton)
    expected_start, expected = clip_from_msg(message, skeleton)
    assert start == expected_start == 40
    assert np.array_equal(read.root_positions, expected.root_positions)
    assert np.array_equal(read.local_rotations, expected.local_rotations)
    wrong = clip_to_msg(clip, skeleton, 40)
    wrong.header.frame_id = 'map'
    with pytest.raises(InputError, match="frame_id 'map'"):
        clip_from_cdr(serialize_message(wrong), skeleton)
    short = clip_to_msg(clip, skeleton, 40)
    short.points[2].transforms = short.points[2].transforms[:5]
    with pytest.raises(InputError, match='hold 5 transforms, expected 34'):
        clip_from_cdr(serialize_message(short), skeleton)
    data = serialize_message(message)
    for cut in (3, 40, len(data) // 2, len(data) - 3):
        with pytest.raises(InputError, match='truncated or not a MultiDOFJointTrajectory|not little-endian CDR'):
            clip_from_cdr(data[:cut], skeleton)


def test_reference_pose_bytes_and_reading_match_the_message_path(rng, placed_clip):
    """`reference_pose_to_cdr` writes what rclpy serializes; `reference_pose_from_cdr` reads and checks as from_msg."""
    from geometry_msgs.msg import PoseArray

    from iguana_ros.ros.messages import reference_pose_from_cdr, reference_pose_from_msg, reference_pose_to_cdr
    from iguana_ros.ros.messages import reference_pose_to_msg
    from iguana_ros.terrain.adaptation import pose_kinematics
    skeleton, clip = placed_clip
    joints, rotations = pose_kinematics(skeleton, clip.root_positions[4], clip.local_rotations[4])
    message, data = reference_pose_to_msg(joints, rotations, 77), reference_pose_to_cdr(joints, rotations, 77)
    assert len(data) == len(serialize_message(message)) and deserialize_message(data, PoseArray) == message
    read = reference_pose_from_cdr(serialize_message(message), skeleton.n_bones, skeleton)
    expected = reference_pose_from_msg(message, skeleton.n_bones, skeleton)
    assert read[0] == expected[0] == 77
    assert np.array_equal(read[1], expected[1]) and np.array_equal(read[2], expected[2])
    bent = reference_pose_to_msg(joints + rng.normal(scale=0.01, size=joints.shape), rotations, 77)
    with pytest.raises(InputError, match='reference_pose'):
        reference_pose_from_cdr(serialize_message(bent), skeleton.n_bones, skeleton)      # bone lengths do not fit
    with pytest.raises(InputError, match='truncated or not a PoseArray'):
        reference_pose_from_cdr(data[:-9], skeleton.n_bones, skeleton)


def test_iguana_state_reading_matches_the_message_path(rng):
    """`state_from_cdr` reads what rclpy serializes as `state_from_msg` reads the message, with the same checks."""
    from iguana_ros.ros.messages import state_from_cdr, state_from_msg, state_to_msg
    quat = rng.normal(size=4)
    message = state_to_msg(np.array([1.0, -2.0, 0.3]), quat / np.linalg.norm(quat), rng.normal(size=3),
                           rng.normal(size=3), 123)
    message.pose.covariance[7] = 0.5                  # covariances are skipped, whatever they hold
    read, expected = state_from_cdr(serialize_message(message), 15.0), state_from_msg(message, 15.0)
    assert read[0] == expected[0] == 123
    assert np.array_equal(read[1], expected[1]) and np.array_equal(read[2], expected[2])
    far = state_to_msg(np.array([20.0, 0.0, 0.0]), np.array([0.0, 0.0, 0.0, 1.0]), np.zeros(3), np.zeros(3), 1)
    with pytest.raises(InputError, match='iguana_state'):
        state_from_cdr(serialize_message(far), 15.0)
    spinning = state_to_msg(np.zeros(3), np.array([0.0, 0.0, 0.0, 1.0]), np.zeros(3), np.zeros(3), 1)
    spinning.twist.twist.angular.y = float('nan')
    with pytest.raises(InputError, match='iguana_state twist'):
        state_from_cdr(serialize_message(spinning))
    data = serialize_message(message)
    for cut in (3, 30, len(data) // 2, len(data) - 8):
        with pytest.raises(InputError, match='truncated or not an Odometry|not little-endian CDR'):
            state_from_cdr(data[:cut])


@pytest.mark.parametrize('frame', [0, 1, 29, 12345])
def test_per_frame_bytes_are_the_messages_rclpy_serializes(rng, frame):
    """
    The nodes publish these per frame as bytes built from numpy.

    rclpy reads each back as the message the `_msg` builder makes, and mcap-ros2-support decodes the same values.
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
    cases = [(m.lengths_to_msg(lengths, frame), m.lengths_to_cdr(lengths, frame), JointState),
             (m.state_to_msg(*state), m.state_to_cdr(*state), Odometry),
             (m.foot_state_to_msg(heights, flags, frame), m.foot_state_to_cdr(heights, flags, frame), JointState),
             (m.reference_stance_to_msg(flags, frame), m.reference_stance_to_cdr(flags, frame), JointState),
             (m.foot_positions_to_msg(soles, frame), m.foot_positions_to_cdr(soles, frame), PoseArray),
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


def test_lengths_reading_matches_the_message_path(rng):
    """`lengths_from_cdr` (the simulator node's read) gives what `lengths_from_msg` gives, with the same checks."""
    from iguana_ros.ros.messages import frame_of_cdr, lengths_from_cdr, lengths_from_msg, lengths_to_msg
    rest = rng.uniform(0.05, 0.2, size=40)
    message = lengths_to_msg(rest * 1.1, 77)
    read, expected = lengths_from_cdr(serialize_message(message), 40, rest), lengths_from_msg(message, 40, rest)
    assert read[0] == expected[0] == 77 and np.array_equal(read[1], expected[1])
    for bad, match in ((lengths_to_msg(rest[:-1], 1), r'shape \(39,\)'), (lengths_to_msg(-rest, 1), 'negative'),
                       (lengths_to_msg(rest * 1e3, 1), 'spring_rest_lengths')):
        with pytest.raises(InputError, match=match):
            lengths_from_msg(bad, 40, rest)
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
