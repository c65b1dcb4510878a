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
Locomotion metrics of a run (paper Sections VIII-IX).

Goal reached, path, speed, foot slip, lateral bending, inter-joint distance variation, falls and getting stuck. Plain
arrays in, plain numbers out.
"""
from __future__ import annotations

from collections import deque
from dataclasses import asdict, dataclass

import numpy as np

from iguana_ros.constants import FALL_TILT
from iguana_ros.geometry import rigid_fit

STUCK_WINDOW = 3.0
"""A goal-seeking iguana that moves less than STUCK_PROGRESS in this many seconds is stuck, s."""

STUCK_PROGRESS = 0.05
"""Minimum progress toward the goal over STUCK_WINDOW, m."""

SWING_CLEARANCE = 0.01
"""Mid-swing height of a foot's lowest sole node above the terrain that counts as a clear swing, m."""

N_FEET = 4
"""Feet in every per-foot figure, in the order fl, fr, hl, hr."""


@dataclass(frozen=True)
class LocomotionMetrics:
    """Summary of one run; lengths in m, times in s, angles in deg."""

    reached_goal: bool
    time_to_goal: float
    final_goal_distance: float
    path_length: float
    mean_forward_speed: float
    foot_slip_per_stride: float
    lateral_bending_amplitude_deg: float
    inter_joint_distance_variation: float
    fell: bool
    stuck: bool
    strides: int
    gait: GaitMetrics | None = None
    steering: SteeringMetrics | None = None

    def as_dict(self) -> dict:
        """
        Plain dict for JSON and the summary line (NaN, e.g. no arrival time, becomes None).

        The gait and steering figures are flattened in (per-foot figures as lists in the order fl, fr, hl, hr).
        """
        values = asdict(self)
        gait = values.pop('gait') or {}
        steering = values.pop('steering') or {}
        return {k: _plain(v) for k, v in {**values, **gait, **steering}.items()}


@dataclass(frozen=True)
class SteeringMetrics:
    """
    How a run steered to its goal.

    `straight_distance` (m, from the start along the route's waypoints to the edge of the goal's radius), `path_ratio`
    (the length of the root's stride-averaged path until it first came within the goal's radius after passing the
    waypoints, or of the whole run, over it: `stride_path_length`; turning to a heading there is not way) and
    `path_ratio_frames` (the same of the root's frame-by-frame path, sway included), the heading error at arrival
    (within radius and tolerance) and at the end (deg; NaN where no heading is asked or the goal was not reached), the
    stride ends before arrival spent circling (`circling_strides`, two full turns without getting closer) or making no
    progress (`stuck_strides`, `no_progress`), and for a route its waypoints, how many were passed in order and
    whether all were.
    """

    straight_distance: float
    path_ratio: float
    path_ratio_frames: float
    heading_error_at_arrival_deg: float
    final_heading_error_deg: float
    circling_strides: int
    stuck_strides: int
    waypoints: int = 0
    waypoints_in_order: int = 0
    route_completed: bool = False


@dataclass(frozen=True)
class GaitMetrics:
    """
    Per-foot gait figures of a run against its reference motion (feet in the order fl, fr, hl, hr).

    stance_fraction, reference_stance_fraction: fraction of frames a foot touches the ground (simulated) and
    is in stance in the clip; swing_clearance: median over the foot's reference swings of the lowest sole
    node's mid-swing height above the terrain (m); swings_clear_fraction: fraction of all swings whose
    mid-swing clearance is at least SWING_CLEARANCE; slip_per_foot_per_stride: a foot's horizontal travel
    while in contact, per stride (m); speed_fraction: forward speed while walking as a fraction of the
    clips' speed; shape_error_median, shape_error_p90: RMS node distance (m) between the body and the
    reference mesh after a rigid fit, over frames; foot_height_error: RMS (m) of the simulated minus the
    reference foot height above the terrain.
    """

    stance_fraction: tuple
    reference_stance_fraction: tuple
    swing_clearance: tuple
    swings_clear_fraction: float
    swings: int
    slip_per_foot_per_stride: tuple
    speed_fraction: float
    shape_error_median: float
    shape_error_p90: float
    foot_height_error: tuple


