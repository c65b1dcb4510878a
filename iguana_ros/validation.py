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
What a node accepts from a topic: one check per topic payload, bounded by the model and the scene (ROS-free).

`iguana_ros.ros.messages` decodes each subscribed topic's message into numpy values and calls the check of that
topic here, so every node that reads a topic applies the same rules (the planner and the simulator both read
`goal_pose`). Each check raises InputError with one line naming the topic, the value and what was expected; the
nodes log it as `rejected <topic>: …` and keep running. Finite but absurd values are rejected too, against bounds
derived from the model and the scene: desired spring lengths within rest / DESIRED_SHRINK_FACTOR .. rest x
DESIRED_STRETCH_FACTOR, pushes within MAX_PUSH_FORCE and the velocity changes MAX_PUSH_REGION_DELTA_V and
MAX_PUSH_BODY_DELTA_V, poses within the terrain's extent plus WORLD_MARGIN, bone frames that fit the skeleton, frame
stamps at most MAX_FRAME_GAP ahead.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import NamedTuple

import numpy as np

from iguana_ros.constants import (BONE_LENGTH_TOLERANCE, DESIRED_SHRINK_FACTOR, DESIRED_STRAIN_RMS,
                                  DESIRED_STRETCH_FACTOR, MAX_FRAME_GAP,
                                  MAX_PUSH_BODY_DELTA_V, MAX_PUSH_REGION_DELTA_V,
                                  QUATERNION_NORM_TOLERANCE, WORLD_MARGIN)
from iguana_ros.errors import InputError
from iguana_ros.geometry import yaw_of
from iguana_ros.physics.pushes import push_active, push_active_time
from iguana_ros.scene import MAX_PUSH_FORCE, MAX_WAYPOINTS

FRAME_STALE, FRAME_REPEAT, FRAME_NEW = 'stale', 'repeat', 'new'
"""Outcomes of `check_frame`: older than the last frame handled, the same frame again, a newer frame."""


def validate_array(name: str, values, shape: Sequence[int | None]) -> np.ndarray:
    """`values` as a float64 array of `shape` (None = any size), all finite; else InputError naming `name`."""
    try:
        arr = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(f'{name} must be numeric, got {type(values).__name__}: {exc}') from exc
    expected = '(' + ', '.join('n' if s is None else str(s) for s in shape) + ')'
    if arr.ndim != len(shape) or any(s is not None and s != a for s, a in zip(shape, arr.shape)):
        raise InputError(f'{name} has shape {arr.shape}, expected {expected}')
    if not np.isfinite(arr).all():
        bad = int(np.count_nonzero(~np.isfinite(arr)))
        raise InputError(f'{name} has {bad} non-finite value(s) (NaN or Inf); expected finite numbers')
    return arr


def world_bound(extent: float) -> float:
    """Largest |x|, |y| or |z| (m) a pose of the body or of its reference may have on a terrain of side `extent`."""
    return float(extent) + WORLD_MARGIN


def check_within(name: str, positions: np.ndarray, bound: float) -> np.ndarray:
    """`positions` (any shape, m) unless a coordinate exceeds `bound` in magnitude (InputError)."""
    worst = float(np.max(np.abs(positions))) if np.size(positions) else 0.0
    if worst > bound:
        raise InputError(f'{name} has a coordinate of magnitude {worst:.3g} m; expected within {bound:g} m of the '
                         'origin (the terrain plus a margin)')
    return positions


def check_unit_quaternions(name: str, quaternions: np.ndarray) -> np.ndarray:
    """`quaternions` `(..., 4)` unless one's norm is off 1 by more than QUATERNION_NORM_TOLERANCE (InputError)."""
    with np.errstate(over='ignore'):
        off = np.abs(np.linalg.norm(quaternions, axis=-1) - 1.0)
    if off.size and float(off.max()) > QUATERNION_NORM_TOLERANCE:
        raise InputError(f'{name} holds a quaternion of norm {1.0 + float(off.max()):.6g} or '
                         f'{1.0 - float(off.max()):.6g}; expected unit quaternions')
    return quaternions


def check_frame(what: str, frame: int, last_frame: int) -> str:
    """
    FRAME_STALE, FRAME_REPEAT or FRAME_NEW for a message of `frame` after `last_frame` (-1 = none yet).

    InputError for a frame more than MAX_FRAME_GAP frames ahead of `last_frame` (a stamp from another clock).
    """
    if frame < last_frame:
        return FRAME_STALE
    if frame == last_frame:
        return FRAME_REPEAT
    if frame - max(last_frame, 0) > MAX_FRAME_GAP:
        raise InputError(f'{what} is stamped frame {frame}, {frame - max(last_frame, 0)} frames ahead of frame '
                         f'{max(last_frame, 0)}; expected at most {MAX_FRAME_GAP} ahead (simulated time)')
    return FRAME_NEW


