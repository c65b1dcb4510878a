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
The pipeline's values as the topic table's messages, and back, with validation (float64 end to end).

Every per-frame topic is written and read as serialized bytes (`*_to_cdr`, `*_from_cdr`, over the CDR codec
`iguana_ros.ros.cdr`): the nodes and the bag readers decode the same bytes with the same functions and the same checks.
Only the inputs a person or a tool sends (goal_pose, route) and planner_status are read from rclpy message objects.
"""
from __future__ import annotations

import math
import struct

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
import numpy as np
from std_msgs.msg import Header

from iguana_ros.body.skeleton import FEET
from iguana_ros.constants import BASE_FRAME, FRAME_RATE, GOAL_FRAMES, MAX_CLIP_FRAMES, WORLD_FRAME
from iguana_ros.errors import InputError
from iguana_ros.geometry import yaw_of
from iguana_ros.motion.motion_graph import AlignedClip
from iguana_ros.ros.cdr import (clock_cdr, clock_from_cdr, header_stamp, joint_state_cdr, joint_state_from_cdr,
                                multi_dof_trajectory_cdr, multi_dof_trajectory_from_cdr, odometry_cdr,
                                odometry_from_cdr, pose_array_cdr, pose_array_from_cdr, Trajectory,
                                wrench_stamped_from_cdr)
from iguana_ros.ros.conversions import (frame_stamp, pose_stamped_to_numpy, poses_from_msgs, time_from_msg,
                                        time_to_msg, validate_array)
from iguana_ros.run_metrics import Stride
from iguana_ros.scene import MAX_WAYPOINTS
from iguana_ros.validation import (check_bone_frames, check_clip, check_desired_lengths, check_goal, check_root_pose,
                                   check_route, GoalRequest, PushRequest, RouteRequest)


DEFAULT_PUSH_REGION = 'trunk_left'
"""The region a push whose header.frame_id is empty acts on."""


def check_frame_id(what: str, frame_id: str, allowed: tuple = (WORLD_FRAME,)) -> None:
    """`InputError` unless `frame_id` is one of `allowed` (default: the world frame)."""
    if frame_id not in allowed:
        expected = ' or '.join(repr(f) for f in allowed)
        raise InputError(f'{what} has frame_id {frame_id!r}, expected {expected}')


def clip_to_cdr(clip: AlignedClip, skeleton, start_frame: int) -> bytes:
    """
    Return a placed clip as a serialized motion_clip (MultiDOFJointTrajectory), built from numpy.

    Bone 0 carries the root pose, the others their offsets; stamped with `start_frame` (how the planner publishes).
    """
    return multi_dof_trajectory_cdr(_clip_trajectory(clip, skeleton, start_frame))


def _clip_trajectory(clip: AlignedClip, skeleton, start_frame: int) -> Trajectory:
    """Return the `Trajectory` of a placed clip starting at frame `start_frame`."""
    n = len(clip.root_positions)
    translations = np.broadcast_to(skeleton.offsets, (n,) + skeleton.offsets.shape).copy()
    translations[:, 0] = clip.root_positions
    stamp = frame_stamp(start_frame)
    return Trajectory((stamp.sec, stamp.nanosec), WORLD_FRAME, list(skeleton.names), np.arange(n) / FRAME_RATE,
                      translations, np.asarray(clip.local_rotations, dtype=np.float64))


def clip_from_cdr(data: bytes, skeleton, bound: float = math.inf) -> tuple[int, AlignedClip]:
    """
    (start frame, placed clip) of a serialized motion_clip message (decoded with numpy).

    InputError unless it fits `skeleton` (joint names, bone offsets, unit rotations, 2..MAX_CLIP_FRAMES points) with its
    root within `bound` m.
    """
    trajectory = multi_dof_trajectory_from_cdr(data)
    return _checked_clip(trajectory.frame_id, _cdr_stamp_frame(*trajectory.stamp), trajectory.joint_names,
                         trajectory.translations, trajectory.rotations, skeleton, bound)


def _checked_clip(frame_id: str, frame: int, names: list, translations: np.ndarray, rotations: np.ndarray, skeleton,
                  bound: float) -> tuple[int, AlignedClip]:
    """(start frame, placed clip) of a motion_clip's fields, or InputError (see `clip_from_cdr`)."""
    check_frame_id('motion_clip', frame_id)
    if tuple(names) != tuple(skeleton.names):
        raise InputError(f'motion_clip joint_names do not match the skeleton ({len(names)} names, '
                         f'expected {skeleton.n_bones} starting {skeleton.names[:3]})')
    translations, rotations = check_clip(translations, rotations, skeleton.offsets, bound, MAX_CLIP_FRAMES)
    clip = AlignedClip(name='motion_clip', root_positions=translations[:, 0].copy(),
                       local_rotations=rotations, contacts=np.zeros((len(rotations), 4), bool), source=None)
    return frame, clip


