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

Times are seconds from the first mesh frame, taken from the header stamps (simulated time), or from the
receive times when the stamps do not advance (an unstamped publisher). Frames are subsampled while reading
(`fps`), restricted to a window (`start`, `end`), or reduced to the single frame nearest to `at`
(`math.inf`: the last one), so a long run never has to be held in memory in full.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
import math
from pathlib import Path

import numpy as np

from iguana_ros.bag.storage import BagReader, BagSummary, summarize
from iguana_ros.errors import InputError
from iguana_ros.geometry import quat_normalize, quat_rotate, yaw_of
from iguana_ros.render.run import GoalSet, RecordedRun
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


def match_topic(recorded: list[str], name: str) -> str | None:
    """Return the recorded topic for table name `name`: its absolute form, else the first namespaced '.../name'."""
    absolute = name if name.startswith('/') else '/' + name
    if absolute in recorded:
        return absolute
    namespaced = sorted(r for r in recorded if r.endswith('/' + name.lstrip('/')))
    return namespaced[0] if namespaced else None


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
        self.undecodable.setdefault(key, [0, str(exc)])[0] += 1

    def add_mesh(self, data: bytes, log_ns: int) -> None:
        """Take one serialized mesh Marker; the time base is fixed by the first two messages."""
        try:
            mesh = triangle_list_from_cdr(data)
            stamp = header_stamp_ns(data)
        except InputError as exc:
            self.skip('mesh_marker', exc)
            return
        self.mesh_count += 1
        if self.base is None:
            if not self.stamps:
                self.stamps.append((stamp, log_ns, mesh))
                return
            first = self.stamps.pop()
            self.base = 'stamp' if stamp != first[0] else 'log'
            self.t0_ns = first[0] if self.base == 'stamp' else first[1]
            self._accept(first[0] if self.base == 'stamp' else first[1], first[1], first[2])
        self._accept(stamp if self.base == 'stamp' else log_ns, log_ns, mesh)

    def finish(self) -> None:
        """Flush a lone first mesh message (a one-frame bag)."""
        if self.base is None and self.stamps:
            stamp, log_ns, mesh = self.stamps.pop()
            self.base, self.t0_ns = 'stamp', stamp
            self._accept(stamp, log_ns, mesh)

    def _accept(self, time_ns: int, log_ns: int, mesh: tuple) -> None:
        """Record the centroid of a mesh frame (points, colours) and keep its arrays if the selection wants it."""
        t = (time_ns - self.t0_ns) / NS
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
        if not sel.wants(t, self.times[-1] if self.times else None):
            return
        if len(colors) != len(points):
            colors = np.tile(DEFAULT_MESH_RGBA, (len(points), 1))
        if sel.at is not None:
            self.times, self.points, self.colors = [], [], []
        self.times.append(t)
        self.points.append(points.astype(np.float32))
        self.colors.append(colors.astype(np.float32))

    def time_of(self, stamp_ns: int, log_ns: int) -> float:
        """Seconds from the first mesh frame of a (stamp, receive time) pair in the mesh's time base."""
        return ((stamp_ns if self.base == 'stamp' else log_ns) - self.t0_ns) / NS

    def receive_time_of(self, log_ns: int) -> float:
        """Run time (s) of an unstamped message from its receive time, interpolated between mesh frames."""
        if not self.centroid_logs:
            return 0.0
        return float(np.interp(log_ns, self.centroid_logs, self.centroid_times))


def _role_topics(path: str | Path) -> tuple[dict[str, str], BagSummary]:
    """
    Return {recorded topic name: role} for mesh/state/scene, and the bag's summary (its chunks not yet verified).

    Errors name the bag.
    """
    summary = summarize(path, verify=False)
    recorded = {t.name: t.type for t in summary.topics}
    roles = {}
    for role in ('mesh_marker', 'iguana_state', 'scene_markers'):
        spec = topic(role)
        name = match_topic(list(recorded), spec.name)
        if name is None:
            continue
        if recorded[name] != spec.type:
            raise InputError(f'bag {path}: topic {name} has type {recorded[name]}, expected {spec.type}')
        roles[name] = role
    if 'mesh_marker' not in roles.values():
        raise InputError(f'bag {path} has no {topic("mesh_marker").name} topic '
                         f'(recorded: {", ".join(sorted(recorded)) or "nothing"}); nothing to render')
    return roles, summary


