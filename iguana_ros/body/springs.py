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

"""Internal springs of the soft body (Section V): every node pair within a tet and across adjacent tets."""
from __future__ import annotations

import numpy as np

from iguana_ros.body.mesh import face_adjacency, TET_EDGES


def tet_springs(tets: np.ndarray, n_nodes: int | None = None) -> np.ndarray:
    """
    Return unique node pairs `(n_springs, 2)` (i < j, sorted lexicographically) of a tet mesh `(n_tets, 4)`.

    The pairs are the six edges of every tet plus, for every two tets sharing a face, the pair of their
    vertices opposite that face, so every pair of nodes of two adjacent cells is connected.
    """
    tets = np.asarray(tets, dtype=np.int64)
    edges = tets[:, TET_EDGES].reshape(-1, 2)
    pairs, local, _ = face_adjacency(tets)
    opposite = np.stack([tets[pairs[:, 0], local[:, 0]], tets[pairs[:, 1], local[:, 1]]], axis=1)
    both = np.sort(np.vstack([edges, opposite]), axis=1)
    both = both[both[:, 0] != both[:, 1]]
    return np.unique(both, axis=0)


def spring_lengths(points: np.ndarray, springs: np.ndarray) -> np.ndarray:
    """Lengths `(n_springs,)` of springs `(n_springs, 2)` between points `(..., n_nodes, 3)`."""
    return np.linalg.norm(points[..., springs[:, 1], :] - points[..., springs[:, 0], :], axis=-1)