def stride_from_cdr(data: bytes) -> tuple[int, Stride]:
    """
    (start frame, Stride) of a serialized motion_clip message (no skeleton needed).

    The frames it advances and its root's displacement `(2,)` (first to last point) and first heading, in the world;
    InputError if it does not fit.
    """
    trajectory = multi_dof_trajectory_from_cdr(data)
    check_frame_id('motion_clip', trajectory.frame_id)
    translations, rotations = trajectory.translations, trajectory.rotations
    if len(translations) < 2 or translations.shape[1] < 1:
        raise InputError(f'motion_clip has {len(translations)} points, expected at least 2')
    root = validate_array('motion_clip root translations', translations[:, 0], (None, 3))
    heading = float(yaw_of(validate_array('motion_clip root rotation', rotations[0, 0], (4,))))
    start = _cdr_stamp_frame(*trajectory.stamp)
    return start, Stride(start, len(root) - 1, root[-1, :2] - root[0, :2], heading)


def reference_pose_to_cdr(joint_positions: np.ndarray, joint_rotations: np.ndarray, frame: int) -> bytes:
    """Return a serialized reference_pose (PoseArray) of world bone frames `(n_bones, 3)`, `(n_bones, 4)` at `frame`."""
    stamp = frame_stamp(frame)
    return pose_array_cdr((stamp.sec, stamp.nanosec), WORLD_FRAME,
                          validate_array('reference_pose positions', joint_positions, (None, 3)),
                          validate_array('reference_pose orientations', joint_rotations, (len(joint_positions), 4)))


def reference_pose_from_cdr(data: bytes, n_bones: int, skeleton=None, bound: float = math.inf
                            ) -> tuple[int, np.ndarray, np.ndarray]:
    """
    (frame, positions `(n_bones, 3)`, rotations `(n_bones, 4)`) of a serialized reference_pose message.

    With `skeleton`, InputError unless the bone frames fit it (unit rotations, bone lengths) within `bound` m of the
    origin.
    """
    (sec, nsec), frame_id, positions, rotations = pose_array_from_cdr(data, 'reference_pose')
    return _checked_reference_pose(frame_id, _cdr_stamp_frame(sec, nsec), positions, rotations,
                                   n_bones, skeleton, bound)


def _checked_reference_pose(frame_id: str, frame: int, positions: np.ndarray, rotations: np.ndarray, n_bones: int,
                            skeleton, bound: float) -> tuple[int, np.ndarray, np.ndarray]:
    """(frame, positions, rotations) of a reference_pose's fields, or InputError (see `reference_pose_from_cdr`)."""
    check_frame_id('reference_pose', frame_id)
    validate_array('reference_pose positions', positions, (n_bones, 3))
    validate_array('reference_pose orientations', rotations, (n_bones, 4))
    if skeleton is not None:
        check_bone_frames('reference_pose', positions, rotations, skeleton.parents, skeleton.offsets, bound)
    return frame, positions, rotations


def lengths_to_cdr(lengths: np.ndarray, frame: int) -> bytes:
    """Return a serialized JointState whose position holds the desired spring lengths `(n_springs,)` of `frame`."""
    return joint_state_cdr(_frame_stamp_pair(frame), '', [], validate_array('values', lengths, (None,)))


def lengths_from_cdr(data: bytes, n_springs: int, rest_lengths: np.ndarray | None = None) -> tuple[int, np.ndarray]:
    """
    (frame, lengths `(n_springs,)`) of a serialized spring_rest_lengths message.

    InputError if wrong or negative, or (given the model's `rest_lengths`) outside the factor of rest that
    `check_desired_lengths` allows.
    """
    fields = joint_state_from_cdr(data, 'spring_rest_lengths')
    return _cdr_stamp_frame(*fields['stamp']), _checked_lengths(fields['position'], n_springs, rest_lengths)


