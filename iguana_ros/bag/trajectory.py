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

"""What a run's bag says, read back: the root trajectory (iguana_state) and, per frame, any topic's messages."""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from rclpy.serialization import deserialize_message

from iguana_ros.bag.storage import BagReader
from iguana_ros.ros.conversions import odometry_to_numpy, time_from_msg
from iguana_ros.ros.endpoints import resolve


@dataclass
class RecordedTopics:
    """
    Deserialized messages of some topic-table keys, in file order.

    `rejected` counts, per key, the messages that did not deserialize; `truncated` / `problem` say whether the file
    ended early (see BagReader).
    """

    messages: dict[str, list] = field(default_factory=dict)
    rejected: dict[str, int] = field(default_factory=dict)
    truncated: bool = False
    problem: str = ''


def read_topics(bag: str | Path, keys: list[str] | tuple[str, ...]) -> RecordedTopics:
    """
    Every message of the topics `keys` (topic-table keys) of `bag`, in one pass over the file.

    A key whose topic is not in the bag has an empty list. Raises InputError for a missing or non-MCAP bag.
    """
    wanted = {}
    for key in keys:
        name, cls, _ = resolve(key)
        wanted[name if name.startswith('/') else '/' + name] = (key, cls)
    out = RecordedTopics({key: [] for key in keys}, dict.fromkeys(keys, 0))
    reader = BagReader(bag)
    for record in reader.messages():
        if record.topic in wanted:
            key, cls = wanted[record.topic]
            try:
                out.messages[key].append(deserialize_message(record.data, cls))
            except Exception:  # noqa: BLE001 -- a corrupt payload (recovered chunk): counted, not fatal
                out.rejected[key] += 1
    out.truncated, out.problem = reader.truncated, reader.problem
    return out


def root_trajectory(messages: list) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """
    Return times `(n,)` s, root positions `(n, 3)` and orientations `(n, 4)` xyzw of iguana_state messages.

    In time order of their header stamps (a re-sent stamp counts once, its last message).
    """
    rows: dict[float, tuple] = {}
    for msg in messages:
        position, orientation, _, _ = odometry_to_numpy(msg)
        rows[time_from_msg(msg.header.stamp)] = (position, orientation)
    times = np.array(sorted(rows))
    positions = np.array([rows[t][0] for t in times]).reshape(-1, 3)
    orientations = np.array([rows[t][1] for t in times]).reshape(-1, 4)
    return times, positions, orientations


def read_root_trajectory(bag: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Return times `(n,)` (header stamps, s) and root positions `(n, 3)` of every iguana_state message, in order."""
    times, positions, _ = root_trajectory(read_topics(bag, ['iguana_state']).messages['iguana_state'])
    return times, positions
