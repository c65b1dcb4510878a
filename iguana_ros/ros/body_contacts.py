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
The simulator's body_contacts: body-body contact of a world's frame as a `diagnostic_msgs/DiagnosticArray`.

One DiagnosticStatus per ordered pair in contact, named '<a>/<b>' (nodes of a inside b), values nodes, max_depth_m and
normal_force_n (`physics.body_contact.PairContact`); the header stamp is the simulated time the frame ends at.
"""
from __future__ import annotations

import math
from typing import NamedTuple

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

from iguana_ros.errors import InputError
from iguana_ros.ros.conversions import frame_stamp, stamp_frame


class RecordedContact(NamedTuple):
    """One ordered pair's contact of a frame, as body_contacts carries it: names, node count, m, N."""

    frame: int
    a: str
    b: str
    nodes: int
    max_depth: float
    normal_force: float


def body_contacts_msg(frame: int, names: list[str], pairs: list) -> DiagnosticArray:
    """Return the body_contacts of `frame` (stamped at its end) from `PairContact`s between bodies named `names`."""
    statuses = [DiagnosticStatus(level=DiagnosticStatus.OK, name=f'{names[p.a]}/{names[p.b]}', hardware_id='iguana_ros',
                                 message='in contact',
                                 values=[KeyValue(key='nodes', value=str(int(p.nodes))),
                                         KeyValue(key='max_depth_m', value=repr(float(p.max_depth))),
                                         KeyValue(key='normal_force_n', value=repr(float(p.normal_force)))])
                for p in pairs]
    msg = DiagnosticArray(status=statuses)
    msg.header.stamp = frame_stamp(frame + 1)
    return msg


def body_contacts_from_msg(msg) -> list[RecordedContact]:
    """Return the pairs of a body_contacts message; InputError for a status that is not a pair's finite figures."""
    frame = stamp_frame(msg.header.stamp) - 1
    out = []
    for status in msg.status:
        values = {kv.key: kv.value for kv in status.values}
        a, _, b = status.name.partition('/')
        try:
            nodes, depth, force = int(values['nodes']), float(values['max_depth_m']), float(values['normal_force_n'])
        except (KeyError, ValueError):
            raise InputError(f'body_contacts status {status.name!r}: expected nodes, max_depth_m, normal_force_n') \
                from None
        if not (a and b and math.isfinite(depth) and math.isfinite(force)):
            raise InputError(f'body_contacts status {status.name!r}: not a pair a/b with finite figures')
        out.append(RecordedContact(frame, a, b, nodes, depth, force))
    return out
