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

"""Rendered pixels where the geometry says they are; `iguana render` outputs and its one-line errors."""
import numpy as np
from PIL import Image
import pytest

from iguana_ros.bag.frames import read_run
from iguana_ros.cli import main
from iguana_ros.render.camera import preset_cameras
from iguana_ros.render.output import gif_durations_ms
from iguana_ros.render.renderer import Renderer
from render_synthetic import write_synthetic_bag

W, H = 240, 160


def _render(run, preset, frames=(0,)):
    cams = preset_cameras(preset, run.times, run.root_positions, run.root_yaws, run.extent_points(), W / H)
    renderer = Renderer(run, W, H, label=False)
    return [renderer.frame(i, cams[i]) for i in frames], cams, renderer


def _pixel(cam, point):
    xy = cam.project(cam.to_camera(np.asarray(point, float)), W, H)[0]
    return int(xy[1]), int(xy[0])


def test_top_view_puts_goal_box_and_terrain_where_projected(synthetic_bag):
    run = read_run(synthetic_bag, at=0.0)
    (image,), cams, _ = _render(run, 'top')
    r, g, b = image[_pixel(cams[0], run.goals_at(0.0).positions[0])].astype(int)
    assert r > 2 * g and r > 2 * b                                  # red goal sphere
    r, g, b = image[_pixel(cams[0], run.root_positions[0])].astype(int)
    assert g > 1.3 * r and g > 1.3 * b                              # green box over the root
    corner = image[3, 3].astype(int)
    assert corner[0] > corner[1] > corner[2]                        # sandy terrain, no sky from above


