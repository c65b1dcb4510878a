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
Stride segmentation (Section IV).

Foot contacts from marker height and speed, and stride boundaries at the touchdown of a diagonal foot pair.
"""
from __future__ import annotations

import numpy as np

CONTACT_HEIGHT = 0.010
"""A foot marker within this height (m) of its lowest level may be in contact."""
CONTACT_SPEED = 0.12
"""A foot marker slower than this (m/s) may be in contact."""
MIN_RUN = 3
"""Contact or swing phases shorter than this many frames are merged into their neighbours."""
BOUNDARY_PAIR = (0, 3)
"""The diagonal pair whose touchdown starts a stride: FL and HR (foot order fl, fr, hl, hr)."""


def _debounce(flags: np.ndarray, min_run: int) -> np.ndarray:
    """`(F,)` bool with runs shorter than `min_run` flipped (inner runs only, gaps first then contacts)."""
    out = flags.copy()
    for value in (False, True):
        edges = np.flatnonzero(np.diff(np.concatenate([[False], out == value, [False]]).astype(int)))
        for start, stop in zip(edges[::2], edges[1::2]):
            if stop - start < min_run and start > 0 and stop < len(out):
                out[start:stop] = not value
    return out


def detect_contacts(feet: np.ndarray, frame_rate: float, height: float = CONTACT_HEIGHT,
                    speed: float = CONTACT_SPEED, min_run: int = MIN_RUN) -> np.ndarray:
    """
    Contacts `(F, 4)` of foot marker tracks `feet (F, 4, 3)` (m): low, slow, debounced.

    The speed of a frame is the smaller of its backward and forward one-sided speeds, so a foot counts as
    stopped on the frame it lands and on the frame it lifts off.
    """
    feet = np.asarray(feet, dtype=float)
    level = np.percentile(feet[..., 2], 5.0, axis=0)
    low = feet[..., 2] - level < height
    step = np.linalg.norm(np.diff(feet, axis=0), axis=-1) * frame_rate  # (F-1, 4)
    backward = np.concatenate([step[:1], step])
    forward = np.concatenate([step, step[-1:]])
    slow = np.minimum(backward, forward) < speed
    contacts = low & slow
    return np.stack([_debounce(contacts[:, i], min_run) for i in range(contacts.shape[1])], axis=1)


def touchdowns(contact: np.ndarray) -> np.ndarray:
    """Frames `(k,)` where a contact track `(F,)` switches from swing to stance."""
    contact = np.asarray(contact, dtype=bool)
    return np.flatnonzero(contact[1:] & ~contact[:-1]) + 1


def stride_boundaries(contacts: np.ndarray, pair: tuple = BOUNDARY_PAIR, tolerance: int = 3) -> np.ndarray:
    """
    Frames `(k,)` at which the diagonal `pair` touches down together (within `tolerance` frames).

    Where a capture gap hid one foot's touchdown (a gap between boundaries over 1.5 times their median), the touchdown
    of either foot of the pair inside the gap fills it in.
    """
    first, second = touchdowns(contacts[:, pair[0]]), touchdowns(contacts[:, pair[1]])
    if first.size == 0 or second.size == 0:
        return np.zeros(0, dtype=int)
    nearest = second[np.abs(second[None, :] - first[:, None]).argmin(axis=1)]
    together = np.abs(nearest - first) <= tolerance
    return _fill_gaps(np.minimum(first, nearest)[together], np.union1d(first, second))


def _fill_gaps(boundaries: np.ndarray, candidates: np.ndarray) -> np.ndarray:
    """`boundaries (k,)` with a candidate touchdown inserted into each gap over 1.5 median gaps (nearest a median)."""
    if len(boundaries) < 3:
        return boundaries
    median = float(np.median(np.diff(boundaries)))
    out = [int(boundaries[0])]
    for b in boundaries[1:]:
        while b - out[-1] > 1.5 * median:
            inside = candidates[(candidates >= out[-1] + 0.6 * median) & (candidates <= b - 0.6 * median)]
            if not inside.size:
                break
            out.append(int(inside[np.argmin(np.abs(inside - (out[-1] + median)))]))
        out.append(int(b))
    return np.array(out, dtype=boundaries.dtype)
