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

"""Bag -> RecordedRun: times, subsampling, root poses, terrain, goals and the MarkerArray CDR reader."""
import math

import numpy as np
import pytest

from iguana_ros.bag.frames import match_topic, read_run
from iguana_ros.errors import InputError
from iguana_ros.ros.cdr import marker_array_from_cdr
from render_synthetic import (box_mesh, GOAL, GOAL_DIAMETER, GOAL_RGBA, RATE, root_pose, TERRAIN_RGBA,
                              write_synthetic_bag)


def _box_corners(t):
    verts, tris = box_mesh()
    pos, yaw = root_pose(t)
    c, s = math.cos(yaw), math.sin(yaw)
    return (verts @ np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]]) + pos)[tris.reshape(-1)]


def test_all_frames_with_odometry_terrain_and_goal(synthetic_bag):
    run = read_run(synthetic_bag)
    assert run.n_frames == 61 and np.allclose(run.times, np.arange(61) / RATE)
    assert run.mesh_topic == '/mesh_marker' and run.duration == pytest.approx(2.0)
    assert np.allclose(run.mesh_points[30], _box_corners(1.0), atol=1e-6)
    expected = np.array([root_pose(t)[0] for t in run.times])
    assert np.allclose(run.root_positions, expected) and np.allclose(run.track_positions, expected)
    assert np.allclose(run.root_yaws, [root_pose(t)[1] for t in run.times])
    assert run.terrain_points.shape == (23 * 23 * 2 * 3, 3)
    assert np.allclose(run.terrain_colors, TERRAIN_RGBA)
    goal = run.goals_at(1.0)
    assert np.allclose(goal.positions, [GOAL]) and np.allclose(goal.radii, GOAL_DIAMETER / 2)
    assert np.allclose(goal.colors, [GOAL_RGBA])


def test_fps_window_and_nearest_frame(synthetic_bag):
    assert np.allclose(read_run(synthetic_bag, fps=15).times, np.arange(31) * 2 / RATE)
    window = read_run(synthetic_bag, fps=10, start=0.5, end=1.5)
    assert np.allclose(window.times, 0.5 + 0.1 * np.arange(11))
    assert window.track_times[-1] == pytest.approx(1.5)        # trail ends at the last frame
    one = read_run(synthetic_bag, at=1.01)
    assert one.n_frames == 1 and one.times[0] == pytest.approx(1.0)
    last = read_run(synthetic_bag, at=math.inf)
    assert last.times[0] == pytest.approx(2.0) and len(last.track_times) == 61


def test_without_odometry_or_stamps(tmp_path):
    bag = write_synthetic_bag(tmp_path / 'plain', duration=1.0, odometry=False, scene=False,
                              stamped=False)
    run = read_run(bag)
    assert np.allclose(run.times, np.arange(31) / RATE, atol=1e-6)   # receive times when stamps stay 0
    assert run.root_yaws is None and run.terrain_points is None and run.goals_at(0.0) is None
    centres = np.array([root_pose(t)[0] for t in np.arange(31) / RATE])
    assert np.allclose(run.root_positions, centres, atol=1e-6)      # box centroid = root


def test_sim_time_stamps_are_used_over_receive_times(tmp_path):
    run = read_run(write_synthetic_bag(tmp_path / 'late', duration=0.5, t_start=100.0))
    assert np.allclose(run.times, np.arange(16) / RATE)


def test_goals_change_when_the_simulator_republishes_the_scene(tmp_path):
    run = read_run(write_synthetic_bag(tmp_path / 'goals', duration=2.0, second_goal=(-1.0, 0.5, 0.0)))
    assert np.allclose(run.goals_at(0.9).positions, [GOAL])
    assert np.allclose(run.goals_at(1.0).positions, [GOAL, (-1.0, 0.5, 0.0)])
    assert [g.time for g in run.goals] == pytest.approx([0.0, 1.0], abs=1e-3)


