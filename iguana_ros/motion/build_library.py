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

from iguana_ros.errors import IguanaError
from iguana_ros.motion.c3d_io import read_capture, write_c3d
from iguana_ros.motion.capture import CaptureQuality, synthesize_capture
from iguana_ros.motion.cleanup import PIVOT_TAIL_TIP_HEIGHT, TAIL_TIP_HEIGHT
from iguana_ros.motion.clips import cut_clip, save_clip_library
from iguana_ros.motion.dofs import BodyModel, iguana_body_model
from iguana_ros.motion.gait import GaitParameters, GAITS, generate_take, SYNTHETIC_TAKES
from iguana_ros.motion.ik import IKResult, IKSettings, solve_ik
from iguana_ros.motion.segmentation import detect_contacts, stride_boundaries

DEFAULT_SEED = 2018
"""Seed of the shipped capture (the paper's year)."""


@dataclass(frozen=True)
class ClipSource:
    """
    Where a clip is cut from, and the gaits it starts and ends in (the motion graph's edges).

    `cut` says which stride of take `take`: 'middle' (the full stride nearest the middle), 'rest' (a stand of a stride
    of gait `exit_gait`, in the middle of the take), 'from_rest' (from the frame at `at` s, when the take starts
    stepping, to the first touchdown a stride of the `exit_gait` gait later), 'to_rest' (the stride of gait
    `entry_gait` from the touchdown nearest `at` s, when it stops), 'across' (the stride in which the take's gait
    changes, the one holding `at` s).
    `tail_tip` is the height (m) of the tail tip over the floor (`motion.cleanup.support_tail`).
    """

    take: str
    cut: str = 'middle'
    entry_gait: str = 'trot'
    exit_gait: str = 'trot'
    at: float = 0.0
    tail_tip: float = TAIL_TIP_HEIGHT

    @property
    def cyclic(self) -> bool:
        """Whether the clip repeats (it ends in the gait and pose it starts in)."""
        return self.cut in ('middle', 'rest')


CLIP_SOURCES = {
    'forward': ClipSource('trot_straight'), 'turn_left': ClipSource('trot_turn_left'),
    'turn_right': ClipSource('trot_turn_right'), 'idle': ClipSource('stand', 'rest', 'stand', 'stand'),
    'walk': ClipSource('walk_straight', entry_gait='walk', exit_gait='walk'),
    'pivot_left': ClipSource('pivot_left', entry_gait='walk', exit_gait='walk', tail_tip=PIVOT_TAIL_TIP_HEIGHT),
    'pivot_right': ClipSource('pivot_right', entry_gait='walk', exit_gait='walk', tail_tip=PIVOT_TAIL_TIP_HEIGHT),
    'sharp_left': ClipSource('walk_sharp_left', entry_gait='walk', exit_gait='walk'),
    'sharp_right': ClipSource('walk_sharp_right', entry_gait='walk', exit_gait='walk'),
    'fast': ClipSource('trot_fast', entry_gait='fast', exit_gait='fast'),
    'fast_left': ClipSource('trot_fast_left', entry_gait='fast', exit_gait='fast'),
    'fast_right': ClipSource('trot_fast_right', entry_gait='fast', exit_gait='fast'),
    'start': ClipSource('stand_walk_stand', 'from_rest', 'stand', 'walk', 2.0 / GAITS['walk'][0]),
    'stop': ClipSource('stand_walk_stand', 'to_rest', 'walk', 'stand', 6.0 / GAITS['walk'][0]),
    'walk_to_trot': ClipSource('gait_changes', 'across', 'walk', 'trot', 2.9),
    'trot_to_fast': ClipSource('gait_changes', 'across', 'trot', 'fast', 5.85),
    'fast_to_trot': ClipSource('gait_changes', 'across', 'fast', 'trot', 8.95),
    'trot_to_walk': ClipSource('gait_changes', 'across', 'trot', 'walk', 11.55),
}
"""Clip name -> where it is cut from and its gaits: the trot (forward, turns of 15 deg), standing, the slow walk with
its turns on the spot (40 deg) and sharp turns (30 deg), the fast trot with its turns (10 deg), and the transitions
between them."""


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


