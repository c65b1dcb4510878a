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
What the viewer draws at one moment (ROS-free): the run so far as time series, and the frame at a time.

A `RunView` collects what the topics of a run carry, decoded to arrays by the existing conversions: the terrain
and goal markers (`scene_markers`), the iguana's surface (`mesh_marker`), the root's pose and speed
(`iguana_state`), the feet (`foot_positions`, `foot_state`), pushes (`push`, or a scene's pushes) and the clips
the planner chose (`motion_clip`). `RunView.frame(t)` gives the `ViewFrame` to draw at simulated time `t`: the
latest mesh, the root's path so far, the feet in contact, the push arrows acting, the goals, the current clip,
speed, foot slip and realtime factor. Live mode appends as messages arrive and draws the latest time; bag mode
fills it from a bag and draws the timeline's time. Every method takes the view's lock, so a ROS thread may
append while the web server's thread draws.

A `WorldView` holds a run's characters, one `RunView` each by name: a world's (`iguana run crossing`: `east/...`,
`north/...`) under their names with the terrain and goals in a view of the world's own, a lone iguana's as the
character '' whose view is the world's (everything as before).
"""
from __future__ import annotations

from bisect import bisect_right
from dataclasses import dataclass, field, replace
import math
import threading

import numpy as np

from iguana_ros.metrics import slip_per_foot
from iguana_ros.render.run import GoalSet

ARROW_M_PER_N = 0.01
"""Length of a push arrow per newton of force, m/N (the paper's 40 N push: 0.4 m)."""

ARROW_LIFT = 0.06
"""Height of a push arrow's tip above the root, m."""

ARROW_SHOW_S = 5.0
"""A push arrow is shown at least this long, s (a 0.1 s push would last three frames: too short to notice)."""

SLIP_WINDOW_S = 1.0
"""Simulated seconds over which foot slip is measured."""

RTF_WINDOW_S = 2.0
"""Wall seconds over which the realtime factor is measured."""

RTF_MIN_WALL_S = 0.2
"""Fewer wall seconds than this in the window give no realtime factor."""

PATH_MAX_POINTS = 2000
"""Most points of the root's path drawn at once, besides the latest (a longer path is thinned, see `path_stride`)."""

CLIP_MATCH_TOLERANCE = 1e-6
"""Largest 1 - |q . q_library| of a bone rotation for a motion_clip to be named after a library clip."""

_FEET = 4


@dataclass(frozen=True)
class PushEvent:
    """A push: from `time` s, force `(3,)` N in the world frame on tagged region `region`, for `duration` s."""

    time: float
    force: np.ndarray
    region: str
    duration: float


@dataclass(frozen=True)
class ClipEvent:
    """The planner's clip `name` ('' when not a library clip) playing from `time` s."""

    time: float
    name: str


@dataclass(frozen=True)
class MeshFrame:
    """The iguana's surface at `time` s: TRIANGLE_LIST corners `(3*n_t, 3)` m and RGBA `(3*n_t, 4)`."""

    time: float
    points: np.ndarray
    colors: np.ndarray


@dataclass(frozen=True)
class ViewFrame:
    """Everything drawn at simulated time `time` s (unknown figures are NaN, an unknown clip '')."""

    time: float
    mesh: MeshFrame | None
    root: np.ndarray | None
    """Root position `(3,)` m, None before the first state."""
    path: np.ndarray
    """Root positions so far `(k, 3)` m."""
    contacts: np.ndarray
    """Sole centroids of the feet touching the ground `(c, 3)` m."""
    arrows: np.ndarray
    """Push arrows `(a, 2, 3)`: tail and tip, m."""
    goals: GoalSet | None
    clip: str
    speed: float
    """Horizontal root speed, m/s."""
    slip: float
    """Horizontal travel of the feet while in contact over the last SLIP_WINDOW_S, summed over feet, per s, m/s."""
    realtime_factor: float
    terrain_version: int


class Series:
    """
    Rows stamped with non-decreasing times.

    The rows are `times (n,)` s and `values (n, *shape)`; a row at the last time replaces it (a re-sent message), an
    older one is dropped.
    """

    def __init__(self, shape: tuple, capacity: int = 256) -> None:
        """Start an empty series of rows of `shape`."""
        self._times = np.zeros(capacity)
        self._values = np.zeros((capacity, *shape))
        self.n = 0

    @classmethod
    def of(cls, times: np.ndarray, values: np.ndarray) -> Series:
        """Return a series holding rows `values (n, *shape)` at `times (n,)` (sorted by time, stable)."""
        order = np.argsort(np.asarray(times, float), kind='stable')
        series = cls(np.shape(values)[1:], capacity=max(len(order), 1))
        for k in order:
            series.append(float(times[k]), values[k])
        return series

    def append(self, time: float, value) -> None:
        """Add a row at `time` s (see the class docstring)."""
        if self.n and time < self._times[self.n - 1]:
            return
        if not (self.n and time == self._times[self.n - 1]):
            if self.n == len(self._times):
                self._times = np.concatenate([self._times, np.zeros(self.n)])
                self._values = np.concatenate([self._values, np.zeros_like(self._values)])
            self.n += 1
        self._times[self.n - 1] = time
        self._values[self.n - 1] = value

    @property
    def times(self) -> np.ndarray:
        """Return times `(n,)` s (a view)."""
        return self._times[:self.n]

    @property
    def values(self) -> np.ndarray:
        """Rows `(n, *shape)` (a view)."""
        return self._values[:self.n]

    def index_at(self, time: float) -> int:
        """Index of the last row at or before `time` s (-1 if there is none)."""
        return int(np.searchsorted(self.times, time, side='right')) - 1


def path_stride(k: int) -> int:
    """
    Return every how many state rows a path up to row `k` keeps: the smallest power of two that keeps PATH_MAX_POINTS.

    A power of two that doubles as the run grows: between doublings, the thinned path of a later row only adds points.
    """
    stride = 1
    while k // stride + 1 > PATH_MAX_POINTS:
        stride *= 2
    return stride


def _latest(items: list, time: float):
    """Return the last of `items` (sorted by `.time`) at or before `time`, else the first, else None."""
    if not items:
        return None
    k = bisect_right([item.time for item in items], time) - 1
    return items[max(k, 0)]


@dataclass
class RunView:
    """
    The run so far (see the module docstring).

    `keep_meshes` bounds how many mesh frames are kept (None = all, for a bag's timeline; live mode keeps the latest).
    """

    keep_meshes: int | None = None
    terrain_points: np.ndarray | None = None
    """Terrain TRIANGLE_LIST corners `(3*m, 3)` m."""
    terrain_colors: np.ndarray | None = None
    """Terrain RGBA `(3*m, 4)`."""
    terrain_version: int = 0
    goals: list = field(default_factory=list)
    """GoalSet snapshots in time order."""
    meshes: list = field(default_factory=list)
    states: Series = field(default_factory=lambda: Series((6,)))
    """Rows x, y, z (m), yaw (rad), horizontal speed (m/s), wall receive time (s, NaN unknown)."""
    feet: Series = field(default_factory=lambda: Series((_FEET, 4)))
    """Rows per foot: sole centroid x, y, z (m) and contact flag (1.0 / 0.0); positions and flags may come from
    two messages of the same stamp, so a row starts as NaN until both are in."""
    pushes: list = field(default_factory=list)
    clips: list = field(default_factory=list)
    lock: threading.RLock = field(default_factory=threading.RLock, repr=False)

    def set_terrain(self, points: np.ndarray, colors: np.ndarray) -> None:
        """Take the terrain's TRIANGLE_LIST corners `(3*m, 3)` and RGBA `(3*m, 4)` (a new version is drawn)."""
        with self.lock:
            self.terrain_points, self.terrain_colors = np.asarray(points, float), np.asarray(colors, float)
            self.terrain_version += 1

    def add_goals(self, goals: GoalSet) -> None:
        """Take a snapshot of the goal markers (valid from `goals.time` on)."""
        with self.lock:
            self.goals.append(goals)
            self.goals.sort(key=lambda g: g.time)

    def add_mesh(self, mesh: MeshFrame) -> None:
        """Take one frame of the iguana's surface (frames older than the latest are dropped)."""
        with self.lock:
            if self.meshes and mesh.time < self.meshes[-1].time:
                return
            self.meshes.append(mesh)
            if self.keep_meshes is not None and len(self.meshes) > self.keep_meshes:
                del self.meshes[:-self.keep_meshes]

    def add_state(self, time: float, position: np.ndarray, yaw: float, speed: float,
                  wall: float = math.nan) -> None:
        """
        Take the root's position `(3,)` m, heading (rad) and horizontal speed (m/s) at `time` s.

        `wall` s is the wall time it was received at.
        """
        with self.lock:
            self.states.append(time, [*np.asarray(position, float)[:3], yaw, speed, wall])

    def add_feet(self, time: float, positions: np.ndarray | None = None, contact: np.ndarray | None = None) -> None:
        """Take the sole centroids `(4, 3)` m and/or the contact flags `(4,)` of the feet at `time` s."""
        with self.lock:
            k = self.feet.index_at(time)
            row = self.feet.values[k].copy() if k >= 0 and self.feet.times[k] == time else np.full((_FEET, 4), np.nan)
            if positions is not None:
                row[:, :3] = positions
            if contact is not None:
                row[:, 3] = np.asarray(contact, float)
            self.feet.append(time, row)

    def add_push(self, push: PushEvent) -> None:
        """Take a push."""
        with self.lock:
            self.pushes.append(push)
            self.pushes.sort(key=lambda p: p.time)

    def add_clip(self, clip: ClipEvent) -> None:
        """Take the start of a clip."""
        with self.lock:
            self.clips.append(clip)
            self.clips.sort(key=lambda c: c.time)

    @property
    def end_time(self) -> float:
        """Return the latest simulated time anything was seen at, s (0 before anything)."""
        with self.lock:
            ends = [self.meshes[-1].time] if self.meshes else []
            ends += [s.times[-1] for s in (self.states, self.feet) if s.n]
            return max(ends, default=0.0)

    @property
    def start_time(self) -> float:
        """Return the earliest simulated time of a mesh or state, s (0 before anything)."""
        with self.lock:
            starts = [self.meshes[0].time] if self.meshes else []
            starts += [self.states.times[0]] if self.states.n else []
            return min(starts, default=0.0)

    def frame(self, time: float | None = None) -> ViewFrame:
        """Return what to draw at simulated time `time` s (None: the latest)."""
        with self.lock:
            t = self.end_time if time is None else float(time)
            k = self.states.index_at(t)
            root = self.states.values[max(k, 0), :3].copy() if self.states.n else None
            return ViewFrame(
                time=t, mesh=_latest(self.meshes, t), root=root, path=self._path(k),
                contacts=self._contacts(t), arrows=self._arrows(t, root), goals=_latest(self.goals, t),
                clip=(_latest(self.clips, t).name if self.clips and self.clips[0].time <= t else ''),
                speed=float(self.states.values[k, 4]) if k >= 0 else math.nan, slip=self._slip(t),
                realtime_factor=self._realtime_factor(k), terrain_version=self.terrain_version)

    def _path(self, k: int) -> np.ndarray:
        """Root positions `(<= PATH_MAX_POINTS + 1, 3)` up to state row `k`: every `path_stride(k)`-th row and row k."""
        if k < 0:
            return np.zeros((0, 3))
        idx = np.arange(0, k + 1, path_stride(k))
        if idx[-1] != k:
            idx = np.append(idx, k)
        return self.states.values[idx, :3].copy()

    def _contacts(self, t: float) -> np.ndarray:
        """Sole centroids `(c, 3)` of the feet in contact at `t`."""
        k = self.feet.index_at(t)
        if k < 0:
            return np.zeros((0, 3))
        row = self.feet.values[k]
        touching = (row[:, 3] == 1.0) & np.isfinite(row[:, :3]).all(axis=1)
        return row[touching, :3].copy()

    def _arrows(self, t: float, root: np.ndarray | None) -> np.ndarray:
        """Tail and tip `(a, 2, 3)` of the pushes acting at `t` (shown at least ARROW_SHOW_S), tips above the root."""
        acting = [p for p in self.pushes if p.time <= t < p.time + max(p.duration, ARROW_SHOW_S)]
        if root is None or not acting:
            return np.zeros((0, 2, 3))
        tip = root + np.array([0.0, 0.0, ARROW_LIFT])
        return np.array([[tip - np.asarray(p.force, float) * ARROW_M_PER_N, tip] for p in acting])

    def _slip(self, t: float) -> float:
        """Horizontal travel of the feet while in contact over the last SLIP_WINDOW_S before `t`, per s (m/s)."""
        times = self.feet.times
        hi = self.feet.index_at(t) + 1
        lo = int(np.searchsorted(times, t - SLIP_WINDOW_S, side='left'))
        rows = self.feet.values[lo:hi]
        rows = rows[np.isfinite(rows).all(axis=(1, 2))]
        if len(rows) < 2:
            return math.nan
        span = times[hi - 1] - times[lo]
        travel = slip_per_foot(rows[:, :, :2], rows[:, :, 3] == 1.0, 1).sum()
        return float(travel / span) if span > 0 else math.nan

    def _realtime_factor(self, k: int) -> float:
        """Return simulated over wall seconds between state row `k` and the row RTF_WINDOW_S wall seconds before it."""
        if k < 1:
            return math.nan
        wall = self.states.values[:k + 1, 5]
        if not np.isfinite(wall[k]):
            return math.nan
        j = int(np.argmax(wall >= wall[k] - RTF_WINDOW_S))
        dwall = wall[k] - wall[j]
        if not np.isfinite(dwall) or dwall < RTF_MIN_WALL_S:
            return math.nan
        return float((self.states.times[k] - self.states.times[j]) / dwall)


@dataclass(frozen=True)
class Body:
    """One character's body at a time: its name ('' for a lone iguana), latest surface, root position `(3,)` m."""

    name: str
    mesh: MeshFrame | None
    root: np.ndarray | None


class WorldView:
    """
    The characters of a run, each a `RunView` by name, and the world's terrain and goals (see the module docstring).

    The character '' (a lone iguana, whose topics are the root ones) is the world's view itself; a named one has a view
    of its own (sharing the world's lock) made by `character`. `keep_meshes` is each view's (None: all).
    """

    def __init__(self, world: RunView | None = None, keep_meshes: int | None = None) -> None:
        """Wrap `world` (None: a new RunView keeping `keep_meshes`): terrain, goals and the character ''."""
        self.world = RunView(keep_meshes=keep_meshes) if world is None else world
        self.lock = self.world.lock
        self.views: dict[str, RunView] = {'': self.world}

    @classmethod
    def of(cls, view: RunView | WorldView) -> WorldView:
        """Return `view` if it is a WorldView, else a WorldView of the lone iguana `view`."""
        return view if isinstance(view, WorldView) else cls(view)

    def character(self, name: str) -> RunView:
        """Return the view of character `name`, made empty (sharing the world's lock) the first time."""
        with self.lock:
            if name not in self.views:
                self.views[name] = RunView(keep_meshes=self.world.keep_meshes, lock=self.lock)
            return self.views[name]

    @property
    def names(self) -> list[str]:
        """Return the names of the characters seen so far (that have a mesh), sorted."""
        with self.lock:
            return sorted(name for name, view in self.views.items() if view.meshes)

    @property
    def end_time(self) -> float:
        """Return the latest simulated time anything was seen at, over every character, s (0 before anything)."""
        with self.lock:
            return max(view.end_time for view in self.views.values())

    @property
    def start_time(self) -> float:
        """Return the earliest simulated time of a mesh or state of a character that has one, s (0 before anything)."""
        with self.lock:
            started = [view.start_time for view in self.views.values() if view.meshes or view.states.n]
            return min(started, default=0.0)

    def frame(self, name: str, time: float | None = None) -> ViewFrame:
        """Return what to draw of character `name` at simulated time `time` s (None: its latest), with the goals."""
        with self.lock:
            view = self.views.get(name, self.world)
            frame = view.frame(time)
            if view is self.world:
                return frame
            goals = self.world.goals
            return replace(frame, goals=(goals[-1] if goals else None) if time is None else _latest(goals, frame.time),
                           terrain_version=self.world.terrain_version)

    def bodies(self, time: float | None = None) -> list[Body]:
        """Return every character that has a mesh, by name: its surface and root at `time` s (None: its latest)."""
        with self.lock:
            out = []
            for name in self.names:
                view = self.views[name]
                t = view.end_time if time is None else float(time)
                k = view.states.index_at(t)
                root = view.states.values[max(k, 0), :3].copy() if view.states.n else None
                out.append(Body(name, _latest(view.meshes, t), root))
            return out


def panel_lines(frame: ViewFrame) -> list[str]:
    """Return the panel's lines for `frame`: simulated time, realtime factor, clip, speed, foot slip."""
    def figure(value: float, text: str) -> str:
        return text.format(value) if math.isfinite(value) else '–'
    return [f'simulated time {frame.time:.2f} s',
            f'realtime factor {figure(frame.realtime_factor, "{:.2f}")}',
            f'clip {frame.clip or "–"}',
            f'speed {figure(frame.speed, "{:.2f} m/s")}',
            f'foot slip {figure(frame.slip * 100.0, "{:.1f} cm/s")}']


def terrain_hit(origin, direction, corners: np.ndarray) -> np.ndarray | None:
    """
    Return the nearest point `(3,)` where a ray meets a triangle of the TRIANGLE_LIST `corners (3*m, 3)`.

    The ray goes from `origin (3,)` along `direction (3,)`; the test is Moller-Trumbore. Returns None if the ray misses
    them all.
    """
    o, d = np.asarray(origin, float), np.asarray(direction, float)
    n = len(corners) - len(corners) % 3
    if n == 0 or not (np.isfinite(o).all() and np.isfinite(d).all()) or not d.any():
        return None
    a, b, c = corners[0:n:3], corners[1:n:3], corners[2:n:3]
    e1, e2 = b - a, c - a
    p = np.cross(d, e2)
    det = np.einsum('ij,ij->i', e1, p)
    ok = np.abs(det) > 1e-12
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    s = o - a
    u = np.einsum('ij,ij->i', s, p) * inv
    q = np.cross(s, e1)
    v = (q @ d) * inv
    dist = np.einsum('ij,ij->i', e2, q) * inv
    hit = ok & (u >= 0.0) & (v >= 0.0) & (u + v <= 1.0) & (dist > 0.0)
    if not hit.any():
        return None
    return o + d * float(dist[hit].min())


def identify_clip(rotations: np.ndarray, library: dict) -> str:
    """
    Return the name of the library clip a placed clip's rotations `(n_frames, n_bones, 4)` play; '' if none.

    The library maps name -> clip with `local_rotations (n_frames, n_bones, 4)`. A match has the same length and the
    same bone rotations in the last frame (the root's heading and the first frames' blend differ).
    """
    rot = np.asarray(rotations, float)
    best, best_error = '', CLIP_MATCH_TOLERANCE
    for name, clip in library.items():
        ref = np.asarray(clip.local_rotations, float)
        if ref.shape != rot.shape or rot.ndim != 3 or rot.shape[1] < 2:
            continue
        error = float(np.max(1.0 - np.abs(np.einsum('ij,ij->i', rot[-1, 1:], ref[-1, 1:]))))
        if error <= best_error:
            best, best_error = name, error
    return best


PUSH_SIDES = {'left': 'trunk_left', 'right': 'trunk_right'}
"""Flank pushed -> the model's tagged node group a push on that flank acts on."""


def flank_push(yaw: float, newtons: float, side: str) -> tuple[np.ndarray, str]:
    """
    Return (force `(3,)` N, region) of a sideways push of `newtons` N on the trunk's `side` flank.

    `side` is 'left' or 'right' and the body heads `yaw` rad; the left flank is pushed towards the body's right, as in
    Section VIII-D.
    """
    towards_right = np.array([math.sin(yaw), -math.cos(yaw), 0.0])
    return (1.0 if side == 'left' else -1.0) * float(newtons) * towards_right, PUSH_SIDES[side]
