"""Locomotion metrics of a run (paper Sections VIII-IX): goal reached, path, speed, foot slip, lateral
bending, inter-joint distance variation, falls and getting stuck. Plain arrays in, plain numbers out.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

FALL_TILT = np.radians(60.0)
"""Root tilt (roll or pitch) beyond which the iguana counts as fallen, rad."""

STUCK_WINDOW = 3.0
"""A goal-seeking iguana that moves less than STUCK_PROGRESS in this many seconds is stuck, s."""

STUCK_PROGRESS = 0.05
"""Minimum progress toward the goal over STUCK_WINDOW, m."""


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

    def as_dict(self) -> dict:
        """Plain dict for JSON and the summary line (NaN, e.g. no arrival time, becomes None)."""
        def plain(v):
            if isinstance(v, (float, np.floating)):
                return float(v) if np.isfinite(v) else None
            return v
        return {k: plain(v) for k, v in asdict(self).items()}


def path_length(root_xy: np.ndarray) -> float:
    """Horizontal path length of the root `(n_frames, 2)`, m."""
    return float(np.sum(np.linalg.norm(np.diff(root_xy, axis=0), axis=1)))


def goal_arrival(times: np.ndarray, root_xy: np.ndarray, goal_xy: np.ndarray,
                 radius: float) -> tuple[bool, float, float]:
    """(reached, first time within `radius`, final distance) for root `(n_frames, 2)` and goal `(2,)`."""
    dist = np.linalg.norm(root_xy - np.asarray(goal_xy)[None, :2], axis=1)
    inside = np.flatnonzero(dist <= radius)
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
    """Horizontal travel of feet while in contact, per stride, m.

    `foot_xy (n_frames, n_feet, 2)` foot centroids, `foot_contact (n_frames, n_feet)` bool.
    """
    step = np.linalg.norm(np.diff(foot_xy, axis=0), axis=2)
    held = foot_contact[1:] & foot_contact[:-1]
    return float(np.sum(step * held) / max(n_strides, 1))


def lateral_bending(pelvis: np.ndarray, mid_trunk: np.ndarray, shoulders: np.ndarray) -> float:
    """Amplitude (deg) of the trunk's lateral bend: half the range of the horizontal angle at mid-trunk.

    Each argument is a landmark trajectory `(n_frames, 3)`.
    """
    back = (mid_trunk - pelvis)[:, :2]
    front = (shoulders - mid_trunk)[:, :2]
    angle = np.arctan2(back[:, 0] * front[:, 1] - back[:, 1] * front[:, 0],
                       np.sum(back * front, axis=1))
    return float(np.degrees(0.5 * (np.max(angle) - np.min(angle)))) if len(angle) else 0.0


def inter_joint_variation(landmarks: np.ndarray, reference_landmarks: np.ndarray, pairs: np.ndarray) -> float:
    """Largest relative deviation of simulated landmark distances from the reference's (0.05 = 5 %).

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
                       root_up: np.ndarray, goal_xy: np.ndarray, goal_radius: float,
                       foot_xy: np.ndarray, foot_contact: np.ndarray, n_strides: int,
                       trunk_landmarks: np.ndarray, landmarks: np.ndarray, reference_landmarks: np.ndarray,
                       landmark_pairs: np.ndarray) -> LocomotionMetrics:
    """All metrics of a run; shapes as in the helper functions, `trunk_landmarks (n_frames, 3, 3)`."""
    xy = root_positions[:, :2]
    reached, t_goal, final = goal_arrival(times, xy, goal_xy, goal_radius)
    dist = np.linalg.norm(xy - np.asarray(goal_xy)[None, :2], axis=1)
    return LocomotionMetrics(
        reached_goal=reached, time_to_goal=t_goal, final_goal_distance=final,
        path_length=path_length(xy), mean_forward_speed=mean_forward_speed(times, xy, root_yaw),
        foot_slip_per_stride=foot_slip(foot_xy, foot_contact, n_strides),
        lateral_bending_amplitude_deg=lateral_bending(*np.moveaxis(trunk_landmarks, 1, 0)),
        inter_joint_distance_variation=inter_joint_variation(landmarks, reference_landmarks, landmark_pairs),
        fell=fell(root_up), stuck=stuck(times, dist, goal_radius) and not reached,
        strides=int(n_strides))
