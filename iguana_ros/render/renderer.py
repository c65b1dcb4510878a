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
Draws a `RecordedRun` frame by frame: sky, terrain, goal spheres, root trails and the flat-shaded iguanas.

Every character of a world is drawn, the followed one's trail in TRAIL_RGB, the others' in OTHER_TRAIL_RGB.

A z-buffered software rasterizer (numba kernels in `raster`) at `supersample`x the output size, box-filtered
down (anti-aliasing). Colours are flat per triangle: the mean of its corners' marker colours times a
two-sided Lambert term for a fixed light. For a static camera (the same Camera object as the previous
frame) the sky + terrain buffers are rasterized once and copied for every frame.
"""
from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from iguana_ros.errors import InputError
from iguana_ros.render.camera import Camera
from iguana_ros.render.raster import clip_near, downsample, draw_segments, rasterize_triangles, surface_heights
from iguana_ros.render.run import RecordedRun

SUPERSAMPLE = 2
"""Rendering resolution factor per axis before the box filter."""

LIGHT_DIRECTION = (0.35, 0.3, 0.89)
"""Direction towards the light, world frame (normalised where used)."""

AMBIENT, DIFFUSE = 0.38, 0.62
"""Shade = AMBIENT + DIFFUSE * |n . light| (two-sided, so triangle winding does not matter)."""

SKY_TOP, SKY_HORIZON = (0.55, 0.72, 0.90), (0.90, 0.93, 0.96)
"""Sky gradient colours (top row, bottom row) in RGB [0, 1]."""

GROUND_RGB = (0.70, 0.66, 0.56)
"""Colour of the plain ground drawn when the bag has no terrain marker."""

MESH_RGB = (0.36, 0.62, 0.30)
"""Iguana colour when its marker carries no per-vertex colours."""

TRAIL_RGB = (0.95, 0.45, 0.10)
"""Colour of the root trail (of the followed character in a world)."""

OTHER_TRAIL_RGB = (0.80, 0.30, 0.60)
"""Colour of the root trails of a world's other characters."""

TRAIL_PX, OTHER_TRAIL_PX = 1.5, 1.2
"""Half widths (output pixels) of the followed character's trail and of the others'."""

TRAIL_LIFT = 0.01
"""The trail is drawn this far (m) above the terrain under the recorded root path."""

CHECKER_CELL, CHECKER_DARK = 0.5, 0.9
"""Ground checkerboard: cell side (m) and darkening of odd cells (motion cue for the follow camera)."""

OUTLINE_PX, OUTLINE_DARK = 1.0, 0.78
"""Iguana triangle edges: width in rendering pixels and darkening factor."""

GROUND_HALF_SIZE = 50.0
"""Half side (m) of the plain ground square drawn when the bag has no terrain marker."""


def flat_shade(corners: np.ndarray, colors: np.ndarray) -> np.ndarray:
    """Flat colours `(n, 3)` float32 of triangles given as corners `(3n, 3)` and corner RGBA `(3n, 4)`."""
    tris = corners.reshape(-1, 3, 3)
    normal = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    norm = np.linalg.norm(normal, axis=1)
    light = np.array(LIGHT_DIRECTION) / np.linalg.norm(LIGHT_DIRECTION)
    lambert = np.abs(normal @ light) / np.where(norm > 0.0, norm, 1.0)
    base = colors[:, :3].reshape(-1, 3, 3).mean(axis=1)
    return np.clip(base * (AMBIENT + DIFFUSE * lambert)[:, None], 0.0, 1.0).astype(np.float32)


def unit_sphere(subdivisions: int = 1) -> np.ndarray:
    """Triangles `(20 * 4**subdivisions, 3, 3)` of an icosphere of radius 1."""
    p = (1.0 + 5.0 ** 0.5) / 2.0
    v = np.array([[-1, p, 0], [1, p, 0], [-1, -p, 0], [1, -p, 0], [0, -1, p], [0, 1, p],
                  [0, -1, -p], [0, 1, -p], [p, 0, -1], [p, 0, 1], [-p, 0, -1], [-p, 0, 1]], dtype=float)
    f = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4],
                  [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8],
                  [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]])
    tris = v[f]
    for _ in range(subdivisions):
        a, b, c = tris[:, 0], tris[:, 1], tris[:, 2]
        ab, bc, ca = (a + b) / 2, (b + c) / 2, (c + a) / 2
        tris = np.concatenate([np.stack(t, axis=1) for t in
                               ((a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca))])
    return tris / np.linalg.norm(tris, axis=2, keepdims=True)


