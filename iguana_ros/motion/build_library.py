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
Build the motion data deterministically from a seed.

Synthetic takes -> degraded C3D captures -> full-body IK -> contacts and stride boundaries -> the clip library
(`iguana motion build`).
"""
from __future__ import annotations

from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np

from iguana_ros.constants import TROT_STRIDE_FREQUENCY
from iguana_ros.errors import IguanaError
from iguana_ros.motion.c3d_io import read_capture, write_c3d
from iguana_ros.motion.capture import CaptureQuality, synthesize_capture
from iguana_ros.motion.clips import cut_clip, save_clip_library
from iguana_ros.motion.dofs import BodyModel, iguana_body_model
from iguana_ros.motion.gait import GaitParameters, generate_take, SYNTHETIC_TAKES
from iguana_ros.motion.ik import IKResult, IKSettings, solve_ik
from iguana_ros.motion.segmentation import detect_contacts, stride_boundaries

DEFAULT_SEED = 2018
"""Seed of the shipped capture (the paper's year)."""
CLIP_SOURCES = {'forward': 'trot_straight', 'turn_left': 'trot_turn_left', 'turn_right': 'trot_turn_right',
                'idle': 'stand'}
"""Clip name -> take it is cut from."""


@dataclass(frozen=True)
class TakeResult:
    """A processed take: IK result, detected contacts `(F, 4)`, stride boundaries `(k,)`, missing fraction."""

    name: str
    ik: IKResult
    contacts: np.ndarray
    boundaries: np.ndarray
    missing_fraction: float
    frame_rate: float


def package_capture_dir() -> Path:
    """Folder of the shipped C3D captures (`iguana_ros/data/capture`)."""
    return Path(str(resources.files('iguana_ros').joinpath('data', 'capture')))


def write_synthetic_captures(out_dir: str | Path, seed: int = DEFAULT_SEED, gait: GaitParameters = GaitParameters(),
                             quality: CaptureQuality = CaptureQuality(), model: BodyModel | None = None) -> dict:
    """Generate every synthetic take, degrade it and write `<take>.c3d`; returns name -> SyntheticTake."""
    model = model or iguana_body_model()
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    takes = {}
    for k, spec in enumerate(SYNTHETIC_TAKES):
        take = generate_take(spec, gait, model=model)
        markers = synthesize_capture(take, seed + k, quality, model)
        write_c3d(out_dir / f'{spec.name}.c3d', model.markers.labels, markers, take.frame_rate)
        takes[spec.name] = take
    return takes


def process_capture(path: str | Path, model: BodyModel | None = None,
                    settings: IKSettings = IKSettings()) -> TakeResult:
    """Full-body IK, contacts and stride boundaries of one C3D capture."""
    model = model or iguana_body_model()
    observed, rate = read_capture(path, model.markers)
    ik = solve_ik(observed, model, settings)
    feet = model.marker_positions(ik.theta)[:, :4]
    contacts = detect_contacts(feet, rate)
    return TakeResult(name=Path(path).stem, ik=ik, contacts=contacts, boundaries=stride_boundaries(contacts),
                      missing_fraction=float(np.isnan(observed).any(axis=-1).mean()), frame_rate=rate)


def middle_stride(result: TakeResult, nominal: int) -> tuple:
    """(start, end) frames of the full stride nearest the middle of the take, about `nominal` frames long."""
    b = result.boundaries
    strides = [(s, e) for s, e in zip(b[:-1], b[1:]) if s >= 1 and abs((e - s) - nominal) <= 2]
    if not strides:
        raise IguanaError(f'take {result.name}: no full stride found between touchdowns {b.tolist()}')
    middle = 0.5 * len(result.contacts)
    return min(strides, key=lambda se: (abs((se[1] - se[0]) - nominal), abs(0.5 * (se[0] + se[1]) - middle)))


def cut_library(results: dict, model: BodyModel | None = None) -> dict:
    """Return the clip library (name -> Clip) cut from processed takes (name -> TakeResult)."""
    model = model or iguana_body_model()
    clips = {}
    for name, take_name in CLIP_SOURCES.items():
        result = results[take_name]
        nominal = int(round(result.frame_rate / TROT_STRIDE_FREQUENCY))
        if name == 'idle':
            start = (len(result.contacts) - nominal) // 2
            end = start + nominal
        else:
            start, end = middle_stride(result, nominal)
        clips[name] = cut_clip(name, result.ik.theta, result.contacts, start, end, result.frame_rate,
                               source=take_name, model=model)
    return clips


def build_library(seed: int = DEFAULT_SEED, capture_dir: str | Path | None = None,
                  library_path: str | Path | None = None, log=print) -> tuple:
    """Regenerate captures, IK and clips; write them; return (clips, name -> TakeResult)."""
    model = iguana_body_model()
    capture_dir = Path(capture_dir) if capture_dir else package_capture_dir()
    library_path = Path(library_path) if library_path else capture_dir.parent / 'clips.npz'
    write_synthetic_captures(capture_dir, seed, model=model)
    results = {}
    for spec in SYNTHETIC_TAKES:
        result = process_capture(capture_dir / f'{spec.name}.c3d', model)
        results[spec.name] = result
        log(f'{spec.name:18s} {len(result.contacts):4d} frames  {100 * result.missing_fraction:4.1f}% missing  '
            f'IK residual {result.ik.marker_rms_mm:.2f} mm RMS  strides at {result.boundaries.tolist()}')
    clips = cut_library(results, model)
    extra = {'seed': np.array(seed)}
    for name, result in results.items():
        extra[f'take/{name}/theta'] = result.ik.theta.astype(np.float32)
        extra[f'take/{name}/contacts'] = result.contacts
        extra[f'take/{name}/boundaries'] = result.boundaries
        extra[f'take/{name}/marker_rms_mm'] = np.array(result.ik.marker_rms_mm)
        extra[f'take/{name}/missing_fraction'] = np.array(result.missing_fraction)
    save_clip_library(library_path, clips, extra)
    return clips, results
