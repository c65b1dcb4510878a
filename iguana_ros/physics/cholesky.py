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
Sparse 3×3-block Cholesky `P A Pᵀ = L Lᵀ` of the system matrix (numba), used as the CG preconditioner.

The symbolic part (`CholeskyPattern.build`: a fill-reducing node ordering — minimum degree or reverse
Cuthill–McKee, whichever needs fewer block updates — the structure of L and every update's target) is computed
once per model from the block pattern (A's upper triangle, `iguana_ros.physics.assembly`); `block_cholesky`
refactorises the numeric values, `cholesky_solve` applies `A⁻¹`.
A factor of the current matrix makes CG converge in one iteration; CG keeps the tolerance check and the
breakdown test, so a stale or failed factor only costs iterations.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numba
import numpy as np

from iguana_ros.jit import FASTMATH
from iguana_ros.physics.assembly import block_rows
from iguana_ros.physics.block_simd import column_products, row_products, scale_column, update_column


FACTOR_STATE_SIZE = 7
"""Entries of a CholeskyFactor's state (`integrator.F_VALID` … `F_EXTRA_ITERS`, `F_ROTATED`)."""

F_ROTATED = 6
"""Index in a CholeskyFactor's state: 1 while its `rotations` turn the factor with the body (`cholesky_solve`), 0 while
it is applied as it is."""


class KernelCosts(NamedTuple):
    """Modelled cost (ns) of the factorisation's and a CG iteration's parts, per unit of work (`refactor_budget`)."""

    per_update: float           # a factorisation: per 3×3 block update
    per_factor_block: float     # … per block of L (copying A, scaling by the pivot)
    per_assembled_block: float  # … per block of A assembled for it (a matrix-free step)
    per_solve_block: float      # a CG iteration: per block of L (forward and backward solves)
    per_operator_term: float    # … per spring of a matrix-free operator, or stored block of A
    per_node: float             # … per node (vector updates)


KERNEL_COSTS = KernelCosts(per_update=2.7, per_factor_block=6.0, per_assembled_block=12.0, per_solve_block=4.0,
                           per_operator_term=5.5, per_node=10.0)
"""Fitted to `iguana bench sim --profile` on the AMD EPYC with the SIMD block kernels (`block_simd`; coarse, medium,
fine, finer: a factorisation 35 / 88 / 1196 / 5845 us, modelled 24 / 68 / 1334 / 5755; 10-15 ns per assembled
block, 3.7-6.4 per solved block, 5.1-7.7 per spring); `refactor_budget` uses only their ratios."""


class CholeskyArrays(NamedTuple):
    """The arrays of a `CholeskyPattern` as the compiled kernels take them (see its fields)."""

    perm: np.ndarray
    l_ptr: np.ndarray
    l_rows: np.ndarray
    a_ptr: np.ndarray
    a_block: np.ndarray
    a_dest: np.ndarray
    a_transpose: np.ndarray
    u_ptr: np.ndarray
    u_col: np.ndarray
    u_from: np.ndarray
    u_start: np.ndarray
    u_dest: np.ndarray
    r_ptr: np.ndarray
    r_pos: np.ndarray
    r_col: np.ndarray


class CholeskyFactor(NamedTuple):
    """
    Storage of the block Cholesky preconditioner.

    The pattern, L, its inverted diagonal, work space, the factor state `(7,)` int64 (`integrator.F_VALID`, `F_STEP`,
    `F_LAST_ITERS`, `F_PENDING`, `F_PENDING_STEP`, `F_EXTRA_ITERS`, `F_ROTATED`), the matrix snapshot for a factor
    thread (empty without one), and the corotated preconditioner's node positions of the factorised matrix, the
    rotations of the body's node clusters since then, and the positions of the snapshot (`physics.factor_rotation`).
    """

    pattern: CholeskyArrays
    values: np.ndarray    # (n_factor_blocks, 3, 3), the blocks of L
    diag_inv: np.ndarray  # (n_nodes, 3, 3), L_jj⁻¹
    work: np.ndarray      # (n_nodes, 3)
    state: np.ndarray     # (7,) int64
    snapshot: np.ndarray  # (n_blocks, 3, 3): A's blocks to factorise beside the step loop, or (0, 3, 3)
    anchor: np.ndarray           # (n_nodes, 3) m, node positions of the factorised matrix
    cluster_quats: np.ndarray    # (n_clusters, 4) xyzw, each node cluster's rotation since then (warm start)
    rotations: np.ndarray        # (n_nodes, 3, 3), each node's cluster's rotation
    snapshot_anchor: np.ndarray  # (n_nodes, 3) m, node positions of the snapshot, or (0, 3)


@dataclass(frozen=True)
class CholeskyPattern:
    """
    Structure of the block factor L over `n_nodes` in the permuted order `perm` (L row/col j = node perm[j]).

    Column j of L holds the blocks `l_rows[l_ptr[j]:l_ptr[j + 1]]` (ascending, the diagonal first).
    A blocks feeding column j: stored blocks `a_block[a_ptr[j]:a_ptr[j + 1]]` of A's upper triangle, copied
    (transposed where `a_transpose`) into L position `a_dest`. Updates of column j: for u in
    `u_ptr[j]:u_ptr[j + 1]`, column `u_col[u]` from its position `u_from[u]` (= L_jk) to its end lands at
    positions `u_dest[u_start[u]:…]` of column j. Row i of L below the diagonal (for the forward solve): blocks at
    positions `r_pos[r_ptr[i]:r_ptr[i + 1]]`, in columns `r_col[…]` (ascending).
    """

    n_nodes: int
    perm: np.ndarray      # (n_nodes,) int64
    l_ptr: np.ndarray     # (n_nodes + 1,) int64
    l_rows: np.ndarray    # (n_l,) int64
    a_ptr: np.ndarray     # (n_nodes + 1,) int64
    a_block: np.ndarray   # (n_a,) int64
    a_dest: np.ndarray    # (n_a,) int64
    a_transpose: np.ndarray  # (n_a,) int64, 1 where L holds the stored block transposed
    u_ptr: np.ndarray     # (n_nodes + 1,) int64
    u_col: np.ndarray     # (n_u,) int64
    u_from: np.ndarray    # (n_u,) int64
    u_start: np.ndarray   # (n_u + 1,) int64
    u_dest: np.ndarray    # (Σ update lengths,) int64
    r_ptr: np.ndarray     # (n_nodes + 1,) int64
    r_pos: np.ndarray     # (n_l − n_nodes,) int64
    r_col: np.ndarray     # (n_l − n_nodes,) int64

    @classmethod
    def build(cls, row_ptr: np.ndarray, cols: np.ndarray) -> 'CholeskyPattern':
        """
        Return the ordering and symbolic factor of the upper-triangle block-CSR pattern of a symmetric matrix.

        The pattern is `(row_ptr (n + 1,), cols (n_blocks,))`.
        """
        n = len(row_ptr) - 1
        full_ptr, full_cols = _symmetric_pattern(row_ptr, cols)
        candidates = []
        for perm in _orderings(full_ptr, full_cols):
            iperm = np.empty(n, dtype=np.int64)
            iperm[perm] = np.arange(n)
            struct = _symbolic(n, full_ptr, full_cols, perm, iperm)
            candidates.append((_update_count([len(s) for s in struct]), perm, iperm, struct))
        _, perm, iperm, struct = min(candidates, key=lambda c: c[0])
        l_ptr = np.zeros(n + 1, dtype=np.int64)
        l_ptr[1:] = np.cumsum([len(s) for s in struct])
        l_rows = np.concatenate(struct).astype(np.int64)
        where = [dict(zip(s.tolist(), range(l_ptr[j], l_ptr[j + 1]))) for j, s in enumerate(struct)]
        a_block, a_dest, a_transpose, a_ptr = _gather_map(row_ptr, cols, iperm, where)
        updates = [[] for _ in range(n)]
        for k in range(n):                           # L_jk ≠ 0 (j > k) updates column j with rows ≥ j of column k
            for p in range(l_ptr[k] + 1, l_ptr[k + 1]):
                updates[l_rows[p]].append((k, p))
        u_ptr, u_col, u_from, u_start, u_dest = [0], [], [], [0], []
        for j in range(n):
            for k, p in updates[j]:
                u_col.append(k)
                u_from.append(p)
                u_dest.extend(where[j][i] for i in l_rows[p:l_ptr[k + 1]])
                u_start.append(len(u_dest))
            u_ptr.append(len(u_col))
        as_int = lambda a: np.asarray(a, dtype=np.int64)          # noqa: E731
        return cls(n_nodes=n, perm=perm, l_ptr=l_ptr, l_rows=l_rows, a_ptr=a_ptr, a_block=a_block, a_dest=a_dest,
                   a_transpose=a_transpose, u_ptr=as_int(u_ptr), u_col=as_int(u_col), u_from=as_int(u_from),
                   u_start=as_int(u_start), u_dest=as_int(u_dest), **_row_structure(l_ptr, l_rows))

    @property
    def n_factor_blocks(self) -> int:
        """Return number of 3×3 blocks of L (diagonal included)."""
        return len(self.l_rows)

    @property
    def n_updates(self) -> int:
        """Return the block updates `Σ_j k_j (k_j − 1) / 2` of one factorisation (k_j: blocks of column j)."""
        return _update_count(np.diff(self.l_ptr))

    def refactor_budget(self, n_assembled_blocks: int, n_operator_terms: int) -> float:
        """
        Return the CG iterations that cost as much as one factorisation (KERNEL_COSTS).

        `n_assembled_blocks`: blocks of A assembled for a factorisation only (a matrix-free step), else 0;
        `n_operator_terms`: springs of a matrix-free operator, or stored blocks of A.
        """
        c = KERNEL_COSTS
        factor = (c.per_update * self.n_updates + c.per_factor_block * self.n_factor_blocks
                  + c.per_assembled_block * n_assembled_blocks)
        iteration = (c.per_solve_block * self.n_factor_blocks + c.per_operator_term * n_operator_terms
                     + c.per_node * self.n_nodes)
        return factor / iteration

    def arrays(self) -> CholeskyArrays:
        """Return the arrays as the compiled kernels take them."""
        return CholeskyArrays(*(getattr(self, name) for name in CholeskyArrays._fields))

    def factor(self, threaded: bool = False, n_clusters: int = 0) -> CholeskyFactor:
        """
        Zeroed factor storage over this pattern (no valid factor yet).

        `threaded`: with a matrix snapshot; `n_clusters`: node clusters of the corotated preconditioner (0: none).
        """
        n = self.n_nodes
        return CholeskyFactor(self.arrays(), np.zeros((self.n_factor_blocks, 3, 3)), np.zeros((n, 3, 3)),
                              np.zeros((n, 3)), np.zeros(FACTOR_STATE_SIZE, dtype=np.int64),
                              np.zeros((len(self.a_block) if threaded else 0, 3, 3)),
                              *_rotation_storage(n, n_clusters, threaded))


def _rotation_storage(n_nodes: int, n_clusters: int, threaded: bool) -> tuple:
    """Return zeroed `anchor`, `cluster_quats`, `rotations` and `snapshot_anchor` of a CholeskyFactor."""
    return (np.zeros((n_nodes, 3)), np.zeros((n_clusters, 4)), np.zeros((n_nodes, 3, 3)),
            np.zeros((n_nodes if threaded else 0, 3)))


def _row_structure(l_ptr: np.ndarray, l_rows: np.ndarray) -> dict:
    """Return `r_ptr`, `r_pos`, `r_col`: the positions and columns of L's blocks below the diagonal, row by row."""
    n = len(l_ptr) - 1
    column = np.repeat(np.arange(n, dtype=np.int64), np.diff(l_ptr))
    below = np.flatnonzero(l_rows != column)
    order = below[np.lexsort((column[below], l_rows[below]))]
    r_ptr = np.zeros(n + 1, dtype=np.int64)
    r_ptr[1:] = np.cumsum(np.bincount(l_rows[below], minlength=n))
    return {'r_ptr': r_ptr, 'r_pos': order.astype(np.int64), 'r_col': column[order]}


def _symmetric_pattern(row_ptr: np.ndarray, cols: np.ndarray) -> tuple:
    """Both triangles `(row_ptr (n + 1,), cols)` of the symmetric pattern whose upper triangle is given."""
    from scipy.sparse import csr_matrix

    n = len(row_ptr) - 1
    upper = csr_matrix((np.ones(len(cols)), cols, row_ptr), shape=(n, n))
    full = (upper + upper.T).tocsr()
    full.sort_indices()
    return full.indptr.astype(np.int64), full.indices.astype(np.int64)


def _gather_map(row_ptr: np.ndarray, cols: np.ndarray, iperm: np.ndarray, where: list) -> tuple:
    """
    Where each stored upper block (r, c) of A goes in L.

    Column min(iperm[r], iperm[c]), row the max, transposed when iperm[c] ≥ iperm[r] (then L holds A(c, r) = blockᵀ).
    Returns (a_block, a_dest, a_transpose, a_ptr).
    """
    n = len(row_ptr) - 1
    rows = block_rows(row_ptr)
    pr, pc = iperm[rows], iperm[cols]
    transpose = pc >= pr
    l_col = np.where(transpose, pr, pc)
    l_row = np.where(transpose, pc, pr)
    order = np.argsort(l_col, kind='stable')
    dest = np.array([where[j][i] for i, j in zip(l_row[order], l_col[order])], dtype=np.int64)
    a_ptr = np.zeros(n + 1, dtype=np.int64)
    a_ptr[1:] = np.cumsum(np.bincount(l_col, minlength=n))
    return order.astype(np.int64), dest, transpose[order].astype(np.int64), a_ptr


def _orderings(row_ptr: np.ndarray, cols: np.ndarray) -> list:
    """Candidate node orderings `(n,)` of the full symmetric block pattern: reverse Cuthill–McKee and minimum degree."""
    from scipy.sparse import csr_matrix, identity
    from scipy.sparse.csgraph import reverse_cuthill_mckee
    from scipy.sparse.linalg import splu

    n = len(row_ptr) - 1
    graph = csr_matrix((np.ones(len(cols)), cols, row_ptr), shape=(n, n))
    orders = [np.asarray(reverse_cuthill_mckee(graph, symmetric_mode=True), dtype=np.int64)]
    dominant = (graph + float(n + 1) * identity(n)).tocsc()   # no pivoting: SuperLU keeps its column order
    lu = splu(dominant, permc_spec='MMD_AT_PLUS_A', diag_pivot_thresh=0.0, options={'SymmetricMode': True})
    minimum_degree = np.empty(n, dtype=np.int64)
    minimum_degree[lu.perm_c] = np.arange(n)
    orders.append(minimum_degree)
    return orders


def _update_count(lengths: np.ndarray) -> int:
    """Block updates `Σ_j k_j (k_j − 1) / 2` of a factorisation whose columns hold `lengths (n,)` = k_j blocks."""
    lengths = np.asarray(lengths, dtype=np.int64)
    return int((lengths * (lengths - 1) // 2).sum())


def _symbolic(n: int, row_ptr: np.ndarray, cols: np.ndarray, perm: np.ndarray, iperm: np.ndarray) -> list:
    """Row structure (sorted, diagonal first) of every column of L, by symbolic elimination."""
    struct = []
    for j in range(n):
        c = iperm[cols[row_ptr[perm[j]]:row_ptr[perm[j] + 1]]]
        struct.append(set(c[c > j].tolist()))
    for j in range(n):                               # column j's rows below its first off-diagonal join that column
        if struct[j]:
            parent = min(struct[j])
            struct[parent] |= struct[j] - {parent}
    return [np.array([j] + sorted(s), dtype=np.int64) for j, s in enumerate(struct)]


def empty_factor(n_nodes: int) -> CholeskyFactor:
    """Return the CholeskyFactor of no factor (empty pattern and blocks) for a preconditioner that uses none."""
    e = np.zeros(0, dtype=np.int64)
    no_pattern = CholeskyArrays(*(e,) * len(CholeskyArrays._fields))
    return CholeskyFactor(no_pattern, np.zeros((0, 3, 3)), np.zeros((n_nodes, 3, 3)), np.zeros((n_nodes, 3)),
                          np.zeros(FACTOR_STATE_SIZE, dtype=np.int64), np.zeros((0, 3, 3)),
                          *_rotation_storage(0, 0, False))


@numba.njit(cache=True, inline='always', fastmath=FASTMATH)
def _factor_pivot(values, p, diag_inv, j):
    """
    Replace the symmetric 3×3 `values[p]` by its lower Cholesky factor L and write L⁻¹ into `diag_inv[j]`.

    False if the block is not positive definite.
    """
    d0 = values[p, 0, 0]
    if not d0 > 0.0:
        return False
    l00 = np.sqrt(d0)
    l10 = values[p, 1, 0] / l00
    l20 = values[p, 2, 0] / l00
    d1 = values[p, 1, 1] - l10 * l10
    if not d1 > 0.0:
        return False
    l11 = np.sqrt(d1)
    l21 = (values[p, 2, 1] - l20 * l10) / l11
    d2 = values[p, 2, 2] - l20 * l20 - l21 * l21
    if not d2 > 0.0:
        return False
    l22 = np.sqrt(d2)
    values[p, 0, 0], values[p, 0, 1], values[p, 0, 2] = l00, 0.0, 0.0
    values[p, 1, 0], values[p, 1, 1], values[p, 1, 2] = l10, l11, 0.0
    values[p, 2, 0], values[p, 2, 1], values[p, 2, 2] = l20, l21, l22
    i00 = 1.0 / l00
    i11 = 1.0 / l11
    i22 = 1.0 / l22
    i10 = -l10 * i00 * i11
    i21 = -l21 * i11 * i22
    diag_inv[j, 0, 0], diag_inv[j, 0, 1], diag_inv[j, 0, 2] = i00, 0.0, 0.0
    diag_inv[j, 1, 0], diag_inv[j, 1, 1], diag_inv[j, 1, 2] = i10, i11, 0.0
    diag_inv[j, 2, 0], diag_inv[j, 2, 1], diag_inv[j, 2, 2] = -(l20 * i00 + l21 * i10) * i22, i21, i22
    return True


@numba.njit(cache=True, fastmath=FASTMATH, nogil=True)   # nogil: a factor thread runs it beside the step loop
def block_cholesky(pattern, blocks, values, diag_inv):
    """
    Factorise A (`blocks (n_blocks, 3, 3)`) into `values (n_l, 3, 3)` = L and `diag_inv (n, 3, 3)` = L_jj⁻¹.

    Left-looking; returns False (values unusable) if a pivot block is not positive definite. Blocks are indexed
    in place (numba array views cost more than the arithmetic here).
    """
    perm, l_ptr, a_ptr, a_block, a_dest = pattern.perm, pattern.l_ptr, pattern.a_ptr, pattern.a_block, pattern.a_dest
    a_transpose, u_ptr, u_from, u_start, u_dest = (pattern.a_transpose, pattern.u_ptr, pattern.u_from,
                                                   pattern.u_start, pattern.u_dest)
    for j in range(perm.shape[0]):
        lo, hi = l_ptr[j], l_ptr[j + 1]
        values[lo:hi] = 0.0
        for t in range(a_ptr[j], a_ptr[j + 1]):      # L position (i, j) ← A(perm[i], perm[j])
            k, p = a_block[t], a_dest[t]
            if a_transpose[t]:
                for r in range(3):
                    for c in range(3):
                        values[p, r, c] = blocks[k, c, r]
            else:
                for r in range(3):
                    for c in range(3):
                        values[p, r, c] = blocks[k, r, c]
        for u in range(u_ptr[j], u_ptr[j + 1]):      # S(i, j) −= L(i, k) L(j, k)ᵀ
            update_column(values, u_from[u], u_dest, u_start[u], u_start[u + 1])
        if not _factor_pivot(values, lo, diag_inv, j):
            return False
        scale_column(values, lo + 1, hi, diag_inv, j)   # L(i, j) = S(i, j) L_jj⁻ᵀ (L_jj⁻¹ lower triangular)
    return True


@numba.njit(cache=True)
def cholesky_solve(pattern, values, diag_inv, r, z, y, rotations=None):
    """
    `z` = A⁻¹ r `(n, 3)` with the factor of `block_cholesky`; `y (n, 3)` is work space.

    With node `rotations (n, 3, 3)` R: `z` = R A⁻¹ Rᵀ r, the inverse of the factorised matrix turned with the body
    (`physics.factor_rotation`); a node's rotation is applied where its entry is read and where it is written, off
    the solves' row-to-row dependency.
    """
    perm, l_ptr, l_rows, r_ptr = pattern.perm, pattern.l_ptr, pattern.l_rows, pattern.r_ptr
    n = perm.shape[0]
    for i in range(n):                               # L y = P Rᵀ r, row by row
        t0, t1, t2 = row_products(values, pattern.r_pos, pattern.r_col, y, r_ptr[i], r_ptr[i + 1])
        p = perm[i]
        b0, b1, b2 = r[p, 0], r[p, 1], r[p, 2]
        if rotations is not None:
            b0, b1, b2 = (rotations[p, 0, 0] * b0 + rotations[p, 1, 0] * b1 + rotations[p, 2, 0] * b2,
                          rotations[p, 0, 1] * b0 + rotations[p, 1, 1] * b1 + rotations[p, 2, 1] * b2,
                          rotations[p, 0, 2] * b0 + rotations[p, 1, 2] * b1 + rotations[p, 2, 2] * b2)
        s0, s1, s2 = b0 - t0, b1 - t1, b2 - t2
        y[i, 0] = diag_inv[i, 0, 0] * s0
        y[i, 1] = diag_inv[i, 1, 0] * s0 + diag_inv[i, 1, 1] * s1
        y[i, 2] = diag_inv[i, 2, 0] * s0 + diag_inv[i, 2, 1] * s1 + diag_inv[i, 2, 2] * s2
    for j in range(n - 1, -1, -1):                   # Lᵀ z' = y, column by column
        t0, t1, t2 = column_products(values, l_rows, y, l_ptr[j] + 1, l_ptr[j + 1])
        s0, s1, s2 = y[j, 0] - t0, y[j, 1] - t1, y[j, 2] - t2
        y[j, 2] = diag_inv[j, 2, 2] * s2             # L_jj⁻ᵀ is upper triangular
        y[j, 1] = diag_inv[j, 1, 1] * s1 + diag_inv[j, 2, 1] * s2
        y[j, 0] = diag_inv[j, 0, 0] * s0 + diag_inv[j, 1, 0] * s1 + diag_inv[j, 2, 0] * s2
    for j in range(n):                               # z = R Pᵀ z'
        p = perm[j]
        if rotations is None:
            z[p, 0], z[p, 1], z[p, 2] = y[j, 0], y[j, 1], y[j, 2]
        else:
            for a in range(3):
                z[p, a] = rotations[p, a, 0] * y[j, 0] + rotations[p, a, 1] * y[j, 1] + rotations[p, a, 2] * y[j, 2]
