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


def region_force(node_mass: np.ndarray, mask: np.ndarray, force: np.ndarray) -> np.ndarray:
    """Return forces `(n_nodes, 3)` N summing to `force (3,)`, on the nodes of `mask (n_nodes,)` by mass."""
    weights = np.where(np.asarray(mask, bool), np.asarray(node_mass, float), 0.0)
    return np.outer(weights / weights.sum(), np.asarray(force, float))