def test_follow_view_centres_the_iguana_and_shows_sky(synthetic_bag):
    run = read_run(synthetic_bag, at=1.0)
    (image,), cams, _ = _render(run, 'follow')
    row, col = _pixel(cams[0], run.root_positions[0])
    assert abs(col - W / 2) < W / 8 and abs(row - H / 2) < H / 4
    r, g, b = image[row, col].astype(int)
    assert g > 1.3 * r and g > 1.3 * b
    top = image[1, W // 2].astype(int)
    assert top[2] > top[0]                                          # blue sky above the horizon


def test_cached_static_background_gives_the_same_pixels(synthetic_bag):
    run = read_run(synthetic_bag, fps=10)
    cached, _, renderer = _render(run, 'side', frames=(0, 5))
    fresh, _, _ = _render(run, 'side', frames=(5,))
    assert renderer._static is not None and np.array_equal(cached[1], fresh[0])
    assert not np.array_equal(cached[0], cached[1])                 # the box moved


def test_png_gif_and_mp4(tmp_path, synthetic_bag, capsys):
    import imageio_ffmpeg

    assert main(['render', str(synthetic_bag), '-o', str(tmp_path / 'f.png'), '--size', '200x120',
                 '--camera', 'side']) == 0
    assert 'f.png: 1 frame(s) 200x120, camera side, t = 2.00 s from /mesh_marker' in capsys.readouterr().out
    assert Image.open(tmp_path / 'f.png').size == (200, 120)
    assert main(['render', str(synthetic_bag), '-o', str(tmp_path / 'a.gif'), '--size', '120x80',
                 '--fps', '15', '--camera', 'orbit']) == 0
    gif = Image.open(tmp_path / 'a.gif')
    durations = []
    for k in range(gif.n_frames):
        gif.seek(k)
        durations.append(gif.info['duration'])
    assert gif.n_frames == 31 and sum(durations) == 2070 and gif.size == (120, 80)
    assert main(['render', str(synthetic_bag), '-o', str(tmp_path / 'a.mp4'), '--size', '121x81',
                 '--fps', '10', '--camera', 'top', '--start', '1']) == 0
    n_frames, seconds = imageio_ffmpeg.count_frames_and_secs(str(tmp_path / 'a.mp4'))
    assert n_frames == 11 and seconds == pytest.approx(1.1, abs=0.05)
    reader = imageio_ffmpeg.read_frames(str(tmp_path / 'a.mp4'))
    assert next(reader)['size'] == (122, 82)                        # rounded up to even for H.264
    reader.close()


def test_gif_delays_track_the_frame_rate():
    assert gif_durations_ms(3, 15) == [70, 60, 70]
    assert sum(gif_durations_ms(300, 15)) == 20000


@pytest.fixture(scope='module')
def meshless_bag(tmp_path_factory):
    return write_synthetic_bag(tmp_path_factory.mktemp('nomesh') / 'b', duration=0.2, mesh=False)


@pytest.mark.parametrize('args, message', [
    (['{tmp}/absent', '-o', '{tmp}/x.png'], 'no bag at {tmp}/absent'),
    (['{bag}', '-o', '{tmp}/x.avi'], "has extension '.avi'; expected one of .png, .gif, .mp4"),
    (['{bag}', '-o', '{tmp}/x.gif', '--size', '640-480'], "--size '640-480' is not of the form"),
    (['{bag}', '-o', '{tmp}/x.gif', '--fps', '0'], '--fps is 0.0; expected a positive number'),
    (['{bag}', '-o', '{tmp}/x.gif', '--start', '3', '--end', '1'], 'expected 0 <= start < end'),
    (['{bag}', '-o', '{tmp}/x.gif', '--frame', '1'], '--frame selects the frame of a .png output'),
    (['{bag}', '-o', '{tmp}/x.png', '--frame', '9'], '--frame 9 s is outside the run (0 to 2.00 s)'),
    (['{nomesh}', '-o', '{tmp}/x.png'], 'has no /mesh_marker messages; nothing to render'),
])
def test_errors_are_one_line_and_exit_1(tmp_path, synthetic_bag, meshless_bag, capsys, args, message):
    fill = {'tmp': tmp_path, 'bag': synthetic_bag, 'nomesh': meshless_bag}
    assert main(['render', *[a.format(**fill) for a in args]]) == 1
    err = capsys.readouterr().err.strip()
    assert err.startswith('iguana render: error: ') and message.format(**fill) in err
    assert len(err.splitlines()) == 1


def test_flat_shade_is_lambert_of_the_triangle_normal():
    from iguana_ros.render.renderer import AMBIENT, DIFFUSE, LIGHT_DIRECTION, flat_shade, unit_sphere
    light = np.array(LIGHT_DIRECTION) / np.linalg.norm(LIGHT_DIRECTION)
    corners = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0],          # horizontal
                        [0, 0, 0], [0, 0, 1], [0, 1, 0.0]])        # facing -x (two-sided)
    colors = np.repeat([[1.0, 1.0, 1.0, 1.0], [1.0, 0.5, 0.0, 1.0]], 3, axis=0)
    rgb = flat_shade(corners, colors)
    assert np.allclose(rgb[0], AMBIENT + DIFFUSE * light[2], atol=1e-6)
    assert np.allclose(rgb[1], (AMBIENT + DIFFUSE * light[0]) * np.array([1.0, 0.5, 0.0]), atol=1e-6)
    sphere = unit_sphere(1)
    assert sphere.shape == (80, 3, 3) and np.allclose(np.linalg.norm(sphere, axis=2), 1.0)


def test_gif_palette_keeps_rare_key_colours(tmp_path):
    from iguana_ros.render.output import write_gif
    ramp = np.linspace(0, 255, 200).astype(np.uint8)
    frame = np.stack(np.broadcast_arrays(ramp[None, :], ramp[:, None], np.uint8(90)), axis=-1)
    frame = np.ascontiguousarray(frame[:100])                      # 100x200 colour ramps
    frame[50, 50] = (242, 115, 26)                                 # one pixel of the trail colour
    assert write_gif(tmp_path / 'k.gif', [frame, frame], 15, key_colors=[(0.95, 0.45, 0.10)]) == 2
    back = np.asarray(Image.open(tmp_path / 'k.gif').convert('RGB')).astype(int)
    assert np.abs(back[50, 50] - [242, 115, 26]).max() <= 2
    assert np.abs(back - frame).mean() < 4.0                       # the ramps survive 256 colours
