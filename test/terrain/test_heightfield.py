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

"""Height-field terrain: exact planes, bilinear interpolation, clamping, normals, file loading, errors."""
import numpy as np
import pytest

from iguana_ros.errors import InputError
from iguana_ros.terrain.heightfield import (above_block_maximum, bilinear_height_gradient, block_maxima,
                                            HEIGHT_BOUND_CELLS, HeightField)


def test_flat_is_constant_with_up_normal():
    hf = HeightField.flat(height=0.25)
    xy = np.array([[0.0, 0.0], [3.3, -7.1], [1e3, 1e3]])
    np.testing.assert_allclose(hf.height(xy), 0.25)
    np.testing.assert_allclose(hf.normal(xy), [[0, 0, 1]] * 3)
    assert hf.is_flat


@pytest.mark.parametrize('slope, direction', [(30.0, (1.0, 0.0)), (45.0, (1.0, 1.0)), (-12.0, (0.0, 2.0))])
def test_tilted_plane_height_and_normal_are_exact(slope, direction):
    hf = HeightField.tilted_plane(slope, direction)
    d = np.asarray(direction) / np.linalg.norm(direction)
    rng = np.random.default_rng(1)
    xy = rng.uniform(-10, 10, size=(50, 2))
    expected = np.tan(np.radians(slope)) * xy @ d
    np.testing.assert_allclose(hf.height(xy), expected, atol=1e-12)
    n = hf.normal(xy)
    np.testing.assert_allclose(np.degrees(np.arccos(n[:, 2])), abs(slope), atol=1e-9)
    np.testing.assert_allclose(n[:, :2] @ d, -np.sin(np.radians(slope)), atol=1e-12)
    assert not hf.is_flat


def test_bilinear_values_gradient_and_clamping():
    heights = np.array([[0.0, 1.0], [2.0, 5.0]])  # h(i=1, j=1) = 5
    hf = HeightField(heights, origin=(1.0, 2.0), spacing=0.5)
    # centre of the cell: mean of the corners; gradient from the bilinear formula
    h, g = hf.height_and_gradient(np.array([1.25, 2.25]))
    assert h == pytest.approx(2.0)
    np.testing.assert_allclose(g, [(0.5 * 2 + 0.5 * 4) / 0.5, (0.5 * 1 + 0.5 * 3) / 0.5])
    # corners reproduce grid values; outside is clamped with zero gradient across the edge
    assert hf.height(np.array([1.5, 2.5])) == pytest.approx(5.0)
    h_out, g_out = hf.height_and_gradient(np.array([10.0, 2.0]))
    assert h_out == pytest.approx(2.0)
    assert g_out[0] == 0.0 and g_out[1] == pytest.approx(3.0 / 0.5)
    assert hf.extent == (1.0, 1.5, 2.0, 2.5)


def test_kernel_matches_vectorised_and_finite_differences():
    hf = HeightField.hills(amplitude=0.08, wavelength=0.5, seed=3, extent=2.0)
    rng = np.random.default_rng(0)
    xy = rng.uniform(-1.5, 1.5, size=(200, 2))
    h, g = hf.height_and_gradient(xy)
    args = hf.kernel_args()
    for k in (0, 17, 199):
        hk, gx, gy = bilinear_height_gradient(*args, xy[k, 0], xy[k, 1])
        assert (hk, gx, gy) == (h[k], g[k, 0], g[k, 1])
    eps = 1e-7  # central differences agree inside cells (measure-zero chance of hitting a cell edge)
    fd_x = (hf.height(xy + [eps, 0]) - hf.height(xy - [eps, 0])) / (2 * eps)
    np.testing.assert_allclose(fd_x, g[:, 0], atol=1e-5)
    assert h.shape == (200,) and g.shape == (200, 2) and hf.normal(xy.reshape(10, 20, 2)).shape == (10, 20, 3)


