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

"""Synthetic bags for the render tests: a box 'iguana' driving along an arc over a wavy terrain."""
from __future__ import annotations

import math

import numpy as np

BOX = (0.6, 0.2, 0.1)          # length, width, height of the box body (m)
RATE = 30.0                    # mesh / odometry rate (Hz)
SPEED = 0.5                    # m/s along the arc
TURN_RATE = 0.4                # rad/s
GOAL = (1.6, 1.0, 0.0)
GOAL_DIAMETER = 0.2
GOAL_RGBA = (0.9, 0.1, 0.1, 1.0)
TERRAIN_RGBA = (0.75, 0.70, 0.55, 1.0)


def terrain_height(x, y):
    """Wavy terrain height (m)."""
    return 0.03 * np.sin(2.0 * x) * np.cos(1.5 * y)


def box_mesh():
    """Vertices (8, 3) centred at the origin and outward triangles (12, 3) of the box."""
    lx, ly, lz = BOX
    v = np.array([[x, y, z] for x in (-lx / 2, lx / 2) for y in (-ly / 2, ly / 2) for z in (-lz / 2, lz / 2)])
    tris = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                     [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])
    return v, tris


def root_pose(t):
    """Root position (3,) and yaw (rad) at time t on the arc (starts at the origin heading +x)."""
    yaw = TURN_RATE * t
    r = SPEED / TURN_RATE
    x, y = r * math.sin(yaw), r * (1.0 - math.cos(yaw))
    return np.array([x, y, float(terrain_height(x, y)) + BOX[2] / 2]), yaw


def terrain_mesh(n=24, half=3.0):
    """Grid vertices, triangles and colours of the wavy terrain."""
    axis = np.linspace(-half, half, n)
    gx, gy = np.meshgrid(axis, axis, indexing='ij')
    verts = np.stack([gx.ravel(), gy.ravel(), terrain_height(gx, gy).ravel()], axis=1)
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    tris = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    return verts, tris, np.tile(TERRAIN_RGBA, (len(verts), 1))


def _scene_bytes(*goals):
    """Return serialized MarkerArray: the terrain (stamp 0, like the simulator's) and one sphere per goal."""
    from rclpy.serialization import serialize_message
    from visualization_msgs.msg import Marker

    from iguana_ros.ros.conversions import marker_array_msg, triangle_list_marker
    tv, tt, tc = terrain_mesh()
    markers = [triangle_list_marker(tv, tt, tc, ns='terrain')]
    for i, position in enumerate(goals):
        goal = Marker(ns='goal', id=i, type=Marker.SPHERE, action=Marker.ADD)
        goal.header.frame_id = 'world'
        goal.pose.position.x, goal.pose.position.y, goal.pose.position.z = position
        goal.pose.orientation.w = 1.0
        goal.scale.x = goal.scale.y = goal.scale.z = GOAL_DIAMETER
        goal.color.r, goal.color.g, goal.color.b, goal.color.a = GOAL_RGBA
        markers.append(goal)
    return serialize_message(marker_array_msg(markers))


