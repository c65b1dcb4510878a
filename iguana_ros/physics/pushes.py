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

"""External pushes (Section VIII-D): a force spread over a group of nodes in proportion to their mass."""
from __future__ import annotations

import numpy as np

from iguana_ros.constants import FRAME_RATE


def region_force(node_mass: np.ndarray, mask: np.ndarray, force: np.ndarray) -> np.ndarray:
    """Return forces `(n_nodes, 3)` N summing to `force (3,)`, on the nodes of `mask (n_nodes,)` by mass."""
    weights = np.where(np.asarray(mask, bool), np.asarray(node_mass, float), 0.0)
    return np.outer(weights / weights.sum(), np.asarray(force, float))


def push_active(at: float, duration: float, time: float) -> bool:
    """Whether a push from `at` lasting `duration` s acts in the frame that starts at `time` s."""
    return at <= time + 1e-9 < at + duration


def push_active_time(at: float, duration: float) -> float:
    """Seconds a push from `at` lasting `duration` s acts: a push acts over whole frames (`push_active`)."""
    first = max(0, int(np.floor(at * FRAME_RATE)) - 1)
    frames = np.arange(first, int(np.ceil((at + duration) * FRAME_RATE)) + 2) / FRAME_RATE
    return float(np.count_nonzero((at <= frames + 1e-9) & (frames + 1e-9 < at + duration))) / FRAME_RATE


def region_masses(node_mass: np.ndarray, node_tags: dict) -> dict:
    """Mass (kg) of every pushable region: each node tag of `node_tags` and 'all' (the body), by `node_mass (n,)`."""
    masses = {tag: float(np.sum(node_mass[np.asarray(mask, bool)])) for tag, mask in node_tags.items()}
    masses['all'] = float(np.sum(node_mass))
    return masses
