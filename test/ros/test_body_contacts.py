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

"""body_contacts: a world's pair contacts as a DiagnosticArray, read back exactly; a damaged status is refused."""
from __future__ import annotations

from diagnostic_msgs.msg import KeyValue
import pytest
from rclpy.serialization import deserialize_message, serialize_message

from iguana_ros.errors import InputError
from iguana_ros.physics.body_contact import PairContact
from iguana_ros.ros.body_contacts import body_contacts_from_msg, body_contacts_msg, RecordedContact


def test_the_pairs_of_a_frame_come_back_bit_for_bit_with_their_names():
    pairs = [PairContact(0, 2, 7, 0.0012345678901234567, 3.3333333333333335), PairContact(2, 0, 1, 1e-9, 0.1)]
    msg = body_contacts_msg(41, ['east', 'north', 'west'], pairs)
    back = body_contacts_from_msg(deserialize_message(serialize_message(msg), type(msg)))
    assert back == [RecordedContact(41, 'east', 'west', 7, 0.0012345678901234567, 3.3333333333333335),
                    RecordedContact(41, 'west', 'east', 1, 1e-9, 0.1)]
    assert msg.header.stamp.sec == 1 and msg.header.stamp.nanosec == 400_000_000     # the end of frame 41


@pytest.mark.parametrize('key, value', [('max_depth_m', 'nan'), ('nodes', 'many'), ('normal_force_n', 'inf')])
def test_a_status_without_finite_figures_is_refused_in_one_line(key, value):
    msg = body_contacts_msg(3, ['a', 'b'], [PairContact(0, 1, 2, 0.001, 1.0)])
    msg.status[0].values = [kv if kv.key != key else KeyValue(key=key, value=value) for kv in msg.status[0].values]
    with pytest.raises(InputError, match="body_contacts status 'a/b'"):
        body_contacts_from_msg(msg)
