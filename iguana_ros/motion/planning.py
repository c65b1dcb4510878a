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
A search over the motion graph (Section IV): which clips to play, several strides ahead, to reach a goal.

The graph walks of the motion-graph literature (Kovar, Gleicher and Pighin 2002; Lee et al. 2002): from the body's
measured planar pose (x, y, yaw of the root) and the clip it plays, a beam search expands every clip the graph lets
follow, `depth` strides deep, keeping the `beam_width` sequences of least cost-so-far plus estimated cost-to-go. A
stride moves the pose by what the soft body *achieves* with that clip (`motion.tracking`: level ground plus a gain per
unit of terrain gradient in the body frame), corrected online by the error of the strides it has played
(`MotionPlanner.observe`). The cost (`PlannerParams`) is time (clip durations, longer on a slope across the heading),
the way walked, a small cost per change of clip and a larger one for turning the other way, and height steps along a
stride. The cost-to-go (`heuristic`) is the quickest of turning in one gait and travelling in another, with the times
to change gait, the way along the turning arc and on, and the time to come to rest, turning to a requested heading
first; a gait cannot turn toward a goal inside its turning circle. A sequence ends once a stride brings the body to
rest at its last target (position within the planning radius and, if asked, heading within the planning tolerance); a
route's earlier waypoints are passed on the way. Re-planned at every stride end, the first clip of the best sequence
is played.

