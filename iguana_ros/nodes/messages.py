"""The pipeline's values as the topic table's messages, and back, with validation (float64 end to end)."""
from __future__ import annotations

import numpy as np

from iguana_ros.constants import FRAME_RATE, WORLD_FRAME
from iguana_ros.errors import InputError
from iguana_ros.motion.motion_graph import AlignedClip
from iguana_ros.nodes.base import frame_stamp, stamp_frame
from iguana_ros.nodes.conversions import (joint_state_msg, joint_state_positions, multi_dof_trajectory_msg,
                                          multi_dof_trajectory_to_numpy, odometry_msg, odometry_to_numpy,
                                          pose_array_msg, pose_array_to_numpy, validate_array)


def check_frame_id(what: str, frame_id: str) -> None:
    """InputError unless `frame_id` is the world frame."""
    if frame_id != WORLD_FRAME:
        raise InputError(f'{what} has frame_id {frame_id!r}, expected {WORLD_FRAME!r}')


def clip_to_msg(clip: AlignedClip, skeleton, start_frame: int):
    """MultiDOFJointTrajectory of a placed clip: bone 0 carries the root pose, the others their offsets."""
    n = len(clip.root_positions)
    translations = np.broadcast_to(skeleton.offsets, (n,) + skeleton.offsets.shape).copy()
    translations[:, 0] = clip.root_positions
    msg = multi_dof_trajectory_msg(np.arange(n) / FRAME_RATE, skeleton.names, translations,
                                   clip.local_rotations, stamp=frame_stamp(start_frame))
    msg.header.frame_id = WORLD_FRAME
    return msg


def clip_from_msg(msg, skeleton) -> tuple[int, AlignedClip]:
    """(start frame, placed clip) of a motion_clip message; InputError if it does not fit."""
    check_frame_id('motion_clip', msg.header.frame_id)
    _times, names, translations, rotations = multi_dof_trajectory_to_numpy(msg)
    if tuple(names) != tuple(skeleton.names):
        raise InputError(f'motion_clip joint_names do not match the skeleton ({len(names)} names, '
                         f'expected {skeleton.n_bones} starting {skeleton.names[:3]})')
    if len(translations) < 2:
        raise InputError(f'motion_clip has {len(translations)} points, expected at least 2')
    validate_array('motion_clip translations', translations, (None, skeleton.n_bones, 3))
    validate_array('motion_clip rotations', rotations, (None, skeleton.n_bones, 4))
    clip = AlignedClip(name='motion_clip', root_positions=translations[:, 0].copy(),
                       local_rotations=rotations, contacts=np.zeros((len(rotations), 4), bool), source=None)
    return stamp_frame(msg.header.stamp), clip


def reference_pose_to_msg(joint_positions: np.ndarray, joint_rotations: np.ndarray, frame: int):
    """PoseArray of world bone frames `(n_bones, 3)`, `(n_bones, 4)` stamped with `frame`."""
    return pose_array_msg(joint_positions, joint_rotations, stamp=frame_stamp(frame), frame_id=WORLD_FRAME)


def reference_pose_from_msg(msg, n_bones: int) -> tuple[int, np.ndarray, np.ndarray]:
    """(frame, positions `(n_bones, 3)`, rotations `(n_bones, 4)`) of a reference_pose message."""
    check_frame_id('reference_pose', msg.header.frame_id)
    positions, rotations = pose_array_to_numpy(msg)
    validate_array('reference_pose positions', positions, (n_bones, 3))
    validate_array('reference_pose orientations', rotations, (n_bones, 4))
    return stamp_frame(msg.header.stamp), positions, rotations


def lengths_to_msg(lengths: np.ndarray, frame: int):
    """JointState whose position holds the desired spring lengths `(n_springs,)` of `frame`."""
    return joint_state_msg(lengths, stamp=frame_stamp(frame))


def lengths_from_msg(msg, n_springs: int) -> tuple[int, np.ndarray]:
    """(frame, lengths `(n_springs,)`) of a spring_rest_lengths message; InputError if wrong or negative."""
    lengths = validate_array('spring_rest_lengths', joint_state_positions(msg), (n_springs,))
    if np.any(lengths < 0.0):
        raise InputError('spring_rest_lengths has negative lengths')
    return stamp_frame(msg.header.stamp), lengths


def state_to_msg(root: np.ndarray, orientation: np.ndarray, linear: np.ndarray, angular: np.ndarray,
                 frame: int):
    """Odometry of the iguana root at the start of `frame`."""
    return odometry_msg(root, orientation, linear, angular, stamp=frame_stamp(frame))


def state_from_msg(msg) -> tuple[int, np.ndarray, np.ndarray]:
    """(frame, root position `(3,)`, orientation `(4,)`) of an iguana_state message."""
    check_frame_id('iguana_state', msg.header.frame_id)
    position, orientation, _lin, _ang = odometry_to_numpy(msg)
    validate_array('iguana_state position', position, (3,))
    validate_array('iguana_state orientation', orientation, (4,))
    return stamp_frame(msg.header.stamp), position, orientation