def plain_ground(run: RecordedRun) -> tuple[np.ndarray, np.ndarray]:
    """Corners `(6, 3)` and RGBA `(6, 4)` of a horizontal square under the lowest mesh point of the run."""
    z = float(run.extent_points()[:, 2].min())
    cx, cy = run.track_positions[:, :2].mean(axis=0) if len(run.track_positions) else (0.0, 0.0)
    h = GROUND_HALF_SIZE
    quad = np.array([[cx - h, cy - h, z], [cx + h, cy - h, z], [cx + h, cy + h, z],
                     [cx - h, cy - h, z], [cx + h, cy + h, z], [cx - h, cy + h, z]])
    return quad, np.tile([*GROUND_RGB, 1.0], (6, 1))


def ground_track(positions: np.ndarray, terrain_tris: np.ndarray) -> np.ndarray:
    """Root path `(k, 3)` dropped onto the terrain triangles `(n, 3, 3)` below it (kept where none is below)."""
    track = np.array(positions, dtype=np.float64).reshape(-1, 3)
    if len(track) == 0:
        return track
    z = surface_heights(np.asarray(terrain_tris, dtype=np.float64), np.ascontiguousarray(track[:, :2]))
    track[:, 2] = np.where(np.isnan(z), track[:, 2], z)
    return track