def write_synthetic_bag(directory, duration=2.0, odometry=True, scene=True, mesh=True, stamped=True,
                        t_start=0.0, second_goal=None, chunk_bytes=768 * 1024, strays=False):
    """
    Write a bag of the synthetic run; returns the bag directory.

    `strays`: a sound bag with payloads that do not decode besides, at 0.5 s: a mesh Marker on iguana_state, a cut
    mesh_marker and a cut scene_markers.
    """
    from rclpy.serialization import serialize_message

    from iguana_ros.bag.schema import message_definition
    from iguana_ros.bag.storage import BagWriter
    from iguana_ros.geometry import quat_from_yaw
    from iguana_ros.ros.cdr import triangle_list_marker_cdr
    from iguana_ros.ros.conversions import odometry_msg
    from iguana_ros.topics import topic

    writer = BagWriter(directory, chunk_bytes=chunk_bytes)
    channels = {}
    for key in ('mesh_marker', 'iguana_state', 'scene_markers'):
        spec = topic(key)
        channels[key] = writer.add_topic('/' + spec.name, spec.type, message_definition(spec.type))
    base_ns = 1_700_000_000 * 10**9
    if scene:
        writer.write(channels['scene_markers'], _scene_bytes(GOAL), base_ns)
    verts, tris = box_mesh()
    colors = np.tile([0.3, 0.6, 0.3, 1.0], (len(verts), 1))
    for k in range(int(round(duration * RATE)) + 1):
        t = k / RATE
        pos, yaw = root_pose(t)
        c, s = math.cos(yaw), math.sin(yaw)
        world = verts @ np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]]) + pos
        stamp = t_start + t if stamped else 0.0
        log_ns = base_ns + int(t * 1e9) + 1000
        if mesh:
            writer.write(channels['mesh_marker'], triangle_list_marker_cdr(world, tris, colors, stamp=stamp), log_ns)
        if second_goal is not None and k == int(round(RATE)):   # a new goal arrives at t = 1 s
            writer.write(channels['scene_markers'], _scene_bytes(GOAL, second_goal), log_ns - 500)
        if odometry:
            msg = odometry_msg(pos, quat_from_yaw(yaw), [SPEED * c, SPEED * s, 0.0], [0.0, 0.0, TURN_RATE],
                               stamp=stamp)
            writer.write(channels['iguana_state'], serialize_message(msg), log_ns + 10)
        if strays and k == int(round(0.5 * RATE)):
            marker = triangle_list_marker_cdr(world, tris, colors, stamp=stamp)
            writer.write(channels['iguana_state'], marker, log_ns + 20)
            writer.write(channels['mesh_marker'], marker[:len(marker) // 2], log_ns + 30)
            writer.write(channels['scene_markers'], _scene_bytes(GOAL)[:200], log_ns + 40)
    writer.close()
    return directory


WORLD_RGBA = {'east': (0.3, 0.6, 0.3, 1.0), 'west': (0.25, 0.35, 0.9, 1.0)}
"""Box colours of the two characters of the synthetic world: green east, blue west."""


def world_pose(name, t):
    """Root position (3,) and yaw (rad) of a world character at time t: east drives +x at y = 1, west -x at y = -1."""
    if name == 'east':
        return np.array([SPEED * t, 1.0, 0.0]), 0.0
    return np.array([1.0 - SPEED * t, -1.0, 0.0]), math.pi


def world_frame_times(name, duration=2.0):
    """Stamps (s) of a world character's mesh frames: east every frame at RATE, west every other one."""
    step = 1 if name == 'east' else 2
    return [k / RATE for k in range(0, int(round(duration * RATE)) + 1, step)]


def write_world_bag(directory, duration=2.0):
    """
    Write a bag of a world of two box characters, east and west, on flat ground; returns the bag directory.

    Each has /NAME/mesh_marker and /NAME/iguana_state; the world /scene_markers. West's frames come at half the rate,
    recorded alternately before and after east's of the same stamp.
    """
    from rclpy.serialization import serialize_message

    from iguana_ros.bag.schema import message_definition
    from iguana_ros.bag.storage import BagWriter
    from iguana_ros.geometry import quat_from_yaw
    from iguana_ros.ros.cdr import triangle_list_marker_cdr
    from iguana_ros.ros.conversions import odometry_msg
    from iguana_ros.topics import topic

    writer = BagWriter(directory)
    spec = topic('scene_markers')
    scene = writer.add_topic('/' + spec.name, spec.type, message_definition(spec.type))
    channels = {}
    for name in WORLD_RGBA:
        for key in ('mesh_marker', 'iguana_state'):
            spec = topic(key)
            channels[name, key] = writer.add_topic(f'/{name}/{spec.name}', spec.type, message_definition(spec.type))
    base_ns = 1_700_000_000 * 10**9
    writer.write(scene, _scene_bytes(GOAL), base_ns)
    verts, tris = box_mesh()
    for k in range(int(round(duration * RATE)) + 1):
        t = k / RATE
        log_ns = base_ns + int(t * 1e9) + 1000
        names = ['east'] + (['west'] if k % 2 == 0 else [])
        for j, name in enumerate(names if k % 4 else names[::-1]):
            pos, yaw = world_pose(name, t)
            c, s = math.cos(yaw), math.sin(yaw)
            world = verts @ np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]]) + pos + [0.0, 0.0, BOX[2] / 2]
            colors = np.tile(WORLD_RGBA[name], (len(verts), 1))
            writer.write(channels[name, 'mesh_marker'], triangle_list_marker_cdr(world, tris, colors, stamp=t),
                         log_ns + 10 * j)
            msg = odometry_msg(pos, quat_from_yaw(yaw), [SPEED * c, 0.0, 0.0], [0.0, 0.0, 0.0], stamp=t)
            writer.write(channels[name, 'iguana_state'], serialize_message(msg), log_ns + 10 * j + 5)
    writer.close()
    return directory
