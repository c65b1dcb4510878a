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

"""Camera projection and presets against hand-computed positions."""
import numpy as np
import pytest

from iguana_ros.errors import InputError
from iguana_ros.render.camera import (Camera, FOLLOW_OFFSET, heading_track, ORBIT_HEIGHT, ORBIT_PERIOD, ORBIT_RADIUS,
                                      preset_cameras)

W, H = 200, 100


def test_perspective_projection_of_axis_and_frustum_edge():
    cam = Camera.look_at([0, 0, 0], [10, 0, 0], fov_deg=90.0)
    pts = cam.to_camera(np.array([[4.0, 0, 0], [4.0, 0, 4.0], [4.0, -4.0, 0]]))
    xy, key, q = cam.project(pts, W, H)
    assert np.allclose(xy[0], [W / 2, H / 2])                   # on the optical axis: image centre
    assert np.allclose(xy[1], [W / 2, 0.0])                     # 45 deg up with a 90 deg fov: top edge
    assert np.allclose(xy[2], [W / 2 + H / 2, H / 2])           # world -y is image right when looking +x
    assert np.allclose(key, 0.25) and np.allclose(q, 0.25)


def test_orthographic_projection_scale_and_keys():
    cam = Camera(np.array([0.0, 0, 10]), np.array([0.0, 0, -1]), np.array([0.0, 1, 0]), ortho_height=2.0)
    pts = cam.to_camera(np.array([[0.0, 0, 0], [1.0, 1.0, 3.0]]))
    xy, key, _ = cam.project(pts, W, H)
    assert np.allclose(xy, [[100, 50], [150, 0]])               # 50 px per m, x right, y up
    assert key[1] > key[0]                                      # higher point is nearer a top camera


def _straight_track(n=90, speed=0.5, rate=30.0):
    t = np.arange(n) / rate
    return t, np.stack([speed * t, np.zeros(n), np.full(n, 0.05)], axis=1)


def test_follow_camera_sits_behind_left_above_the_root():
    t, pos = _straight_track()
    cams = preset_cameras('follow', t, pos, np.zeros(len(t)), pos, W / H)
    mid = len(t) // 2
    assert np.allclose(cams[mid].eye - pos[mid], FOLLOW_OFFSET, atol=1e-6)
    # the same with the track turned by 90 deg and heading taken from the motion (no yaw)
    rot = np.array([[0.0, -1, 0], [1, 0, 0], [0, 0, 1]])
    cams = preset_cameras('follow', t, pos @ rot.T, None, pos, W / H)
    assert np.allclose(cams[mid].eye - (pos @ rot.T)[mid], rot @ FOLLOW_OFFSET, atol=1e-6)


def test_heading_from_motion_holds_while_stopped():
    t = np.arange(120) / 30.0
    x = np.where(t < 2.0, 0.5 * t, 1.0)                         # walks along +y then stands still
    pos = np.stack([np.zeros_like(t), x, np.zeros_like(t)], axis=1)
    heading = heading_track(t, pos, None)
    assert np.allclose(heading, np.pi / 2, atol=1e-6)


def test_orbit_revolves_once_per_period():
    t = np.linspace(0.0, ORBIT_PERIOD, 121)
    pos = np.zeros((len(t), 3))
    cams = preset_cameras('orbit', t, pos, np.zeros(len(t)), pos, W / H)
    eyes = np.array([c.eye for c in cams])
    assert np.allclose(eyes[0], [-ORBIT_RADIUS, 0, ORBIT_HEIGHT])  # starts behind a root heading +x
    assert np.allclose(eyes[60], [ORBIT_RADIUS, 0, ORBIT_HEIGHT], atol=1e-9)
    assert np.allclose(eyes[-1], eyes[0], atol=1e-9)


@pytest.mark.parametrize('preset', ['side', 'top'])
def test_static_views_frame_every_point(preset):
    t, pos = _straight_track()
    extent = np.concatenate([pos, pos + [0, 0.3, 0], pos - [0, 0.3, 0]])
    cams = preset_cameras(preset, t, pos, None, extent, W / H)
    assert all(c is cams[0] for c in cams) and cams[0].orthographic
    xy, _, _ = cams[0].project(cams[0].to_camera(extent), W, H)
    assert xy[:, 0].min() > 0 and xy[:, 0].max() < W and xy[:, 1].min() > 0 and xy[:, 1].max() < H
    # the travel direction (+x) runs left to right in the image
    first, last = cams[0].project(cams[0].to_camera(pos[[0, -1]]), W, H)[0]
    assert last[0] - first[0] > 0.5 * W


def test_unknown_preset_is_an_input_error():
    t, pos = _straight_track(3)
    with pytest.raises(InputError, match="unknown camera 'fish'"):
        preset_cameras('fish', t, pos, None, pos, 1.0)