# ----------------------------------------------------------------------------------------- per topic payload

GOAL_QUATERNION_TOLERANCE = 0.01
"""Largest |norm - 1| of a goal's orientation (a user's message: RViz2, a script); it is normalised before use."""


class GoalRequest(NamedTuple):
    """A goal from goal_pose: position `(2,)` m, adoption time s, heading rad (None: any)."""

    xy: np.ndarray
    at: float
    yaw: float | None


class PushRequest(NamedTuple):
    """A push from the push topic: force and torque `(3,)` (finite; `check_push` bounds them) and the region's tag."""

    force: np.ndarray
    torque: np.ndarray
    region: str


class RouteRequest(NamedTuple):
    """
    A route from the route topic.

    Waypoints ((x, y, yaw or None), ...) m and rad, the last's yaw only, and the adoption time s.
    """

    waypoints: tuple
    at: float


def goal_heading(orientation: np.ndarray) -> float | None:
    """
    Heading (rad) asked by a goal orientation `(4,)` xyzw: its yaw; None for the all-zero quaternion (no heading).

    InputError unless it is finite and of unit norm within GOAL_QUATERNION_TOLERANCE.
    """
    q = validate_array('goal orientation', orientation, (4,))
    norm = float(np.linalg.norm(q))
    if norm == 0.0:
        return None
    if abs(norm - 1.0) > GOAL_QUATERNION_TOLERANCE:
        raise InputError(f'goal orientation has norm {norm:.6g}; expected a unit quaternion (all zeros: no heading)')
    return float(yaw_of(q / norm))


def check_goal(position: np.ndarray, orientation: np.ndarray, at: float, half_extent: float) -> GoalRequest:
    """
    Return the GoalRequest of a goal_pose at `position` `(3,)`, `orientation` `(4,)` stamped `at` s.

    On a terrain reaching `half_extent` m from the origin; InputError if non-finite, off the terrain, stamped before 0,
    or of an orientation that is neither a unit quaternion nor all zeros (`goal_heading`).
    """
    position = validate_array('goal position', position, (3,))
    yaw = goal_heading(orientation)
    xy = position[:2]
    if np.any(np.abs(xy) > half_extent):
        raise InputError(f'goal ({xy[0]:.6g}, {xy[1]:.6g}) is off the terrain (|x|, |y| <= {half_extent:g} m)')
    if not at >= 0.0:
        raise InputError(f'goal stamp is {at:g} s; expected a simulated time >= 0 (0 = at the next stride)')
    return GoalRequest(xy, float(at), yaw)


MAX_GOAL_TOLERANCE = 10.0
"""Largest position tolerance of a goal, m."""


def check_goal_tolerances(position_tolerance: float, yaw_tolerance: float) -> None:
    """Check a goal's tolerances: InputError unless in [0, MAX_GOAL_TOLERANCE] m and [0, pi] rad (0 = default)."""
    if not 0.0 <= position_tolerance <= MAX_GOAL_TOLERANCE:
        raise InputError(f"goal position tolerance is {position_tolerance:g} m; expected 0 (the planner's goal "
                         f'radius) to {MAX_GOAL_TOLERANCE:g} m')
    if not 0.0 <= yaw_tolerance <= np.pi:
        raise InputError(f"goal yaw tolerance is {yaw_tolerance:g} rad; expected 0 (the planner's yaw tolerance) "
                         'to pi rad')


def check_route(positions: np.ndarray, orientations: np.ndarray, at: float, half_extent: float) -> RouteRequest:
    """
    route: the RouteRequest of waypoints at `positions (k, 3)` with `orientations (k, 4)` stamped `at` s.

    1..MAX_WAYPOINTS waypoints, each checked as a goal (`check_goal`); only the last one's heading is kept.
    """
    positions = validate_array('route positions', positions, (None, 3))
    if not 1 <= len(positions) <= MAX_WAYPOINTS:
        raise InputError(f'route has {len(positions)} waypoints, expected 1 to {MAX_WAYPOINTS}')
    goals = [check_goal(p, q, at, half_extent) for p, q in zip(positions, np.asarray(orientations))]
    waypoints = tuple((float(g.xy[0]), float(g.xy[1]), g.yaw if k == len(goals) - 1 else None)
                      for k, g in enumerate(goals))
    return RouteRequest(waypoints, float(at))


