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
Pinhole and orthographic cameras, and the camera presets of `iguana render` (follow, side, top, orbit).

World frame: z up. A camera frame has x to the image right, y to the image top and z forward (into the
scene). Presets turn a recorded root track into one camera per rendered frame; `side` and `top` are static
orthographic views that frame the whole run (so the terrain is rasterized once), `follow` and `orbit` are
perspective views that track the smoothed root.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.ndimage import gaussian_filter1d

from iguana_ros.errors import InputError

PRESETS = ('follow', 'side', 'top', 'orbit')
"""Camera preset names; the first is the default."""

NEAR_PLANE = 0.05
"""Near clipping distance of perspective cameras, m."""

FOLLOW_OFFSET = (-1.4, 0.85, 0.75)
"""Follow-cam eye relative to the root in the heading frame (behind, left, above), m."""

ORBIT_RADIUS, ORBIT_HEIGHT, ORBIT_PERIOD = 1.8, 0.8, 12.0
"""Orbit-cam horizontal distance (m) and height (m) from the root, and seconds per revolution."""

TRACK_SMOOTHING_S, HEADING_SMOOTHING_S = 0.3, 1.0
"""Gaussian smoothing (standard deviation, s) of the tracked root position and of the heading."""

STATIC_TILT_DEG = 25.0
"""Downward tilt of the `side` view, degrees (a level view would see the terrain edge-on)."""

FRAME_MARGIN = 1.2
"""Static views show this multiple of the run's bounding box."""

MIN_VIEW_HEIGHT = 0.5
"""Smallest visible height (m) of a static orthographic view."""

_Z = np.array([0.0, 0.0, 1.0])
_Z.setflags(write=False)