def _checked_lengths(values: np.ndarray, n_springs: int, rest_lengths: np.ndarray | None) -> np.ndarray:
    """Spring lengths `(n_springs,)` as float64, or InputError (see `lengths_from_cdr`)."""
    lengths = validate_array('spring_rest_lengths', values, (n_springs,))
    if np.any(lengths < 0.0):
        raise InputError('spring_rest_lengths has negative lengths')
    if rest_lengths is not None:
        check_desired_lengths(lengths, rest_lengths)
    return lengths


def state_to_cdr(root: np.ndarray, orientation: np.ndarray, linear: np.ndarray, angular: np.ndarray,
                 frame: int, child_frame_id: str = BASE_FRAME) -> bytes:
    """Return the serialized iguana_state (Odometry) of the iguana root at the start of `frame` (the simulator's)."""
    pose = np.concatenate([validate_array('position', root, (3,)), validate_array('quaternion', orientation, (4,))])
    twist = np.concatenate([validate_array('linear_velocity', linear, (3,)),
                            validate_array('angular_velocity', angular, (3,))])
    return odometry_cdr(_frame_stamp_pair(frame), WORLD_FRAME, child_frame_id, pose, twist)


def clock_to_cdr(frame: int) -> bytes:
    """Return the serialized rosgraph_msgs/Clock of the start of `frame` (the simulator's /clock)."""
    return clock_cdr(_frame_stamp_pair(frame))


def clock_frame_from_cdr(data: bytes) -> int:
    """Return the frame of a serialized /clock message (`clock_to_cdr`'s inverse); InputError if it is not one."""
    return _cdr_stamp_frame(*clock_from_cdr(data))


def _frame_stamp_pair(frame: int) -> tuple[int, int]:
    """(sec, nanosec) of `frame_stamp(frame)`."""
    stamp = frame_stamp(frame)
    return stamp.sec, stamp.nanosec


def state_from_cdr(data: bytes, bound: float = math.inf) -> tuple[int, np.ndarray, np.ndarray]:
    """
    (frame, root position `(3,)`, orientation `(4,)`) of a serialized iguana_state message.

    InputError if non-finite (pose or twist), not a unit orientation, or beyond `bound` m.
    """
    return state_twist_from_cdr(data, bound)[:3]


def state_twist_from_cdr(data: bytes, bound: float = math.inf) -> tuple[int, np.ndarray, np.ndarray, np.ndarray]:
    """(frame, root position `(3,)`, orientation `(4,)`, twist `(6,)` linear + angular) of an iguana_state message."""
    (sec, nsec), frame_id, pose, twist = odometry_from_cdr(data, 'iguana_state')
    return _checked_state(frame_id, _cdr_stamp_frame(sec, nsec), pose[:3], pose[3:], twist, bound)


def stamp_of_cdr(data: bytes) -> float:
    """Return the header stamp (s) of a serialized stamped message, as `time_from_msg` of its header.stamp."""
    sec, nsec = header_stamp(data)
    return sec + nsec * 1e-9


def frame_of_cdr(data: bytes) -> int | str:
    """Frame index of a serialized stamped message's header stamp, or '?' if its bytes are too short to hold one."""
    try:
        return _cdr_stamp_frame(*header_stamp(data))
    except struct.error:
        return '?'


def _cdr_stamp_frame(sec: int, nsec: int) -> int:
    """Frame index of a serialized stamp (sec, nanosec), as `stamp_frame` of a Time."""
    return int(round((sec + nsec * 1e-9) * FRAME_RATE))


def _checked_state(frame_id: str, frame: int, position: np.ndarray, orientation: np.ndarray, twist: np.ndarray,
                   bound: float) -> tuple[int, np.ndarray, np.ndarray, np.ndarray]:
    """(frame, position, orientation, twist) of an iguana_state's fields, or InputError (see `state_from_cdr`)."""
    check_frame_id('iguana_state', frame_id)
    position, orientation = check_root_pose('iguana_state', position, orientation, bound)
    twist = validate_array('iguana_state twist', twist, (6,))
    return frame, position, orientation, twist


