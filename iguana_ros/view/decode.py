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
The topic table's serialized messages into a `RunView`, one function per topic.

The live node and the bag reader both use these, on the bytes the nodes exchange, and they decode them with the nodes'
own `*_from_cdr` functions of ros/messages.py and their checks. Messages that do not fit their topic raise InputError;
the caller counts or logs them and goes on.
"""
from __future__ import annotations

import functools

import numpy as np

from iguana_ros.bag.frames import DEFAULT_MESH_RGBA, NS, scene_update
from iguana_ros.errors import InputError
from iguana_ros.geometry import yaw_of
from iguana_ros.ros.cdr import header_stamp_ns, marker_array_from_cdr, triangle_list_from_cdr
from iguana_ros.ros.messages import (clip_from_cdr, foot_positions_from_cdr, foot_state_from_cdr, push_from_cdr,
                                     stamp_of_cdr, state_twist_from_cdr)
from iguana_ros.view.scene import ClipEvent, identify_clip, MeshFrame, PushEvent, RunView


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


def take_state(view: RunView, data: bytes, wall: float) -> None:
    """Take a serialized iguana_state (Odometry) received at wall time `wall` s: root position, heading, speed."""
    _, position, quaternion, twist = state_twist_from_cdr(data)
    view.add_state(stamp_of_cdr(data), position, float(yaw_of(quaternion)), float(np.hypot(twist[0], twist[1])), wall)


def take_foot_state(view: RunView, data: bytes) -> None:
    """Take a serialized foot_state (JointState named by foot): which feet touch the ground."""
    _, _, contact = foot_state_from_cdr(data)
    view.add_feet(stamp_of_cdr(data), contact=contact)


def take_foot_positions(view: RunView, data: bytes) -> None:
    """Take a serialized foot_positions (PoseArray): the sole centroids of the feet."""
    _, centroids = foot_positions_from_cdr(data)
    view.add_feet(stamp_of_cdr(data), positions=centroids)


@functools.lru_cache(maxsize=1)
def _skeleton():
    """Return the iguana skeleton the terrain adaptation node checks a motion_clip against."""
    from iguana_ros.body.skeleton import iguana_skeleton
    return iguana_skeleton()


def take_clip(view: RunView, data: bytes, library: dict) -> None:
    """Take a serialized motion_clip (MultiDOFJointTrajectory): the clip playing from its stamp, named by `library`."""
    _, clip = clip_from_cdr(data, _skeleton())
    view.add_clip(ClipEvent(stamp_of_cdr(data), identify_clip(clip.local_rotations, library)))


def take_push(view: RunView, data: bytes, time: float, duration: float) -> None:
    """Take a serialized push (WrenchStamped) that acts from simulated time `time` s for `duration` s."""
    request = push_from_cdr(data)
    view.add_push(PushEvent(time, request.force, request.region, duration))