def middle_stride(result: TakeResult, nominal: int, duty: float | None = None) -> tuple:
    """
    (start, end) frames of a full stride of the take, about `nominal` frames long.

    Of the strides nearest that length, the one whose detected duty factor is nearest `duty` (in steps of 0.05: where
    a capture gap made the contacts wrong it is off), then the one nearest the middle of the take.
    """
    b = result.boundaries
    strides = [(s, e) for s, e in zip(b[:-1], b[1:]) if s >= 1 and abs((e - s) - nominal) <= 2]
    if not strides:
        raise IguanaError(f'take {result.name}: no full stride found between touchdowns {b.tolist()}')
    middle = 0.5 * len(result.contacts)

    def off_duty(se: tuple) -> int:
        return 0 if duty is None else int(round(abs(result.contacts[se[0]:se[1]].mean() - duty) / 0.05))
    return min(strides, key=lambda se: (abs((se[1] - se[0]) - nominal), off_duty(se),
                                        abs(0.5 * (se[0] + se[1]) - middle)))


def take_gait(take: str) -> str:
    """Return the gait (a name in GAITS) a take starts in: its first gait knot's, else the trot."""
    spec = next((s for s in SYNTHETIC_TAKES if s.name == take), None)
    return spec.gait_knots[0][1] if spec is not None and spec.gait_knots else 'trot'


def nominal_frames(gait: str, frame_rate: float) -> int:
    """Frames of one stride of gait `gait` (a name in GAITS; 'stand' stands for a trot stride) at `frame_rate`."""
    return int(round(frame_rate / GAITS.get(gait, GAITS['trot'])[0]))


def source_frames(result: TakeResult, source: ClipSource) -> tuple:
    """(start, end) take frames of the clip `source` cuts from the processed take `result`."""
    rate, b = result.frame_rate, result.boundaries
    at = int(round(source.at * rate))
    if source.cut == 'middle':
        gait = take_gait(source.take)
        return middle_stride(result, nominal_frames(gait, rate), GAITS[gait][1])
    if source.cut == 'rest':
        nominal = nominal_frames(source.exit_gait, rate)
        start = (len(result.contacts) - nominal) // 2
        return start, start + nominal
    if source.cut == 'from_rest':
        later = b[b >= at + nominal_frames(source.exit_gait, rate) // 2]
        return at, _first(later, result, source)
    if source.cut == 'to_rest':
        start = int(b[np.argmin(np.abs(b - at))]) if len(b) else -1
        return start, start + nominal_frames(source.entry_gait, rate)
    holding = [(int(s), int(e)) for s, e in zip(b[:-1], b[1:]) if s <= at < e]
    if not holding:
        raise IguanaError(f'take {result.name}: no stride holds frame {at} (touchdowns {b.tolist()})')
    return holding[0]


def _first(frames: np.ndarray, result: TakeResult, source: ClipSource) -> int:
    """Return the first of `frames`, or raise IguanaError naming the take and the cut."""
    if not len(frames):
        raise IguanaError(f'take {result.name}: no touchdown after {source.at:g} s for its {source.cut!r} clip')
    return int(frames[0])


def cut_library(results: dict, model: BodyModel | None = None) -> dict:
    """Return the clip library (name -> Clip) cut from processed takes (name -> TakeResult)."""
    model = model or iguana_body_model()
    clips = {}
    for name, source in CLIP_SOURCES.items():
        result = results[source.take]
        start, end = source_frames(result, source)
        clips[name] = cut_clip(name, result.ik.theta, result.contacts, start, end, result.frame_rate,
                               source=source.take, model=model, cyclic=source.cyclic, entry_gait=source.entry_gait,
                               exit_gait=source.exit_gait, tail_tip=source.tail_tip)
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