def goal_from_msg(msg, half_extent: float) -> GoalRequest:
    """
    Return the GoalRequest (position `(2,)` m, adoption time s, heading rad or None) of a goal_pose message.

    On a terrain reaching `half_extent` m from the origin; InputError if its frame, numbers, orientation or stamp are
    wrong or the goal is off the terrain (`check_goal`).
    """
    check_frame_id('goal_pose', msg.header.frame_id, GOAL_FRAMES)
    position, orientation = pose_stamped_to_numpy(msg)
    return check_goal(position, orientation, time_from_msg(msg.header.stamp), half_extent)


def route_from_msg(msg, half_extent: float) -> RouteRequest:
    """Return the RouteRequest of a route message (nav_msgs/Path): waypoints and adoption time (`check_route`)."""
    check_frame_id('route', msg.header.frame_id, GOAL_FRAMES)
    if len(msg.poses) > MAX_WAYPOINTS:
        raise InputError(f'route has {len(msg.poses)} waypoints, expected at most {MAX_WAYPOINTS}')
    for pose in msg.poses:
        check_frame_id('a route waypoint', pose.header.frame_id or WORLD_FRAME, GOAL_FRAMES)
    positions, orientations = poses_from_msgs([p.pose for p in msg.poses])
    return check_route(positions, orientations, time_from_msg(msg.header.stamp), half_extent)


def planner_status_msg(status, goals: int, frame: int, stamp: float, readers: dict | None = None):
    """
    Return the planner_status message: a DiagnosticArray stamped `stamp` s (simulated) of one PlannerStatus.

    With the number of goal and route messages accepted, the frame of the stride end, and `readers`: the volatile
    subscriptions of goal_pose and route the planner sees ('goal_pose_readers', 'route_readers'; see
    `goal_readers_from_msg`).
    """
    level = DiagnosticStatus.WARN if status.recovery else DiagnosticStatus.OK
    values = {'waypoint': status.waypoint, 'waypoints': status.waypoints, 'distance': f'{status.distance:.4f}',
              'heading_error': f'{status.heading_error:.4f}', 'recovery': status.recovery, 'goals': goals,
              'frame': frame, **{f'{key}_readers': n for key, n in (readers or {}).items()}}
    entry = DiagnosticStatus(level=level, name='planner_node', message=status.state,
                             values=[KeyValue(key=k, value=str(v)) for k, v in values.items()])
    return DiagnosticArray(header=Header(stamp=time_to_msg(stamp)), status=[entry])


def planner_status_from_msg(msg) -> dict:
    """
    Return a planner_status message as a dict.

    state, waypoint, waypoints, distance, heading_error, recovery, goals, frame, time (s); InputError unless it holds
    one status with those values as numbers.
    """
    if len(msg.status) != 1:
        raise InputError(f'planner_status holds {len(msg.status)} statuses, expected 1')
    values = {kv.key: kv.value for kv in msg.status[0].values}
    try:
        out = {k: int(values[k]) for k in ('waypoint', 'waypoints', 'recovery', 'goals', 'frame')}
        out.update({k: float(values[k]) for k in ('distance', 'heading_error')})
    except (KeyError, ValueError) as exc:
        raise InputError(f'planner_status lacks a number: {exc}') from None
    return {'state': msg.status[0].message, **out, 'time': time_from_msg(msg.header.stamp)}


def goal_readers_from_msg(msg) -> dict:
    """
    Return {topic key: volatile subscriptions the planner sees} of a planner_status message ({} when it has none).

    A goal sender waits until it has matched as many (`goal_sender.publish_goals`): the planner's long-settled view of
    the graph names the readers, a bag recorder among them, that a sender's fresh view may not list yet.
    """
    if len(msg.status) != 1:
        return {}
    values = {kv.key: kv.value for kv in msg.status[0].values}
    out = {}
    for key in ('goal_pose', 'route'):
        try:
            out[key] = int(values[f'{key}_readers'])
        except (KeyError, ValueError):
            continue
    return out


def push_from_cdr(data: bytes) -> PushRequest:
    """
    Decode a serialized push message: the force and torque `(3,)` of a WrenchStamped and the region its frame_id names.

    '' names trunk_left; InputError unless both are finite. The simulator stage checks them against the body
    (`SimulatorStage.add_push`).
    """
    _stamp, frame_id, force, torque = wrench_stamped_from_cdr(data, 'push')
    force = validate_array('push force', force, (3,))
    torque = validate_array('push torque', torque, (3,))
    return PushRequest(force, torque, frame_id or DEFAULT_PUSH_REGION)


