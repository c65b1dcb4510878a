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
What the soft body achieves with each clip: the library's tracking figures.

A clip's nominal stride motion (`root_displacement`, `heading_change`) is the captured animal's; the soft body that
tracks it moves less or otherwise, and more so on a slope (a turn on a side slope turns less). `fit_tracking` fits,
per clip, the stride motion the body achieves as a linear function of the terrain gradient in the body frame (level
ground plus a gain per unit of uphill-ahead and uphill-to-the-left slope) from measured strides; the planner predicts
with it (`iguana_ros.motion.planning`). The figures are measured by `iguana motion calibrate`
(`iguana_ros.clip_calibration`) for each fidelity preset (the `fast` preset's larger steps damp the body: its turns
turn a fraction of the balanced preset's) and shipped with the library as `iguana_ros/data/clip_tracking.json`.

A cyclic clip is fitted on its steady strides (played after itself): the first stride after another clip carries some
of that clip's turning over (the body does not turn its heading rate at once). That carry-over is one coefficient for
the library (`LibraryTracking.carry`): the first stride's heading change moves by `carry` times the difference between
the previous stride's heading change and the clip's own.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, field
from importlib import resources
import json
import math
from pathlib import Path

import numpy as np

from iguana_ros.errors import InputError

TRACKING_FILE = 'clip_tracking.json'
"""Package-data file of the clip library's tracking figures (`iguana_ros/data/clip_tracking.json`)."""

SLOPE_GAIN_LIMIT = 2.0
"""Largest |gain| kept per unit gradient (m or rad per stride per unit slope): a fit over strides that saw too little
slope says nothing about it, so its gains are clipped here."""


@dataclass(frozen=True)
class StrideSample:
    """
    One measured stride.

    The clip played, the terrain gradient at its start in the body frame `(2,)` (uphill ahead, uphill to the left), the
    stride motion achieved `(3,)` (dx m, dy m in the start frame, dyaw rad), the feet's slip in contact (m, four feet
    summed), the terrain category it was measured on ('level', 'uphill', 'downhill', 'cross'), the clip played before
    ('' for none) and that stride's achieved motion `(3,)`.
    """

    clip: str
    gradient: tuple
    motion: tuple
    slip: float
    terrain: str
    previous: str = ''
    previous_motion: tuple = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class ClipTracking:
    """
    The tracking figures of one clip.

    `nominal` `(3,)` the clip's own stride motion (dx m, dy m, dyaw rad); `level` `(3,)` what the body achieves on
    level ground; `slope_gain` `(3, 2)` the change of that motion per unit gradient (uphill ahead, uphill to the
    left); `slip` the feet's slip per stride on level ground (m); `residual` `(3,)` the RMS misfit of the linear model
    over the strides; `samples` how many strides were measured; `by_terrain` the mean achieved motion, slip and
    count per terrain category.
    """

    name: str
    nominal: tuple
    level: tuple
    slope_gain: tuple
    slip: float
    residual: tuple
    samples: int
    by_terrain: dict = field(default_factory=dict)

    def predict(self, gradient: np.ndarray) -> np.ndarray:
        """Stride motions `(..., 3)` achieved at body-frame gradients `(..., 2)`."""
        gain = np.asarray(self.slope_gain, dtype=float)
        return np.asarray(self.level, dtype=float) + np.asarray(gradient, dtype=float) @ gain.T


@dataclass(frozen=True)
class LibraryTracking:
    """The tracking figures of a library: name -> ClipTracking, and the heading carry-over of a first stride."""

    clips: dict
    carry: float = 0.0


def fit_tracking(samples: list[StrideSample], nominal: dict, cyclic: set) -> LibraryTracking:
    """
    Return the LibraryTracking of measured strides, given each clip's nominal motion `(3,)` (name -> tuple).

    Least squares of motion = level + gain @ gradient per clip, over the steady strides of a `cyclic` clip (those after
    itself, if there are two or more) or over all strides of the others; a clip measured only on level ground (or on
    fewer than four strides) keeps zero gains. Clips without samples are left out. The carry-over is the least-squares
    coefficient of the first strides' heading-change error on the previous stride's excess heading change.
    """
    out = {}
    for name, motion in nominal.items():
        rows = [s for s in samples if s.clip == name]
        steady = [s for s in rows if s.previous == name]
        fitted = steady if name in cyclic and len(steady) >= 2 else rows
        if not rows:
            continue
        grad = np.array([s.gradient for s in fitted], dtype=float).reshape(-1, 2)
        achieved = np.array([s.motion for s in fitted], dtype=float).reshape(-1, 3)
        level, gain = _linear_fit(grad, achieved)
        residual = achieved - (level + grad @ gain.T)
        level_slip = [s.slip for s in rows if s.terrain == 'level'] or [s.slip for s in rows]
        out[name] = ClipTracking(
            name=name, nominal=tuple(float(v) for v in motion), level=tuple(float(v) for v in level),
            slope_gain=tuple(tuple(float(v) for v in row) for row in gain), slip=float(np.mean(level_slip)),
            residual=tuple(float(v) for v in np.sqrt(np.mean(residual ** 2, axis=0))), samples=len(rows),
            by_terrain=_by_terrain(rows))
    firsts = [s for s in samples if s.clip in cyclic and s.clip in out and s.previous not in ('', s.clip)]
    return LibraryTracking(out, _carry(firsts, out))


def _carry(firsts: list[StrideSample], clips: dict) -> float:
    """Least-squares heading carry-over of first strides (error on the previous stride's excess), in [0, 1]."""
    if not firsts:
        return 0.0
    steady = np.array([clips[s.clip].predict(np.array(s.gradient))[2] for s in firsts])
    excess = np.array([s.previous_motion[2] for s in firsts]) - steady
    error = np.array([s.motion[2] for s in firsts]) - steady
    return float(np.clip(excess @ error / max(excess @ excess, 1e-12), 0.0, 1.0))


def _linear_fit(gradient: np.ndarray, motion: np.ndarray) -> tuple:
    """(level `(3,)`, gain `(3, 2)`) of motion `(n, 3)` against gradient `(n, 2)`; zero gain where slope is unseen."""
    seen = np.ptp(gradient, axis=0) > 0.05 if len(gradient) >= 4 else np.zeros(2, bool)
    columns = np.concatenate([np.ones((len(gradient), 1)), gradient[:, seen]], axis=1)
    coef, *_ = np.linalg.lstsq(columns, motion, rcond=None)
    gain = np.zeros((3, 2))
    gain[:, seen] = np.clip(coef[1:].T, -SLOPE_GAIN_LIMIT, SLOPE_GAIN_LIMIT)
    return coef[0], gain


def _by_terrain(rows: list[StrideSample]) -> dict:
    """Terrain category -> {'motion': mean `(3,)`, 'slip': mean m, 'n': strides}."""
    out = {}
    for terrain in sorted({s.terrain for s in rows}):
        of = [s for s in rows if s.terrain == terrain]
        out[terrain] = {'motion': [float(v) for v in np.mean([s.motion for s in of], axis=0)],
                        'slip': float(np.mean([s.slip for s in of])), 'n': len(of)}
    return out


def default_tracking_path() -> Path:
    """Path of the tracking figures shipped with the clip library."""
    return Path(str(resources.files('iguana_ros').joinpath('data', TRACKING_FILE)))


def save_tracking(path: str | Path, tracking: LibraryTracking, conditions: dict) -> Path:
    """
    Write a LibraryTracking measured at the fidelity preset `conditions['fidelity']` into a tracking file.

    The conditions it was measured in (scene settings, tour) go with it; the figures of the other presets already in the
    file are kept. Returns the path.
    """
    path = Path(path)
    presets = _read(path).get('presets', {}) if path.is_file() else {}
    presets[conditions['fidelity']] = {'conditions': conditions, 'carry': tracking.carry,
                                       'clips': {name: asdict(t) for name, t in tracking.clips.items()}}
    path.write_text(json.dumps({'presets': presets}, indent=1, sort_keys=True) + '\n')
    return path


def tracking_presets(path: str | Path | None = None) -> list[str]:
    """Return the fidelity presets a tracking file holds figures for (default: the shipped file)."""
    path = Path(path) if path is not None else default_tracking_path()
    return sorted(_read(path).get('presets', {})) if path.is_file() else []


def load_tracking(path: str | Path | None = None, fidelity: str = 'balanced') -> LibraryTracking:
    """
    Return the LibraryTracking of a tracking file (default: the shipped one) for fidelity preset `fidelity`.

    The balanced preset's figures where the file has none for it; none at all if the file does not exist.
    """
    path = Path(path) if path is not None else default_tracking_path()
    if not path.is_file():
        return LibraryTracking({})
    presets = _read(path).get('presets', {})
    data = presets.get(fidelity, presets.get('balanced'))
    if data is None:
        return LibraryTracking({})
    try:
        carry = float(data['carry'])
        if not 0.0 <= carry <= 1.0:
            raise ValueError(f'carry {carry} is not within [0, 1]')
        return LibraryTracking({name: _tracking_from_dict(name, entry) for name, entry in data['clips'].items()},
                               carry)
    except (ValueError, KeyError, TypeError, AttributeError) as exc:
        raise InputError(f'clip tracking file {path} is damaged: {exc}') from None


def _read(path: Path) -> dict:
    """Return the JSON object of a tracking file; InputError if it is not one."""
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise InputError(f'clip tracking file {path} is unreadable: {exc}') from None
    if not isinstance(data, dict) or not isinstance(data.get('presets', {}), dict):
        raise InputError(f'clip tracking file {path} is damaged: expected an object of presets')
    return data


def _tracking_from_dict(name: str, entry: dict) -> ClipTracking:
    """One ClipTracking from its JSON entry; ValueError on a wrong shape or a non-finite number."""
    tracking = ClipTracking(
        name=name, nominal=tuple(entry['nominal']), level=tuple(entry['level']),
        slope_gain=tuple(tuple(row) for row in entry['slope_gain']), slip=float(entry['slip']),
        residual=tuple(entry['residual']), samples=int(entry['samples']), by_terrain=dict(entry['by_terrain']))
    numbers = (*tracking.nominal, *tracking.level, *np.ravel(tracking.slope_gain))
    if len(tracking.level) != 3 or np.shape(tracking.slope_gain) != (3, 2) or not all(map(math.isfinite, numbers)):
        raise ValueError(f'clip {name!r}: level (3,) and slope_gain (3, 2) of finite numbers expected')
    return tracking
