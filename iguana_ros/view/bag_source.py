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
A recorded bag read into a `WorldView` for the timeline.

Every mesh frame, the root's states, the feet, pushes, clips, terrain and goals, in one pass over the bag (the same
decoders as live mode: the nodes' own, on the recorded bytes), of every character: each recorded `.../mesh_marker` is
one, with the topics beside it (`/east/mesh_marker`, `/east/iguana_state`, ...; a lone iguana's are the root's). Wall
time is each message's publish time (its publisher's send time, wall clock in every bag): a run's log times are
simulated time, which would make the realtime factor 1.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from iguana_ros.bag.frames import characters as frames_characters, match_topic, NS
from iguana_ros.bag.storage import accept, BagReader, summarize
from iguana_ros.errors import IguanaError, InputError
from iguana_ros.topics import topic
from iguana_ros.view import decode
from iguana_ros.view.scene import RunView, WorldView

ROLES = ('mesh_marker', 'scene_markers', 'iguana_state', 'foot_state', 'foot_positions', 'push', 'motion_clip')
"""Topic-table keys the viewer reads from a bag."""

WORLD_ROLES = ('scene_markers',)
"""Of ROLES, the world's (one for every character); the others are each character's, beside its mesh_marker."""


@dataclass
class BagView:
    """
    A bag's characters (`world`), its damage report line ('' when sound) and what was skipped, one sentence each.

    `view` is the first character's RunView: a lone iguana's, holding the terrain and goals too.
    """

    world: WorldView
    damage: str = ''
    notes: list[str] = field(default_factory=list)

    @property
    def view(self) -> RunView:
        """Return the RunView of the first character: a lone iguana's, the only one."""
        names = self.world.names
        return self.world.views[names[0]] if names else self.world.world


def characters(recorded: dict[str, str]) -> dict[str, str]:
    """
    Return {character name: topic prefix} of every recorded `.../mesh_marker` of the mesh type (`frames.characters`).

    `recorded` maps each recorded topic to its type.
    """
    spec = topic('mesh_marker')
    return frames_characters([name for name, kind in recorded.items() if kind == spec.type])


def _roles(path: str | Path) -> tuple[dict, dict, object]:
    """
    Return ({recorded topic: (table key, character)} of the ROLES in the bag, {character: prefix}, its BagSummary).

    The bag is checked in full. A character's topics are those beside its mesh_marker; the world's, the
    `match_topic` of the table's name. InputError for a missing bag or one without a mesh_marker topic.
    """
    summary = summarize(path)
    recorded = {t.name: t.type for t in summary.topics}
    cast = characters(recorded)
    if not cast:
        raise InputError(f'bag {path} has no {topic("mesh_marker").name} topic of type {topic("mesh_marker").type} '
                         f'(recorded: {", ".join(sorted(recorded)) or "nothing"}); nothing to show')
    roles = {}
    for key in ROLES:
        spec = topic(key)
        if key in WORLD_ROLES:
            name = match_topic(list(recorded), spec.name)
            if name is not None and recorded[name] == spec.type:
                roles[name] = (key, '')
            continue
        for character, prefix in cast.items():
            name = prefix + spec.name.lstrip('/')
            if recorded.get(name) == spec.type:
                roles[name] = (key, character)
    return roles, cast, summary


def load_bag(path: str | Path, allow_damaged: bool = False, library: dict | None = None,
             push_duration: float = 0.1) -> BagView:
    """
    Read bag `path` (see the module docstring): every character of it.

    `library` names the clips (name -> clip), pushes last `push_duration` s. InputError for a missing bag or one without
    mesh frames; DamagedBag for a damaged or truncated bag unless `allow_damaged`.
    """
    roles, cast, summary = _roles(path)
    damage = accept(summary, allow_damaged)
    world, skipped = WorldView(), {}
    pushes, scenes = {name: [] for name in {'', *cast}}, []

    def takers(view: RunView, character: str) -> dict[str, Callable]:
        return {
            'mesh_marker': lambda data, _: decode.take_mesh(view, data),
            'scene_markers': lambda data, wall_ns: scenes.append((wall_ns, data)),
            'iguana_state': lambda data, wall_ns: decode.take_state(view, data, wall_ns / NS),
            'foot_state': lambda data, _: decode.take_foot_state(view, data),
            'foot_positions': lambda data, _: decode.take_foot_positions(view, data),
            'motion_clip': lambda data, _: decode.take_clip(view, data, library or {}),
            'push': lambda data, wall_ns: pushes[character].append((wall_ns, data)),
        }
    by_character = {name: takers(world.character(name), name) for name in {'', *cast}}   # '': the world's topics
    for record in BagReader(path).messages():
        role = roles.get(record.topic)
        if role is None:
            continue
        key, character = role
        try:
            by_character[character][key](bytes(record.data), record.publish_time)
        except IguanaError as exc:  # a message that does not decode or fit: counted, not fatal
            skipped.setdefault(_label(key, character), [0, str(exc)])[0] += 1
    first = world.views[sorted(cast)[0]]
    _place_by_receive_time(first, world.world, scenes, lambda view, data, t: decode.take_scene(view, data, t),
                           'scene_markers', skipped)
    for name, messages in pushes.items():
        view = world.views[name]
        _place_by_receive_time(view, view, messages,
                               lambda into, data, t: decode.take_push(into, data, t, push_duration),
                               _label('push', name), skipped)
    if not world.names:
        raise InputError(f'bag {path} has no usable {topic("mesh_marker").name} messages; nothing to show')
    notes = [f'skipped {n} {key} message(s) that did not fit (first: {why})' for key, (n, why) in skipped.items()]
    return BagView(world, damage, notes)


def _label(key: str, character: str) -> str:
    """Return how a note names topic `key` of `character` ('east/push'; a lone iguana's: 'push')."""
    return f'{character}/{key}' if character else key


def _place_by_receive_time(clock: RunView, into: RunView, messages: list, take: Callable, key: str,
                           skipped: dict) -> None:
    """
    Scene markers and pushes carry no simulated time.

    Each of `messages` (wall-clock send time, bytes) is taken into `into` by `take(into, data, t)` at the simulated time
    `t` of the states of `clock` sent around it (from the messages' wall-clock send times); one that does not decode is
    counted in `skipped` under `key`.
    """
    states = clock.states
    walls, times = states.values[:, 5], states.times
    known = np.isfinite(walls)

    def sim_time(log_ns: int) -> float:
        if not known.any():
            return clock.start_time
        return float(np.interp(log_ns / NS, walls[known], times[known]))

    for log_ns, data in messages:
        try:
            take(into, data, sim_time(log_ns))
        except IguanaError as exc:  # a damaged marker array or push: the others still show
            skipped.setdefault(key, [0, str(exc)])[0] += 1