def test_hills_deterministic_amplitude():
    a = HeightField.hills(amplitude=0.05, wavelength=0.6, seed=7, extent=3.0)
    b = HeightField.hills(amplitude=0.05, wavelength=0.6, seed=7, extent=3.0)
    c = HeightField.hills(amplitude=0.05, wavelength=0.6, seed=8, extent=3.0)
    assert np.array_equal(a.heights, b.heights) and not np.array_equal(a.heights, c.heights)
    assert np.max(np.abs(a.heights)) == pytest.approx(0.05)
    assert a.extent[0] == pytest.approx(-3.0) and a.extent[1] >= 3.0


def test_from_file_npy_and_png(tmp_path):
    import imageio.v3 as iio

    grid = np.arange(12, dtype=float).reshape(4, 3)  # [i (x), j (y)]
    np.save(tmp_path / 'h.npy', grid)
    hf = HeightField.from_file(tmp_path / 'h.npy', scale=0.1, spacing=0.2)
    np.testing.assert_allclose(hf.heights, grid * 0.1)
    assert hf.origin == pytest.approx((-0.3, -0.2))
    # PNG seen from above: top row is max y, columns are x
    img = np.zeros((3, 4), dtype=np.uint16)
    img[0, 3] = 65535  # top-right pixel = (max x, max y)
    iio.imwrite(tmp_path / 'h.png', img)
    hp = HeightField.from_file(tmp_path / 'h.png', scale=2.0, spacing=1.0)
    assert hp.heights.shape == (4, 3)
    assert hp.heights[3, 2] == pytest.approx(2.0) and hp.heights.sum() == pytest.approx(2.0)
    assert hp.height(np.array([1.5, 1.0])) == pytest.approx(2.0)


@pytest.mark.parametrize('make, words', [
    (lambda p: HeightField(np.zeros(3)), '2-D grid'),
    (lambda p: HeightField(np.array([[0, np.nan], [0, 0]])), 'NaN'),
    (lambda p: HeightField(np.zeros((2, 2)), spacing=0.0), 'spacing'),
    (lambda p: HeightField.from_file(p / 'missing.npy'), 'does not exist'),
    (lambda p: HeightField.tilted_plane(95.0), 'slope_deg'),
])
def test_bad_input_raises_clear_error(tmp_path, make, words):
    with pytest.raises(InputError, match=words):
        make(tmp_path)


def test_bad_file_format(tmp_path):
    (tmp_path / 'h.txt').write_text('1 2 3')
    with pytest.raises(InputError, match='.npy array or a .png'):
        HeightField.from_file(tmp_path / 'h.txt')
    np.save(tmp_path / 'v.npy', np.zeros(5))
    with pytest.raises(InputError, match='2-D numeric'):
        HeightField.from_file(tmp_path / 'v.npy')


@pytest.mark.parametrize('shape', [(23, 17), (9, 9), (2, 2), (161, 161)])
def test_block_maxima_bound_the_clamped_bilinear_height(shape):
    """Each block's bound is the highest corner of its cells; at any point (also off the grid) it bounds the height."""
    rng = np.random.default_rng(sum(shape))
    heights = rng.normal(scale=0.05, size=shape)
    bounds = block_maxima(heights)
    b = HEIGHT_BOUND_CELLS
    assert bounds.shape == (-(-(shape[0] - 1) // b), -(-(shape[1] - 1) // b))
    for (bi, bj), bound in np.ndenumerate(bounds):
        assert bound == heights[bi * b:bi * b + b + 1, bj * b:bj * b + b + 1].max()
    spacing, ox, oy = 0.1, -0.3, 0.2
    xy = rng.uniform([ox - 1, oy - 1], [ox + shape[0] * spacing + 1, oy + shape[1] * spacing + 1], size=(2000, 2))
    for x, y in xy:
        h = bilinear_height_gradient(heights, ox, oy, spacing, x, y)[0]
        assert not above_block_maximum(heights, bounds, ox, oy, spacing, x, y, h - 1e-9)
    assert above_block_maximum(heights, bounds, ox, oy, spacing, ox, oy, bounds[0, 0])
