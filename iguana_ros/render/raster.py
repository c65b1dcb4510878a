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
Compiled rasterization kernels: near-plane clipping, z-buffered flat triangles, depth-tested line segments.

Screen coordinates are pixels with the origin at the top-left corner; pixel (row i, column j) has its centre
at (j + 0.5, i + 0.5). Every depth test compares a per-vertex `key` interpolated linearly in screen space where
a *bigger* key is nearer (1/z for perspective cameras, -z for orthographic ones), so one depth buffer filled
with -inf serves both projections.
"""
from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True)
def clip_near(cam, attrs, near):
    """
    Clip triangles `cam (n, 3, 3)` (camera frame, z forward) against the plane z = `near`.

    Per-vertex attributes `attrs (n, 3, a)` are interpolated along clipped edges. Returns clipped
    triangles `(m, 3, 3)`, their attributes `(m, 3, a)` and the source triangle of each `(m,)`; a triangle
    cut by the plane yields one or two triangles, one wholly behind it none.
    """
    n = cam.shape[0]
    a = attrs.shape[2]
    out_c = np.empty((2 * n, 3, 3))
    out_a = np.empty((2 * n, 3, a))
    src = np.empty(2 * n, np.int64)
    poly_c = np.empty((4, 3))
    poly_a = np.empty((4, a))
    m = 0
    for t in range(n):
        n_in = 0
        for i in range(3):
            if cam[t, i, 2] >= near:
                n_in += 1
        if n_in == 0:
            continue
        if n_in == 3:
            out_c[m] = cam[t]
            out_a[m] = attrs[t]
            src[m] = t
            m += 1
            continue
        k = 0
        for i in range(3):
            j = (i + 1) % 3
            zi = cam[t, i, 2]
            zj = cam[t, j, 2]
            if zi >= near:
                poly_c[k] = cam[t, i]
                poly_a[k] = attrs[t, i]
                k += 1
            if (zi >= near) != (zj >= near):
                s = (near - zi) / (zj - zi)
                poly_c[k] = cam[t, i] + s * (cam[t, j] - cam[t, i])
                poly_a[k] = attrs[t, i] + s * (attrs[t, j] - attrs[t, i])
                k += 1
        for f in range(1, k - 1):
            out_c[m, 0] = poly_c[0]
            out_c[m, 1] = poly_c[f]
            out_c[m, 2] = poly_c[f + 1]
            out_a[m, 0] = poly_a[0]
            out_a[m, 1] = poly_a[f]
            out_a[m, 2] = poly_a[f + 1]
            src[m] = t
            m += 1
    return out_c[:m], out_a[:m], src[:m]


@numba.njit(cache=True)
def _pixel_range(lo, hi, size):
    """First and last pixel index whose centre lies in [lo, hi], clamped to 0..size-1."""
    first = max(int(np.ceil(lo - 0.5)), 0)
    last = min(int(np.floor(hi - 0.5)), size - 1)
    return first, last


@numba.njit(cache=True)
def _checker_factor(w0, w1, w2, q, wxy, t, cell, dark):
    """`dark` on odd cells of a world-xy checkerboard of side `cell` m (perspective-correct), else 1."""
    s = w0 * q[t, 0] + w1 * q[t, 1] + w2 * q[t, 2]
    wx = (w0 * q[t, 0] * wxy[t, 0, 0] + w1 * q[t, 1] * wxy[t, 1, 0] + w2 * q[t, 2] * wxy[t, 2, 0]) / s
    wy = (w0 * q[t, 0] * wxy[t, 0, 1] + w1 * q[t, 1] * wxy[t, 1, 1] + w2 * q[t, 2] * wxy[t, 2, 1]) / s
    parity = (int(np.floor(wx / cell)) + int(np.floor(wy / cell))) & 1
    return dark if parity == 1 else 1.0


@numba.njit(cache=True)
def rasterize_triangles(color, depth, xy, key, q, rgb, wxy, checker_cell, checker_dark,
                        outline_px, outline_dark):
    """
    Z-buffered flat fill of triangles `xy (n, 3, 2)` px into `color (H, W, 3)` and `depth (H, W)`.

    `key (n, 3)`: depth key per vertex (bigger = nearer); `rgb (n, 3)`: flat colour per triangle;
    `q (n, 3)`: perspective weights (1/z, or 1 for orthographic) and `wxy (n, 3, 2)` world x, y per vertex,
    used for a checkerboard of side `checker_cell` m darkened by `checker_dark` (cell <= 0: none);
    pixels within `outline_px` of a triangle edge are darkened by `outline_dark` (outline_px <= 0: none).
    Returns the number of pixels written.
    """
    height, width = depth.shape
    written = 0
    for t in range(xy.shape[0]):
        x0, y0 = xy[t, 0, 0], xy[t, 0, 1]
        x1, y1 = xy[t, 1, 0], xy[t, 1, 1]
        x2, y2 = xy[t, 2, 0], xy[t, 2, 1]
        area = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0)
        if not np.isfinite(area) or abs(area) < 1e-12:
            continue
        c0, c1 = _pixel_range(min(x0, x1, x2), max(x0, x1, x2), width)
        r0, r1 = _pixel_range(min(y0, y1, y2), max(y0, y1, y2), height)
        if c0 > c1 or r0 > r1:
            continue
        inv = 1.0 / area
        len0 = np.hypot(x2 - x1, y2 - y1)
        len1 = np.hypot(x0 - x2, y0 - y2)
        len2 = np.hypot(x1 - x0, y1 - y0)
        two_a = abs(area)
        for row in range(r0, r1 + 1):
            cy = row + 0.5
            for col in range(c0, c1 + 1):
                cx = col + 0.5
                w0 = ((x1 - cx) * (y2 - cy) - (x2 - cx) * (y1 - cy)) * inv
                w1 = ((x2 - cx) * (y0 - cy) - (x0 - cx) * (y2 - cy)) * inv
                w2 = 1.0 - w0 - w1
                if w0 < 0.0 or w1 < 0.0 or w2 < 0.0:
                    continue
                k = w0 * key[t, 0] + w1 * key[t, 1] + w2 * key[t, 2]
                if k <= depth[row, col]:
                    continue
                depth[row, col] = k
                f = 1.0
                if checker_cell > 0.0:
                    f = _checker_factor(w0, w1, w2, q, wxy, t, checker_cell, checker_dark)
                if outline_px > 0.0:
                    d = min(w0 * two_a / len0, w1 * two_a / len1, w2 * two_a / len2)
                    if d < outline_px:
                        f *= outline_dark
                for c in range(3):
                    color[row, col, c] = rgb[t, c] * f
                written += 1
    return written


@numba.njit(cache=True)
def draw_segments(color, depth, p0, p1, k0, k1, radius, rgb):
    """
    Depth-tested round-capped segments `p0 (m, 2)` -> `p1 (m, 2)` px of `radius` px in colour `rgb (3,)`.

    `k0, k1 (m,)` are the depth keys of the end points (bigger = nearer); a pixel is painted where the
    segment's key is at least the stored one. Segments longer than 4 (W + H) px are skipped (off-screen
    projections). Returns the number of pixels written.
    """
    height, width = depth.shape
    limit = 4.0 * (width + height)
    r2 = radius * radius
    written = 0
    for s in range(p0.shape[0]):
        dx = p1[s, 0] - p0[s, 0]
        dy = p1[s, 1] - p0[s, 1]
        length = np.hypot(dx, dy)
        if not np.isfinite(length) or length > limit:
            continue
        steps = int(np.ceil(length / max(0.5 * radius, 0.5))) + 1
        for i in range(steps + 1):
            u = i / steps
            x = p0[s, 0] + u * dx
            y = p0[s, 1] + u * dy
            k = k0[s] + u * (k1[s] - k0[s])
            c0, c1 = _pixel_range(x - radius, x + radius, width)
            r0, r1 = _pixel_range(y - radius, y + radius, height)
            for row in range(r0, r1 + 1):
                for col in range(c0, c1 + 1):
                    ex = col + 0.5 - x
                    ey = row + 0.5 - y
                    if ex * ex + ey * ey > r2 or k < depth[row, col]:
                        continue
                    depth[row, col] = k
                    for c in range(3):
                        color[row, col, c] = rgb[c]
                    written += 1
    return written


@numba.njit(cache=True)
def surface_heights(tris, xy):
    """Height `(m,)` of the highest triangle of `tris (n, 3, 3)` above each point `xy (m, 2)`; NaN where none is."""
    out = np.full(xy.shape[0], np.nan)
    for t in range(tris.shape[0]):
        x0, y0 = tris[t, 0, 0], tris[t, 0, 1]
        x1, y1 = tris[t, 1, 0], tris[t, 1, 1]
        x2, y2 = tris[t, 2, 0], tris[t, 2, 1]
        area = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0)
        if abs(area) < 1e-15:
            continue
        lo_x, hi_x = min(x0, x1, x2), max(x0, x1, x2)
        lo_y, hi_y = min(y0, y1, y2), max(y0, y1, y2)
        for i in range(xy.shape[0]):
            px, py = xy[i, 0], xy[i, 1]
            if px < lo_x or px > hi_x or py < lo_y or py > hi_y:
                continue
            w0 = ((x1 - px) * (y2 - py) - (x2 - px) * (y1 - py)) / area
            w1 = ((x2 - px) * (y0 - py) - (x0 - px) * (y2 - py)) / area
            w2 = 1.0 - w0 - w1
            if w0 < -1e-12 or w1 < -1e-12 or w2 < -1e-12:
                continue
            z = w0 * tris[t, 0, 2] + w1 * tris[t, 1, 2] + w2 * tris[t, 2, 2]
            if np.isnan(out[i]) or z > out[i]:
                out[i] = z
    return out


@numba.njit(cache=True)
def downsample(color, factor):
    """Box-filter `color (H*f, W*f, 3)` floats in [0, 1] down by `factor` to uint8 `(H, W, 3)`."""
    h, w = color.shape[0] // factor, color.shape[1] // factor
    out = np.empty((h, w, 3), np.uint8)
    scale = 255.0 / (factor * factor)
    for row in range(h):
        for col in range(w):
            for c in range(3):
                acc = 0.0
                for i in range(factor):
                    for j in range(factor):
                        acc += color[row * factor + i, col * factor + j, c]
                out[row, col, c] = np.uint8(min(max(acc * scale + 0.5, 0.0), 255.0))
    return out
