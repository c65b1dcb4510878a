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
Vectorised conversions between numpy arrays and the ROS messages of the topic table.

Quaternions are xyzw everywhere (ROS and scipy order). Times are float seconds on the numpy side.
Message construction is bounded by the Python message classes (one object per point); the large per-frame mesh
marker is built and read as serialized bytes with numpy by the CDR codec, `iguana_ros.ros.cdr`.
"""
from __future__ import annotations

import array
from collections.abc import Sequence

from builtin_interfaces.msg import Duration, Time
from geometry_msgs.msg import (Point, Pose, PoseArray, PoseStamped, Quaternion, Transform,
                               Twist, Vector3, Wrench, WrenchStamped)
from nav_msgs.msg import Odometry
import numpy as np
from sensor_msgs.msg import JointState
from std_msgs.msg import ColorRGBA, Header
from trajectory_msgs.msg import MultiDOFJointTrajectory, MultiDOFJointTrajectoryPoint
from visualization_msgs.msg import Marker, MarkerArray

from iguana_ros.constants import BASE_FRAME, FRAME_RATE, WORLD_FRAME
from iguana_ros.errors import InputError
from iguana_ros.validation import validate_array  # noqa: F401 (the one definition, re-exported here)

_NS_PER_S = 1_000_000_000


# ----------------------------------------------------------------------------- time

def time_to_msg(seconds: float) -> Time:
    """builtin_interfaces/Time for a time in seconds (>= 0)."""
    ns = int(round(float(seconds) * _NS_PER_S))
    if ns < 0:
        raise InputError(f'time {seconds} s is negative; builtin_interfaces/Time needs >= 0')
    return Time(sec=ns // _NS_PER_S, nanosec=ns % _NS_PER_S)


def time_from_msg(stamp: Time | Duration) -> float:
    """Seconds of a builtin_interfaces/Time or Duration."""
    return stamp.sec + stamp.nanosec * 1e-9


def frame_stamp(frame: int) -> Time:
    """builtin_interfaces/Time of the start of frame `frame` (1/30 s frames of simulated time)."""
    return time_to_msg(frame / FRAME_RATE)


def stamp_frame(stamp) -> int:
    """Frame index of a stamp produced by `frame_stamp`."""
    return int(round(time_from_msg(stamp) * FRAME_RATE))


def _header(stamp: float | Time, frame_id: str) -> Header:
    """std_msgs/Header from seconds or a Time."""
    return Header(stamp=stamp if isinstance(stamp, Time) else time_to_msg(stamp), frame_id=frame_id)


# ----------------------------------------------------------------------------- poses

def poses_to_msgs(positions, quaternions) -> list[Pose]:
    """List of Pose from positions `(n, 3)` and quaternions `(n, 4)` xyzw."""
    pos = validate_array('positions', positions, (None, 3))
    quat = validate_array('quaternions', quaternions, (pos.shape[0], 4))
    return [Pose(position=Point(x=px, y=py, z=pz), orientation=Quaternion(x=qx, y=qy, z=qz, w=qw))
            for (px, py, pz), (qx, qy, qz, qw) in zip(pos.tolist(), quat.tolist())]


def poses_from_msgs(poses: Sequence[Pose]) -> tuple[np.ndarray, np.ndarray]:
    """Positions `(n, 3)` and quaternions `(n, 4)` xyzw of a sequence of Pose."""
    pos = np.array([(p.position.x, p.position.y, p.position.z) for p in poses],
                   dtype=np.float64).reshape(-1, 3)
    quat = np.array([(p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w)
                     for p in poses], dtype=np.float64).reshape(-1, 4)
    return pos, quat


def pose_array_msg(positions, quaternions, stamp: float | Time = 0.0,
                   frame_id: str = WORLD_FRAME) -> PoseArray:
    """geometry_msgs/PoseArray from positions `(n, 3)` and quaternions `(n, 4)`."""
    return PoseArray(header=_header(stamp, frame_id), poses=poses_to_msgs(positions, quaternions))


def pose_array_to_numpy(msg: PoseArray) -> tuple[np.ndarray, np.ndarray]:
    """Positions `(n, 3)` and quaternions `(n, 4)` of a PoseArray."""
    return poses_from_msgs(msg.poses)


def pose_stamped_msg(position, quaternion, stamp: float | Time = 0.0,
                     frame_id: str = WORLD_FRAME) -> PoseStamped:
    """geometry_msgs/PoseStamped from a position `(3,)` and quaternion `(4,)` xyzw."""
    pos = validate_array('position', position, (3,))
    quat = validate_array('quaternion', quaternion, (4,))
    return PoseStamped(header=_header(stamp, frame_id), pose=poses_to_msgs(pos[None], quat[None])[0])


def pose_stamped_to_numpy(msg: PoseStamped) -> tuple[np.ndarray, np.ndarray]:
    """Position `(3,)` and quaternion `(4,)` of a PoseStamped."""
    pos, quat = poses_from_msgs([msg.pose])
    return pos[0], quat[0]


# ----------------------------------------------------------------------------- stamped float arrays

def joint_state_msg(values, stamp: float | Time = 0.0, names: Sequence[str] | None = None,
                    frame_id: str = '') -> JointState:
    """sensor_msgs/JointState whose `position` holds `values` `(n,)`; `name` optional (n strings)."""
    arr = validate_array('values', values, (None,))
    if names is not None and len(names) != arr.shape[0]:
        raise InputError(f'names has {len(names)} entries, expected {arr.shape[0]} (one per value)')
    msg = JointState(header=_header(stamp, frame_id))
    msg.position = array.array('d', arr.tobytes())
    if names is not None:
        msg.name = [str(n) for n in names]
    return msg


def joint_state_positions(msg: JointState) -> np.ndarray:
    """JointState.position as a float64 array `(n,)`."""
    return np.array(msg.position, dtype=np.float64)


# ----------------------------------------------------------------------------- odometry

def odometry_msg(position, quaternion, linear_velocity, angular_velocity,
                 stamp: float | Time = 0.0, frame_id: str = WORLD_FRAME,
                 child_frame_id: str = BASE_FRAME) -> Odometry:
    """nav_msgs/Odometry from position `(3,)`, quaternion `(4,)`, linear and angular velocity `(3,)`."""
    lin = validate_array('linear_velocity', linear_velocity, (3,))
    ang = validate_array('angular_velocity', angular_velocity, (3,))
    msg = Odometry(header=_header(stamp, frame_id), child_frame_id=child_frame_id)
    msg.pose.pose = pose_stamped_msg(position, quaternion).pose
    msg.twist.twist = Twist(linear=Vector3(x=lin[0], y=lin[1], z=lin[2]),
                            angular=Vector3(x=ang[0], y=ang[1], z=ang[2]))
    return msg


def odometry_to_numpy(msg: Odometry) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Position `(3,)`, quaternion `(4,)`, linear `(3,)` and angular `(3,)` velocity of an Odometry."""
    pos, quat = poses_from_msgs([msg.pose.pose])
    lin, ang = msg.twist.twist.linear, msg.twist.twist.angular
    return pos[0], quat[0], np.array([lin.x, lin.y, lin.z]), np.array([ang.x, ang.y, ang.z])


