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
C3D marker files (the motion-capture field's standard format) through the `c3d` package.

In the file positions are millimetres (float32) and a missing sample has residual -1; in the code they are
metres with NaN for a missing sample. `read_capture` checks the labels against the iguana's 15 markers.
"""
from __future__ import annotations

from pathlib import Path
import struct
import warnings

import numpy as np

from iguana_ros.body.markers import iguana_markers, MarkerSet
from iguana_ros.errors import InputError

MM = 1000.0
"""Millimetres per metre (C3D point unit 'mm')."""


def write_c3d(path: str | Path, labels: tuple, positions: np.ndarray, frame_rate: float) -> None:
    """Write marker `positions (F, n_markers, 3)` in metres (NaN = missing) with `labels` to a C3D file."""
    import c3d

    positions = np.asarray(positions, dtype=float)
    if positions.ndim != 3 or positions.shape[1:] != (len(labels), 3):
        raise InputError(f'C3D positions must have shape (frames, {len(labels)}, 3), got {positions.shape}')
    if np.isinf(positions).any():
        raise InputError('C3D positions contain an infinite value; use NaN for a missing sample')
    writer = c3d.Writer(point_rate=float(frame_rate), point_units='mm  ')
    writer.set_point_labels([str(label) for label in labels])
    missing = np.isnan(positions).any(axis=-1)
    frames = []
    for f in range(positions.shape[0]):
        points = np.zeros((len(labels), 5), dtype=np.float32)
        points[:, :3] = np.where(missing[f, :, None], 0.0, positions[f] * MM)
        points[:, 3] = np.where(missing[f], -1.0, 0.0)
        frames.append((points, np.zeros((0, 0), dtype=np.float32)))
    writer.add_frames(frames)
    with open(path, 'wb') as handle, warnings.catch_warnings():
        warnings.simplefilter('ignore')
        writer.write(handle)


def read_c3d(path: str | Path) -> tuple:
    """(labels tuple, positions `(F, n_markers, 3)` in metres with NaN for missing, frame rate Hz) of a C3D."""
    import c3d

    path = Path(path)
    if not path.is_file():
        raise InputError(f'C3D file {path} does not exist')
    try:
        with open(path, 'rb') as handle, warnings.catch_warnings():
            warnings.simplefilter('ignore')
            reader = c3d.Reader(handle)
            labels = tuple(str(label).strip() for label in reader.point_labels)
            rate = float(reader.point_rate)
            frames = [points[:, :4].copy() for _, points, _ in reader.read_frames(copy=True)]
    except (AssertionError, ValueError, KeyError, EOFError, OSError, AttributeError, TypeError, struct.error) as exc:
        raise InputError(f'{path} is not a readable C3D file ({exc})') from None
    if not frames:
        raise InputError(f'C3D file {path} has no frames')
    data = np.stack(frames).astype(float)
    positions = data[..., :3] / MM
    positions[data[..., 3] < 0.0] = np.nan
    return labels, positions, rate


def order_markers(labels: tuple, positions: np.ndarray, markers: MarkerSet, source: str) -> np.ndarray:
    """Positions `(F, n_markers, 3)` re-ordered to `markers.labels`; InputError names missing/unknown labels."""
    missing = [label for label in markers.labels if label not in labels]
    unknown = [label for label in labels if label not in markers.labels]
    problems = []
    if missing:
        problems.append(f'missing marker labels {", ".join(missing)}')
    if unknown:
        problems.append(f'unknown marker labels {", ".join(unknown)}')
    if problems:
        raise InputError(f'{source}: {"; ".join(problems)} (expected exactly {", ".join(markers.labels)})')
    return positions[:, [labels.index(label) for label in markers.labels]]


def read_capture(path: str | Path, markers: MarkerSet | None = None) -> tuple:
    """(positions `(F, n_markers, 3)` m in marker-set order, frame rate Hz) of an iguana capture C3D."""
    markers = markers or iguana_markers()
    labels, positions, rate = read_c3d(path)
    return order_markers(labels, positions, markers, str(path)), rate
