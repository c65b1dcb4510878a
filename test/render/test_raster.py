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

"""Rasterizer kernels against exact pixel counts, depth order, clipping geometry and box filtering."""
import numpy as np

from iguana_ros.render.raster import clip_near, downsample, draw_segments, rasterize_triangles


def _area(t):
    """Area of a triangle from the x, y of its 3 corners."""
    (ax, ay), (bx, by), (cx, cy) = t[:, 0:2]
    return 0.5 * abs((bx - ax) * (cy - ay) - (cx - ax) * (by - ay))


def _buffers(h, w):
    return np.zeros((h, w, 3), np.float32), np.full((h, w), -np.inf)


def _fill(color, depth, xy, key, rgb, checker=0.0, outline=0.0, wxy=None):
    n = len(xy)
    q = np.ones((n, 3))
    wxy = np.zeros((n, 3, 2)) if wxy is None else wxy
    return rasterize_triangles(color, depth, np.asarray(xy, float), np.asarray(key, float), q,
                               np.asarray(rgb, np.float32), wxy, checker, 0.5, outline, 0.5)


def test_right_triangle_covers_exactly_the_pixel_centres_inside():
    color, depth = _buffers(8, 8)
    n = _fill(color, depth, [[[0, 0], [8, 0], [0, 8]]], [[1, 1, 1]], [[1, 0, 0]])
    rows, cols = np.nonzero(depth > -np.inf)
    assert n == 36 and len(rows) == 36                       # centres (c+.5, r+.5) with r + c <= 7
    assert np.all(rows + cols <= 7)
    assert np.allclose(color[rows, cols], [1, 0, 0]) and np.all(color[depth == -np.inf] == 0)


def test_winding_does_not_matter_and_degenerate_triangles_draw_nothing():
    color, depth = _buffers(8, 8)
    assert _fill(color, depth, [[[0, 0], [0, 8], [8, 0]]], [[1, 1, 1]], [[1, 0, 0]]) == 36
    assert _fill(color, depth, [[[0, 0], [4, 4], [8, 8]]], [[2, 2, 2]], [[0, 1, 0]]) == 0


def test_nearer_key_wins_in_either_drawing_order():
    square = [[[0, 0], [6, 0], [6, 6]], [[0, 0], [6, 6], [0, 6]]]
    for order in ((0, 1), (1, 0)):
        color, depth = _buffers(6, 6)
        layers = [([[1.0] * 3] * 2, [[1, 0, 0]] * 2), ([[2.0] * 3] * 2, [[0, 0, 1]] * 2)]
        for k in order:
            _fill(color, depth, square, *layers[k])
        assert np.allclose(color.reshape(-1, 3), [0, 0, 1]) and np.allclose(depth, 2.0)


def test_depth_is_interpolated_across_the_triangle():
    color, depth = _buffers(4, 4)
    _fill(color, depth, [[[0, 0], [8, 0], [0, 8]]], [[0.0, 8.0, 0.0]], [[1, 1, 1]])
    # key = x along the edge x in [0, 8]: equals the pixel centre's x
    assert np.allclose(depth[0], [0.5, 1.5, 2.5, 3.5])


def test_outline_darkens_only_pixels_near_edges():
    color, depth = _buffers(20, 20)
    _fill(color, depth, [[[0, 0], [20, 0], [0, 20]]], [[1, 1, 1]], [[1, 1, 1]], outline=1.0)
    assert color[0, 5, 0] == 0.5 and color[5, 0, 0] == 0.5     # 0.5 px from the straight edges
    assert color[5, 5, 0] == 1.0                                # interior
    assert color[9, 9, 0] == 0.5                                # centre 0.707 px from the hypotenuse


def test_checkerboard_follows_world_cells():
    color, depth = _buffers(4, 4)
    xy = [[[0, 0], [4, 0], [4, 4]], [[0, 0], [4, 4], [0, 4]]]
    wxy = np.array([[[0, 0], [2, 0], [2, 2]], [[0, 0], [2, 2], [0, 2]]], float)   # 2 m across 4 px
    _fill(color, depth, xy, [[1] * 3] * 2, [[1, 1, 1]] * 2, checker=1.0, wxy=wxy)
    expected = np.array([[1, 1, .5, .5], [1, 1, .5, .5], [.5, .5, 1, 1], [.5, .5, 1, 1]])
    assert np.allclose(color[:, :, 0], expected)


def test_clip_near_keeps_the_visible_part_with_attributes():
    near = 1.0
    tri = np.array([[[0.0, 0, 2], [2, 0, 2], [0, 2, 0]]])       # one vertex behind z = 1
    attrs = tri[:, :, 2:].copy()                               # attribute = z
    cam, att, src = clip_near(tri, attrs, near)
    assert len(cam) == 2 and np.all(src == 0)
    assert np.all(cam[:, :, 2] >= near - 1e-12) and np.allclose(att[..., 0], cam[..., 2])
    # visible part: the trapezoid z in [1, 2] of the triangle, area 2 - 0.5 = 1.5 (in x, y)
    area = sum(_area(t) for t in cam)
    assert np.isclose(area, 1.5)
    two_behind = np.array([[[0.0, 0, 2], [2, 0, 0], [0, 2, 0]]])
    cam, _, _ = clip_near(two_behind, two_behind[:, :, 2:].copy(), near)
    assert len(cam) == 1 and np.isclose(_area(cam[0]), 0.5)
    behind = np.array([[[0.0, 0, 0.5], [1, 0, 0.5], [0, 1, 0.2]]])
    assert len(clip_near(behind, behind[:, :, 2:].copy(), near)[0]) == 0


def test_segments_are_depth_tested():
    color, depth = _buffers(10, 20)
    depth[:, 10:] = 5.0                                       # something nearer on the right half
    n = draw_segments(color, depth, np.array([[2.0, 5.0]]), np.array([[18.0, 5.0]]),
                      np.array([1.0]), np.array([1.0]), 1.0, np.array([0.0, 1.0, 0.0]))
    painted = color[:, :, 1] == 1.0
    assert n > 0 and painted[:, :10].any() and not painted[:, 10:].any()
    assert set(np.nonzero(painted)[0]) <= {4, 5}               # rows whose centres are within 1 px of y = 5


def test_downsample_box_filters_to_uint8():
    color = np.zeros((4, 4, 3), np.float32)
    color[:2, :2] = 1.0
    color[2:, 2:, 0] = np.array([[0.0, 1.0], [1.0, 1.0]])
    out = downsample(color, 2)
    assert out.shape == (2, 2, 3) and out.dtype == np.uint8
    assert out[0, 0].tolist() == [255, 255, 255] and out[1, 1].tolist() == [191, 0, 0]
    assert out[0, 1].tolist() == [0, 0, 0]


def test_surface_heights_interpolate_the_top_triangle():
    from iguana_ros.render.raster import surface_heights
    plane = np.array([[[0.0, 0, 0], [2, 0, 2], [0, 2, 0]], [[0.0, 0, 1], [2, 0, 1], [0, 2, 1]]])  # z = x, z = 1
    z = surface_heights(plane, np.array([[0.5, 0.5], [1.5, 0.25], [3.0, 3.0]]))
    assert np.allclose(z[:2], [1.0, 1.5]) and np.isnan(z[2])