def test_truncated_bag_and_non_finite_frames_are_reported(tmp_path):
    import struct

    from iguana_ros.bag.storage import BagWriter
    from iguana_ros.ros.cdr import triangle_list_marker_cdr
    from iguana_ros.topics import topic
    bag = write_synthetic_bag(tmp_path / 'full', duration=2.0, scene=False, chunk_bytes=4096)
    data = (bag / 'full.mcap').read_bytes()
    (tmp_path / 'cut.mcap').write_bytes(data[:len(data) // 2])
    run = read_run(tmp_path / 'cut.mcap')
    assert 5 < run.n_frames < 61 and np.allclose(run.times, np.arange(run.n_frames) / RATE)
    assert len(run.notes) == 1 and run.damage.startswith('truncated: ') and 'cut.mcap' in run.notes[0]
    writer = BagWriter(tmp_path / 'nan')
    spec = topic('mesh_marker')
    channel = writer.add_topic('/' + spec.name, spec.type, '')
    verts, tris = box_mesh()
    for k in range(3):
        shifted = verts + [0.0, 0.0, 12345.0 * (k == 1)]
        msg = triangle_list_marker_cdr(shifted, tris, np.ones((8, 4)), stamp=k / RATE)
        msg = msg.replace(struct.pack('<d', 12345.0 - 0.05), struct.pack('<d', float('nan')))
        writer.write(channel, msg, 10**9 + k)
    writer.close()
    run = read_run(tmp_path / 'nan')
    assert run.n_frames == 2 and run.notes == ['skipped 1 mesh frame(s) with NaN or Inf coordinates']


def test_missing_mesh_is_a_clear_error(tmp_path, synthetic_bag):
    bag = write_synthetic_bag(tmp_path / 'nomesh', duration=0.2, mesh=False)
    with pytest.raises(InputError, match='has no /mesh_marker messages'):
        read_run(bag)
    with pytest.raises(InputError, match=r'no /mesh_marker frames between 5 s and 6 s \(the run spans 0 to 2.00 s\)'):
        read_run(synthetic_bag, start=5.0, end=6.0)
    with pytest.raises(InputError, match='no bag at'):
        read_run(tmp_path / 'absent')


def test_match_topic_prefers_absolute_then_namespaced():
    assert match_topic(['/a/mesh_marker', '/mesh_marker'], 'mesh_marker') == '/mesh_marker'
    assert match_topic(['/b/mesh_marker', '/a/mesh_marker'], 'mesh_marker') == '/a/mesh_marker'
    assert match_topic(['/other'], 'mesh_marker') is None


def test_marker_array_reader_matches_rclpy():
    from rclpy.serialization import serialize_message
    from visualization_msgs.msg import Marker, MarkerArray, UVCoordinate

    from iguana_ros.ros.conversions import triangle_list_marker
    tri = triangle_list_marker(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.5]]), np.array([[0, 1, 2]]),
                               np.array([[1, 0, 0, 1], [0, 1, 0, 1], [0, 0, 1, 1.0]]), ns='terrain')
    tri.texture_resource = 'file://x.png'
    tri.texture.format = 'png'
    tri.texture.data = [1, 2, 3, 4, 5]
    tri.uv_coordinates = [UVCoordinate(u=0.1, v=0.2)] * 3
    odd = Marker(ns='goal', id=7, type=Marker.SPHERE, text='hello', mesh_resource='pkg://m.dae')
    odd.mesh_file.filename = 'm.stl'
    odd.mesh_file.data = [9] * 7
    odd.pose.position.x, odd.pose.orientation.w, odd.scale.x = 2.5, 1.0, 0.3
    odd.color.g = 0.75
    markers = marker_array_from_cdr(serialize_message(MarkerArray(markers=[tri, odd, Marker(action=3)])))
    assert [m.ns for m in markers] == ['terrain', 'goal', ''] and [m.action for m in markers] == [0, 0, 3]
    assert np.allclose(markers[0].points, [[0, 0, 0], [1, 0, 0], [0, 1, 0.5]])
    assert np.allclose(markers[0].colors[:, :3], np.eye(3))
    assert markers[1].type == Marker.SPHERE and np.allclose(markers[1].position, [2.5, 0, 0])
    assert markers[1].scale[0] == pytest.approx(0.3) and markers[1].color[1] == pytest.approx(0.75)
    assert markers[1].points.shape == (0, 3)
    with pytest.raises(InputError, match='truncated or not a MarkerArray'):
        marker_array_from_cdr(serialize_message(MarkerArray(markers=[tri]))[:60])


def test_terrain_marker_pose_and_scale_are_applied(tmp_path):
    from rclpy.serialization import serialize_message

    from iguana_ros.bag.frames import marker_triangles
    from iguana_ros.ros.conversions import marker_array_msg, triangle_list_marker
    m = triangle_list_marker(np.array([[1.0, 0, 0], [0, 1, 0], [0, 0, 1]]), np.array([[0, 1, 2]]),
                             np.ones((3, 4)), ns='terrain')
    m.scale.x = m.scale.y = m.scale.z = 2.0
    m.pose.position.x = 10.0
    m.pose.orientation.z, m.pose.orientation.w = math.sin(math.pi / 4), math.cos(math.pi / 4)  # +90 deg yaw
    points, _ = marker_triangles(marker_array_from_cdr(serialize_message(marker_array_msg([m])))[0])
    assert np.allclose(points, [[10, 2, 0], [8, 0, 0], [10, 0, 2]])