def read_run(path: str | Path, fps: float | None = None, start: float = 0.0, end: float = math.inf,
             at: float | None = None, progress: Callable[[int, int], None] | None = None) -> RecordedRun:
    """
    Read the frames of a bag (see module docstring); `progress(n_read, n_total)` reports the messages read.

    Every intact chunk is read; `RecordedRun.damage` holds the report line of a damaged or truncated bag (or of
    a bad metadata.yaml), '' for a sound one.
    """
    roles, summary = _role_topics(path)
    total = summary.message_count
    collector = _Collector(_Selection(start=start, end=end, fps=fps, at=at))
    reader = BagReader(path)
    for k, msg in enumerate(reader.messages()):
        role = roles.get(msg.topic)
        if role == 'mesh_marker':
            collector.add_mesh(msg.data, msg.log_time)
        elif role == 'iguana_state':
            collector.odometry.append((msg.log_time, msg.data))
        elif role == 'scene_markers':
            collector.scenes.append((msg.log_time, msg.data))
        if progress is not None and k % 64 == 63:
            progress(k + 1, total)
    collector.finish()
    if progress is not None:
        progress(total, total)
    summary.health = reader.health
    try:
        run = _assemble(collector, path, next(n for n, r in roles.items() if r == 'mesh_marker'))
    except InputError as exc:
        raise InputError(str(exc) if summary.sound else f'{exc} ({summary.report_line()})') from None
    if not summary.sound:
        run.damage = summary.report_line()
        run.notes.append(f'{run.damage}; rendered the recovered frames')
    if collector.non_finite:
        run.notes.append(f'skipped {collector.non_finite} mesh frame(s) with NaN or Inf coordinates')
    run.notes += [f'skipped {n} {key} message(s) that did not decode (first: {why})'
                  for key, (n, why) in collector.undecodable.items()]
    return run


def _assemble(c: _Collector, path: str | Path, mesh_topic: str) -> RecordedRun:
    """`RecordedRun` from a finished collector; InputError when no frame was selected."""
    sel = c.selection
    if c.mesh_count == 0 and 'mesh_marker' in c.undecodable:
        n, why = c.undecodable['mesh_marker']
        raise InputError(f'bag {path}: none of its {n} {mesh_topic} messages decodes (first: {why}); nothing to render')
    if c.mesh_count == 0:
        raise InputError(f'bag {path} has no {mesh_topic} messages; nothing to render')
    if c.non_finite == c.mesh_count:
        raise InputError(f'bag {path}: all {c.mesh_count} {mesh_topic} frames have NaN or Inf coordinates')
    if not c.times:
        raise InputError(f'bag {path}: no {mesh_topic} frames between {sel.start:g} s and {sel.end:g} s '
                         f'(the run spans 0 to {c.last_t:.2f} s)')
    times = np.array(c.times)
    track_t, track_p, yaw_t, yaws = _odometry(c)
    if track_t is None:
        track_t, track_p = np.array(c.centroid_times), np.array(c.centroids)
        order = np.argsort(track_t, kind='stable')
        track_t, track_p = track_t[order], track_p[order]
    roots = np.stack([np.interp(times, track_t, track_p[:, k]) for k in range(3)], axis=1)
    root_yaws = np.interp(times, yaw_t, np.unwrap(yaws)) if yaw_t is not None else None
    keep = track_t <= times[-1] + 1e-9
    terrain, goals = _scene(c)
    return RecordedRun(times=times, mesh_points=c.points, mesh_colors=c.colors, root_positions=roots,
                       root_yaws=root_yaws, track_times=track_t[keep], track_positions=track_p[keep],
                       terrain_points=terrain[0], terrain_colors=terrain[1], goals=goals,
                       mesh_topic=mesh_topic, duration=max(c.last_t, 0.0))


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