class Renderer:
    """Renders frames of one RecordedRun at `width` x `height` pixels (uint8 RGB arrays)."""

    def __init__(self, run: RecordedRun, width: int, height: int, supersample: int = SUPERSAMPLE,
                 trail: bool = True, label: bool = True) -> None:
        if width < 16 or height < 16 or supersample < 1:
            raise InputError(f'image size {width}x{height} is too small; expected at least 16x16 pixels')
        self.run, self.width, self.height, self.ss = run, int(width), int(height), int(supersample)
        self.trail, self.label = trail, label
        terrain = (run.terrain_points, run.terrain_colors)
        if run.terrain_points is None or len(run.terrain_points) < 3:
            terrain = plain_ground(run)
        self.terrain_tris = terrain[0].reshape(-1, 3, 3)
        self.terrain_rgb = flat_shade(*terrain)
        self.sphere = unit_sphere(1)
        lift = np.array([0.0, 0.0, TRAIL_LIFT])
        self.trail_points = ground_track(run.track_positions, self.terrain_tris) + lift
        self.other_trails = [ground_track(o.track_positions, self.terrain_tris) + lift for o in run.others]
        rows, cols = self.buffer_shape
        u = np.linspace(0.0, 1.0, rows)[:, None, None]
        sky = ((1 - u) * np.array(SKY_TOP) + u * np.array(SKY_HORIZON)).astype(np.float32)
        self.sky = np.ascontiguousarray(np.broadcast_to(sky, (rows, cols, 3)))
        self._static: tuple[Camera, np.ndarray, np.ndarray] | None = None

    @property
    def buffer_shape(self) -> tuple[int, int]:
        """(rows, columns) of the rendering buffers."""
        return self.height * self.ss, self.width * self.ss

    def draw_triangles(self, color: np.ndarray, depth: np.ndarray, camera: Camera, tris: np.ndarray,
                       rgb: np.ndarray, checker: bool = False, outline: bool = False) -> int:
        """Clip, project and rasterize world triangles `(n, 3, 3)` with flat colours `(n, 3)`; pixels written."""
        if len(tris) == 0:
            return 0
        tris = np.asarray(tris, dtype=np.float64)
        cam, wxy, src = clip_near(camera.to_camera(tris), np.ascontiguousarray(tris[:, :, :2]), camera.near)
        xy, key, q = camera.project(cam, *self.buffer_shape[::-1])
        return rasterize_triangles(color, depth, xy, key, q, np.ascontiguousarray(rgb[src]), wxy,
                                   CHECKER_CELL if checker else 0.0, CHECKER_DARK,
                                   OUTLINE_PX if outline else 0.0, OUTLINE_DARK)

    def draw_polyline(self, color: np.ndarray, depth: np.ndarray, camera: Camera, points: np.ndarray,
                      rgb: np.ndarray, radius_px: float) -> int:
        """Depth-tested polyline through world points `(m, 3)`; segments reaching behind the camera are dropped."""
        if len(points) < 2:
            return 0
        cam = camera.to_camera(points)
        keep = (cam[:-1, 2] >= camera.near) & (cam[1:, 2] >= camera.near)
        xy, key, _ = camera.project(cam, *self.buffer_shape[::-1])
        return draw_segments(color, depth, np.ascontiguousarray(xy[:-1][keep]), np.ascontiguousarray(xy[1:][keep]),
                             key[:-1][keep], key[1:][keep], radius_px * self.ss, rgb)

    def background(self, camera: Camera) -> tuple[np.ndarray, np.ndarray]:
        """Fresh colour `(H, W, 3)` and depth `(H, W)` buffers holding sky and terrain seen from `camera`."""
        if self._static is not None and self._static[0] is camera:
            return self._static[1].copy(), self._static[2].copy()
        color = self.sky.copy()
        depth = np.full(self.buffer_shape, -np.inf)
        self.draw_triangles(color, depth, camera, self.terrain_tris, self.terrain_rgb, checker=True)
        if camera.orthographic:  # static presets: keep the buffers for the next frame
            self._static = (camera, color.copy(), depth.copy())
        return color, depth

    def frame(self, i: int, camera: Camera) -> np.ndarray:
        """Frame `i` of the run seen from `camera`, uint8 `(height, width, 3)`."""
        run = self.run
        color, depth = self.background(camera)
        goals = run.goals_at(float(run.times[i]))
        if goals is not None and len(goals.positions):
            tris = (self.sphere[None] * goals.radii[:, None, None, None]
                    + goals.positions[:, None, None, :]).reshape(-1, 3, 3)
            colors = np.repeat(goals.colors, 3 * len(self.sphere), axis=0)
            self.draw_triangles(color, depth, camera, tris, flat_shade(tris.reshape(-1, 3), colors))
        t = run.times[i]
        if self.trail:
            self.draw_polyline(color, depth, camera, self.trail_points[run.track_times <= t + 1e-9],
                               np.array(TRAIL_RGB), TRAIL_PX)
            for other, trail in zip(run.others, self.other_trails):
                self.draw_polyline(color, depth, camera, trail[other.track_times <= t + 1e-9],
                                   np.array(OTHER_TRAIL_RGB), OTHER_TRAIL_PX)
        meshes = [(run.mesh_points[i], run.mesh_colors[i])] + [(o.mesh_points[i], o.mesh_colors[i]) for o in run.others]
        for points, colors in meshes:
            if points is not None:
                self.draw_triangles(color, depth, camera, points.reshape(-1, 3, 3), flat_shade(points, colors),
                                    outline=True)
        image = downsample(color, self.ss)
        following = f', following {run.character}' if run.others else ''
        return stamp_label(image, f't = {t:.2f} s{following}') if self.label else image

    def frames(self, cameras: list[Camera], indices: list[int] | None = None) -> Iterator[np.ndarray]:
        """Frames `indices` (default all) of the run, frame k seen from `cameras[k]`."""
        for k, i in enumerate(range(self.run.n_frames) if indices is None else indices):
            yield self.frame(i, cameras[k])


def stamp_label(image: np.ndarray, text: str) -> np.ndarray:
    """`image (H, W, 3)` uint8 with `text` written in its top-left corner (dark text on a light box)."""
    from PIL import Image, ImageDraw, ImageFont

    pil = Image.fromarray(image)
    draw = ImageDraw.Draw(pil)
    size = max(10, image.shape[0] // 28)
    try:
        font = ImageFont.load_default(size=size)
    except (TypeError, OSError):  # Pillow without FreeType: fixed bitmap font
        font = ImageFont.load_default()
    box = draw.textbbox((6, 4), text, font=font)
    draw.rectangle((box[0] - 3, box[1] - 2, box[2] + 3, box[3] + 2), fill=(255, 255, 255))
    draw.text((6, 4), text, fill=(20, 20, 20), font=font)
    return np.asarray(pil)
