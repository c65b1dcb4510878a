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
Height-field terrain: a regular grid of heights, bilinear in between, clamped outside.

`heights[i, j]` is the terrain height (m) at world `x = origin[0] + i * spacing`, `y = origin[1] + j * spacing`.
Outside the grid the height is that of the nearest edge (the grid is clamped, so the gradient across the edge
is zero). The numba kernels `bilinear_height` / `bilinear_height_gradient` take `kernel_args()` and are meant to be
called inside other compiled kernels (ground contact); the methods are their vectorised wrappers.
"""
from __future__ import annotations

from dataclasses import dataclass
import math
from pathlib import Path

import numba
import numpy as np

from iguana_ros.errors import InputError

DEFAULT_EXTENT = 50.0
"""Half-size (m) of the square grid built by the analytic constructors (`flat`, `tilted_plane`)."""
STEPS_PAD_RADIUS = 0.4
"""Radius (m) of the flat start pad at height 0 around the origin (the default start) of `HeightField.steps`."""
NOISE_MIN_SAMPLES = 4
"""Fewest grid samples per `wavelength` that `HeightField.noise` accepts (fewer would be aliased white noise)."""
HILLS_SAMPLES = 16
"""Grid samples per `wavelength` of `HeightField.hills` (its spacing is wavelength / HILLS_SAMPLES)."""
MAX_GRID_NODES = 2000 ** 2
"""Most nodes a height field built here may have (32 MB of float64 heights; e.g. a 99.9 m square at 5 cm): the
generated grids (`hills`, `steps`, `noise`) and height-map files are checked before anything is allocated."""
MAX_HEIGHTMAP_BYTES = MAX_GRID_NODES * 8 + 65536
"""Largest height-map file (bytes) `from_file` opens: a float64 .npy of MAX_GRID_NODES values and its header."""
_PNG_SIGNATURE = b'\x89PNG\r\n\x1a\n'


@numba.njit(cache=True)
def _cell(u: float, n: int):
    """Clamped cell index and fraction along one axis; `inside` is False when `u` was clamped."""
    inside = True
    if u < 0.0:
        u = 0.0
        inside = False
    elif u > n - 1:
        u = float(n - 1)
        inside = False
    i = min(int(u), n - 2)
    return i, u - i, inside


@numba.njit(cache=True)
def bilinear_height_gradient(heights, ox, oy, spacing, x, y):
    """Height (m) and gradient (dh/dx, dh/dy) of the clamped bilinear grid at one world point."""
    nx, ny = heights.shape
    i, t, in_x = _cell((x - ox) / spacing, nx)
    j, s, in_y = _cell((y - oy) / spacing, ny)
    h00 = heights[i, j]
    h10 = heights[i + 1, j]
    h01 = heights[i, j + 1]
    h11 = heights[i + 1, j + 1]
    h = (1 - t) * (1 - s) * h00 + t * (1 - s) * h10 + (1 - t) * s * h01 + t * s * h11
    gx = ((1 - s) * (h10 - h00) + s * (h11 - h01)) / spacing if in_x else 0.0
    gy = ((1 - t) * (h01 - h00) + t * (h11 - h10)) / spacing if in_y else 0.0
    return h, gx, gy


HEIGHT_BOUND_CELLS = 4
"""Grid cells per side of a block of `block_maxima`: contact tests a node against its block's highest grid height
before it interpolates (on the bench gait over hills 87 % of the iguana's nodes are above it)."""


def block_maxima(heights: np.ndarray, cells: int = HEIGHT_BOUND_CELLS) -> np.ndarray:
    """
    Highest grid height over every block of `cells` × `cells` cells `(ceil((nx − 1) / cells), ...)`.

    Block (I, J) covers the corners of the cells i in [I cells, (I + 1) cells) (clamped like `_cell`), so it bounds
    the clamped bilinear height anywhere in them.
    """
    nx, ny = heights.shape
    starts_x, starts_y = np.arange(0, nx - 1, cells), np.arange(0, ny - 1, cells)
    rows = np.maximum.reduceat(heights, starts_x, axis=0)
    rows = np.maximum(rows, heights[np.minimum(starts_x + cells, nx - 1)])        # the blocks' last corner row
    out = np.maximum.reduceat(rows, starts_y, axis=1)
    return np.ascontiguousarray(np.maximum(out, rows[:, np.minimum(starts_y + cells, ny - 1)]))


@numba.njit(cache=True)
def above_block_maximum(heights, bounds, ox, oy, spacing, x, y, z):
    """Whether height `z` is at or above the grid everywhere in the block of point (x, y) (`bounds`: block_maxima)."""
    nx, ny = heights.shape
    i = _cell((x - ox) / spacing, nx)[0]
    j = _cell((y - oy) / spacing, ny)[0]
    return z >= bounds[i // HEIGHT_BOUND_CELLS, j // HEIGHT_BOUND_CELLS]


@numba.njit(cache=True)
def bilinear_height(heights, ox, oy, spacing, x, y):
    """Height (m) of the clamped bilinear grid at one world point."""
    return bilinear_height_gradient(heights, ox, oy, spacing, x, y)[0]


@numba.njit(cache=True)
def _height_gradient_many(heights, ox, oy, spacing, xy, out):
    """Fill `out (n, 3)` with height, dh/dx, dh/dy at the points `xy (n, 2)`."""
    for k in range(xy.shape[0]):
        h, gx, gy = bilinear_height_gradient(heights, ox, oy, spacing, xy[k, 0], xy[k, 1])
        out[k, 0] = h
        out[k, 1] = gx
        out[k, 2] = gy


@dataclass(frozen=True)
class HeightField:
    """Terrain heights `(nx, ny)` in m on a square grid of `spacing` m whose node [0, 0] is at `origin` (x, y)."""

    heights: np.ndarray
    origin: tuple = (0.0, 0.0)
    spacing: float = 1.0

    def __post_init__(self) -> None:
        heights = np.array(self.heights, dtype=np.float64, order='C')   # a private copy: read-only below
        if heights.ndim != 2 or min(heights.shape) < 2:
            raise InputError(f'height field: heights must be a 2-D grid of at least 2x2, got shape {heights.shape}')
        if not np.all(np.isfinite(heights)):
            raise InputError('height field: heights contain NaN or Inf')
        if not (np.isfinite(self.spacing) and self.spacing > 0):
            raise InputError(f'height field: spacing must be a positive number of metres, got {self.spacing!r}')
        heights.setflags(write=False)
        object.__setattr__(self, 'heights', heights)
        object.__setattr__(self, 'origin', (float(self.origin[0]), float(self.origin[1])))
        object.__setattr__(self, 'spacing', float(self.spacing))

    # ------------------------------------------------------------------ queries
    def kernel_args(self) -> tuple:
        """`(heights, origin_x, origin_y, spacing)` for the compiled `bilinear_height*` kernels."""
        return self.heights, self.origin[0], self.origin[1], self.spacing

    def height_and_gradient(self, xy: np.ndarray) -> tuple:
        """Heights `(...)` and gradients `(..., 2)` (dh/dx, dh/dy) at world points `xy (..., 2)`."""
        xy = np.asarray(xy, dtype=np.float64)
        if xy.shape[-1:] != (2,):
            raise InputError(f'height field: query points must have shape (..., 2), got {xy.shape}')
        flat = np.ascontiguousarray(xy.reshape(-1, 2))
        out = np.empty((flat.shape[0], 3))
        _height_gradient_many(*self.kernel_args(), flat, out)
        out = out.reshape(xy.shape[:-1] + (3,))
        return out[..., 0], out[..., 1:]

    def height(self, xy: np.ndarray) -> np.ndarray:
        """Terrain height `(...)` (m) at world points `xy (..., 2)`."""
        return self.height_and_gradient(xy)[0]

    def gradient(self, xy: np.ndarray) -> np.ndarray:
        """Height gradient `(..., 2)` (dh/dx, dh/dy) at world points `xy (..., 2)`."""
        return self.height_and_gradient(xy)[1]

    def normal(self, xy: np.ndarray) -> np.ndarray:
        """Return unit upward surface normal `(..., 3)` at world points `xy (..., 2)`."""
        grad = self.gradient(xy)
        n = np.concatenate([-grad, np.ones(grad.shape[:-1] + (1,))], axis=-1)
        return n / np.linalg.norm(n, axis=-1, keepdims=True)

    @property
    def extent(self) -> tuple:
        """`(x_min, x_max, y_min, y_max)` of the grid in m."""
        nx, ny = self.heights.shape
        ox, oy = self.origin
        return ox, ox + (nx - 1) * self.spacing, oy, oy + (ny - 1) * self.spacing

    @property
    def is_flat(self) -> bool:
        """Return True when every height is the same (a horizontal plane)."""
        return bool(np.ptp(self.heights) == 0.0)

    # ------------------------------------------------------------ constructors
    @classmethod
    def flat(cls, height: float = 0.0, extent: float = DEFAULT_EXTENT) -> 'HeightField':
        """Horizontal plane at `height` m covering `[-extent, extent]²`."""
        return cls(np.full((2, 2), float(height)), origin=(-extent, -extent), spacing=2.0 * extent)

    @classmethod
    def tilted_plane(cls, slope_deg: float, direction: tuple = (1.0, 0.0),
                     extent: float = DEFAULT_EXTENT) -> 'HeightField':
        """Plane through the origin rising at `slope_deg` degrees along the xy `direction` (exact, bilinear)."""
        if not -89.0 <= slope_deg <= 89.0:
            raise InputError(f'tilted_plane: slope_deg must be within [-89, 89] degrees, got {slope_deg}')
        d = np.asarray(direction, dtype=float)
        if d.shape != (2,) or np.linalg.norm(d) == 0:
            raise InputError(f'tilted_plane: direction must be a non-zero (x, y) pair, got {direction!r}')
        d = d / np.linalg.norm(d)
        corners = np.array([-extent, extent])
        gx, gy = np.meshgrid(corners, corners, indexing='ij')
        heights = np.tan(np.radians(slope_deg)) * (d[0] * gx + d[1] * gy)
        return cls(heights, origin=(-extent, -extent), spacing=2.0 * extent)

    @classmethod
    def hills(cls, amplitude: float = 0.05, wavelength: float = 0.6, seed: int = 0,
              extent: float = 5.0) -> 'HeightField':
        """Smooth random hills: a sum of 8 plane waves near `wavelength` m, peak |height| = `amplitude` m."""
        if amplitude < 0 or wavelength <= 0 or extent <= 0:
            raise InputError('hills: amplitude must be >= 0 and wavelength, extent > 0 (metres)')
        rng = np.random.default_rng(seed)
        spacing = wavelength / HILLS_SAMPLES
        axis = _grid_axis(extent, spacing)
        gx, gy = np.meshgrid(axis, axis, indexing='ij')
        heights = np.zeros(gx.shape)
        for _ in range(8):  # 8 components, once per construction (not a per-step loop)
            angle = rng.uniform(0, 2 * np.pi)
            k = 2 * np.pi / (wavelength * rng.uniform(0.7, 1.4))
            heights += np.sin(k * (np.cos(angle) * gx + np.sin(angle) * gy) + rng.uniform(0, 2 * np.pi))
        peak = np.max(np.abs(heights))
        heights *= amplitude / peak if peak > 0 else 0.0
        return cls(heights, origin=(-extent, -extent), spacing=spacing)

    @classmethod
    def steps(cls, block_size: float = 0.3, step_min: float = 0.03, step_max: float = 0.05, seed: int = 0,
              extent: float = 5.0, spacing: float = 0.05, pad_radius: float = STEPS_PAD_RADIUS) -> 'HeightField':
        """
        Square blocks of side `block_size` m, each of a height drawn uniformly in [`step_min`, `step_max`] m.

        Blocks are aligned to the origin (block `(a, b)` covers `[a, a + 1) * block_size` in x, likewise in y);
        the grid of `spacing` m over `[-extent, extent]²` gives each node the height of its block, so an edge is
        a ramp over the one grid cell before it (the field is bilinear). Nodes within `pad_radius` m of the
        origin are a flat start pad at height 0, so a body starting there stands on level ground and first steps
        up onto a block.
        """
        if not (block_size > 0 and spacing > 0 and extent > 0 and pad_radius >= 0):
            raise InputError('steps: block_size, spacing, extent must be > 0 and pad_radius >= 0 (metres)')
        if not 0 <= step_min <= step_max:
            raise InputError(f'steps: need 0 <= step_min <= step_max (m), got {step_min} and {step_max}')
        axis = _grid_axis(extent, spacing)
        block = np.floor(axis / block_size + 1e-9).astype(np.int64)   # eps: a node on an edge joins the next
        rng = np.random.default_rng(seed)
        table = rng.uniform(step_min, step_max, size=(block[-1] - block[0] + 1,) * 2)
        heights = table[np.ix_(block - block[0], block - block[0])]
        heights[np.hypot(axis[:, None], axis[None, :]) <= pad_radius] = 0.0
        return cls(heights, origin=(-extent, -extent), spacing=spacing)

    @classmethod
    def noise(cls, amplitude: float = 0.05, wavelength: float = 0.8, seed: int = 0, extent: float = 5.0,
              spacing: float = 0.05) -> 'HeightField':
        """
        Band-limited Gaussian noise on a `spacing` m grid over `[-extent, extent]²`, peak |height| = `amplitude`.

        White noise is smoothed by a Gaussian filter (periodic boundary) of sigma `wavelength / (2 pi sqrt 2)`,
        which puts the peak of the radial power spectrum at `wavelength` m, as the plane waves of `hills`; the
        heights' autocorrelation falls to 1/e at `wavelength / (pi sqrt 2)`. The mean is removed before scaling.
        Deterministic for a `seed`.
        """
        from scipy.ndimage import gaussian_filter

        if amplitude < 0 or wavelength <= 0 or extent <= 0 or spacing <= 0:
            raise InputError('noise: amplitude must be >= 0 and wavelength, extent, spacing > 0 (metres)')
        if wavelength < NOISE_MIN_SAMPLES * spacing:
            raise InputError(f'noise: wavelength {wavelength} m needs a grid spacing of at most '
                             f'{wavelength / NOISE_MIN_SAMPLES:g} m, got {spacing}')
        n = _grid_axis(extent, spacing).size
        white = np.random.default_rng(seed).standard_normal((n, n))
        heights = gaussian_filter(white, wavelength / (2.0 * np.pi * np.sqrt(2.0)) / spacing, mode='wrap')
        heights -= heights.mean()
        peak = np.max(np.abs(heights))
        heights *= amplitude / peak if peak > 0 else 0.0
        return cls(heights, origin=(-extent, -extent), spacing=spacing)

    @classmethod
    def from_file(cls, path, scale: float = 1.0, spacing: float = 0.05, origin=None) -> 'HeightField':
        """
        Load heights from `.npy` (values × `scale` m) or a grey PNG (value / dtype max × `scale` m), centred.

        A `.npy` array is indexed `[i (x), j (y)]`; a PNG is an image seen from above, x to the right and y up
        (its top row is the largest y). `origin` defaults to centring the grid on (0, 0).
        """
        path = Path(path)
        heightmap_shape(path)   # size and header checked before anything is loaded
        suffix = path.suffix.lower()
        if suffix == '.npy':
            heights = _load_npy(path) * float(scale)
        elif suffix == '.png':
            heights = _load_png(path) * float(scale)
        else:
            raise InputError(f'height field: {path} must be a .npy array or a .png image, got {suffix!r}')
        if origin is None:
            origin = (-(heights.shape[0] - 1) * spacing / 2.0, -(heights.shape[1] - 1) * spacing / 2.0)
        try:
            return cls(heights, origin=origin, spacing=spacing)
        except InputError as exc:
            raise InputError(f'{path}: {exc}') from None


def grid_nodes(extent: float, spacing: float) -> float:
    """
    Nodes (an int) of the square grid the generated terrains build over `[-extent, extent]²` at `spacing` m.

    Inf when there would be more than 1e30 (a spacing too small to count with).
    """
    cells = 2.0 * extent / spacing if spacing > 0 else math.inf
    return (math.ceil(cells) + 1) ** 2 if cells < 1e15 else math.inf


def node_count(nodes: float) -> str:
    """Return a grid's node count for a message: in full up to 1e9, else in %.3g."""
    return str(nodes) if nodes < 1e9 else f'{nodes:.3g}'


def _grid_axis(extent: float, spacing: float) -> np.ndarray:
    """
    Node coordinates `(n,)` (m) of a grid from `-extent` in steps of `spacing`, reaching at least `extent`.

    InputError if the square grid would have more than MAX_GRID_NODES nodes.
    """
    nodes = grid_nodes(extent, spacing)
    if nodes > MAX_GRID_NODES:
        raise InputError(f'height field: a {2.0 * extent:g} m square at spacing {spacing:g} m has {node_count(nodes)} '
                         f'grid nodes, at most {MAX_GRID_NODES} allowed')
    return -extent + spacing * np.arange(math.isqrt(nodes))


def heightmap_shape(path) -> tuple[int, int]:
    """
    Return the grid shape `(nx, ny)` of a height-map file (.npy or PNG) read from its header only.

    The file is checked first: it must exist, be at most MAX_HEIGHTMAP_BYTES and hold at most MAX_GRID_NODES values;
    InputError otherwise.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f'height field: file {path} does not exist')
    size = path.stat().st_size
    if size > MAX_HEIGHTMAP_BYTES:
        raise InputError(f'height field: {path} has {size} bytes, at most {MAX_HEIGHTMAP_BYTES} allowed')
    suffix = path.suffix.lower()
    if suffix == '.npy':
        shape = _npy_header_shape(path)
    elif suffix == '.png':
        shape = _png_header_shape(path)
    else:
        raise InputError(f'height field: {path} must be a .npy array or a .png image, got {suffix!r}')
    shown = str(shape) if len(str(shape)) <= 60 else str(shape)[:57] + '...'
    if len(shape) != 2:
        raise InputError(f'height field: {path} must hold a 2-D numeric array, got shape {shown}')
    if math.prod(shape) > MAX_GRID_NODES:
        raise InputError(f'height field: {path} holds a grid of shape {shown}, {node_count(math.prod(shape))} nodes; '
                         f'at most {MAX_GRID_NODES} allowed')
    return shape


def _npy_header_shape(path: Path) -> tuple:
    """Return the array shape in a .npy file's header (the data is not read)."""
    try:
        with path.open('rb') as f:
            version = np.lib.format.read_magic(f)
            read = np.lib.format.read_array_header_1_0 if version == (1, 0) else np.lib.format.read_array_header_2_0
            shape, _fortran, _dtype = read(f)
    except (ValueError, OSError, SyntaxError, TypeError) as exc:
        raise InputError(f'height field: {path} is not a readable .npy array ({exc})') from None
    return tuple(int(n) for n in shape)


def _png_header_shape(path: Path) -> tuple:
    """(width, height) from a PNG's IHDR chunk (the image is not decoded)."""
    try:
        with path.open('rb') as f:
            head = f.read(24)
    except OSError as exc:
        raise InputError(f'height field: {path} is not a readable PNG ({exc})') from None
    if len(head) < 24 or head[:8] != _PNG_SIGNATURE or head[12:16] != b'IHDR':
        raise InputError(f'height field: {path} is not a readable PNG (no PNG header)')
    return int.from_bytes(head[16:20], 'big'), int.from_bytes(head[20:24], 'big')


def _load_npy(path: Path) -> np.ndarray:
    """Return a 2-D float array from a .npy file, or InputError naming the file."""
    try:
        data = np.load(path, allow_pickle=False)
    except (ValueError, OSError) as exc:
        raise InputError(f'height field: {path} is not a readable .npy array ({exc})') from None
    if data.ndim != 2 or not np.issubdtype(data.dtype, np.number):
        raise InputError(f'height field: {path} must hold a 2-D numeric array, got {data.dtype} {data.shape}')
    return data.astype(np.float64)


def _load_png(path: Path) -> np.ndarray:
    """Heights in [0, 1] `(nx, ny)` from a grey 8- or 16-bit PNG, or InputError naming the file."""
    import imageio.v3 as iio

    try:
        img = iio.imread(path)
    except Exception as exc:  # imageio raises many types for corrupt files
        raise InputError(f'height field: {path} is not a readable PNG ({exc})') from None
    if img.ndim == 3:
        if not np.all(img[..., :3] == img[..., :1]):
            raise InputError(f'height field: {path} must be a grey-scale PNG (16-bit preferred)')
        img = img[..., 0]
    if img.dtype not in (np.uint8, np.uint16):
        raise InputError(f'height field: {path} must be an 8- or 16-bit PNG, got {img.dtype}')
    values = img.astype(np.float64) / np.iinfo(img.dtype).max
    return values[::-1, :].T.copy()
