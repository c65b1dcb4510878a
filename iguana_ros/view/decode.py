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
The topic table's messages into a `RunView`, one function per topic.

The live node and the bag reader both use these. Messages that do not fit their topic (the decoders of ros/messages.py
decide) raise InputError; the caller counts or logs them and goes on.
"""
from __future__ import annotations

import numpy as np

from iguana_ros.bag.frames import DEFAULT_MESH_RGBA, NS, scene_update
from iguana_ros.errors import InputError
from iguana_ros.geometry import yaw_of
from iguana_ros.ros.cdr import header_stamp_ns, marker_array_from_cdr, triangle_list_from_cdr
from iguana_ros.ros.conversions import multi_dof_trajectory_to_numpy, odometry_to_numpy, time_from_msg
from iguana_ros.ros.messages import foot_positions_from_msg, foot_state_from_msg
from iguana_ros.view.scene import ClipEvent, identify_clip, MeshFrame, PushEvent, RunView

DEFAULT_PUSH_REGION = 'trunk_left'
"""The region of a push whose header.frame_id is empty (as the simulator reads it)."""


def take_mesh(view: RunView, data: bytes) -> None:
    """Take a serialized mesh_marker (TRIANGLE_LIST): the iguana's surface at its stamp."""
    points, colors = triangle_list_from_cdr(data)
    if len(points) < 3 or not np.isfinite(points).all():
        raise InputError(f'mesh_marker with {len(points)} points, or NaN/Inf coordinates')
    if len(colors) != len(points):
        colors = np.tile(DEFAULT_MESH_RGBA, (len(points), 1))
    view.add_mesh(MeshFrame(header_stamp_ns(data) / NS, points.astype(np.float32), colors.astype(np.float32)))


def take_scene(view: RunView, data: bytes, time: float) -> None:
    """Take a serialized scene_markers (MarkerArray) received at simulated time `time` s: terrain and goals."""
    terrain, goals = scene_update(marker_array_from_cdr(data), time)
    if terrain is not None:
        view.set_terrain(*terrain)
    for goal in goals:
        view.add_goals(goal)


def take_state(view: RunView, msg, wall: float) -> None:
    """Take an iguana_state (Odometry) received at wall time `wall` s: root position, heading, horizontal speed."""
    position, quaternion, linear, _ = odometry_to_numpy(msg)
    if not (np.isfinite(position).all() and np.isfinite(quaternion).all() and np.isfinite(linear).all()):
        raise InputError('iguana_state with NaN or Inf values')
    view.add_state(time_from_msg(msg.header.stamp), position, float(yaw_of(quaternion)),
                   float(np.hypot(linear[0], linear[1])), wall)


def take_foot_state(view: RunView, msg) -> None:
    """Take a foot_state (JointState named by foot): which feet touch the ground."""
    _, _, contact = foot_state_from_msg(msg)
    view.add_feet(time_from_msg(msg.header.stamp), contact=contact)


def take_foot_positions(view: RunView, msg) -> None:
    """Take a foot_positions (PoseArray): the sole centroids of the feet."""
    _, centroids = foot_positions_from_msg(msg)
    view.add_feet(time_from_msg(msg.header.stamp), positions=centroids)


def take_clip(view: RunView, msg, library: dict) -> None:
    """Take a motion_clip (MultiDOFJointTrajectory): the clip playing from its stamp, named from `library`."""
    _, _, _, rotations = multi_dof_trajectory_to_numpy(msg)
    view.add_clip(ClipEvent(time_from_msg(msg.header.stamp), identify_clip(rotations, library)))


def take_push(view: RunView, msg, time: float, duration: float) -> None:
    """Take a push (WrenchStamped) that acts from simulated time `time` s for `duration` s."""
    force = np.array([msg.wrench.force.x, msg.wrench.force.y, msg.wrench.force.z])
    if not np.isfinite(force).all():
        raise InputError('push with a NaN or Inf force')
    view.add_push(PushEvent(time, force, msg.header.frame_id or DEFAULT_PUSH_REGION, duration))
