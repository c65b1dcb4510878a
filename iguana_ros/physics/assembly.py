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
Sparse 3×3-block matrix pattern of the system matrix, built once; numba block kernels.

The system matrix is symmetric; its upper triangle (blocks (i, j) with i ≤ j, the diagonal block first in each
row) is stored in block-CSR form: `row_ptr (n_nodes + 1,)`, `cols (n_blocks,)` and values
`blocks (n_blocks, 3, 3)`; block (j, i) is the transpose of stored block (i, j). Storing one triangle halves the
memory traffic of assembly and of every matrix–vector product. `BlockPattern` also holds, for every tet and
spring, the indices of the blocks its stiffness lands in, so force kernels scatter straight into `blocks`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np


@dataclass(frozen=True)
class BlockPattern:
    """Upper-triangle block-CSR pattern `(row_ptr, cols)` over `n_nodes` with per-tet and per-spring block indices."""

    n_nodes: int
    row_ptr: np.ndarray        # (n_nodes + 1,) int64
    cols: np.ndarray           # (n_blocks,) int64, ascending in each row, ≥ the row
    diag: np.ndarray           # (n_nodes,) int64, index of block (i, i)
    tet_blocks: np.ndarray     # (n_tets, 16) int64, stored block of node pair (tets[t, a], tets[t, b]) at 4 a + b
    spring_blocks: np.ndarray  # (n_springs, 3) int64, blocks (i, i), (j, j) and the stored one of (i, j)

    @classmethod
    def build(cls, n_nodes: int, tets: np.ndarray, springs: np.ndarray) -> 'BlockPattern':
        """Pattern of every (i, i) and every node pair coupled by a tet or a spring."""
        tets = np.asarray(tets, dtype=np.int64).reshape(-1, 4)
        springs = np.asarray(springs, dtype=np.int64).reshape(-1, 2)
        a, b = np.meshgrid(np.arange(4), np.arange(4), indexing='ij')
        tet_keys = _upper_key(tets[:, a.ravel()], tets[:, b.ravel()], n_nodes)
        i, j = springs[:, 0], springs[:, 1]
        spring_keys = _upper_key(np.stack([i, j, i], axis=1), np.stack([i, j, j], axis=1), n_nodes)
        diag = np.arange(n_nodes, dtype=np.int64)
        unique = np.unique(np.concatenate([tet_keys.ravel(), spring_keys.ravel(), diag * n_nodes + diag]))
        rows, cols = np.divmod(unique, n_nodes)
        row_ptr = np.zeros(n_nodes + 1, dtype=np.int64)
        np.add.at(row_ptr, rows + 1, 1)
        return cls(n_nodes=int(n_nodes), row_ptr=np.cumsum(row_ptr), cols=cols.astype(np.int64),
                   diag=np.searchsorted(unique, diag * n_nodes + diag).astype(np.int64),
                   tet_blocks=np.searchsorted(unique, tet_keys).astype(np.int64),
                   spring_blocks=np.searchsorted(unique, spring_keys).astype(np.int64))

    @property
    def n_blocks(self) -> int:
        """Return number of stored 3×3 blocks."""
        return len(self.cols)

    @property
    def rows(self) -> np.ndarray:
        """Row of every stored block `(n_blocks,)`."""
        return block_rows(self.row_ptr)

    def to_scipy(self, blocks: np.ndarray):
        """
        Return the full symmetric matrix as `scipy.sparse.csc_matrix (3 n_nodes, 3 n_nodes)` from the stored blocks.

        The stored `blocks` are `(n_blocks, 3, 3)`.
        """
        from scipy.sparse import bsr_matrix

        n = 3 * self.n_nodes
        upper = bsr_matrix((blocks, self.cols, self.row_ptr), shape=(n, n)).tocsc()
        off = self.rows != self.cols
        strict = bsr_matrix((np.where(off[:, None, None], blocks, 0.0), self.cols, self.row_ptr),
                            shape=(n, n)).tocsc()
        return (upper + strict.T).tocsc()


def block_rows(row_ptr: np.ndarray) -> np.ndarray:
    """Row of every block `(n_blocks,)` of a block-CSR pattern with `row_ptr (n + 1,)`."""
    return np.repeat(np.arange(len(row_ptr) - 1), np.diff(row_ptr))


def _upper_key(rows: np.ndarray, cols: np.ndarray, n_nodes: int) -> np.ndarray:
    """Key `min · n + max` of the stored (upper-triangle) block of each node pair."""
    return np.minimum(rows, cols) * n_nodes + np.maximum(rows, cols)


@numba.njit(cache=True)
def block_matvec(row_ptr, cols, blocks, x, out):
    """`out` = A x for the symmetric matrix A stored as its upper block triangle; `x, out (n_nodes, 3)`."""
    n = row_ptr.shape[0] - 1
    out[:] = 0.0
    for i in range(n):                               # blocks indexed in place: views cost 2x here (measured)
        x0, x1, x2 = x[i, 0], x[i, 1], x[i, 2]
        k = row_ptr[i]                               # the diagonal block
        s0 = blocks[k, 0, 0] * x0 + blocks[k, 0, 1] * x1 + blocks[k, 0, 2] * x2
        s1 = blocks[k, 1, 0] * x0 + blocks[k, 1, 1] * x1 + blocks[k, 1, 2] * x2
        s2 = blocks[k, 2, 0] * x0 + blocks[k, 2, 1] * x1 + blocks[k, 2, 2] * x2
        for k in range(row_ptr[i] + 1, row_ptr[i + 1]):
            j = cols[k]
            b00, b01, b02 = blocks[k, 0, 0], blocks[k, 0, 1], blocks[k, 0, 2]
            b10, b11, b12 = blocks[k, 1, 0], blocks[k, 1, 1], blocks[k, 1, 2]
            b20, b21, b22 = blocks[k, 2, 0], blocks[k, 2, 1], blocks[k, 2, 2]
            y0, y1, y2 = x[j, 0], x[j, 1], x[j, 2]
            s0 += b00 * y0 + b01 * y1 + b02 * y2
            s1 += b10 * y0 + b11 * y1 + b12 * y2
            s2 += b20 * y0 + b21 * y1 + b22 * y2
            out[j, 0] += b00 * x0 + b10 * x1 + b20 * x2    # the lower block (j, i) = bᵀ
            out[j, 1] += b01 * x0 + b11 * x1 + b21 * x2
            out[j, 2] += b02 * x0 + b12 * x1 + b22 * x2
        out[i, 0] += s0
        out[i, 1] += s1
        out[i, 2] += s2