# ----------------------------------------------------------------------------- pushes

def push_msg(force, region: str, stamp: float | Time = 0.0) -> WrenchStamped:
    """
    Return the geometry_msgs/WrenchStamped of a push.

    The force `(3,)` N acts in the world frame on the node group `region` (header.frame_id, e.g. 'trunk_left'); there is
    no torque.
    """
    f = validate_array('force', force, (3,))
    return WrenchStamped(header=_header(stamp, region), wrench=Wrench(force=Vector3(x=f[0], y=f[1], z=f[2])))


# ----------------------------------------------------------------------------- trajectories

def multi_dof_trajectory_msg(times, joint_names: Sequence[str], translations, rotations,
                             stamp: float | Time = 0.0,
                             frame_id: str = WORLD_FRAME) -> MultiDOFJointTrajectory:
    """
    Return a MultiDOFJointTrajectory from times, names, translations and rotations.

    The times are `(n_frames,)` s, the translations `(n_frames, n_joints, 3)` and the rotations
    `(n_frames, n_joints, 4)` xyzw.
    """
    t = validate_array('times', times, (None,))
    n_joints = len(joint_names)
    trans = validate_array('translations', translations, (t.shape[0], n_joints, 3))
    rot = validate_array('rotations', rotations, (t.shape[0], n_joints, 4))
    points = [MultiDOFJointTrajectoryPoint(
        transforms=[Transform(translation=Vector3(x=tx, y=ty, z=tz),
                              rotation=Quaternion(x=qx, y=qy, z=qz, w=qw))
                    for (tx, ty, tz), (qx, qy, qz, qw) in zip(frame_t, frame_r)],
        time_from_start=Duration(sec=int(ns // _NS_PER_S), nanosec=int(ns % _NS_PER_S)))
        for frame_t, frame_r, ns in zip(trans.tolist(), rot.tolist(),
                                        np.round(t * _NS_PER_S).astype(np.int64).tolist())]
    return MultiDOFJointTrajectory(header=_header(stamp, frame_id),
                                   joint_names=[str(n) for n in joint_names], points=points)


def multi_dof_trajectory_to_numpy(msg: MultiDOFJointTrajectory
                                  ) -> tuple[np.ndarray, list[str], np.ndarray, np.ndarray]:
    """
    Return times `(n_frames,)`, joint names, translations `(n_frames, n_joints, 3)`, rotations `(..., 4)`.

    InputError if a point holds another number of transforms than there are joint names.
    """
    n_joints = len(msg.joint_names)
    counts = {len(p.transforms) for p in msg.points}
    if counts - {n_joints}:
        raise InputError(f'trajectory points hold {sorted(counts)} transforms, expected {n_joints} '
                         '(one per joint name)')
    times = np.array([time_from_msg(p.time_from_start) for p in msg.points], dtype=np.float64)
    trans = np.array([[(tf.translation.x, tf.translation.y, tf.translation.z) for tf in p.transforms]
                      for p in msg.points], dtype=np.float64).reshape(-1, n_joints, 3)
    rot = np.array([[(tf.rotation.x, tf.rotation.y, tf.rotation.z, tf.rotation.w)
                     for tf in p.transforms] for p in msg.points],
                   dtype=np.float64).reshape(-1, n_joints, 4)
    return times, list(msg.joint_names), trans, rot


# ----------------------------------------------------------------------------- triangle-list markers

def triangle_soup(vertices, triangles, colors) -> tuple[np.ndarray, np.ndarray]:
    """Per-corner points `(3*n_t, 3)` and RGBA `(3*n_t, 4)` from an indexed mesh (validated)."""
    verts = validate_array('vertices', vertices, (None, 3))
    rgba = validate_array('colors', colors, (verts.shape[0], 4))
    tris = np.asarray(triangles)
    if tris.ndim != 2 or tris.shape[1] != 3 or not np.issubdtype(tris.dtype, np.integer):
        raise InputError(f'triangles has shape {tris.shape} and dtype {tris.dtype}, '
                         f'expected integer (n_t, 3)')
    if tris.size and (tris.min() < 0 or tris.max() >= verts.shape[0]):
        raise InputError(f'triangles index vertices outside 0..{verts.shape[0] - 1}')
    corners = tris.reshape(-1)
    return np.take(verts, corners, axis=0), np.take(rgba, corners, axis=0)   # 3-8x faster than verts[corners]


def triangle_list_marker(vertices, triangles, colors, stamp: float | Time = 0.0,
                         frame_id: str = WORLD_FRAME, ns: str = 'iguana',
                         marker_id: int = 0) -> Marker:
    """
    TRIANGLE_LIST Marker from vertices `(n_v, 3)`, triangles `(n_t, 3)` and RGBA `(n_v, 4)` in [0, 1].

    points/colors get 3*n_t entries; color.a = 1, scale = 1, identity pose so RViz2 and Foxglove draw it.
    """
    points, rgba = triangle_soup(vertices, triangles, colors)
    msg = Marker(header=_header(stamp, frame_id), ns=ns, id=int(marker_id),
                 type=Marker.TRIANGLE_LIST, action=Marker.ADD)
    msg.pose.orientation.w = 1.0
    msg.scale = Vector3(x=1.0, y=1.0, z=1.0)
    msg.color = ColorRGBA(r=1.0, g=1.0, b=1.0, a=1.0)
    msg.points = [Point(x=x, y=y, z=z) for x, y, z in points.tolist()]
    msg.colors = [ColorRGBA(r=r, g=g, b=b, a=a)
                  for r, g, b, a in rgba.astype(np.float32).tolist()]
    return msg


def triangle_list_from_marker(msg: Marker) -> tuple[np.ndarray, np.ndarray]:
    """Points `(3*n_t, 3)` and per-point RGBA `(3*n_t, 4)` of a TRIANGLE_LIST Marker."""
    points = np.array([(p.x, p.y, p.z) for p in msg.points], dtype=np.float64).reshape(-1, 3)
    colors = np.array([(c.r, c.g, c.b, c.a) for c in msg.colors], dtype=np.float64).reshape(-1, 4)
    return points, colors


def marker_array_msg(markers: Sequence[Marker], delete_all_first: bool = False) -> MarkerArray:
    """`MarkerArray` of `markers`, optionally preceded by a DELETEALL marker that clears old ones."""
    items = list(markers)
    if delete_all_first:
        items.insert(0, Marker(action=Marker.DELETEALL))
    return MarkerArray(markers=items)