ROS-free; poses are planar `(x, y, yaw)` in the world frame, yaw being the root's heading (rad).
"""
from __future__ import annotations

from dataclasses import dataclass, field
import math

import numpy as np

from iguana_ros.constants import FRAME_RATE
from iguana_ros.geometry import planar_compose, planar_relative, wrap_angle
from iguana_ros.motion.clips import ANY_GAIT

STAND = 'stand'
"""The gait of a body at rest (the idle clip's; the body before its first clip)."""

FACING = 0.05
"""A goal within this bearing (rad) of a gait's direction of travel needs no turn."""


@dataclass(frozen=True)
class Target:
    """
    Where to go: a position (m), optionally a heading (rad), reached within `radius` m and `yaw_tolerance` rad.

    An intermediate waypoint of a route (`final` False) is passed through (its heading is not asked for).
    """

    xy: tuple
    yaw: float | None = None
    radius: float = 0.15
    yaw_tolerance: float = math.inf
    final: bool = True

    @property
    def wants_heading(self) -> bool:
        """Whether arrival asks for a heading (a final target with a yaw and a tolerance below pi)."""
        return self.final and self.yaw is not None and self.yaw_tolerance < math.pi

    def distance(self, xy: np.ndarray) -> float:
        """Return how far (m, horizontally) `xy (2,)` is from the target."""
        return float(math.hypot(xy[0] - self.xy[0], xy[1] - self.xy[1]))

    def heading_error(self, yaw: float) -> float:
        """Return |yaw - the target's heading| (rad, wrapped); 0 when no heading is asked for."""
        return abs(float(wrap_angle(yaw - self.yaw))) if self.wants_heading else 0.0

    def reached(self, pose: np.ndarray) -> bool:
        """Whether planar pose `(3,)` is within the radius and (if asked) the heading tolerance."""
        return self.distance(pose[:2]) <= self.radius and self.heading_error(pose[2]) <= self.yaw_tolerance


@dataclass(frozen=True)
class PlannerParams:
    """Settings of the motion-graph search (`MotionPlanner`)."""

    depth: int = 4
    """Strides searched ahead."""
    beam_width: int = 32
    """Sequences kept at each depth."""
    switch_cost: float = 0.05
    """Cost (s) of changing clip: between two near-equal sequences, keep the clip playing."""
    reverse_cost: float = 0.5
    """Cost (s) of turning the other way from the clip before (both turning by over 0.1 rad a stride): a goal about
    behind is as near turning left as right, and a body that turns less than predicted must not swing between them."""
    path_weight: float = 1.5
    """Cost (s per m) of the way walked, besides its time: between a quick wide turn on the move and turning on the
    spot first, take the shorter way unless it is much slower."""
    arrive_fraction: float = 0.6
    """A sequence counts as arriving within this fraction of the target's radius and yaw tolerance (the body
    does not end a stride exactly where predicted)."""
    cross_slope_cost: float = 1.0
    """Extra time per stride, as a fraction of its duration, per unit squared gradient across the heading."""
    step_height: float = 0.02
    """Height change (m) over a tenth of a stride's chord above which the terrain counts as a step."""
    step_cost: float = 20.0
    """Cost (s per m) of the step height above `step_height` along a stride."""
    slope_probe: float = 0.15
    """Half-width (m) of the body-scale finite differences that give the terrain gradient."""
    correction_rate: float = 0.5
    """Weight of the newest stride's error in a clip's online correction (exponential average)."""
    clearance: float = 0.6
    """Root-to-root distance (m) below which a stride passes too near another body (an iguana is 0.85 m long)."""
    obstacle_cost: float = 10.0
    """Cost (s) of a stride that passes through another body's predicted root, falling off quadratically to 0 at
    `clearance`: a detour of a few strides is cheaper than walking into another iguana."""
    obstacle_horizon: float = 3.0
    """Seconds ahead over which another body's motion is extrapolated at its current velocity (held after)."""
    obstacle_velocity_window: float = 0.5
    """Seconds over which another body's root must travel STANDING_SPEED on average to count as moving: a body
    pivoting on the spot sways at 0.1-0.3 m/s while going nowhere (it stands, see `way_round`)."""
    correction_limit: tuple = (0.1, 0.1, 0.8)
    """Largest |online correction| of a clip's stride motion: dx m, dy m, dyaw rad (enough to cancel any clip's motion:
    a turn on the spot whose tail catches on a step turns little or not at all)."""


@dataclass(frozen=True)
class GaitTable:
    """
    The gaits as the cost-to-go sees them.

    Per gait (index into `names`): speed m/s and direction of travel (rad, from the root's heading) of its straightest
    cyclic clip, turn rate rad/s and turning radius m of its fastest-turning cyclic clip, and `switch_time (K, K)` s,
    the least time from ending a clip in gait a to starting one in gait b.
    """

    names: tuple
    speed: np.ndarray
    direction: np.ndarray
    turn_rate: np.ndarray
    turn_radius: np.ndarray
    switch_time: np.ndarray


@dataclass(frozen=True)
class ClipTable:
    """
    The clips as the search sees them, arrays over the `names` (n clips).

    `duration (n,)` s; achieved stride motion on level ground `level (n, 3)` and its gain per unit gradient
    `slope_gain (n, 3, 2)`; `entry_gait`, `exit_gait (n,)` gait indices; `successors (n + 1, n)`: which clip may follow
    which (the last row: from rest, before any clip); `gaits` the per-gait figures of the cost-to-go; `carry` the
    fraction of the previous stride's excess heading change a stride carries over (`motion.tracking.LibraryTracking`).
    """

    names: tuple
    duration: np.ndarray
    level: np.ndarray
    slope_gain: np.ndarray
    entry_gait: np.ndarray
    exit_gait: np.ndarray
    successors: np.ndarray
    gaits: GaitTable
    carry: float = 0.0

    def index(self, name: str | None) -> int:
        """Row of `successors` for a body playing clip `name` (None: at rest, the last row)."""
        return len(self.names) if name is None else self.names.index(name)


def may_follow(first, second) -> bool:
    """Whether clip `second` may follow clip `first` (None: from rest): their gaits meet, or either is any gait."""
    exit_gait = STAND if first is None else getattr(first, 'exit_gait', ANY_GAIT)
    entry_gait = getattr(second, 'entry_gait', ANY_GAIT)
    return ANY_GAIT in (exit_gait, entry_gait) or exit_gait == entry_gait


def clip_table(clips: dict, tracking: dict | None = None, carry: float = 0.0) -> ClipTable:
    """
    Return the ClipTable of a clip library (name -> Clip).

    With its tracking figures (name -> ClipTracking; a clip without them moves as captured) and heading carry-over.
    """
    tracking = tracking or {}
    names = tuple(clips)
    entries = [getattr(clips[n], 'entry_gait', ANY_GAIT) for n in names]
    exits = [getattr(clips[n], 'exit_gait', ANY_GAIT) for n in names]
    gaits = tuple(dict.fromkeys([STAND] + entries + exits))
    duration = np.array([(len(clips[n].root_positions) - 1) / getattr(clips[n], 'frame_rate', FRAME_RATE)
                         for n in names])
    level = np.array([tracking[n].level if n in tracking else
                      (*clips[n].root_displacement[:2], clips[n].heading_change) for n in names], dtype=float)
    gain = np.array([tracking[n].slope_gain if n in tracking else np.zeros((3, 2)) for n in names], dtype=float)
    entry = np.array([gaits.index(g) for g in entries])
    exit_ = np.array([gaits.index(g) for g in exits])
    successors = np.array([[may_follow(None if a is None else clips[a], clips[b]) for b in names]
                           for a in names + (None,)], dtype=bool)
    cyclic = np.array([getattr(clips[n], 'cyclic', True) and entry[i] == exit_[i] for i, n in enumerate(names)])
    table = gait_table(gaits, duration, level, entry, exit_, cyclic)
    return ClipTable(names, duration, level, gain, entry, exit_, successors, table, float(carry))


def gait_table(gaits: tuple, duration: np.ndarray, level: np.ndarray, entry: np.ndarray, exit_: np.ndarray,
               cyclic: np.ndarray) -> GaitTable:
    """Return the GaitTable of `gaits` from the clips' durations, motions `(n, 3)`, gaits and cyclic flags `(n,)`."""
    k = len(gaits)
    speed, direction, turn_rate, turn_radius = np.zeros(k), np.zeros(k), np.zeros(k), np.zeros(k)
    for g in range(k):
        own = np.flatnonzero(cyclic & (entry == g))
        if not len(own):
            continue
        rate = np.abs(level[own, 2]) / duration[own]
        velocity = level[own, 0] / duration[own]
        straight = own[np.argmax(np.where(np.abs(level[own, 2]) < 0.15, velocity, -np.inf))]
        if level[straight, 0] > 1e-3:
            speed[g] = np.hypot(*level[straight, :2]) / duration[straight]
            direction[g] = math.atan2(level[straight, 1], level[straight, 0])
        turner = own[np.argmax(rate)]
        if rate.max() > 1e-3:
            turn_rate[g] = rate.max()
            turn_radius[g] = np.hypot(*level[turner, :2]) / abs(level[turner, 2])
    switch = np.full((k, k), np.inf)
    np.fill_diagonal(switch, 0.0)
    for j in np.flatnonzero(entry != exit_):
        switch[entry[j], exit_[j]] = min(switch[entry[j], exit_[j]], duration[j])
    for m in range(k):                                    # Floyd-Warshall over the gaits
        switch = np.minimum(switch, switch[:, m:m + 1] + switch[m:m + 1, :])
    return GaitTable(gaits, speed, direction, turn_rate, turn_radius, switch)


def rest_steps(table: ClipTable) -> np.ndarray:
    """
    Return the first clip `(n + 1,)` of the quickest way to rest from each row of `successors`.

    Rest is a clip ending in the stand gait; a row is a clip just played, or rest itself (then the idle clip); -1 where
    none leads there.
    """
    n, stand = len(table.names), table.gaits.names.index(STAND)
    to_rest = np.where(table.exit_gait == stand, 0.0, np.inf)       # s after a clip ends until the body rests
    for _ in range(n):
        via = np.where(table.successors[:n], table.duration[None, :] + to_rest[None, :], np.inf)
        to_rest = np.minimum(to_rest, via.min(axis=1))
    via = np.where(table.successors, table.duration[None, :] + to_rest[None, :], np.inf)
    return np.where(np.isfinite(via.min(axis=1)), via.argmin(axis=1), -1)


@dataclass(frozen=True)
class _CostToGo:
    """
    The gait figures the cost to go reads, for the gaits that turn (T) and those that travel (V).

    `direction`, `cos`, `sin`, `radius`, `seconds_per_rad` `(T,)`; `seconds_per_m (V,)`; least switch times
    `switch_into (K, T)` from every gait, `switch_between (T, V)`, `travel_to_turn (V, T)`, `turn_to_rest (T,)`,
    `travel_to_rest (V,)`.
    """

    direction: np.ndarray
    cos: np.ndarray
    sin: np.ndarray
    radius: np.ndarray
    seconds_per_rad: np.ndarray
    seconds_per_m: np.ndarray
    switch_into: np.ndarray
    switch_between: np.ndarray
    travel_to_turn: np.ndarray
    turn_to_rest: np.ndarray
    travel_to_rest: np.ndarray

    @classmethod
    def of(cls, g: GaitTable, rest: list) -> _CostToGo:
        """Return the figures of GaitTable `g` with resting gaits `rest` (indices)."""
        turning = np.flatnonzero((g.turn_rate > 0) | (g.speed > 0))   # a gait that cannot turn goes straight on
        travelling = np.flatnonzero(g.speed > 0)
        to_rest = g.switch_time[:, rest].min(axis=1) if rest else np.full(len(g.names), np.inf)
        rate = g.turn_rate[turning]
        per_rad = np.divide(1.0, rate, out=np.full(len(rate), np.inf), where=rate > 0)
        return cls(g.direction[turning], np.cos(g.direction[turning]), np.sin(g.direction[turning]),
                   g.turn_radius[turning], per_rad, 1.0 / g.speed[travelling],
                   g.switch_time[:, turning], g.switch_time[np.ix_(turning, travelling)],
                   g.switch_time[np.ix_(travelling, turning)], to_rest[turning], to_rest[travelling])


@dataclass
class Plan:
    """The best sequence found: its clips, the predicted planar poses `(k + 1, 3)`, its cost (s), whether it arrives."""

    clips: tuple
    poses: np.ndarray
    cost: float
    arrives: bool

    @property
    def first(self) -> str:
        """Return the clip to play now."""
        return self.clips[0]


@dataclass
class _Targets:
    """The route's targets as arrays `(t,)`, and the time (s) of the rest of the route after each."""

    xy: np.ndarray
    yaw: np.ndarray
    has_yaw: np.ndarray
    radius: np.ndarray
    tolerance: np.ndarray
    final: np.ndarray
    rest: np.ndarray


@dataclass(frozen=True)
class MovingObstacles:
    """Other bodies the search keeps clear of (`PlannerParams.clearance`): planar roots `(k, 2)` m, velocities m/s."""

    xy: np.ndarray
    velocity: np.ndarray

    def cost(self, start: np.ndarray, end: np.ndarray, t0: np.ndarray, t1: np.ndarray,
             params: PlannerParams) -> np.ndarray:
        """Return the cost `(m,)` s of strides from `start` to `end` `(m, 3)` over times `t0`..`t1` `(m,)` s."""
        if not len(self.xy) or not len(start):
            return np.zeros(len(start))
        u = np.linspace(0.0, 1.0, 5)[None, :, None]                                   # (1, S, 1)
        points = start[:, None, :2] + u * (end[:, None, :2] - start[:, None, :2])     # (m, S, 2)
        when = np.minimum(t0[:, None] + u[..., 0] * (t1 - t0)[:, None], params.obstacle_horizon)   # (m, S)
        others = self.xy[None, None] + when[..., None, None] * self.velocity[None, None]           # (m, S, k, 2)
        gap = np.linalg.norm(points[:, :, None, :] - others, axis=-1)                 # (m, S, k)
        near = np.clip(1.0 - gap / params.clearance, 0.0, 1.0) ** 2
        return params.obstacle_cost * near.max(axis=1).sum(axis=1)

    def way_round(self, xy: np.ndarray, target: np.ndarray, params: PlannerParams) -> np.ndarray | None:
        """
        Return a point `(2,)` m beside the nearest standing body that blocks the way from `xy` to `target`, or None.

        The search's horizon of a few strides cannot see round a body standing across the way (every stride toward it
        costs; standing still does not), so the point is a waypoint past its side. Every walker passes a standing body
        on the same hand (keeping it on its left, as traffic keeps right): walkers that met at a crossing and stopped
        then go round one another like a roundabout instead of each stepping to its own side into the next. A moving
        body is left to the search's costs.
        """
        if not len(self.xy):
            return None
        way = np.asarray(target, float) - xy
        length = float(np.hypot(*way))
        if length < 1e-6:
            return None
        ahead = (self.xy - xy) @ way / length
        side = (way[0] * (self.xy[:, 1] - xy[1]) - way[1] * (self.xy[:, 0] - xy[0])) / length
        standing = np.hypot(*self.velocity.T) < STANDING_SPEED
        blocking = standing & (ahead > 0.0) & (ahead < length) & (np.abs(side) < params.clearance)
        if not blocking.any():
            return None
        k = np.flatnonzero(blocking)[np.argmin(ahead[blocking])]
        right = np.array([way[1], -way[0]]) / length               # to the right of the way
        return self.xy[k] + right * (params.clearance + WAY_ROUND_MARGIN)


STANDING_SPEED = 0.05
"""Root speed (m/s) below which another body counts as standing (the planner plans a way round it)."""
WAY_ROUND_MARGIN = 0.15
"""Metres beyond the clearance at which the way round a standing body passes its root."""


@dataclass
class _Level:
    """One depth of the search: `(m,)` arrays of the sequences kept."""

    pose: np.ndarray          # (m, 3) planar pose at the end of the sequence
    turn: np.ndarray          # (m,) rad, heading change of its last stride
    clip: np.ndarray          # (m,) row of successors: the clip the sequence ends with
    target: np.ndarray        # (m,) index of the target it heads for
    cost: np.ndarray          # (m,) s so far
    estimate: np.ndarray      # (m,) s: cost so far plus cost to go
    parent: np.ndarray        # (m,) index into the previous level
    done: np.ndarray          # (m,) bool: it has reached its final target (not expanded further)
    time: np.ndarray          # (m,) s from now to the end of the sequence


@dataclass
class MotionPlanner:
    """Beam search over a ClipTable on a terrain (None: level ground), with online correction of the clips' motion."""

    table: ClipTable
    terrain: object = None
    params: PlannerParams = PlannerParams()
    correction: np.ndarray = field(default=None)
    last_turn: float = 0.0

    def __post_init__(self) -> None:
        """Start with no correction; note which clips bring the body to rest."""
        if self.correction is None:
            self.correction = np.zeros((len(self.table.names), 3))
        self._rest_gaits = [self.table.gaits.names.index(g) for g in (STAND, ANY_GAIT) if g in self.table.gaits.names]
        yaw = self.table.level[:, 2]
        self._turning = np.append(np.where(np.abs(yaw) > 0.1, np.sign(yaw), 0.0), 0.0)   # per successors row
        self._cost_to_go = _CostToGo.of(self.table.gaits, self._rest_gaits)
        self._resting = np.isin(self.table.exit_gait, self._rest_gaits)

    # ---------------------------------------------------------------------------------------------- prediction
    def gradient(self, pose: np.ndarray) -> np.ndarray:
        """Body-frame terrain gradients `(m, 2)` (uphill ahead, uphill to the left) at planar poses `(m, 3)`."""
        pose = np.atleast_2d(pose)
        if self.terrain is None or getattr(self.terrain, 'is_flat', False):
            return np.zeros((len(pose), 2))
        a = self.params.slope_probe
        offsets = np.array([[a, 0.0], [-a, 0.0], [0.0, a], [0.0, -a]])
        heights = self.terrain.height((pose[:, None, :2] + offsets[None]).reshape(-1, 2)).reshape(len(pose), 4)
        gx, gy = (heights[:, 0] - heights[:, 1]) / (2 * a), (heights[:, 2] - heights[:, 3]) / (2 * a)
        c, s = np.cos(pose[:, 2]), np.sin(pose[:, 2])
        return np.stack([c * gx + s * gy, -s * gx + c * gy], axis=-1)

    def motion(self, clips: np.ndarray, gradient: np.ndarray, turn: np.ndarray, corrected: bool = True) -> np.ndarray:
        """
        Return the predicted stride motions `(m, 3)` of clip indices `(m,)`.

        Started at body-frame gradients `(m, 2)` after strides that turned by `turn (m,)` rad (the carry-over), with the
        online correction unless `corrected` is False.
        """
        steady = self.table.level[clips] + np.einsum('mij,mj->mi', self.table.slope_gain[clips], gradient)
        if corrected:
            steady = steady + self.correction[clips]
        steady[:, 2] += self.table.carry * (turn - steady[:, 2])
        return steady

    def predict(self, name: str, pose: np.ndarray) -> np.ndarray:
        """Planar pose `(3,)` after playing clip `name` from planar pose `(3,)` (after the last stride observed)."""
        j = np.array([self.table.index(name)])
        return planar_compose(pose, self.motion(j, self.gradient(pose), np.array([self.last_turn]))[0])

    def observe(self, name: str, start: np.ndarray, end: np.ndarray) -> None:
        """Update clip `name`'s online correction from a stride it played from planar pose `start` to `end` `(3,)`."""
        j = np.array([self.table.index(name)])
        model = self.motion(j, self.gradient(start), np.array([self.last_turn]), corrected=False)[0]
        achieved = planar_relative(start, end)
        rate, limit = self.params.correction_rate, np.asarray(self.params.correction_limit)
        self.correction[j[0]] = np.clip((1.0 - rate) * self.correction[j[0]] + rate * (achieved - model), -limit, limit)
        self.last_turn = float(achieved[2])

    def load_kernels(self) -> None:
        """Search once from rest toward a goal 1 m ahead, changing nothing: the terrain's compiled lookups load."""
        self.plan(np.zeros(3), None, [Target((1.0, 0.0))])

    # ------------------------------------------------------------------------------------------------ search
    def plan(self, pose: np.ndarray, current: str | None, targets: list, allowed: np.ndarray | None = None,
             obstacles: MovingObstacles | None = None) -> Plan:
        """
        Return the best clip sequence from planar `pose (3,)` playing `current` (None: at rest) through `targets`.

        The targets are the route's remaining ones in order (the last is final); `allowed (n,)` (optional) masks the
        clips the search may use; strides near the `obstacles` (other bodies, optional) cost more. At each depth the
        `beam_width` open sequences of least estimate are kept, and the cheapest one that arrives; the plan is the
        cheapest arrival found or, if it costs more, the deepest open sequence of least estimate.
        """
        table, p = self.table, self.params
        goals = self._targets(targets)
        allowed = np.ones(len(table.names), bool) if allowed is None else np.asarray(allowed, bool)
        turn = self.last_turn if current is not None else 0.0
        root = _Level(np.asarray(pose, float)[None, :3], np.array([turn]), np.array([table.index(current)]),
                      np.zeros(1, int), np.zeros(1), np.zeros(1), np.zeros(1, int), np.zeros(1, bool), np.zeros(1))
        levels, best = [root], (np.inf, None)
        for depth in range(1, p.depth + 1):
            child, arrived = self._expand(levels[-1], goals, allowed, obstacles)
            if not len(child.cost):
                break
            keep = _smallest(np.where(arrived, np.inf, child.estimate), p.beam_width)
            if arrived.any():
                k = np.flatnonzero(arrived)[np.argmin(child.cost[arrived])]
                keep = np.append(keep, k)
                if child.cost[k] < best[0]:
                    best = (float(child.cost[k]), (depth, len(keep) - 1, True))
            levels.append(_take(child, keep))
        last = levels[-1]
        open_estimate = np.where(last.done, np.inf, last.estimate)
        if len(levels) > 1 and open_estimate.min() < best[0]:
            best = (float(open_estimate.min()), (len(levels) - 1, int(np.argmin(open_estimate)), False))
        return self._backtrack(levels, best, pose)

    def _targets(self, targets: list) -> _Targets:
        """Arrays of the targets, and after each the time of the rest of the route at the fastest gait."""
        xy = np.array([t.xy for t in targets], dtype=float).reshape(-1, 2)
        legs = np.linalg.norm(np.diff(xy, axis=0), axis=1) / max(self.table.gaits.speed.max(), 1e-3)
        rest = np.concatenate([np.cumsum(legs[::-1])[::-1], [0.0]]) if len(xy) > 1 else np.zeros(len(xy))
        return _Targets(xy=xy, yaw=np.array([t.yaw if t.wants_heading else 0.0 for t in targets]),
                        has_yaw=np.array([t.wants_heading for t in targets]),
                        radius=np.array([t.radius for t in targets]) * self.params.arrive_fraction,
                        tolerance=np.array([min(t.yaw_tolerance, math.pi) for t in targets])
                        * self.params.arrive_fraction,
                        final=np.array([t.final for t in targets]), rest=rest)

    def _expand(self, level: _Level, goals: _Targets, allowed: np.ndarray,
                obstacles: MovingObstacles | None = None) -> tuple:
        """Return the children of every open sequence of `level` (one per clip that may follow), and which arrive."""
        table, p = self.table, self.params
        parents, clips = np.nonzero(table.successors[level.clip] & allowed[None, :] & ~level.done[:, None])
        start = level.pose[parents]
        grad = self.gradient(start)
        motion = self.motion(clips, grad, level.turn[parents])
        end = planar_compose(start, motion)
        cost = (level.cost[parents] + table.duration[clips] * (1.0 + p.cross_slope_cost * grad[:, 1] ** 2)
                + p.switch_cost * (clips != level.clip[parents]) + self._step_cost(start, end)
                + p.path_weight * np.hypot(*(end[:, :2] - start[:, :2]).T)
                + p.reverse_cost * (self._turning[level.clip[parents]] * self._turning[clips] < 0))
        t0 = level.time[parents]
        t1 = t0 + table.duration[clips]
        if obstacles is not None:
            cost = cost + obstacles.cost(start, end, t0, t1, p)
        target = level.target[parents].copy()
        hit = _arrives(start, end, target, goals, self._resting[clips])
        arrived = hit & goals.final[target]
        target[hit & ~arrived] += 1                          # a waypoint passed: head for the next target
        estimate = cost + np.where(arrived, 0.0, self.heuristic(end, table.exit_gait[clips], target, goals))
        return _Level(end, motion[:, 2], clips, target, cost, estimate, parents, arrived, t1), arrived

    def _step_cost(self, start: np.ndarray, end: np.ndarray) -> np.ndarray:
        """Cost `(m,)` s of the height steps along each stride's chord (none on level or unknown ground)."""
        if self.terrain is None or getattr(self.terrain, 'is_flat', False) or not len(start):
            return np.zeros(len(start))
        u = np.linspace(0.0, 1.0, 11)
        points = start[:, None, :2] + u[None, :, None] * (end[:, None, :2] - start[:, None, :2])
        heights = self.terrain.height(points.reshape(-1, 2)).reshape(len(start), len(u))
        step = np.abs(np.diff(heights, axis=1)).max(axis=1)
        return self.params.step_cost * np.maximum(step - self.params.step_height, 0.0)

    def heuristic(self, pose: np.ndarray, gait: np.ndarray, target: np.ndarray, goals: _Targets) -> np.ndarray:
        """
        Estimated time (s) `(m,)` from planar poses `(m, 3)` ending a clip in gait `(m,)` to the end of the route.

        For each pair of gaits (turn in the first, travel in the second): the time to change into the first, turn
        toward the target at its turn rate (impossible for a target inside its turning circle) along an arc of its
        turning radius, change into the second and travel the distance left from the arc's end at its speed, and at
        a final target come to rest (`_finish`: turning to a heading asked there first); the least of them, plus the
        rest of the route.
        """
        t, c = target, self._cost_to_go
        if not len(pose):
            return np.zeros(0)
        goal = goals.xy[t]
        delta = goal - pose[:, :2]
        dist = np.hypot(delta[:, 0], delta[:, 1])
        bearing = np.arctan2(delta[:, 1], delta[:, 0])
        cy, sy = np.cos(pose[:, 2]), np.sin(pose[:, 2])
        lx, ly = cy * delta[:, 0] + sy * delta[:, 1], -sy * delta[:, 0] + cy * delta[:, 1]     # goal in the body frame
        radius = goals.radius[t][:, None]
        signed = wrap_angle(bearing[:, None] - pose[:, 2:3] - c.direction)         # (m, T): to turn in turning gait
        beta = np.abs(signed)
        side = np.where(ly >= 0.0, 1.0, -1.0)[:, None]
        inside = (np.hypot(lx[:, None], ly[:, None] - side * c.radius) < c.radius) & (c.radius > radius)
        # turning by beta in a gait moves the body along an arc of its turning radius; from the arc's end, the rest
        ahead = lx[:, None] * c.cos + ly[:, None] * c.sin
        across = ly[:, None] * c.cos - lx[:, None] * c.sin
        left = np.maximum(np.hypot(ahead - c.radius * np.sin(beta),
                                   across - np.sign(signed) * c.radius * (1.0 - np.cos(beta))) - radius, 0.0)
        with np.errstate(invalid='ignore'):                          # 0 rad at inf s per rad: facing, no turn
            turn = np.where(inside, np.inf, np.where(beta < FACING, 0.0, beta * c.seconds_per_rad))
        way = self.params.path_weight * (c.radius * beta + left)                      # (m, T): cost of the way
        there = dist <= goals.radius[t]
        turn[there], left[there], way[there] = 0.0, 0.0, 0.0
        total = (c.switch_into[gait][:, :, None] + (turn + way)[:, :, None] + c.switch_between[None]
                 + left[:, :, None] * c.seconds_per_m[None, None, :])          # (m, turning gait, travelling gait)
        finish = self._finish(np.abs(wrap_angle(goals.yaw[t] - np.where(there, pose[:, 2], bearing))),
                              goals.has_yaw[t], goals.final[t])            # (m, travelling gait)
        h = (total + finish[:, None, :]).reshape(len(pose), -1).min(axis=1)
        return np.where(np.isfinite(h), h, 1e6) + goals.rest[t]

    def _finish(self, yaw_error: np.ndarray, has_yaw: np.ndarray, final: np.ndarray) -> np.ndarray:
        """
        Return the time (s) `(m, V)` from travelling in each travelling gait to resting at a final target.

        It is 0 at a waypoint. At a final target the body changes gait to one that turns, turns by `yaw_error (m,)` rad
        if a heading is asked (`has_yaw (m,)`), and changes to a resting gait.
        """
        c = self._cost_to_go
        with np.errstate(invalid='ignore'):
            turn = np.where(yaw_error[:, None] > 0.0, yaw_error[:, None] * c.seconds_per_rad, 0.0)    # (m, T)
        via = (c.travel_to_turn[None] + turn[:, None, :] + c.turn_to_rest[None, None, :]).min(axis=2)   # (m, V)
        finish = np.where(has_yaw[:, None], via, c.travel_to_rest[None, :])
        return np.where(final[:, None], finish, 0.0)

    def _backtrack(self, levels: list, best: tuple, pose: np.ndarray) -> Plan:
        """Return the Plan of the best sequence found (`best`: cost, (depth, index, arrives)); an empty one if none."""
        if best[1] is None:
            return Plan((), np.asarray(pose, float)[None, :3], math.inf, False)
        depth, index, arrives = best[1]
        clips, poses = [], []
        while depth > 0:
            level = levels[depth]
            clips.append(self.table.names[level.clip[index]])
            poses.append(level.pose[index])
            index, depth = level.parent[index], depth - 1
        poses.append(np.asarray(pose, float)[:3])
        return Plan(tuple(clips[::-1]), np.array(poses[::-1]), float(best[0]), bool(arrives))


def _arrives(start: np.ndarray, end: np.ndarray, target: np.ndarray, goals: _Targets,
             resting: np.ndarray) -> np.ndarray:
    """
    Whether each stride from `start` to `end` `(m, 3)` reaches its target `(m,)` (an index into `goals`).

    A waypoint is passed where the stride's chord comes within the planning radius; the final target is reached by a
    stride that brings the body to rest (`resting (m,)`) within the radius and, if one is asked, the heading tolerance.
    """
    t = target
    a, b, goal = start[:, :2], end[:, :2], goals.xy[t]
    ab = b - a
    length2 = np.einsum('mi,mi->m', ab, ab)
    u = np.clip(np.einsum('mi,mi->m', goal - a, ab) / np.where(length2 > 0, length2, 1.0), 0.0, 1.0)
    closest = np.hypot(*(a + u[:, None] * ab - goal).T)
    at_end = np.hypot(*(b - goal).T)
    heading = ~goals.has_yaw[t] | (np.abs(wrap_angle(end[:, 2] - goals.yaw[t])) <= goals.tolerance[t])
    return np.where(goals.final[t], (at_end <= goals.radius[t]) & heading & resting, closest <= goals.radius[t])


def _smallest(values: np.ndarray, k: int) -> np.ndarray:
    """Return the indices of the `k` smallest finite `values`, in increasing order (ties by index)."""
    finite = np.flatnonzero(np.isfinite(values))
    order = finite[np.lexsort((finite, values[finite]))]
    return order[:k]


def _take(level: _Level, keep: np.ndarray) -> _Level:
    """Return the sequences `keep` of `level`."""
    return _Level(level.pose[keep], level.turn[keep], level.clip[keep], level.target[keep], level.cost[keep],
                  level.estimate[keep], level.parent[keep], level.done[keep], level.time[keep])
