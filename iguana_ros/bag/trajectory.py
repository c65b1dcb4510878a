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

from iguana_ros.bag.storage import BagReader
from iguana_ros.errors import InputError
from iguana_ros.ros.messages import stamp_of_cdr, state_from_cdr
from iguana_ros.topics import check_namespace, shared_topic, topic_name


@dataclass
class RecordedTopics:
    """
    The serialized messages of some topic-table keys, in file order, as the nodes received them.

    Decode them with the nodes' `ros.messages.*_from_cdr` functions. `truncated` / `problem` say whether the file ended
    early (see BagReader).
    """

    messages: dict[str, list[bytes]] = field(default_factory=dict)
    truncated: bool = False
    problem: str = ''


def read_topics(bag: str | Path, keys: list[str] | tuple[str, ...], namespace: str | None = None) -> RecordedTopics:
    """
    Every message of the topics `keys` (topic-table keys) of `bag`, in one pass over the file.

    The run's topics in ROS `namespace` ('' the root), or with None in whichever namespace the bag's run had
    (`iguana run --namespace`). A key whose topic is not in the bag has an empty list. Raises InputError for a
    missing or non-MCAP bag, and with None for a key recorded under several names (a world's characters: each has its
    namespace, '/east').
    """
    key_of: dict[str, str | None] = {}
    out = RecordedTopics({key: [] for key in keys})
    reader = BagReader(bag)
    for record in reader.messages():
        if record.topic not in key_of:
            key_of[record.topic] = recorded_key(record.topic, keys, namespace)
        key = key_of[record.topic]
        if key is not None:
            out.messages[key].append(bytes(record.data))
    _one_name_per_key(bag, key_of)
    out.truncated, out.problem = reader.truncated, reader.problem
    return out


def _one_name_per_key(bag: str | Path, key_of: dict[str, str | None]) -> None:
    """Raise InputError if a topic-table key was recorded under two names (the bag of a world of characters)."""
    names: dict[str, list[str]] = {}
    for name, key in key_of.items():
        if key is not None:
            names.setdefault(key, []).append(name)
    for key, found in names.items():
        if len(found) > 1:
            spaces = ', '.join(sorted(name[:-len(topic_name(key))] or '/' for name in found))
            raise InputError(f'bag {bag} holds {key} of several characters ({", ".join(sorted(found))}): read one '
                             f'with its namespace ({spaces})')


def recorded_key(name: str, keys: list[str] | tuple[str, ...], namespace: str | None = None) -> str | None:
    """Return which of topic-table `keys` recorded topic `name` is in a run in `namespace` (None: any), else None."""
    for key in keys:
        if namespace is not None:
            if name == topic_name(key, namespace):
                return key
            continue
        root = topic_name(key)
        if name == root or (not shared_topic(key) and name.endswith(root) and name.startswith('/')
                            and check_namespace_quietly(name[:-len(root)])):
            return key
    return None


def check_namespace_quietly(text: str) -> bool:
    """Whether `text` is a ROS namespace of one or more parts ('/iguana1', '/zoo/iguana1')."""
    try:
        return bool(check_namespace(text))
    except InputError:
        return False


def root_trajectory(messages: list[bytes]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """
    Return times `(n,)` s, root positions `(n, 3)` and orientations `(n, 4)` xyzw of serialized iguana_state messages.

    Read with the nodes' `state_from_cdr` (and its checks); in time order of their header stamps (a re-sent stamp
    counts once, its last message). Messages that do not decode are left out (`run_gait` counts them in a note).
    """
    rows: dict[float, tuple] = {}
    for data in messages:
        try:
            _, position, orientation = state_from_cdr(data)
        except InputError:
            continue
        rows[stamp_of_cdr(data)] = (position, orientation)
    times = np.array(sorted(rows))
    positions = np.array([rows[t][0] for t in times]).reshape(-1, 3)
    orientations = np.array([rows[t][1] for t in times]).reshape(-1, 4)
    return times, positions, orientations


def read_root_trajectory(bag: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Return times `(n,)` (header stamps, s) and root positions `(n, 3)` of every iguana_state message, in order."""
    times, positions, _ = root_trajectory(read_topics(bag, ['iguana_state']).messages['iguana_state'])
    return times, positions
