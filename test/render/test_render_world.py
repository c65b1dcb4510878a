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

"""A world's bag: every character drawn at each frame time, the cameras following the first or `--character`."""
import math

import numpy as np
from PIL import Image
import pytest

from iguana_ros.bag.frames import characters, read_run
from iguana_ros.cli import main
from iguana_ros.errors import InputError
from iguana_ros.render.camera import preset_cameras
from iguana_ros.render.renderer import Renderer
from render_synthetic import BOX, box_mesh, RATE, world_frame_times, world_pose, write_world_bag

W, H = 240, 160


@pytest.fixture(scope='module')
def world_bag(tmp_path_factory):
    """Return the two-character synthetic world bag (east at RATE, west at half of it)."""
    return write_world_bag(tmp_path_factory.mktemp('world') / 'world')


def _box_corners(name, t):
    verts, tris = box_mesh()
    pos, yaw = world_pose(name, t)
    c, s = math.cos(yaw), math.sin(yaw)
    return (verts @ np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]]) + pos + [0, 0, BOX[2] / 2])[tris.ravel()]


def _at_or_before(name, t):
    return max(s for s in world_frame_times(name) if s <= t + 1e-9)


def test_characters_are_named_by_their_prefix_without_the_shared_namespace():
    assert characters(['/east/mesh_marker', '/clock', '/west/mesh_marker']) == {'east': '/east/', 'west': '/west/'}
    assert characters(['/ns/b/mesh_marker', '/ns/a/mesh_marker']) == {'a': '/ns/a/', 'b': '/ns/b/'}
    assert characters(['/ns/mesh_marker', '/ns/iguana_state']) == {'': '/ns/'}
    assert characters(['/mesh_marker']) == {'': '/'} and characters(['/clock']) == {}


def test_every_character_has_its_latest_frame_at_or_before_each_frame_time(world_bag):
    run = read_run(world_bag)
    assert run.character == 'east' and run.mesh_topic == '/east/mesh_marker' and run.notes == []
    assert np.allclose(run.times, np.arange(61) / RATE)
    (west,) = run.others
    assert west.name == 'west' and west.mesh_topic == '/west/mesh_marker' and len(west.mesh_points) == 61
    for i, t in enumerate(run.times):
        assert np.allclose(run.mesh_points[i], _box_corners('east', t), atol=1e-6)
        assert np.allclose(west.mesh_points[i], _box_corners('west', _at_or_before('west', t)), atol=1e-6), t
    assert np.allclose(west.mesh_colors[7][:, 2], 0.9)
    assert np.allclose(west.track_times, world_frame_times('west'))
    assert np.allclose(west.track_positions, [world_pose('west', t)[0] for t in world_frame_times('west')])
    window = read_run(world_bag, fps=10, start=0.5, end=1.0)
    assert np.allclose(window.others[0].mesh_points[-1], _box_corners('west', 1.0), atol=1e-6)
    assert window.others[0].track_times[-1] == pytest.approx(1.0)      # trails end at the last frame too
    one = read_run(world_bag, at=1.0 + 1.0 / RATE)                     # a frame time west has no frame at
    assert np.allclose(one.others[0].mesh_points[0], _box_corners('west', 1.0), atol=1e-6)


def test_character_picks_the_followed_one(world_bag):
    run = read_run(world_bag, character='west', fps=30)
    assert run.character == 'west' and [o.name for o in run.others] == ['east']
    assert np.allclose(run.times, world_frame_times('west'))
    assert np.allclose(run.root_positions, [world_pose('west', t)[0] for t in run.times])
    for i, t in enumerate(run.times):
        assert np.allclose(run.others[0].mesh_points[i], _box_corners('east', t), atol=1e-6)
    with pytest.raises(InputError, match=r"has no character 'north'; its characters: east, west$"):
        read_run(world_bag, character='north')


def _colour_at(image, cam, point):
    xy = cam.project(cam.to_camera(np.asarray(point, float)), W, H)[0]
    return image[int(xy[1]), int(xy[0])].astype(int)


@pytest.mark.parametrize('followed', ['east', 'west'])
def test_top_view_draws_both_and_follow_view_centres_the_followed(world_bag, followed):
    run = read_run(world_bag, at=1.0, character=followed)
    views = {}
    for preset in ('top', 'follow'):
        cams = preset_cameras(preset, run.times, run.root_positions, run.root_yaws, run.extent_points(), W / H)
        views[preset] = (Renderer(run, W, H, label=False).frame(0, cams[0]), cams[0])
    image, cam = views['top']
    r, g, b = _colour_at(image, cam, world_pose('east', 1.0)[0] + [0, 0, BOX[2]])
    assert g > 1.3 * r and g > 1.3 * b                                   # green east
    r, g, b = _colour_at(image, cam, world_pose('west', 1.0)[0] + [0, 0, BOX[2]])
    assert b > 1.5 * r and b > 1.5 * g                                   # blue west
    image, cam = views['follow']
    r, g, b = image[H // 2 + 5, W // 2].astype(int)                      # the followed box under the view's centre
    assert (g > 1.3 * r and g > 1.3 * b) if followed == 'east' else (b > 1.5 * r and b > 1.5 * g)


def test_cli_renders_every_character_and_names_them(tmp_path, world_bag, capsys):
    png = tmp_path / 'top.png'
    assert main(['render', str(world_bag), '-o', str(png), '--camera', 'top', '--size', '240x160', '-q']) == 0
    out = capsys.readouterr().out
    assert 'from /east/mesh_marker (following east; also drawn: west)' in out
    pixels = np.asarray(Image.open(png).convert('RGB')).reshape(-1, 3).astype(int)
    r, g, b = pixels.T
    assert ((g > 1.3 * r) & (g > 1.3 * b)).sum() > 20 and ((b > 1.5 * r) & (b > 1.5 * g)).sum() > 20
    gif = tmp_path / 'west.gif'
    assert main(['render', str(world_bag), '-o', str(gif), '--character', 'west', '--size', '96x64', '-q']) == 0
    assert 'from /west/mesh_marker (following west; also drawn: east)' in capsys.readouterr().out
    assert Image.open(gif).n_frames == 31                                  # west's 15 Hz frames, 0 to 2 s


@pytest.mark.parametrize('bag, message', [
    ('world', "bag {bag} has no character 'nope'; its characters: east, west"),
    ('lone', "bag {bag} has no character 'nope'; it holds one iguana (/mesh_marker)"),
])
def test_unknown_character_is_one_line_and_exit_1(tmp_path, world_bag, synthetic_bag, capsys, bag, message):
    path = world_bag if bag == 'world' else synthetic_bag
    assert main(['render', str(path), '-o', str(tmp_path / 'x.png'), '--character', 'nope']) == 1
    err = capsys.readouterr().err.strip()
    assert err == f'iguana render: error: {message.format(bag=path)}'
    assert not (tmp_path / 'x.png').exists()
