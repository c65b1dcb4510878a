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
A recorded bag read into a `RunView` for the timeline.

Every mesh frame, the root's states, the feet, pushes, clips, terrain and goals, in one pass over the bag (the same
decoders as live mode: the nodes' own, on the recorded bytes). Wall time is each message's publish time (its
publisher's send time, wall clock in every bag): a run's log times are simulated time, which would make the realtime
factor 1.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from iguana_ros.bag.frames import match_topic, NS
from iguana_ros.bag.storage import accept, BagReader, summarize
from iguana_ros.errors import IguanaError, InputError
from iguana_ros.topics import topic
from iguana_ros.view import decode
from iguana_ros.view.scene import RunView

ROLES = ('mesh_marker', 'scene_markers', 'iguana_state', 'foot_state', 'foot_positions', 'push', 'motion_clip')
"""Topic-table keys the viewer reads from a bag."""


@dataclass
class BagView:
    """A bag's RunView, its damage report line ('' when sound) and what was skipped, one sentence each."""

    view: RunView
    damage: str = ''
    notes: list[str] = field(default_factory=list)


def _roles(path: str | Path) -> tuple[dict, object]:
    """
    Return ({recorded topic: table key} of the ROLES in the bag, its BagSummary, checked in full).

    InputError for a missing bag or one without a mesh_marker topic.
    """
    summary = summarize(path)
    recorded = {t.name: t.type for t in summary.topics}
    roles = {}
    for key in ROLES:
        spec = topic(key)
        name = match_topic(list(recorded), spec.name)
        if name is not None and recorded[name] == spec.type:
            roles[name] = key
    if 'mesh_marker' not in roles.values():
        raise InputError(f'bag {path} has no {topic("mesh_marker").name} topic of type {topic("mesh_marker").type} '
                         f'(recorded: {", ".join(sorted(recorded)) or "nothing"}); nothing to show')
    return roles, summary


def load_bag(path: str | Path, allow_damaged: bool = False, library: dict | None = None,
             push_duration: float = 0.1) -> BagView:
    """
    Read bag `path` (see the module docstring).

    `library` names the clips (name -> clip), pushes last `push_duration` s. InputError for a missing bag or one without
    mesh frames; DamagedBag for a damaged or truncated bag unless `allow_damaged`.
    """
    roles, summary = _roles(path)
    damage = accept(summary, allow_damaged)
    view, skipped = RunView(), {}
    pushes, scenes = [], []
    takers: dict[str, Callable] = {
        'mesh_marker': lambda data, _: decode.take_mesh(view, data),
        'scene_markers': lambda data, wall_ns: scenes.append((wall_ns, data)),
        'iguana_state': lambda data, wall_ns: decode.take_state(view, data, wall_ns / NS),
        'foot_state': lambda data, _: decode.take_foot_state(view, data),
        'foot_positions': lambda data, _: decode.take_foot_positions(view, data),
        'motion_clip': lambda data, _: decode.take_clip(view, data, library or {}),
        'push': lambda data, wall_ns: pushes.append((wall_ns, data)),
    }
    for record in BagReader(path).messages():
        key = roles.get(record.topic)
        if key is None:
            continue
        try:
            takers[key](bytes(record.data), record.publish_time)
        except IguanaError as exc:  # a message that does not decode or fit: counted, not fatal
            skipped.setdefault(key, [0, str(exc)])[0] += 1
    _place_by_receive_time(view, scenes, pushes, push_duration, skipped)
    if not view.meshes:
        raise InputError(f'bag {path} has no usable {topic("mesh_marker").name} messages; nothing to show')
    notes = [f'skipped {n} {key} message(s) that did not fit (first: {why})' for key, (n, why) in skipped.items()]
    return BagView(view, damage, notes)


def _place_by_receive_time(view: RunView, scenes: list, pushes: list, push_duration: float, skipped: dict) -> None:
    """
    Scene markers and pushes carry no simulated time.

    Each takes the simulated time of the states sent around it (from the messages' wall-clock send times); one that
    does not decode is counted in `skipped`.
    """
    states = view.states
    walls, times = states.values[:, 5], states.times
    known = np.isfinite(walls)

    def sim_time(log_ns: int) -> float:
        if not known.any():
            return view.start_time
        return float(np.interp(log_ns / NS, walls[known], times[known]))

    for key, messages, take in (('scene_markers', scenes, lambda data, t: decode.take_scene(view, data, t)),
                                ('push', pushes, lambda data, t: decode.take_push(view, data, t, push_duration))):
        for log_ns, data in messages:
            try:
                take(data, sim_time(log_ns))
            except IguanaError as exc:  # a damaged marker array or push: the others still show
                skipped.setdefault(key, [0, str(exc)])[0] += 1