@numba.njit(cache=True)
def block_matvec_pair(row_ptr, cols, blocks, x, y, out_x, out_y):
    """`out_x` = A x and `out_y` = A y in one pass over the blocks (each bitwise as `block_matvec`); `(n_nodes, 3)`."""
    n = row_ptr.shape[0] - 1
    out_x[:] = 0.0
    out_y[:] = 0.0
    for i in range(n):
        x0, x1, x2 = x[i, 0], x[i, 1], x[i, 2]
        y0, y1, y2 = y[i, 0], y[i, 1], y[i, 2]
        k = row_ptr[i]
        s0 = blocks[k, 0, 0] * x0 + blocks[k, 0, 1] * x1 + blocks[k, 0, 2] * x2
        s1 = blocks[k, 1, 0] * x0 + blocks[k, 1, 1] * x1 + blocks[k, 1, 2] * x2
        s2 = blocks[k, 2, 0] * x0 + blocks[k, 2, 1] * x1 + blocks[k, 2, 2] * x2
        t0 = blocks[k, 0, 0] * y0 + blocks[k, 0, 1] * y1 + blocks[k, 0, 2] * y2
        t1 = blocks[k, 1, 0] * y0 + blocks[k, 1, 1] * y1 + blocks[k, 1, 2] * y2
        t2 = blocks[k, 2, 0] * y0 + blocks[k, 2, 1] * y1 + blocks[k, 2, 2] * y2
        for k in range(row_ptr[i] + 1, row_ptr[i + 1]):
            j = cols[k]
            b00, b01, b02 = blocks[k, 0, 0], blocks[k, 0, 1], blocks[k, 0, 2]
            b10, b11, b12 = blocks[k, 1, 0], blocks[k, 1, 1], blocks[k, 1, 2]
            b20, b21, b22 = blocks[k, 2, 0], blocks[k, 2, 1], blocks[k, 2, 2]
            u0, u1, u2 = x[j, 0], x[j, 1], x[j, 2]
            s0 += b00 * u0 + b01 * u1 + b02 * u2
            s1 += b10 * u0 + b11 * u1 + b12 * u2
            s2 += b20 * u0 + b21 * u1 + b22 * u2
            out_x[j, 0] += b00 * x0 + b10 * x1 + b20 * x2
            out_x[j, 1] += b01 * x0 + b11 * x1 + b21 * x2
            out_x[j, 2] += b02 * x0 + b12 * x1 + b22 * x2
            w0, w1, w2 = y[j, 0], y[j, 1], y[j, 2]
            t0 += b00 * w0 + b01 * w1 + b02 * w2
            t1 += b10 * w0 + b11 * w1 + b12 * w2
            t2 += b20 * w0 + b21 * w1 + b22 * w2
            out_y[j, 0] += b00 * y0 + b10 * y1 + b20 * y2
            out_y[j, 1] += b01 * y0 + b11 * y1 + b21 * y2
            out_y[j, 2] += b02 * y0 + b12 * y1 + b22 * y2
        out_x[i, 0] += s0
        out_x[i, 1] += s1
        out_x[i, 2] += s2
        out_y[i, 0] += t0
        out_y[i, 1] += t1
        out_y[i, 2] += t2


@numba.njit(cache=True)
def invert_3x3(a, out):
    """`out` = a⁻¹ for a symmetric positive-definite 3×3 block (cofactor formula); returns the determinant."""
    c00 = a[1, 1] * a[2, 2] - a[1, 2] * a[2, 1]
    c01 = a[1, 2] * a[2, 0] - a[1, 0] * a[2, 2]
    c02 = a[1, 0] * a[2, 1] - a[1, 1] * a[2, 0]
    det = a[0, 0] * c00 + a[0, 1] * c01 + a[0, 2] * c02
    inv = 1.0 / det
    out[0, 0] = c00 * inv
    out[1, 0] = c01 * inv
    out[2, 0] = c02 * inv
    out[0, 1] = (a[0, 2] * a[2, 1] - a[0, 1] * a[2, 2]) * inv
    out[1, 1] = (a[0, 0] * a[2, 2] - a[0, 2] * a[2, 0]) * inv
    out[2, 1] = (a[0, 1] * a[2, 0] - a[0, 0] * a[2, 1]) * inv
    out[0, 2] = (a[0, 1] * a[1, 2] - a[0, 2] * a[1, 1]) * inv
    out[1, 2] = (a[0, 2] * a[1, 0] - a[0, 0] * a[1, 2]) * inv
    out[2, 2] = (a[0, 0] * a[1, 1] - a[0, 1] * a[1, 0]) * inv
    return det