def _plain(v):
    """JSON-ready value: floats (NaN/Inf -> None), lists of them, everything else as is."""
    if isinstance(v, (tuple, list, np.ndarray)):
        return [_plain(x) for x in v]
    if isinstance(v, (float, np.floating)):
        return float(v) if np.isfinite(v) else None
    if isinstance(v, np.integer):
        return int(v)
    if isinstance(v, np.bool_):
        return bool(v)
    return v


def path_length(root_xy: np.ndarray) -> float:
    """Horizontal path length of the root `(n_frames, 2)`, m."""
    return float(np.sum(np.linalg.norm(np.diff(root_xy, axis=0), axis=1)))


STRIDE_FRAMES = 20
"""Frames of the moving average that takes a stride's sway out of a root path (a trot stride at 30 Hz)."""


def stride_path_length(root_xy: np.ndarray, window: int = STRIDE_FRAMES) -> float:
    """
    Return the length (m) of the root's path `(n_frames, 2)` averaged over `window` frames (a stride).

    The pelvis sways sideways and, turning on the spot, circles its pivot within every stride; the average keeps the
    way the body went (the ends are held at the first and last positions, so the average starts and ends there).
    """
    root_xy = np.asarray(root_xy, dtype=float)
    if len(root_xy) < 2:
        return 0.0
    half = window // 2
    padded = np.concatenate([np.repeat(root_xy[:1], half, axis=0), root_xy, np.repeat(root_xy[-1:], half, axis=0)])
    kernel = np.ones(2 * half + 1) / (2 * half + 1)
    smooth = np.stack([np.convolve(padded[:, k], kernel, mode='valid') for k in range(2)], axis=1)
    return path_length(np.concatenate([root_xy[:1], smooth, root_xy[-1:]]))


def heading_errors(yaw: np.ndarray, goal_yaw) -> np.ndarray:
    """|yaw - goal_yaw| `(n,)` rad (wrapped) of root headings `(n,)` to a heading (or headings `(n,)`); 0 for None."""
    yaw = np.asarray(yaw, dtype=float)
    if goal_yaw is None:
        return np.zeros(yaw.shape)
    return np.abs((yaw - goal_yaw + np.pi) % (2.0 * np.pi) - np.pi)


def goal_arrival(times: np.ndarray, root_xy: np.ndarray, goal_xy: np.ndarray, radius: float,
                 yaw: np.ndarray | None = None, goal_yaw: float | None = None,
                 yaw_tolerance: float = np.inf) -> tuple[bool, float, float]:
    """
    (reached, first time within `radius`, final distance) for root `(n_frames, 2)` and goal `(2,)`.

    With a goal heading `goal_yaw` (rad) and root headings `yaw (n_frames,)`, arrival also needs the heading within
    `yaw_tolerance` rad (as nav2's goal checker).
    """
    dist = np.linalg.norm(root_xy - np.asarray(goal_xy)[None, :2], axis=1)
    ok = dist <= radius
    if goal_yaw is not None and yaw is not None and yaw_tolerance < np.pi:
        ok &= heading_errors(yaw, goal_yaw) <= yaw_tolerance
    inside = np.flatnonzero(ok)
    reached = inside.size > 0
    return reached, float(times[inside[0]]) if reached else float('nan'), float(dist[-1])


def mean_forward_speed(times: np.ndarray, root_xy: np.ndarray, yaw: np.ndarray) -> float:
    """Mean root speed along the body heading, m/s."""
    if len(times) < 2:
        return 0.0
    vel = np.diff(root_xy, axis=0) / np.diff(times)[:, None]
    mid_yaw = yaw[:-1]
    forward = vel[:, 0] * np.cos(mid_yaw) + vel[:, 1] * np.sin(mid_yaw)
    return float(np.mean(forward))