def check_desired_lengths(lengths: np.ndarray, rest_lengths: np.ndarray) -> np.ndarray:
    """
    Check a spring_rest_lengths payload: desired lengths `(n_springs,)` m within the limits of their rest lengths.

    Each above rest / DESIRED_SHRINK_FACTOR and below rest x DESIRED_STRETCH_FACTOR,
    their RMS log strain at most DESIRED_STRAIN_RMS (every such message is simulated stably: `iguana bench faults
    limits`); InputError naming the worst spring (or the strain) otherwise.
    """
    rest = np.asarray(rest_lengths, dtype=np.float64)
    lengths = validate_array('spring_rest_lengths', lengths, rest.shape)
    with np.errstate(over='ignore', divide='ignore'):
        ratio = lengths / rest
    low, high = 1.0 / DESIRED_SHRINK_FACTOR, DESIRED_STRETCH_FACTOR
    bad = (ratio < low) | (ratio > high)
    if bad.any():
        worst = int(np.argmax(np.abs(np.log(np.maximum(ratio, 1e-300)))))
        raise InputError(f'spring_rest_lengths has {int(bad.sum())} of {len(ratio)} lengths outside '
                         f'{low:.3g}..{high:g} x their rest length (spring {worst}: {lengths[worst]:.6g} m, rest '
                         f'{rest[worst]:.6g} m)')
    strain = float(np.sqrt(np.mean(np.log(ratio) ** 2))) if len(ratio) else 0.0
    if strain > DESIRED_STRAIN_RMS:
        raise InputError(f'spring_rest_lengths strain the whole body: RMS |ln(length / rest)| is {strain:.3g}, '
                         f'above {DESIRED_STRAIN_RMS:g} (median length {float(np.median(ratio)):.3g} x rest)')
    return lengths


def check_push(force: np.ndarray, torque: np.ndarray, region: str, region_masses: Mapping[str, float], at: float,
               duration: float, acting: Sequence = ()) -> np.ndarray:
    """
    Check a push: its force `(3,)` N on `region` from `at` for `duration` s, while the pushes `acting` act.

    `region_masses`: kg per region (`physics.pushes.region_masses`). InputError if non-finite, with a torque (not
    applied), on an unknown region, above MAX_PUSH_FORCE (alone or with `acting`), or giving its region more than
    MAX_PUSH_REGION_DELTA_V or the body (with `acting`) more than MAX_PUSH_BODY_DELTA_V; returns the force.
    """
    force = validate_array('push force', force, (3,))
    torque = validate_array('push torque', torque, (3,))
    if np.any(torque != 0.0):
        raise InputError(f'push has torque {torque.tolist()} N m; only a force is applied, expected torque 0')
    if region not in region_masses:
        raise InputError(f'push region {region!r} is not a node tag; tags: {", ".join(region_masses)}')
    magnitude = _norm(force)
    if magnitude > MAX_PUSH_FORCE:
        raise InputError(f'push force {magnitude:.6g} N is above the {MAX_PUSH_FORCE:g} N limit')
    total = magnitude + sum(_norm(p.force) for p in acting)
    if total > MAX_PUSH_FORCE:
        raise InputError(f'push force {magnitude:.6g} N with the {len(acting)} push(es) still acting '
                         f'totals {total:.6g} N, above the {MAX_PUSH_FORCE:g} N limit')
    _check_push_velocity(magnitude, region, region_masses, push_active_time(at, duration),
                         sum(_norm(p.force) * push_active_time(p.at, p.duration) for p in acting))
    return force


def _norm(vector) -> float:
    """Euclidean norm of a vector (inf when it overflows)."""
    with np.errstate(over='ignore'):
        return float(np.linalg.norm(np.asarray(vector, dtype=np.float64)))


