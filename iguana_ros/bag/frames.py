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
Bag -> `RecordedRun`: per-frame iguana surface triangles, root poses, terrain and goals as numpy arrays.

Reads the topics `mesh_marker` (Marker TRIANGLE_LIST, fast CDR path), `iguana_state` (Odometry, optional) and
`scene_markers` (MarkerArray: namespace 'terrain' TRIANGLE_LIST, namespace 'goal' spheres; optional) of
msg_configs/topics.yaml, recorded under their absolute name or inside a namespace. The bytes are decoded with the CDR
codec and, for iguana_state, with the nodes' own `state_from_cdr` and its checks; a message that does not decode (a
damaged payload, another type's bytes) is skipped and counted in a note, never raised.

A bag of a world of several characters has each one's `mesh_marker` and `iguana_state` under its name
(`/east/mesh_marker`, ...; `characters`). The followed character (the first by name, or the one asked for) is read
as a lone iguana is; each other's frame for a kept frame time is its latest mesh frame at or before that time, kept
while reading (`_Companion`), in the followed character's time base.

Times are seconds from the first mesh frame, taken from the header stamps (simulated time), or from the
receive times when the stamps do not advance (an unstamped publisher). Frames are subsampled while reading
(`fps`), restricted to a window (`start`, `end`), or reduced to the single frame nearest to `at`
(`math.inf`: the last one), so a long run never has to be held in memory in full.
"""
from __future__ import annotations

import bisect
from collections.abc import Callable
from dataclasses import dataclass, field
import math
from pathlib import Path

import numpy as np

from iguana_ros.bag.storage import BagReader, BagSummary, summarize
from iguana_ros.errors import InputError
from iguana_ros.geometry import quat_normalize, quat_rotate, yaw_of
from iguana_ros.render.run import CharacterFrames, GoalSet, RecordedRun
from iguana_ros.ros.cdr import header_stamp_ns, marker_array_from_cdr, MarkerData, triangle_list_from_cdr
from iguana_ros.ros.messages import state_from_cdr
from iguana_ros.topics import topic

NS = 1_000_000_000
TERRAIN_NS, GOAL_NS = 'terrain', 'goal'
"""Marker namespaces of the terrain mesh and of the goal markers in scene_markers."""

_TRIANGLE_LIST, _ADD, _DELETEALL = 11, 0, 3
"""visualization_msgs/Marker type and action codes used here."""

FPS_TOLERANCE = 0.3
"""A frame is kept when it is at most this fraction of a frame period early for its slot."""

DEFAULT_MESH_RGBA = (0.36, 0.62, 0.30, 1.0)
"""Iguana colour when a mesh marker carries no per-vertex colours."""

REORDER_S = 1.0
"""Another character's mesh frame recorded more than this (s) ahead of the followed one's newest is skipped."""

_SAME_TIME = 1e-9
"""Frame times (s) this close are the same time."""


def match_topic(recorded: list[str], name: str) -> str | None:
    """Return the recorded topic for table name `name`: its absolute form, else the first namespaced '.../name'."""
    absolute = name if name.startswith('/') else '/' + name
    if absolute in recorded:
        return absolute
    namespaced = sorted(r for r in recorded if r.endswith('/' + name.lstrip('/')))
    return namespaced[0] if namespaced else None


def characters(recorded: list[str]) -> dict[str, str]:
    """
    Return {character name: topic prefix} of the recorded `.../mesh_marker` topics, sorted by name.

    One such topic is a lone iguana, the character '' (whatever its namespace); of several, each is named by its prefix
    without the namespace they all share (`/east/mesh_marker` -> 'east', `/ns/east/mesh_marker` -> 'east'), as the
    viewer names them.
    """
    suffix = topic('mesh_marker').name.lstrip('/')
    prefixes = sorted(name[:-len(suffix)] for name in recorded if name == '/' + suffix or name.endswith('/' + suffix))
    if len(prefixes) <= 1:
        return {'': prefix for prefix in prefixes}
    parts = [p.strip('/').split('/') if p.strip('/') else [] for p in prefixes]
    shared = 0
    while all(len(q) > shared + 1 for q in parts) and len({q[shared] for q in parts}) == 1:
        shared += 1
    return dict(sorted(('/'.join(q[shared:]), p) for q, p in zip(parts, prefixes)))


@dataclass
class _Selection:
    """Which mesh frames to keep: a time window and a frame rate, or the one nearest to `at`."""

    start: float = 0.0
    end: float = math.inf
    fps: float | None = None
    at: float | None = None
    next_due: float = -math.inf

    def wants(self, t: float, best: float | None) -> bool:
        """Whether the frame at `t` s is kept (for `at`: whether it beats the current `best` time)."""
        if self.at is not None:
            return best is None or abs(t - self.at) <= abs(best - self.at)
        if not self.start <= t <= self.end:
            return False
        if self.fps is None:
            return True
        period = 1.0 / self.fps
        if t < self.next_due - FPS_TOLERANCE * period:
            return False
        if self.next_due == -math.inf:
            self.next_due = t
        self.next_due = max(self.next_due + period, t + (1.0 - FPS_TOLERANCE) * period)
        return True


@dataclass
class _Collector:
    """Accumulates the messages of one pass over the bag."""

    selection: _Selection
    label: str = ''                                      # prefix of note keys: '' (lone iguana) or 'east/'
    companions: list = field(default_factory=list)      # _Companion of each other character of a world
    stamps: list = field(default_factory=list)          # (stamp_ns, log_ns, (points, colors)) of the first mesh
    base: str | None = None                              # 'stamp' or 'log'
    t0_ns: int = 0
    times: list = field(default_factory=list)
    points: list = field(default_factory=list)
    colors: list = field(default_factory=list)
    centroid_times: list = field(default_factory=list)
    centroid_logs: list = field(default_factory=list)    # receive time (ns) of each centroid's frame
    centroids: list = field(default_factory=list)
    odometry: list = field(default_factory=list)        # (log_ns, data)
    scenes: list = field(default_factory=list)          # (log_ns, data)
    last_t: float = -math.inf
    mesh_count: int = 0
    non_finite: int = 0
    undecodable: dict = field(default_factory=dict)     # topic key -> [count, first reason]

    def skip(self, key: str, exc: Exception) -> None:
        """Count a message of topic `key` that did not decode (the first one's reason is kept)."""
        self.undecodable.setdefault(self.label + key, [0, str(exc)])[0] += 1

    def add_mesh(self, data: bytes, log_ns: int) -> None:
        """Take one serialized mesh Marker."""
        try:
            mesh = triangle_list_from_cdr(data)
            stamp = header_stamp_ns(data)
        except InputError as exc:
            self.skip('mesh_marker', exc)
            return
        self.mesh_count += 1
        self._timed(stamp, log_ns, mesh)

    def _timed(self, stamp: int, log_ns: int, mesh: tuple) -> None:
        """Take a decoded mesh frame; the time base is fixed by the first two messages."""
        if self.base is None:
            if not self.stamps:
                self.stamps.append((stamp, log_ns, mesh))
                return
            first = self.stamps.pop()
            self.base = 'stamp' if stamp != first[0] else 'log'
            self.t0_ns = first[0] if self.base == 'stamp' else first[1]
            self._accept(self.time_of(first[0], first[1]), first[1], first[2])
        self._accept(self.time_of(stamp, log_ns), log_ns, mesh)

    def finish(self) -> None:
        """Flush a lone first mesh message (a one-frame bag)."""
        if self.base is None and self.stamps:
            stamp, log_ns, mesh = self.stamps.pop()
            self.base, self.t0_ns = 'stamp', stamp
            self._accept(self.time_of(stamp, log_ns), log_ns, mesh)

    def _accept(self, t: float, log_ns: int, mesh: tuple) -> None:
        """Record the centroid of a mesh frame (points, colours) at `t` s and offer it to `_keep`."""
        self.last_t = max(self.last_t, t)
        sel = self.selection
        if sel.at is None and t > sel.end:
            return
        points, colors = mesh
        if len(points) < 3 or not np.isfinite(points).all():
            self.non_finite += int(len(points) >= 3)
            return
        self.centroid_times.append(t)
        self.centroid_logs.append(log_ns)
        self.centroids.append(points.mean(axis=0))
        self._keep(t, points, colors)

    def _keep(self, t: float, points: np.ndarray, colors: np.ndarray) -> None:
        """Keep the frame at `t` s if the selection wants it, and give its time to the other characters."""
        sel = self.selection
        if not sel.wants(t, self.times[-1] if self.times else None):
            return
        if sel.at is not None:
            self.times, self.points, self.colors = [], [], []
        points, colors = frame_arrays(points, colors)
        self.times.append(t)
        self.points.append(points)
        self.colors.append(colors)
        for other in self.companions:
            other.slot(t, replace=sel.at is not None)

    def time_of(self, stamp_ns: int, log_ns: int) -> float:
        """Seconds from the first mesh frame of a (stamp, receive time) pair in the mesh's time base."""
        return ((stamp_ns if self.base == 'stamp' else log_ns) - self.t0_ns) / NS

    def receive_time_of(self, log_ns: int) -> float:
        """Run time (s) of an unstamped message from its receive time, interpolated between mesh frames."""
        if not self.centroid_logs:
            return 0.0
        return float(np.interp(log_ns, self.centroid_logs, self.centroid_times))


def frame_arrays(points: np.ndarray, colors: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Float32 corners `(3n, 3)` and RGBA `(3n, 4)` of a mesh frame (DEFAULT_MESH_RGBA without per-corner colours)."""
    if len(colors) != len(points):
        colors = np.tile(DEFAULT_MESH_RGBA, (len(points), 1))
    return points.astype(np.float32), colors.astype(np.float32)


@dataclass
class _Companion(_Collector):
    """
    Another character of a world: its latest mesh frame at or before each frame time its `clock` keeps.

    The followed character's collector is the clock: its time base, and a `slot` per frame it keeps. Frames a later
    slot may still take wait in `waiting`: those after the newest slot, and the latest one before it.
    """

    clock: _Collector | None = None
    pending: list = field(default_factory=list)         # (stamp_ns, log_ns, mesh) until the clock's time base is fixed
    waiting: list = field(default_factory=list)         # (t, points, colors), sorted by t
    slots: list = field(default_factory=list)           # [slot time, (t, points, colors) or None] per kept frame time
    ahead: int = 0                                       # frames skipped: more than REORDER_S ahead of the clock

    def time_of(self, stamp_ns: int, log_ns: int) -> float:
        """Seconds from the followed character's first mesh frame, in its time base."""
        return self.clock.time_of(stamp_ns, log_ns)

    def _timed(self, stamp: int, log_ns: int, mesh: tuple) -> None:
        """Take a decoded mesh frame once the clock's time base is fixed (until then it waits in `pending`)."""
        self.pending.append((stamp, log_ns, mesh))
        if self.clock.base is not None:
            self.finish()

    def finish(self) -> None:
        """Take the frames that waited for the clock's time base (after the clock's own `finish`)."""
        if self.clock.base is None:
            return
        pending, self.pending = self.pending, []
        for stamp, log_ns, mesh in pending:
            self._accept(self.time_of(stamp, log_ns), log_ns, mesh)

    def _keep(self, t: float, points: np.ndarray, colors: np.ndarray) -> None:
        """Offer the frame at `t` s to the slots it is the latest frame at or before, and keep it for later ones."""
        if t > self.clock.last_t + REORDER_S:
            self.ahead += 1
            return
        if t > self._reach()[1] + _SAME_TIME:
            return
        frame = (t, *frame_arrays(points, colors))
        for slot in reversed(self.slots):                # a frame recorded after the followed one's of its time
            if t > slot[0] + _SAME_TIME:
                break
            if slot[1] is None or slot[1][0] < t:
                slot[1] = frame
        bisect.insort(self.waiting, frame, key=lambda f: f[0])
        self._trim()

    def slot(self, t: float, replace: bool) -> None:
        """Give a new frame time `t` s the latest waiting frame at or before it (`replace`: the last slot's time)."""
        if replace and self.slots:
            old = self.slots.pop()[1]
            if old is not None and not any(f is old for f in self.waiting):
                bisect.insort(self.waiting, old, key=lambda f: f[0])
        before = [f for f in self.waiting if f[0] <= t + _SAME_TIME]
        self.slots.append([t, before[-1] if before else None])
        self._trim()

    def _reach(self) -> tuple[float, float]:
        """Return the range (s) later frame times can fall in: at or after the newest slot's, and up to `at`'s reach."""
        sel = self.selection
        if not self.slots:
            return (sel.start if sel.at is None else -math.inf), math.inf
        t = self.slots[-1][0]
        if sel.at is None or math.isinf(sel.at):
            return t, math.inf
        return sel.at - abs(t - sel.at), sel.at + abs(t - sel.at)    # none further from `at` than the newest

    def _trim(self) -> None:
        """Drop waiting frames no later slot can take: all but the latest at or before every later slot's time."""
        k = bisect.bisect_right(self.waiting, self._reach()[0] + _SAME_TIME, key=lambda f: f[0])
        del self.waiting[:max(k - 1, 0)]


def _role_topics(path: str | Path) -> tuple[dict[str, tuple[str, str]], dict[str, str], BagSummary]:
    """
    Return {recorded topic: (role, character)} for mesh/state/scene, {character: prefix} and the bag's summary.

    A lone iguana's topics (the character '') are the `match_topic` of each role; a world's characters (`characters`)
    each have their mesh and state beside their name, the scene is the world's (character ''). The summary's chunks
    are not yet verified. Errors name the bag.
    """
    summary = summarize(path, verify=False)
    recorded = {t.name: t.type for t in summary.topics}
    cast = characters(list(recorded))
    wanted = [(role, '', match_topic(list(recorded), topic(role).name)) for role in ('mesh_marker', 'iguana_state')]
    if len(cast) > 1:
        wanted = [(role, name, prefix + topic(role).name.lstrip('/')) for name, prefix in cast.items()
                  for role in ('mesh_marker', 'iguana_state')]
    wanted.append(('scene_markers', '', match_topic(list(recorded), topic('scene_markers').name)))
    roles = {}
    for role, character, name in wanted:
        if name not in recorded:
            continue
        if recorded[name] != topic(role).type:
            raise InputError(f'bag {path}: topic {name} has type {recorded[name]}, expected {topic(role).type}')
        roles[name] = (role, character)
    if not cast:
        raise InputError(f'bag {path} has no {topic("mesh_marker").name} topic '
                         f'(recorded: {", ".join(sorted(recorded)) or "nothing"}); nothing to render')
    return roles, cast, summary


def _followed(path: str | Path, cast: dict[str, str], character: str | None) -> str:
    """Return the character to follow: `character`, else the first by name; InputError naming the bag's characters."""
    if character is None:
        return next(iter(cast))
    if character not in cast or not character:
        lone = f'it holds one iguana ({cast[""]}{topic("mesh_marker").name.lstrip("/")})' if '' in cast else ''
        raise InputError(f'bag {path} has no character {character!r}; '
                         + (lone or f'its characters: {", ".join(cast)}'))
    return character


def read_run(path: str | Path, fps: float | None = None, start: float = 0.0, end: float = math.inf,
             at: float | None = None, progress: Callable[[int, int], None] | None = None,
             character: str | None = None) -> RecordedRun:
    """
    Read the frames of a bag (see module docstring); `progress(n_read, n_total)` reports the messages read.

    `character` names the world's character to follow (default: the first by name). Every intact chunk is read;
    `RecordedRun.damage` holds the report line of a damaged or truncated bag (or of a bad metadata.yaml), '' for a
    sound one.
    """
    roles, cast, summary = _role_topics(path)
    followed = _followed(path, cast, character)
    total = summary.message_count
    selection = _Selection(start=start, end=end, fps=fps, at=at)
    world = len(cast) > 1
    collector = _Collector(selection, label=f'{followed}/' if world else '')
    collectors = {followed: collector}
    for name in cast:
        if name != followed:
            collectors[name] = _Companion(selection, label=f'{name}/', clock=collector)
            collector.companions.append(collectors[name])
    reader = BagReader(path)
    for k, msg in enumerate(reader.messages()):
        role, name = roles.get(msg.topic, ('', ''))
        if role == 'mesh_marker':
            collectors[name].add_mesh(msg.data, msg.log_time)
        elif role == 'iguana_state':
            collectors[name].odometry.append((msg.log_time, msg.data))
        elif role == 'scene_markers':
            collector.scenes.append((msg.log_time, msg.data))
        if progress is not None and k % 64 == 63:
            progress(k + 1, total)
    for c in collectors.values():
        c.finish()
    if progress is not None:
        progress(total, total)
    summary.health = reader.health
    mesh_topics = {name: n for n, (r, name) in roles.items() if r == 'mesh_marker'}
    try:
        run = _assemble(collector, path, mesh_topics[followed if world else ''])
    except InputError as exc:
        raise InputError(str(exc) if summary.sound else f'{exc} ({summary.report_line()})') from None
    if world:
        run.character = followed
        run.others = [_other(collectors[name], name, mesh_topics[name], run.times) for name in cast if name != followed]
    if not summary.sound:
        run.damage = summary.report_line()
        run.notes.append(f'{run.damage}; rendered the recovered frames')
    for name, c in collectors.items():
        of = f' of {name}' if world else ''
        if c.non_finite:
            run.notes.append(f'skipped {c.non_finite} mesh frame(s){of} with NaN or Inf coordinates')
        if getattr(c, 'ahead', 0):
            run.notes.append(f'skipped {c.ahead} mesh frame(s){of} recorded more than {REORDER_S:g} s ahead of '
                             f'those of {followed}')
        run.notes += [f'skipped {n} {key} message(s) that did not decode (first: {why})'
                      for key, (n, why) in c.undecodable.items()]
    return run


def _assemble(c: _Collector, path: str | Path, mesh_topic: str) -> RecordedRun:
    """`RecordedRun` from a finished collector; InputError when no frame was selected."""
    sel = c.selection
    if c.mesh_count == 0 and c.label + 'mesh_marker' in c.undecodable:
        n, why = c.undecodable[c.label + 'mesh_marker']
        raise InputError(f'bag {path}: none of its {n} {mesh_topic} messages decodes (first: {why}); nothing to render')
    if c.mesh_count == 0:
        raise InputError(f'bag {path} has no {mesh_topic} messages; nothing to render')
    if c.non_finite == c.mesh_count:
        raise InputError(f'bag {path}: all {c.mesh_count} {mesh_topic} frames have NaN or Inf coordinates')
    if not c.times:
        raise InputError(f'bag {path}: no {mesh_topic} frames between {sel.start:g} s and {sel.end:g} s '
                         f'(the run spans 0 to {c.last_t:.2f} s)')
    times = np.array(c.times)
    track_t, track_p, yaw_t, yaws = _track(c)
    roots = np.stack([np.interp(times, track_t, track_p[:, k]) for k in range(3)], axis=1)
    root_yaws = np.interp(times, yaw_t, np.unwrap(yaws)) if yaw_t is not None else None
    keep = track_t <= times[-1] + 1e-9
    terrain, goals = _scene(c)
    return RecordedRun(times=times, mesh_points=c.points, mesh_colors=c.colors, root_positions=roots,
                       root_yaws=root_yaws, track_times=track_t[keep], track_positions=track_p[keep],
                       terrain_points=terrain[0], terrain_colors=terrain[1], goals=goals,
                       mesh_topic=mesh_topic, duration=max(c.last_t, 0.0))


def _other(c: _Companion, name: str, mesh_topic: str, times: np.ndarray) -> CharacterFrames:
    """`CharacterFrames` of another character from its finished collector, its trail up to the last of `times`."""
    frames = [frame for _, frame in c.slots]
    track_t, track_p, _, _ = _track(c)
    keep = track_t <= times[-1] + 1e-9
    return CharacterFrames(name=name, mesh_topic=mesh_topic, mesh_points=[f and f[1] for f in frames],
                           mesh_colors=[f and f[2] for f in frames], track_times=track_t[keep],
                           track_positions=track_p[keep])


def _track(c: _Collector) -> tuple:
    """
    Return (times (k,), positions (k, 3), times, yaws (k,)) of a character's root path, sorted by time.

    From its odometry; without any, from its mesh centroids (then the yaws and their times are None).
    """
    track_t, track_p, yaw_t, yaws = _odometry(c)
    if track_t is None:
        track_t, track_p = np.array(c.centroid_times), np.array(c.centroids).reshape(-1, 3)
        order = np.argsort(track_t, kind='stable')
        track_t, track_p = track_t[order], track_p[order]
    return track_t, track_p, yaw_t, yaws


def _odometry(c: _Collector) -> tuple:
    """
    Return (times, positions (k, 3), times, yaws (k,)) of the recorded odometry, or four Nones without any.

    Each message is read with the nodes' `state_from_cdr`; one that does not decode or fails its checks is counted.
    """
    if not c.odometry:
        return None, None, None, None
    rows = []
    for log_ns, data in c.odometry:
        try:
            _, pos, quat = state_from_cdr(data)
        except InputError as exc:
            c.skip('iguana_state', exc)
            continue
        rows.append((c.time_of(header_stamp_ns(data), log_ns), *pos, float(yaw_of(quat))))
    if not rows:
        return None, None, None, None
    table = np.array(sorted(rows, key=lambda r: r[0]))
    return table[:, 0], table[:, 1:4], table[:, 0], table[:, 4]


def _scene(c: _Collector) -> tuple[tuple, list[GoalSet]]:
    """((terrain corners, colours) or (None, None), goal sets by time) from the scene_markers messages."""
    terrain: tuple = (None, None)
    goals: list[GoalSet] = []
    for log_ns, data in sorted(c.scenes, key=lambda s: s[0]):
        t = c.receive_time_of(log_ns)  # a MarkerArray has no header; its markers' stamps are often 0
        try:
            new_terrain, new_goals = scene_update(marker_array_from_cdr(data), t)
        except InputError as exc:     # a damaged marker array: the terrain and goals of the others still show
            c.skip('scene_markers', exc)
            continue
        terrain = new_terrain or terrain
        goals.extend(new_goals)
    return terrain, goals


def scene_update(markers: list[MarkerData], t: float) -> tuple[tuple | None, list[GoalSet]]:
    """
    Return what one scene_markers message received at `t` s changes.

    The terrain's (corners `(3n, 3)`, RGBA `(3n, 4)`) or None, and the goal sets it starts (an empty one for a
    DELETEALL, then its goal spheres).
    """
    terrain, goals = None, []
    if any(m.action == _DELETEALL for m in markers):
        goals.append(GoalSet(t, np.zeros((0, 3)), np.zeros(0), np.zeros((0, 4))))
    for m in markers:
        if m.ns == TERRAIN_NS and m.type == _TRIANGLE_LIST and m.action == _ADD:
            terrain = marker_triangles(m)
    goal = [m for m in markers if m.ns == GOAL_NS and m.action == _ADD]
    if goal:
        goals.append(goal_set(t, goal))
    return terrain, goals


def marker_triangles(m: MarkerData) -> tuple[np.ndarray, np.ndarray]:
    """World corners `(3n, 3)` and RGBA `(3n, 4)` of a TRIANGLE_LIST marker (its pose and scale applied)."""
    n = len(m.points) - len(m.points) % 3
    points = m.points[:n] * m.scale
    if np.any(m.orientation[:3] != 0.0) and np.isfinite(m.orientation).all():
        points = quat_rotate(quat_normalize(m.orientation), points)
    points = points + m.position
    colors = m.colors[:n] if len(m.colors) >= n else np.tile(m.color, (n, 1))
    if not np.isfinite(points).all():
        raise InputError('scene_markers: the terrain marker has NaN or Inf coordinates')
    return points, colors


def goal_set(t: float, markers: list[MarkerData]) -> GoalSet:
    """`GoalSet` of goal markers (spheres of diameter scale.x at their pose)."""
    pos = np.array([m.position for m in markers])
    radii = np.array([0.5 * max(float(m.scale[0]), 1e-3) for m in markers])
    return GoalSet(t, pos, radii, np.array([m.color for m in markers]))
