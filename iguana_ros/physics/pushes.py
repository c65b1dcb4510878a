"""External pushes (Section VIII-D): a force spread over a group of nodes in proportion to their mass."""
from __future__ import annotations

import numpy as np


def region_force(node_mass: np.ndarray, mask: np.ndarray, force: np.ndarray) -> np.ndarray:
    """Forces `(n_nodes, 3)` N summing to `force (3,)`, on the nodes of `mask (n_nodes,)` by mass."""
    weights = np.where(np.asarray(mask, bool), np.asarray(node_mass, float), 0.0)
    return np.outer(weights / weights.sum(), np.asarray(force, float))