def _check_push_velocity(magnitude: float, region: str, region_masses: Mapping[str, float], active_time: float,
                         acting_impulse: float) -> None:
    """Check the velocity change of a push of `magnitude` N acting `active_time` s on its region and on the body."""
    impulse = magnitude * active_time
    region_dv = impulse / region_masses[region]
    if region_dv > MAX_PUSH_REGION_DELTA_V:
        raise InputError(f'push of {magnitude:.6g} N acting {active_time:.4g} s (whole frames) gives {region} '
                         f'({region_masses[region]:.3g} kg) {region_dv:.3g} m/s, above the '
                         f'{MAX_PUSH_REGION_DELTA_V:g} m/s limit ({region_masses[region] * MAX_PUSH_REGION_DELTA_V:.3g}'
                         f' N s on this region)')
    body_dv = (impulse + acting_impulse) / region_masses['all']
    if body_dv > MAX_PUSH_BODY_DELTA_V:
        acting = ' with the pushes still acting' if acting_impulse > 0.0 else ''
        raise InputError(f'push of {magnitude:.6g} N acting {active_time:.4g} s (whole frames){acting} gives the body '
                         f'{body_dv:.3g} m/s, above the {MAX_PUSH_BODY_DELTA_V:g} m/s limit '
                         f'({region_masses["all"] * MAX_PUSH_BODY_DELTA_V:.3g} N s in all)')


def check_scene_pushes(pushes: Sequence, region_masses: Mapping[str, float]) -> None:
    """Every push of a scene by `check_push`, with the pushes acting when it starts; InputError naming pushes[i]."""
    for i, push in enumerate(pushes):
        acting = [q for k, q in enumerate(pushes) if k != i and push_active(q.at, q.duration, push.at)]
        try:
            check_push(push.force, np.zeros(3), push.region, region_masses, push.at, push.duration, acting)
        except InputError as exc:
            raise InputError(f'pushes[{i}]: {exc}') from None


def check_root_pose(what: str, position: np.ndarray, orientation: np.ndarray, bound: float) -> tuple:
    """iguana_state: root position `(3,)` within `bound` m and a unit orientation `(4,)`; InputError otherwise."""
    position = check_within(f'{what} position', validate_array(f'{what} position', position, (3,)), bound)
    orientation = check_unit_quaternions(f'{what} orientation',
                                         validate_array(f'{what} orientation', orientation, (4,)))
    return position, orientation


def check_bone_frames(what: str, positions: np.ndarray, rotations: np.ndarray, parents: np.ndarray,
                      offsets: np.ndarray, bound: float) -> tuple:
    """
    Check a reference_pose payload: world bone positions and rotations that fit the skeleton.

    Positions `(n_bones, 3)` within `bound` m, unit rotations `(n_bones, 4)`, each bone as far from its
    parent as the skeleton's offset (within BONE_LENGTH_TOLERANCE); InputError otherwise.
    """
    n = len(parents)
    positions = check_within(f'{what} positions', validate_array(f'{what} positions', positions, (n, 3)), bound)
    rotations = check_unit_quaternions(f'{what} orientations',
                                       validate_array(f'{what} orientations', rotations, (n, 4)))
    child = np.flatnonzero(np.asarray(parents) >= 0)
    lengths = np.linalg.norm(positions[child] - positions[np.asarray(parents)[child]], axis=1)
    expected = np.linalg.norm(np.asarray(offsets)[child], axis=1)
    off = np.abs(lengths - expected)
    if off.size and float(off.max()) > BONE_LENGTH_TOLERANCE:
        k = int(np.argmax(off))
        raise InputError(f'{what} does not fit the skeleton: bone {int(child[k])} is {lengths[k]:.6g} m from its '
                         f'parent, expected {expected[k]:.6g} m')
    return positions, rotations


def check_clip(translations: np.ndarray, rotations: np.ndarray, offsets: np.ndarray, bound: float,
               max_frames: int) -> tuple:
    """
    Check a motion_clip payload: bone translations and local rotations of 2..`max_frames` frames.

    Translations `(n_frames, n_bones, 3)` (root first, then the skeleton's `offsets`) and unit local rotations
    `(n_frames, n_bones, 4)`, 2..`max_frames` frames, root within `bound` m; InputError otherwise.
    """
    n_bones = len(offsets)
    translations = validate_array('motion_clip translations', translations, (None, n_bones, 3))
    rotations = validate_array('motion_clip rotations', rotations, (len(translations), n_bones, 4))
    if not 2 <= len(translations) <= max_frames:
        raise InputError(f'motion_clip has {len(translations)} points, expected 2..{max_frames}')
    check_within('motion_clip root translations', translations[:, 0], bound)
    misfit = float(np.max(np.abs(translations[:, 1:] - np.asarray(offsets)[1:]))) if n_bones > 1 else 0.0
    if misfit > BONE_LENGTH_TOLERANCE:
        raise InputError(f'motion_clip bone translations differ from the skeleton offsets by up to {misfit:.3g} m; '
                         'only the root translation may vary')
    check_unit_quaternions('motion_clip rotations', rotations)
    return translations, rotations
