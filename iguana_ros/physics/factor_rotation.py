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
The corotated Cholesky preconditioner: a factor of A(x₀) turned with the body to precondition A(x).

A stale factor's extra CG iterations come mostly from the body's local rotations (legs, tail) since its matrix:
a spring's stiffness `c u uᵀ` turns with `u`. With R the block-diagonal rotations of small node clusters from x₀ to
x, `R A(x₀) Rᵀ` is the matrix of x₀'s stiffness turned into x's frames, so the factor applied as `R L⁻ᵀ L⁻¹ Rᵀ`
(`cholesky.cholesky_solve` with rotations) misses only the deformation since x₀. Each cluster's rotation is the
shape-matching rotation of its nodes (Müller et al. 2005), warm-started; the clusters are grown once per body over
its springs (`node_clusters`). Measured on the fine body (docs/RESULTS.md, issue 34): clusters of 16 nodes do as
well as a rotation per node's spring neighbourhood, at a fraction of the cost; of 4, hardly better than none.
"""
from __future__ import annotations

from collections import deque

import numba
import numpy as np

from iguana_ros.jit import FASTMATH
from iguana_ros.physics.cholesky import F_ROTATED
from iguana_ros.physics.forces import extract_rotation

CLUSTER_SIZE = 16
"""Nodes per cluster of one rotation (fine body, CG iterations per step with the factor reused as in `balanced`:
4 nodes 1.62, 8 1.53, 16 1.40, 32 1.48; one rotation per node neighbourhood 1.43, none 1.67)."""

MIN_CLUSTER_SIZE = 4
"""A smaller cluster (the last ones grown in a region) joins a neighbouring one: shape matching needs a few nodes
out of one plane."""

CLUSTER_ROTATION_ITERS = 4
"""Most rotation-extraction iterations per cluster and update (warm-started from the last update)."""


def node_clusters(rest_positions: np.ndarray, springs: np.ndarray, size: int = CLUSTER_SIZE) -> tuple:
    """
    Return `(cluster_ptr (n_clusters + 1,), cluster_nodes (n,))`: the nodes in compact clusters of about `size`.

    Each cluster grows breadth-first over the springs from the lowest unassigned node, nearer neighbours first;
    clusters of fewer than MIN_CLUSTER_SIZE nodes join the cluster of a spring neighbour. Deterministic.
    """
    rest = np.asarray(rest_positions, dtype=np.float64)
    n = len(rest)
    neighbours = _neighbours_by_distance(rest, np.asarray(springs, dtype=np.int64).reshape(-1, 2))
    label = np.full(n, -1, dtype=np.int64)
    count = 0
    for seed in range(n):
        if label[seed] < 0:
            _grow(seed, count, size, neighbours, label)
            count += 1
    label = _merge_small(label, neighbours)
    order = np.argsort(label, kind='stable')
    ptr = np.zeros(label.max() + 2, dtype=np.int64)
    np.add.at(ptr, label + 1, 1)
    return np.cumsum(ptr), order.astype(np.int64)


def _neighbours_by_distance(rest: np.ndarray, springs: np.ndarray) -> list:
    """Return each node's spring neighbours `(k,)` arrays, nearest first (ties by index)."""
    pairs = np.unique(np.concatenate([springs, springs[:, ::-1]]), axis=0)      # (i, j) both ways, once each
    d2 = np.sum((rest[pairs[:, 1]] - rest[pairs[:, 0]]) ** 2, axis=1)
    pairs = pairs[np.lexsort((pairs[:, 1], d2, pairs[:, 0]))]
    return np.split(pairs[:, 1], np.searchsorted(pairs[:, 0], np.arange(1, len(rest))))


def _grow(seed: int, cluster: int, size: int, neighbours: list, label: np.ndarray) -> None:
    """Label up to `size` unassigned nodes reached breadth-first from `seed` with `cluster`."""
    queue, members = deque([seed]), 0
    while queue and members < size:
        i = queue.popleft()
        if label[i] >= 0:
            continue
        label[i] = cluster
        members += 1
        queue.extend(j for j in neighbours[i] if label[j] < 0)


def _merge_small(label: np.ndarray, neighbours: list) -> np.ndarray:
    """Return the labels with every cluster below MIN_CLUSTER_SIZE joined to a neighbour's, renumbered 0, 1, …."""
    label = label.copy()
    for cluster in range(label.max() + 1):
        members = np.flatnonzero(label == cluster)
        if 0 < len(members) < MIN_CLUSTER_SIZE:
            outside = [label[j] for i in members for j in neighbours[i] if label[j] != cluster]
            if outside:
                label[members] = outside[0]
    return np.unique(label, return_inverse=True)[1].astype(np.int64)


@numba.njit(cache=True, fastmath=FASTMATH)
def cluster_rotations(x, anchor, cluster_ptr, cluster_nodes, quats, rotations, max_iter):
    """
    Write `rotations (n, 3, 3)`: each node's cluster's rotation from `anchor` to `x` `(n, 3)`.

    A cluster's rotation maximises tr(Rᵀ Σ_i (x_i − c)(X_i − C)ᵀ) over its nodes (c, C the centroids; shape
    matching), warm-started from and written to `quats (n_clusters, 4)`.
    """
    a, r = np.empty((3, 3)), np.empty((3, 3))
    for k in range(cluster_ptr.shape[0] - 1):
        lo, hi = cluster_ptr[k], cluster_ptr[k + 1]
        c0 = c1 = c2 = g0 = g1 = g2 = 0.0
        for q in range(lo, hi):
            i = cluster_nodes[q]
            c0, c1, c2 = c0 + x[i, 0], c1 + x[i, 1], c2 + x[i, 2]
            g0, g1, g2 = g0 + anchor[i, 0], g1 + anchor[i, 1], g2 + anchor[i, 2]
        inv = 1.0 / (hi - lo)
        c0, c1, c2, g0, g1, g2 = c0 * inv, c1 * inv, c2 * inv, g0 * inv, g1 * inv, g2 * inv
        a[:] = 0.0
        for q in range(lo, hi):
            i = cluster_nodes[q]
            d0, d1, d2 = x[i, 0] - c0, x[i, 1] - c1, x[i, 2] - c2
            e0, e1, e2 = anchor[i, 0] - g0, anchor[i, 1] - g1, anchor[i, 2] - g2
            a[0, 0], a[0, 1], a[0, 2] = a[0, 0] + d0 * e0, a[0, 1] + d0 * e1, a[0, 2] + d0 * e2
            a[1, 0], a[1, 1], a[1, 2] = a[1, 0] + d1 * e0, a[1, 1] + d1 * e1, a[1, 2] + d1 * e2
            a[2, 0], a[2, 1], a[2, 2] = a[2, 0] + d2 * e0, a[2, 1] + d2 * e1, a[2, 2] + d2 * e2
        extract_rotation(a, quats[k], r, max_iter)
        for q in range(lo, hi):
            i = cluster_nodes[q]
            for p in range(3):                       # indices, no array views (dearer than the copy)
                rotations[i, p, 0], rotations[i, p, 1], rotations[i, p, 2] = r[p, 0], r[p, 1], r[p, 2]


@numba.njit(cache=True)
def anchor_factor(positions, chol):
    """Start a new factor's rotations: `chol.anchor` ← the node positions `(n, 3)` of its matrix, no rotation yet."""
    chol.anchor[:] = positions
    chol.cluster_quats[:] = 0.0
    chol.cluster_quats[:, 3] = 1.0
    chol.state[F_ROTATED] = 0