@dataclass(frozen=True, eq=False)
class Camera:
    """A camera at `eye (3,)` looking along unit `forward (3,)`; orthographic when `ortho_height` > 0 (m)."""

    eye: np.ndarray
    forward: np.ndarray
    up_hint: np.ndarray = field(default_factory=lambda: _Z.copy())
    fov_deg: float = 40.0
    ortho_height: float = 0.0

    @classmethod
    def look_at(cls, eye, target, fov_deg: float = 40.0) -> 'Camera':
        """Perspective camera at `eye (3,)` looking at `target (3,)`, world z up."""
        eye = np.asarray(eye, dtype=float)
        d = np.asarray(target, dtype=float) - eye
        norm = np.linalg.norm(d)
        if not np.isfinite(norm) or norm == 0.0:
            raise InputError(f'camera eye {eye} and target {target} must be distinct finite points')
        return cls(eye, d / norm, _Z, fov_deg)

    @property
    def orthographic(self) -> bool:
        """Return True for an orthographic camera."""
        return self.ortho_height > 0.0

    def basis(self) -> np.ndarray:
        """Rows right, up, forward `(3, 3)` of the camera frame in world coordinates."""
        f = self.forward / np.linalg.norm(self.forward)
        right = np.cross(f, self.up_hint)
        if np.linalg.norm(right) < 1e-9:  # looking along the up hint: use world y as up instead
            right = np.cross(f, np.array([0.0, 1.0, 0.0]))
        right /= np.linalg.norm(right)
        return np.stack([right, np.cross(right, f), f])

    def to_camera(self, points: np.ndarray) -> np.ndarray:
        """World points `(..., 3)` in camera coordinates `(..., 3)` (x right, y up, z forward)."""
        return (np.asarray(points, dtype=float) - self.eye) @ self.basis().T

    def project(self, cam: np.ndarray, width: int, height: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pixels `(..., 2)`, depth keys `(...)` (bigger = nearer) and perspective weights `(...)` of camera points."""
        if self.orthographic:
            s = height / self.ortho_height
            xy = np.stack([0.5 * width + s * cam[..., 0], 0.5 * height - s * cam[..., 1]], axis=-1)
            return xy, -cam[..., 2], np.ones(cam.shape[:-1])
        f = 0.5 * height / np.tan(np.radians(0.5 * self.fov_deg))
        inv_z = 1.0 / cam[..., 2]
        xy = np.stack([0.5 * width + f * cam[..., 0] * inv_z, 0.5 * height - f * cam[..., 1] * inv_z], axis=-1)
        return xy, inv_z, inv_z

    @property
    def near(self) -> float:
        """Near clipping distance (m); -inf for orthographic cameras, which clip nothing."""
        return -np.inf if self.orthographic else NEAR_PLANE


def smooth(values: np.ndarray, times: np.ndarray, sigma_s: float) -> np.ndarray:
    """Gaussian smoothing along axis 0 of `values (n, ...)` sampled at `times (n,)` with std `sigma_s` seconds."""
    if values.shape[0] < 2:
        return values.copy()
    dt = float(np.median(np.diff(times)))
    if not dt > 0.0:
        return values.copy()
    return gaussian_filter1d(values, sigma_s / dt, axis=0, mode='nearest')


def heading_track(times: np.ndarray, positions: np.ndarray, yaws: np.ndarray | None) -> np.ndarray:
    """Smoothed heading (rad) `(n,)`: from the root yaws `(n,)` if given, else from the direction of travel."""
    if yaws is not None:
        return smooth(np.unwrap(yaws), times, HEADING_SMOOTHING_S)
    track = smooth(positions[:, :2], times, HEADING_SMOOTHING_S)
    if len(times) < 2:
        return np.zeros(len(times))
    vel = np.gradient(track, times, axis=0)
    moving = np.linalg.norm(vel, axis=1) > 0.02
    if not moving.any():
        return np.zeros(len(times))
    idx = np.where(moving, np.arange(len(times)), -1)
    idx = np.maximum.accumulate(idx)                    # hold the last heading while stopped
    idx[idx < 0] = np.argmax(moving)                    # before the first motion: the first heading
    heading = np.arctan2(vel[idx, 1], vel[idx, 0])
    return np.unwrap(heading)


def follow_cameras(times: np.ndarray, positions: np.ndarray, yaws: np.ndarray | None) -> list[Camera]:
    """Cameras behind-left of and above the smoothed root `(n, 3)`, turning with the smoothed heading."""
    target = smooth(positions, times, TRACK_SMOOTHING_S)
    heading = heading_track(times, positions, yaws)
    c, s = np.cos(heading), np.sin(heading)
    back, left, up = FOLLOW_OFFSET
    offset = np.stack([c * back - s * left, s * back + c * left, np.full_like(c, up)], axis=1)
    ahead = 0.1 * np.stack([c, s, np.zeros_like(c)], axis=1)
    return [Camera.look_at(e, t) for e, t in zip(target + offset, target + ahead)]


def orbit_cameras(times: np.ndarray, positions: np.ndarray, yaws: np.ndarray | None) -> list[Camera]:
    """Cameras circling the smoothed root once per ORBIT_PERIOD s, starting behind it."""
    target = smooth(positions, times, TRACK_SMOOTHING_S)
    start = heading_track(times, positions, yaws)[0] + np.pi if len(times) else 0.0
    angle = start + 2.0 * np.pi * (times - times[0]) / ORBIT_PERIOD if len(times) else times
    offset = np.stack([ORBIT_RADIUS * np.cos(angle), ORBIT_RADIUS * np.sin(angle),
                       np.full_like(angle, ORBIT_HEIGHT)], axis=1)
    return [Camera.look_at(e, t) for e, t in zip(target + offset, target)]


def travel_direction(positions: np.ndarray, heading: float = 0.0) -> np.ndarray:
    """
    Return the unit xy direction `(2,)` of the track's principal axis, oriented start to end.

    It is `heading` if the track barely moves.
    """
    xy = positions[:, :2]
    if len(xy) < 2 or np.ptp(xy, axis=0).max() < 0.05:
        return np.array([np.cos(heading), np.sin(heading)])
    centred = xy - xy.mean(axis=0)
    d = np.linalg.svd(centred, full_matrices=False)[2][0]
    return d if d @ (xy[-1] - xy[0]) >= 0.0 else -d


def framed_camera(forward: np.ndarray, up_hint: np.ndarray, points: np.ndarray, aspect: float) -> Camera:
    """Return static orthographic camera along `forward (3,)` whose view holds every point `(n, 3)` with a margin."""
    cam = Camera(np.zeros(3), forward / np.linalg.norm(forward), up_hint, ortho_height=1.0)
    basis = cam.basis()
    local = points @ basis.T
    lo, hi = local.min(axis=0), local.max(axis=0)
    centre = 0.5 * (lo + hi)
    height = max(FRAME_MARGIN * (hi[1] - lo[1]), FRAME_MARGIN * (hi[0] - lo[0]) / aspect, MIN_VIEW_HEIGHT)
    depth_back = (hi[2] - lo[2]) + 100.0                  # eye well behind everything (terrain included)
    eye = centre[0] * basis[0] + centre[1] * basis[1] + (lo[2] - depth_back) * basis[2]
    return Camera(eye, basis[2], up_hint, ortho_height=float(height))


def side_camera(positions: np.ndarray, extent_points: np.ndarray, aspect: float, heading: float) -> Camera:
    """Return static view from the right of the travel direction, tilted down STATIC_TILT_DEG, framing the run."""
    d = travel_direction(positions, heading)
    level = np.array([-d[1], d[0], 0.0])
    tilt = np.radians(STATIC_TILT_DEG)
    return framed_camera(np.cos(tilt) * level - np.sin(tilt) * _Z, _Z, extent_points, aspect)


def top_camera(positions: np.ndarray, extent_points: np.ndarray, aspect: float, heading: float) -> Camera:
    """Return static view straight down, travel direction to the image right, framing the run."""
    d = travel_direction(positions, heading)
    return framed_camera(-_Z, np.array([-d[1], d[0], 0.0]), extent_points, aspect)


def preset_cameras(preset: str, times: np.ndarray, positions: np.ndarray, yaws: np.ndarray | None,
                   extent_points: np.ndarray, aspect: float) -> list[Camera]:
    """
    Return one camera per frame time `(n,)` for `preset`.

    They are made from root positions `(n, 3)`, yaws `(n,)` or None, and the points `(m, 3)` a static view must show;
    static presets return the same Camera object n times.
    """
    if preset not in PRESETS:
        raise InputError(f'unknown camera {preset!r}; expected one of: {", ".join(PRESETS)}')
    if preset == 'follow':
        return follow_cameras(times, positions, yaws)
    if preset == 'orbit':
        return orbit_cameras(times, positions, yaws)
    heading = float(heading_track(times, positions, yaws)[0]) if len(times) else 0.0
    make = side_camera if preset == 'side' else top_camera
    return [make(positions, extent_points, aspect, heading)] * len(times)