def foot_slip(foot_xy: np.ndarray, foot_contact: np.ndarray, n_strides: int) -> float:
    """
    Horizontal travel of feet while in contact, per stride, summed over feet, m.

    `foot_xy (n_frames, n_feet, 2)` foot centroids, `foot_contact (n_frames, n_feet)` bool.
    """
    return float(np.sum(slip_per_foot(foot_xy, foot_contact, n_strides)))


def slip_per_foot(foot_xy: np.ndarray, foot_contact: np.ndarray, n_strides: int) -> np.ndarray:
    """
    Return the horizontal travel `(n_feet,)` m per stride of each foot while it touches the ground.

    The travel is that of each foot centroid `(n_frames, n_feet, 2)` between consecutive frames in which it touches the
    ground (`foot_contact (n_frames, n_feet)`).
    """
    step = np.linalg.norm(np.diff(foot_xy, axis=0), axis=2)
    held = foot_contact[1:] & foot_contact[:-1]
    return np.sum(step * held, axis=0) / max(n_strides, 1)


def stance_fractions(foot_contact: np.ndarray) -> np.ndarray:
    """Fraction of frames `(n_feet,)` in which each foot touches the ground, from `(n_frames, n_feet)` bool."""
    return np.mean(foot_contact, axis=0) if len(foot_contact) else np.zeros(foot_contact.shape[1])


def swing_intervals(reference_contact: np.ndarray) -> list[list[tuple[int, int]]]:
    """
    Return per foot the (first, last) frame of every swing of `reference_contact (n_frames, n_feet)`.

    Stance is True in `reference_contact`; only swings that start and end inside the run count.
    """
    out = []
    for foot in range(reference_contact.shape[1]):
        swing = ~np.asarray(reference_contact[:, foot], bool)
        edges = np.diff(np.concatenate([[0], swing.astype(np.int8), [0]]))
        starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
        out.append([(int(a), int(b)) for a, b in zip(starts, ends) if a > 0 and b < len(swing) - 1])
    return out


def mid_swing_clearances(foot_height: np.ndarray, reference_contact: np.ndarray) -> list[np.ndarray]:
    """
    Per foot, the clearance (m) of each reference swing.

    The highest `foot_height (n_frames, n_feet)` (lowest sole node above the terrain) over the middle half of the swing.
    """
    out = []
    for foot, swings in enumerate(swing_intervals(reference_contact)):
        values = []
        for a, b in swings:
            quarter = (b - a + 1) // 4
            values.append(float(np.max(foot_height[a + quarter:b - quarter + 1, foot])))
        out.append(np.array(values))
    return out


def speed_fraction(progress: np.ndarray, reference: np.ndarray) -> float:
    """
    Return the body's total progress along the strides' clip displacements as a fraction of those displacements.

    `progress` `(n_strides,)` m is the body's progress along each stride's clip displacement and `reference`
    `(n_strides,)` m the clips' displacements; NaN when no stride moves.
    """
    total = float(np.sum(reference))
    return float(np.sum(progress) / total) if total > 1e-9 else float('nan')


