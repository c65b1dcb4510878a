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

"""The iguana's TF frames and the TFMessage bytes the nodes build from numpy: rclpy's and mcap-ros2-support's."""
from geometry_msgs.msg import Quaternion, TransformStamped, Vector3
from mcap.records import Schema
from mcap_ros2.decoder import DecoderFactory
import numpy as np
import pytest
from rclpy.serialization import deserialize_message
from tf2_msgs.msg import TFMessage

from iguana_ros.bag.schema import message_definition
from iguana_ros.body.skeleton import iguana_skeleton
from iguana_ros.errors import InputError
from iguana_ros.ros.cdr import tf_message_from_cdr
from iguana_ros.ros.conversions import frame_stamp
from iguana_ros.ros.tf import body_tf_to_cdr, bones_tf_to_cdr, static_tf_to_cdr, tf_frames


def _transform(parent: str, child: str, frame: int | None, translation, rotation) -> TransformStamped:
    """Return a TransformStamped built with rclpy's classes."""
    t = TransformStamped(child_frame_id=child)
    t.header.frame_id = parent
    if frame is not None:
        t.header.stamp = frame_stamp(frame)
    t.transform.translation = Vector3(x=float(translation[0]), y=float(translation[1]), z=float(translation[2]))
    t.transform.rotation = Quaternion(x=float(rotation[0]), y=float(rotation[1]), z=float(rotation[2]),
                                      w=float(rotation[3]))
    return t


def test_frame_names_follow_rep_105_under_the_prefix():
    bones = iguana_skeleton().names
    plain = tf_frames('', bones)
    assert (plain.odom, plain.base) == ('odom', 'base_link')
    assert plain.feet == ('foot/fl', 'foot/fr', 'foot/hl', 'foot/hr') and plain.bones[0] == f'reference/{bones[0]}'
    named = tf_frames('zoo/iguana1/', bones)
    assert named.base == 'zoo/iguana1/base_link' and named.bones[-1] == f'zoo/iguana1/reference/{bones[-1]}'
    for bad in ('iguana1', '/iguana1/', 'a b/', '1st/', 'x//'):
        with pytest.raises(InputError, match='frame_prefix'):
            tf_frames(bad)


@pytest.mark.parametrize('frame', [0, 31, 123456])
def test_the_tf_bytes_are_the_messages_rclpy_serializes_and_mcap_decodes(frame):
    rng = np.random.default_rng(frame)
    skeleton = iguana_skeleton()
    frames = tf_frames('iguana1/', skeleton.names)
    quat = rng.normal(size=4)
    root, orientation, soles = rng.normal(size=3), quat / np.linalg.norm(quat), rng.normal(size=(4, 3))
    joints, rotations = rng.normal(size=(len(skeleton.names), 3)), rng.normal(size=(len(skeleton.names), 4))
    identity = (0.0, 0.0, 0.0, 1.0)
    body = [_transform('iguana1/odom', 'iguana1/base_link', frame, root, orientation)]
    body += [_transform('iguana1/odom', child, frame, sole, identity) for child, sole in zip(frames.feet, soles)]
    bones = [_transform('iguana1/odom', child, frame, j, q) for child, j, q in zip(frames.bones, joints, rotations)]
    static = [_transform('world', 'iguana1/odom', None, (0.0, 0.0, 0.0), identity)]
    decoder = DecoderFactory().decoder_for('cdr', Schema(id=1, name='tf2_msgs/msg/TFMessage', encoding='ros2msg',
                                                         data=message_definition('tf2_msgs/msg/TFMessage').encode()))
    for data, expected in ((body_tf_to_cdr(frames, root, orientation, soles, frame), body),
                           (bones_tf_to_cdr(frames, joints, rotations, frame), bones),
                           (static_tf_to_cdr(frames), static)):
        assert deserialize_message(data, TFMessage) == TFMessage(transforms=expected)
        decoded = decoder(data)
        assert [t.child_frame_id for t in decoded.transforms] == [t.child_frame_id for t in expected]
        read = tf_message_from_cdr(data)
        assert [r[2] for r in read] == [t.child_frame_id for t in expected]
    assert np.array_equal(tf_message_from_cdr(body_tf_to_cdr(frames, root, orientation, soles, frame))[0][3], root)


def test_a_cut_tf_message_is_an_input_error():
    data = static_tf_to_cdr(tf_frames(''))
    with pytest.raises(InputError, match='TFMessage'):
        tf_message_from_cdr(data[:-5])


def test_the_static_transform_of_a_world_holds_every_bodys_odom_in_one_latched_message():
    bodies = [tf_frames('east/'), tf_frames('west/')]
    got = tf_message_from_cdr(static_tf_to_cdr(bodies))
    assert [(parent, child) for _, parent, child, _, _ in got] == [('world', 'east/odom'), ('world', 'west/odom')]
    assert all(np.array_equal(rotation, [0, 0, 0, 1]) and not translation.any() for *_, translation, rotation in got)
