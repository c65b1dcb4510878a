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
Low-quality sparse-marker capture from a synthetic take.

Sensor noise, dropouts (gaps) and marker slip, the problems the paper's capture of a small, active iguana had (Section
IV).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from iguana_ros.constants import MARKER_NOISE_STD
from iguana_ros.motion.dofs import BodyModel, iguana_body_model
from iguana_ros.motion.gait import SyntheticTake


@dataclass(frozen=True)
class CaptureQuality:
    """Degradation of a synthetic capture (all assumptions, sized to a small-animal optical capture)."""

    noise_std: float = MARKER_NOISE_STD
    """White sensor noise per axis, m."""
    gap_rate: float = 0.25
    """Dropouts per marker per second (feet x `foot_gap_factor`: occluded by the body)."""
    gap_frames: tuple = (2, 12)
    """Shortest and longest dropout, frames."""
    foot_gap_factor: float = 2.0
    slip_std: float = 0.0015
    """Slow drift of each marker on the skin, m per axis in the bone frame."""
    slip_time: float = 1.0
    """Correlation time of the slip drift, s."""


def _slow_noise(rng: np.random.Generator, shape: tuple, sigma_frames: float) -> np.ndarray:
    """Unit-variance Gaussian noise smoothed along axis 0 with a Gaussian of `sigma_frames`."""
    n = shape[0]
    pad = int(3 * sigma_frames) + 1
    white = rng.normal(size=(n + 2 * pad,) + shape[1:])
    x = np.arange(-pad, pad + 1)
    kernel = np.exp(-0.5 * (x / sigma_frames) ** 2)
    smooth = np.apply_along_axis(lambda v: np.convolve(v, kernel, mode='valid'), 0, white)
    return smooth / np.sqrt((kernel ** 2).sum())


def dropout_mask(rng: np.random.Generator, n_frames: int, n_markers: int, frame_rate: float,
                 quality: CaptureQuality, foot_markers: int = 4) -> np.ndarray:
    """`(n_frames, n_markers)` True where a sample is missing: Poisson gaps of random length."""
    missing = np.zeros((n_frames, n_markers), dtype=bool)
    duration = n_frames / frame_rate
    for m in range(n_markers):
        rate = quality.gap_rate * (quality.foot_gap_factor if m < foot_markers else 1.0)
        for _ in range(rng.poisson(rate * duration)):
            start = rng.integers(0, n_frames)
            length = rng.integers(quality.gap_frames[0], quality.gap_frames[1] + 1)
            missing[start:start + length, m] = True
    return missing


def synthesize_capture(take: SyntheticTake, seed: int, quality: CaptureQuality = CaptureQuality(),
                       model: BodyModel | None = None) -> np.ndarray:
    """Degraded marker positions `(F, n_markers, 3)` (NaN = missing) of a synthetic take, from `seed`."""
    model = model or iguana_body_model()
    rng = np.random.default_rng(seed)
    state = model.state(take.theta)
    n_frames, n_markers = take.n_frames, len(model.markers.labels)
    slip = quality.slip_std * _slow_noise(rng, (n_frames, n_markers, 3), quality.slip_time * take.frame_rate)
    bone_rot = state.rotations[:, model.markers.bones]
    positions = take.markers + np.einsum('fmij,fmj->fmi', bone_rot, slip)
    positions = positions + rng.normal(scale=quality.noise_std, size=positions.shape)
    positions[dropout_mask(rng, n_frames, n_markers, take.frame_rate, quality)] = np.nan
    return positions