def rigid_fit_errors(nodes: np.ndarray, reference: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """
    Return the RMS distance `(n_frames,)` m between nodes and the reference after a rigid fit, frame by frame.

    Nodes and reference are `(n_frames, n, 3)`; in each frame the reference is fitted onto the nodes by the best rigid
    (weighted) fit.
    """
    w = weights / weights.sum()
    out = np.empty(len(nodes))
    for f in range(len(nodes)):
        rot, trans = rigid_fit(reference[f], nodes[f], weights)
        residual = nodes[f] - (reference[f] @ rot.T + trans)
        out[f] = np.sqrt(np.sum(w * np.einsum('nc,nc->n', residual, residual)))
    return out


def gait_metrics(foot_contact: np.ndarray, reference_contact: np.ndarray, foot_height: np.ndarray,
                 reference_foot_height: np.ndarray, foot_xy: np.ndarray, n_strides: int,
                 stride_progress: np.ndarray, stride_reference: np.ndarray,
                 shape_errors: np.ndarray) -> GaitMetrics:
    """
    `GaitMetrics` from per-frame arrays.

    Contacts, reference stance flags, foot heights above the terrain and their reference `(n_frames, 4)`, foot centroids
    `(n_frames, 4, 2)`; per walking stride the body's progress and the clip's displacement `(n_strides,)` m; rigid-fit
    shape errors `(n_frames,)` m.
    """
    clearances = mid_swing_clearances(foot_height, reference_contact)
    every = np.concatenate(clearances) if clearances else np.zeros(0)
    height_error = np.sqrt(np.mean((foot_height - reference_foot_height) ** 2, axis=0)) if len(foot_height) \
        else np.full(N_FEET, np.nan)
    return GaitMetrics(
        stance_fraction=tuple(stance_fractions(foot_contact)),
        reference_stance_fraction=tuple(stance_fractions(reference_contact)),
        swing_clearance=tuple(float(np.median(c)) if len(c) else float('nan') for c in clearances),
        swings_clear_fraction=float(np.mean(every >= SWING_CLEARANCE)) if len(every) else float('nan'),
        swings=int(len(every)),
        slip_per_foot_per_stride=tuple(slip_per_foot(foot_xy, foot_contact, n_strides)),
        speed_fraction=speed_fraction(stride_progress, stride_reference),
        shape_error_median=float(np.median(shape_errors)) if len(shape_errors) else float('nan'),
        shape_error_p90=float(np.percentile(shape_errors, 90)) if len(shape_errors) else float('nan'),
        foot_height_error=tuple(height_error))


BEARING_WEIGHT = 0.25
"""Metres of progress a radian of turning toward the goal counts as (`remaining_way`)."""

PROGRESS_WINDOW = 8
"""Stride ends over which the remaining way to a goal must shrink (the planner's stuck check, `stuck_strides`)."""

PROGRESS_MIN = 0.08
"""Least shrinking (m) of the remaining way to a goal over PROGRESS_WINDOW strides."""

CIRCLING_TURN = 4.0 * np.pi
"""Net heading change (rad) of a circle counted as circling: two full turns without getting closer."""


def remaining_way(xy: np.ndarray, yaw: np.ndarray, goal_xy: np.ndarray, radius: float,
                  goal_yaw: float | None = None, bearing_weight: float = BEARING_WEIGHT) -> np.ndarray:
    """
    Return how far root poses (`xy (n, 2)`, `yaw (n,)`) are from a goal `(2,)`, m.

    The distance plus `bearing_weight` per rad of bearing away from it; within `radius`, the heading error left (rad, 0
    if no `goal_yaw`) less 1.
    """
    xy, yaw = np.atleast_2d(np.asarray(xy, dtype=float)), np.atleast_1d(np.asarray(yaw, dtype=float))
    delta = np.asarray(goal_xy, dtype=float)[None, :2] - xy
    distance = np.hypot(delta[:, 0], delta[:, 1])
    bearing = heading_errors(yaw, np.arctan2(delta[:, 1], delta[:, 0])) if len(yaw) else np.zeros(0)
    return np.where(distance <= radius, heading_errors(yaw, goal_yaw) - 1.0, distance + bearing_weight * bearing)


class ProgressWindow:
    """
    The no-progress rule, stride end by stride end.

    A stride end made no progress when the least remaining way over its last `window` stride ends is no smaller by
    `progress` than the least before them (none before: progress). Constant memory: the stride ends before the window
    are kept as their least value.
    """

    def __init__(self, window: int, progress: float) -> None:
        """Start with no stride end seen."""
        self.window, self.progress = int(window), float(progress)
        self.recent: deque = deque(maxlen=self.window)
        self.before = np.inf

    def add(self, measure: float) -> bool:
        """Take the next stride end's remaining way; return whether it made no progress."""
        if len(self.recent) == self.window:
            self.before = min(self.before, self.recent[0])
        self.recent.append(float(measure))
        return bool(np.isfinite(self.before) and min(self.recent) >= self.before - self.progress)

    @property
    def least(self) -> float:
        """Return the least remaining way seen."""
        return min(self.before, min(self.recent, default=np.inf))


def no_progress(measure: np.ndarray, window: int, progress: float) -> np.ndarray:
    """Return flags `(s,)`: whether each stride end of `measure (s,)` made no progress (`ProgressWindow`)."""
    rule = ProgressWindow(window, progress)
    return np.array([rule.add(m) for m in np.asarray(measure, dtype=float)], dtype=bool)


def circling_strides(yaw: np.ndarray, distance: np.ndarray, progress: float = 0.05) -> int:
    """
    Count the stride ends spent circling.

    Of stride ends `(s,)` (root headings rad, goal distances m), those inside a stretch that turned CIRCLING_TURN net
    without getting `progress` m closer to the goal.
    """
    turned = np.unwrap(np.asarray(yaw, dtype=float))
    flagged = np.zeros(len(turned), bool)
    for a in range(len(turned)):
        later = np.flatnonzero(np.abs(turned[a + 1:] - turned[a]) >= CIRCLING_TURN)
        if later.size and distance[a + 1 + later[0]] >= distance[a] - progress:
            flagged[a:a + 2 + later[0]] = True
    return int(flagged.sum())


def route_progress(root_xy: np.ndarray, waypoints: np.ndarray, radius: float) -> np.ndarray:
    """
    Return the index `(n,)` of the waypoint `(k, 2)` each root position `(n, 2)` heads for.

    Waypoints count as passed in order, each once the root comes within `radius` of it after passing the ones before
    (k: all passed).
    """
    index, out = 0, np.empty(len(root_xy), dtype=int)
    for f, xy in enumerate(np.asarray(root_xy, dtype=float)):
        while index < len(waypoints) and np.hypot(*(xy - waypoints[index])) <= radius:
            index += 1
        out[f] = index
    return out


def route_arrival(times: np.ndarray, root_xy: np.ndarray, waypoints: np.ndarray, radius: float,
                  yaw: np.ndarray | None = None, goal_yaw: float | None = None,
                  yaw_tolerance: float = np.inf) -> tuple[bool, float, float]:
    """
    (reached, first time, final distance) of the end of a route `waypoints (k, 2)` (a goal: k = 1), as `goal_arrival`.

    A frame counts only once the root has passed the waypoints before the last in order (`route_progress`).
    """
    waypoints = np.atleast_2d(np.asarray(waypoints, dtype=float))
    if len(waypoints) == 1:
        return goal_arrival(times, root_xy, waypoints[0], radius, yaw, goal_yaw, yaw_tolerance)
    ready = route_progress(root_xy, waypoints[:-1], radius) == len(waypoints) - 1
    final = float(np.hypot(*(root_xy[-1] - waypoints[-1]))) if len(times) else float('nan')
    if not ready.any():
        return False, float('nan'), final
    reached, first, _ = goal_arrival(times[ready], root_xy[ready], waypoints[-1], radius,
                                     None if yaw is None else yaw[ready], goal_yaw, yaw_tolerance)
    return reached, first, final


def steering_metrics(times: np.ndarray, root_xy: np.ndarray, yaw: np.ndarray, waypoints: np.ndarray,
                     goal_yaw: float | None, radius: float, yaw_tolerance: float,
                     stride_frames: np.ndarray) -> SteeringMetrics:
    """
    Return the SteeringMetrics of a run.

    Root positions `(n, 2)` and headings `(n,)` at `times (n,)` walking to `waypoints (k, 2)` (a goal: k = 1) reached
    within `radius` m and, for `goal_yaw` (rad, None: any), `yaw_tolerance` rad; `stride_frames (s,)` the frames at
    which strides began.
    """
    waypoints = np.atleast_2d(np.asarray(waypoints, dtype=float))
    legs = np.concatenate([root_xy[:1], waypoints]) if len(root_xy) else waypoints
    straight = max(float(np.sum(np.linalg.norm(np.diff(legs, axis=0), axis=1))) - radius, 0.0)
    heading = goal_yaw if yaw_tolerance < np.pi else None
    reached, t_goal, _ = route_arrival(times, root_xy, waypoints, radius, yaw, heading, yaw_tolerance)
    arrival = int(np.searchsorted(times, t_goal)) if reached else len(times)
    there, t_there, _ = route_arrival(times, root_xy, waypoints, radius)          # the way: until at the goal
    way_end = int(np.searchsorted(times, t_there)) if there else len(times)
    errors = np.degrees(heading_errors(yaw, goal_yaw)) if heading is not None else np.full(len(times), np.nan)
    current = np.minimum(route_progress(root_xy, waypoints[:-1], radius), len(waypoints) - 1) \
        if len(waypoints) > 1 else np.zeros(len(times), int)
    strides = np.asarray([f for f in stride_frames if f < arrival], dtype=int)
    goal_of = waypoints[current[strides]]
    remaining = np.array([remaining_way(root_xy[f], yaw[f], g, radius, heading if k == len(waypoints) - 1 else None)[0]
                          for f, g, k in zip(strides, goal_of, current[strides])])
    passed = int(route_progress(root_xy, waypoints, radius)[-1]) if len(times) and len(waypoints) > 1 else 0
    return SteeringMetrics(
        straight_distance=straight,
        path_ratio=stride_path_length(root_xy[:way_end + 1]) / straight if straight > 0 else float('nan'),
        path_ratio_frames=path_length(root_xy[:way_end + 1]) / straight if straight > 0 else float('nan'),
        heading_error_at_arrival_deg=float(errors[arrival]) if reached else float('nan'),
        final_heading_error_deg=float(errors[-1]) if len(times) else float('nan'),
        circling_strides=circling_strides(yaw[strides], np.hypot(*(root_xy[strides] - goal_of).T)),
        stuck_strides=sum(int(no_progress(remaining[current[strides] == leg], PROGRESS_WINDOW, PROGRESS_MIN).sum())
                          for leg in np.unique(current[strides])),
        waypoints=len(waypoints) if len(waypoints) > 1 else 0, waypoints_in_order=passed,
        route_completed=len(waypoints) > 1 and passed == len(waypoints))


def lateral_bending(pelvis: np.ndarray, mid_trunk: np.ndarray, shoulders: np.ndarray) -> float:
    """
    Amplitude (deg) of the trunk's lateral bend: half the range of the horizontal angle at mid-trunk.

    Each argument is a landmark trajectory `(n_frames, 3)`.
    """
    back = (mid_trunk - pelvis)[:, :2]
    front = (shoulders - mid_trunk)[:, :2]
    angle = np.arctan2(back[:, 0] * front[:, 1] - back[:, 1] * front[:, 0],
                       np.sum(back * front, axis=1))
    return float(np.degrees(0.5 * (np.max(angle) - np.min(angle)))) if len(angle) else 0.0


def inter_joint_variation(landmarks: np.ndarray, reference_landmarks: np.ndarray, pairs: np.ndarray) -> float:
    """
    Largest relative deviation of simulated landmark distances from the reference's (0.05 = 5 %).

    The paper's Section IX concern: without a skeleton, inter-articular distances of the soft body may
    drift from the reference pose it tracks. `landmarks`, `reference_landmarks (n_frames, n_landmarks, 3)`,
    `pairs (n_pairs, 2)` landmark indices.
    """
    def distances(points):
        return np.linalg.norm(points[:, pairs[:, 0]] - points[:, pairs[:, 1]], axis=2)
    if len(landmarks) == 0:
        return 0.0
    return float(np.max(np.abs(distances(landmarks) / distances(reference_landmarks) - 1.0)))


def fell(root_up: np.ndarray) -> bool:
    """Whether the root's up axis `(n_frames, 3)` ever tilts beyond FALL_TILT."""
    return bool(np.any(root_up[:, 2] < np.cos(FALL_TILT)))


def stuck(times: np.ndarray, goal_distance: np.ndarray, radius: float) -> bool:
    """Whether, before arrival, the goal distance `(n_frames,)` fails to shrink over any STUCK_WINDOW."""
    active = goal_distance > radius
    if not np.any(active) or times[-1] - times[0] < STUCK_WINDOW:
        return False
    later = np.searchsorted(times, times + STUCK_WINDOW)
    valid = (later < len(times)) & active
    idx = np.flatnonzero(valid)
    progress = goal_distance[idx] - goal_distance[later[idx]]
    return bool(np.any(progress < STUCK_PROGRESS))


def locomotion_metrics(times: np.ndarray, root_positions: np.ndarray, root_yaw: np.ndarray,
                       root_up: np.ndarray, goal_xy: np.ndarray | None, goal_radius: float,
                       foot_xy: np.ndarray, foot_contact: np.ndarray, n_strides: int,
                       trunk_landmarks: np.ndarray, landmarks: np.ndarray, reference_landmarks: np.ndarray,
                       landmark_pairs: np.ndarray, gait: GaitMetrics | None = None, goal_yaw: float | None = None,
                       yaw_tolerance: float = np.inf, stride_frames: np.ndarray | None = None,
                       waypoints: np.ndarray | None = None) -> LocomotionMetrics:
    """
    All metrics of a run.

    Shapes as in the helper functions, `trunk_landmarks (n_frames, 3, 3)`. Without a goal (`goal_xy` None) no goal is
    reached: reached_goal False, time and distance to the goal NaN, never stuck, no steering figures. A goal heading
    `goal_yaw` (rad) counts within `yaw_tolerance` (rad) for arrival; `waypoints (k, 2)` is the route whose last point
    is the goal; `stride_frames (s,)` the frames at which strides began (for the steering figures).
    """
    xy = root_positions[:, :2]
    steering = None
    if goal_xy is None:
        reached, t_goal, final, dist = False, float('nan'), float('nan'), np.zeros(len(times))
    else:
        heading = goal_yaw if yaw_tolerance < np.pi else None
        route = np.asarray(goal_xy, dtype=float)[None, :2] if waypoints is None or not len(waypoints) else waypoints
        reached, t_goal, final = route_arrival(times, xy, route, goal_radius, root_yaw, heading, yaw_tolerance)
        dist = np.linalg.norm(xy - np.asarray(goal_xy)[None, :2], axis=1)
        steering = steering_metrics(times, xy, root_yaw, route, goal_yaw, goal_radius, yaw_tolerance,
                                    np.zeros(0, int) if stride_frames is None else np.asarray(stride_frames))
    return LocomotionMetrics(
        reached_goal=reached, time_to_goal=t_goal, final_goal_distance=final,
        path_length=path_length(xy), mean_forward_speed=mean_forward_speed(times, xy, root_yaw),
        foot_slip_per_stride=foot_slip(foot_xy, foot_contact, n_strides),
        lateral_bending_amplitude_deg=lateral_bending(*np.moveaxis(trunk_landmarks, 1, 0)),
        inter_joint_distance_variation=inter_joint_variation(landmarks, reference_landmarks, landmark_pairs),
        fell=fell(root_up), stuck=stuck(times, dist, goal_radius) and not reached,
        strides=int(n_strides), gait=gait, steering=steering)