def foot_state_to_cdr(heights: np.ndarray, contact: np.ndarray, frame: int) -> bytes:
    """
    Return the serialized foot_state: a JointState named FEET, stamped with `frame` (the state after `frame` frames).

    position = sole heights above the terrain `(4,)` m, effort = contact flags `(4,)` as 1.0 / 0.0.
    """
    return _feet_cdr(heights, contact, frame)


def foot_state_from_cdr(data: bytes) -> tuple[int, np.ndarray, np.ndarray]:
    """(frame, heights `(4,)` m, contact `(4,)` bool) of a serialized foot_state; InputError if it does not fit."""
    return _feet_from_cdr('foot_state', data, with_position=True)


def reference_stance_to_cdr(stance: np.ndarray, frame: int) -> bytes:
    """Return the serialized reference_stance: JointState named FEET, effort = the clip's stance flags `(4,)`."""
    return _feet_cdr(None, stance, frame)


def reference_stance_from_cdr(data: bytes) -> tuple[int, np.ndarray]:
    """(frame, stance flags `(4,)` bool) of a serialized reference_stance; InputError if it does not fit."""
    frame, _, stance = _feet_from_cdr('reference_stance', data, with_position=False)
    return frame, stance


def foot_positions_to_cdr(centroids: np.ndarray, frame: int) -> bytes:
    """Return the serialized foot_positions: PoseArray of the sole centroids `(4, 3)` m (fl, fr, hl, hr; identity)."""
    return pose_array_cdr(_frame_stamp_pair(frame), WORLD_FRAME,
                          validate_array('foot positions', centroids, (len(FEET), 3)), _identity_quats())


def _identity_quats() -> np.ndarray:
    """Identity orientations xyzw `(4, 4)`, one per foot."""
    quats = np.zeros((len(FEET), 4))
    quats[:, 3] = 1.0
    return quats


def foot_positions_from_cdr(data: bytes) -> tuple[int, np.ndarray]:
    """(frame, sole centroids `(4, 3)` m) of a serialized foot_positions; InputError if it does not fit."""
    (sec, nsec), frame_id, positions, _ = pose_array_from_cdr(data, 'foot_positions')
    check_frame_id('foot_positions', frame_id)
    return _cdr_stamp_frame(sec, nsec), validate_array('foot_positions', positions, (len(FEET), 3))


def _feet_cdr(values: np.ndarray | None, flags: np.ndarray, frame: int) -> bytes:
    """Return a serialized JointState named FEET: position = `values` (None = empty), effort = `flags` as 1.0 / 0.0."""
    position, effort = _feet_arrays(values, flags)
    return joint_state_cdr(_frame_stamp_pair(frame), '', list(FEET), position, effort)


def _feet_arrays(values: np.ndarray | None, flags: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(position `(4,)` or `(0,)`, effort `(4,)` 1.0 / 0.0) of a feet JointState, or InputError."""
    shape = (0,) if values is None else (len(FEET),)
    position = validate_array('foot values', np.zeros(0) if values is None else values, shape)
    flags = np.asarray(flags, bool)
    if flags.shape != (len(FEET),):
        raise InputError(f'foot flags have shape {flags.shape}, expected ({len(FEET)},)')
    return position, flags.astype(np.float64)


def _feet_from_cdr(what: str, data: bytes, with_position: bool) -> tuple[int, np.ndarray | None, np.ndarray]:
    """(frame, position `(4,)` or None, effort flags `(4,)` bool) of a serialized JointState named FEET."""
    fields = joint_state_from_cdr(data, what)
    if tuple(fields['name']) != FEET:
        raise InputError(f'{what} names are {list(fields["name"])}, expected {list(FEET)}')
    flags = validate_array(f'{what} effort', fields['effort'], (len(FEET),))
    if not np.all((flags == 0.0) | (flags == 1.0)):
        raise InputError(f'{what} effort holds {flags.tolist()}, expected flags 0.0 or 1.0')
    heights = validate_array(f'{what} position', fields['position'], (len(FEET),)) if with_position else None
    return _cdr_stamp_frame(*fields['stamp']), heights, flags == 1.0
