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
How often the explicit FEM force of each tet is evaluated: the stiffness ratio h² λ_max(A⁻¹ K_e) and the split.

The explicit FEM force may be held for k steps while (k h)² λ_max(A⁻¹ K_e) <= HELD_ELASTIC_LIMIT. One stiff mode
that the springs hardly hold (the coarse body's thin tail tip) would force every tet to every step; instead the tets
that mode runs through are evaluated every step (the *fast* tets) and the rest held for k steps, k chosen so that
the held tets' ratio keeps the same bound and the fewest tet evaluations per step are made. `elastic_rates` grows the
fast set from the largest generalized eigenvector's nodes, a deterministic search at construction.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from iguana_ros.physics.assembly import BlockPattern
from iguana_ros.physics.fidelity import HELD_ELASTIC_LIMIT, MAX_ELASTIC_EVERY
from iguana_ros.physics.forces import corotated_elastic_forces, spring_forces
from iguana_ros.physics.kernel_data import kernel_constant

HOT_NODE_FRACTION = 0.5
"""A node whose amplitude in the stiffest held mode is at least this fraction of the largest makes its tets fast."""
SPLIT_TOLERANCE = 1e-3
"""Relative accuracy of the split's eigenvalues (its thresholds are orders of magnitude apart from the limits)."""
MAX_SPLIT_ROUNDS = 20
"""Most rounds of moving tets to the fast set (each one generalized eigensolve of the held tets)."""


@dataclass(frozen=True)
class ElasticRates:
    """Held tets evaluated every `every` steps, the tets `fast (n_tets,)` bool every step; `held_ratio` their bound."""

    every: int
    fast: np.ndarray
    held_ratio: float

    @property
    def evaluations_per_step(self) -> float:
        """Return tet evaluations per step (the explicit FEM's cost)."""
        n_fast = int(self.fast.sum())
        return n_fast + (len(self.fast) - n_fast) / self.every


def rest_system_matrix(model, pattern: BlockPattern, rest_positions: np.ndarray, rest_lengths: np.ndarray,
                       dt: float, alpha: float, beta: float):
    """Return A = M(1 + hα) + (hβ + h²) K_springs at rest (axial stiffness only, no contact), scipy sparse."""
    h = dt
    x = np.array(rest_positions, dtype=float)
    springs = np.zeros((pattern.n_blocks, 3, 3))
    spring_forces(x, model.springs, model.spring_stiffness, rest_lengths, np.zeros_like(x), springs,
                  model.spring_blocks, h * beta + h * h)
    springs[model.diag] += np.eye(3) * (model.mass * (1.0 + h * alpha))[:, None, None]
    return pattern.to_scipy(springs)


def elastic_stiffness_matrix(model, pattern: BlockPattern, rest_positions: np.ndarray, tets: np.ndarray):
    """Return K_e of the tets `tets` (int indices) at rest, scipy sparse; `model` a KernelModel over `pattern`."""
    x = np.array(rest_positions, dtype=float)
    blocks = np.zeros((pattern.n_blocks, 3, 3))
    rotations = np.zeros((len(tets), 4))
    rotations[:, 3] = 1.0
    part = {name: kernel_constant(getattr(model, name)[tets], getattr(model, name).dtype)   # the kernels' array type
            for name in ('tets', 'shape_gradients', 'volume', 'mu', 'lam', 'tet_blocks')}
    corotated_elastic_forces(x, part['tets'], part['shape_gradients'], part['volume'], part['mu'], part['lam'],
                             rotations, 1, np.zeros_like(x), blocks, part['tet_blocks'], 1.0)
    return pattern.to_scipy(blocks)


def largest_ratio(k_e, a, dt: float, tol: float = 0.0) -> tuple:
    """Return (h² λ_max(A⁻¹ K_e) to `tol` (0: machine precision), its eigenvector `(n, 3)`); (inf, None) on failure."""
    from scipy.sparse.linalg import ArpackError, eigsh

    if k_e.nnz == 0:
        return 0.0, None
    try:
        lam, vec = eigsh(k_e, k=1, M=a, which='LA', v0=np.ones(a.shape[0]), tol=tol)
    except (ArpackError, RuntimeError):
        return float('inf'), None
    return float(dt * dt * max(lam[0], 0.0)), vec[:, 0].reshape(-1, 3)


def elastic_stiffness_ratio(model, pattern: BlockPattern, rest_positions: np.ndarray, rest_lengths: np.ndarray,
                            dt: float, alpha: float, beta: float) -> float:
    """
    h² λ_max(A⁻¹ K_e) at rest: how stiff the FEM is against the rest of the implicit step (`EXPLICIT_ELASTIC_LIMIT`).

    K_e is the corotated FEM's stiffness at the rest shape, A = M(1 + hα) + (hβ + h²) K_s with the springs at their
    rest lengths (axial stiffness only) and no contact; `model` a KernelModel over `pattern`. inf if the generalized
    eigenvalue cannot be found (then the FEM stays implicit).
    """
    a = rest_system_matrix(model, pattern, rest_positions, rest_lengths, dt, alpha, beta)
    k_e = elastic_stiffness_matrix(model, pattern, rest_positions, np.arange(len(model.tets)))
    return largest_ratio(k_e, a, dt)[0]


def elastic_rates(model, pattern: BlockPattern, rest_positions: np.ndarray, rest_lengths: np.ndarray, dt: float,
                  alpha: float, beta: float, ratio: float) -> ElasticRates:
    """
    Return the split of the explicit FEM's tets into held (every k steps) and fast (every step) with the least work.

    `ratio` is every tet's h² λ_max (`elastic_stiffness_ratio`). Unless all tets can be held MAX_ELASTIC_EVERY
    steps, rounds move the tets around the stiffest held mode's nodes to the fast set; each round's held ratio
    allows the largest k with (k h)² λ_max <= HELD_ELASTIC_LIMIT, and the round and k with the fewest tet evaluations
    per step win (all held, none fast, when no round does better). The rounds stop once the fast tets alone (and the
    rest held the longest) would cost as much as the best split so far: the fast set only grows.
    """
    best = _unsplit(len(model.tets), ratio)
    if best.every == MAX_ELASTIC_EVERY or not np.isfinite(ratio):
        return best
    a = rest_system_matrix(model, pattern, rest_positions, rest_lengths, dt, alpha, beta)
    tets = np.asarray(model.tets)
    fast = np.zeros(len(tets), bool)
    for _ in range(MAX_SPLIT_ROUNDS):
        held = elastic_stiffness_matrix(model, pattern, rest_positions, np.flatnonzero(~fast))
        held_ratio, mode = largest_ratio(held, a, dt, SPLIT_TOLERANCE)
        split = _unsplit(len(tets), held_ratio, fast.copy())
        best = _best(best, split)
        if mode is None or split.every == MAX_ELASTIC_EVERY:
            break                                    # nothing left to split, or the held tets take the longest hold
        fast = fast | _hot_tets(tets, mode)
        if fast.all() or _fewest_evaluations(fast) >= best.evaluations_per_step:
            break                                    # every later round has more fast tets: none can do better
    return best


def _fewest_evaluations(fast: np.ndarray) -> float:
    """Return the fewest tet evaluations per step any split with (at least) the tets `fast (n_tets,)` can need."""
    n_fast = int(fast.sum())
    return n_fast + (len(fast) - n_fast) / MAX_ELASTIC_EVERY


def _hot_tets(tets: np.ndarray, mode: np.ndarray) -> np.ndarray:
    """Tets `(n_tets,)` bool with a node of at least HOT_NODE_FRACTION of the largest amplitude in `mode (n, 3)`."""
    amplitude = np.linalg.norm(mode, axis=1)
    return (amplitude >= HOT_NODE_FRACTION * amplitude.max())[tets].any(axis=1)


def _unsplit(n_tets: int, ratio: float, fast: np.ndarray | None = None) -> ElasticRates:
    """Return the held tets' (all but `fast`, default none) largest k within HELD_ELASTIC_LIMIT (<= the max)."""
    every = 1 if not np.isfinite(ratio) else int(np.clip(
        np.floor(np.sqrt(HELD_ELASTIC_LIMIT / max(ratio, 1e-300)) + 1e-9), 1, MAX_ELASTIC_EVERY))
    return ElasticRates(every, np.zeros(n_tets, bool) if fast is None else fast, ratio)


def _best(a: ElasticRates, b: ElasticRates) -> ElasticRates:
    """Return the split with fewer tet evaluations per step (`a` on a tie)."""
    return b if b.evaluations_per_step < a.evaluations_per_step else a
