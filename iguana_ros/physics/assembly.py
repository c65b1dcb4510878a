"""Sparse 3×3-block matrix pattern of the system matrix, built once; numba block kernels.

The system matrix is stored in block-CSR form: `row_ptr (n_nodes + 1,)`, `cols (n_blocks,)` and values
`blocks (n_blocks, 3, 3)`, both triangles stored. `BlockPattern` also holds, for every tet and spring, the
indices of the blocks its stiffness lands in, so force kernels scatter straight into `blocks`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np


@dataclass(frozen=True)
class BlockPattern:
    """Block-CSR pattern `(row_ptr, cols)` over `n_nodes` with per-tet and per-spring block indices."""

    n_nodes: int
    row_ptr: np.ndarray        # (n_nodes + 1,) int64
    cols: np.ndarray           # (n_blocks,) int64
    diag: np.ndarray           # (n_nodes,) int64, index of block (i, i)
    tet_blocks: np.ndarray     # (n_tets, 16) int64, block (tets[t, a], tets[t, b]) at column 4 a + b
    spring_blocks: np.ndarray  # (n_springs, 4) int64, blocks (i, i), (j, j), (i, j), (j, i)

    @classmethod
    def build(cls, n_nodes: int, tets: np.ndarray, springs: np.ndarray) -> 'BlockPattern':
        """Pattern of every (i, i) and every node pair coupled by a tet or a spring."""
        tets = np.asarray(tets, dtype=np.int64).reshape(-1, 4)
        springs = np.asarray(springs, dtype=np.int64).reshape(-1, 2)
        a, b = np.meshgrid(np.arange(4), np.arange(4), indexing='ij')
        tet_rows, tet_cols = tets[:, a.ravel()], tets[:, b.ravel()]
        i, j = springs[:, 0], springs[:, 1]
        spr_rows = np.stack([i, j, i, j], axis=1)
        spr_cols = np.stack([i, j, j, i], axis=1)
        diag = np.arange(n_nodes, dtype=np.int64)
        keys = np.concatenate([(tet_rows * n_nodes + tet_cols).ravel(), (spr_rows * n_nodes + spr_cols).ravel(),
                               diag * n_nodes + diag])
        unique = np.unique(keys)
        rows, cols = np.divmod(unique, n_nodes)
        row_ptr = np.zeros(n_nodes + 1, dtype=np.int64)
        np.add.at(row_ptr, rows + 1, 1)
        return cls(n_nodes=int(n_nodes), row_ptr=np.cumsum(row_ptr), cols=cols.astype(np.int64),
                   diag=np.searchsorted(unique, diag * n_nodes + diag).astype(np.int64),
                   tet_blocks=np.searchsorted(unique, tet_rows * n_nodes + tet_cols).astype(np.int64),
                   spring_blocks=np.searchsorted(unique, spr_rows * n_nodes + spr_cols).astype(np.int64))

    @property
    def n_blocks(self) -> int:
        """Number of stored 3×3 blocks."""
        return len(self.cols)

    def to_scipy(self, blocks: np.ndarray):
        """The matrix as `scipy.sparse.csc_matrix (3 n_nodes, 3 n_nodes)` from `blocks (n_blocks, 3, 3)`."""
        from scipy.sparse import bsr_matrix

        n = 3 * self.n_nodes
        return bsr_matrix((blocks, self.cols, self.row_ptr), shape=(n, n)).tocsc()


@numba.njit(cache=True)
def block_matvec(row_ptr, cols, blocks, x, out):
    """out = A x for the block-CSR matrix A and vectors `x, out (n_nodes, 3)`."""
    for i in range(row_ptr.shape[0] - 1):
        s0 = 0.0
        s1 = 0.0
        s2 = 0.0
        for k in range(row_ptr[i], row_ptr[i + 1]):
            j = cols[k]
            b = blocks[k]
            x0, x1, x2 = x[j, 0], x[j, 1], x[j, 2]
            s0 += b[0, 0] * x0 + b[0, 1] * x1 + b[0, 2] * x2
            s1 += b[1, 0] * x0 + b[1, 1] * x1 + b[1, 2] * x2
            s2 += b[2, 0] * x0 + b[2, 1] * x1 + b[2, 2] * x2
        out[i, 0] = s0
        out[i, 1] = s1
        out[i, 2] = s2


@numba.njit(cache=True)
def invert_3x3(a, out):
    """out = a⁻¹ for a symmetric positive-definite 3×3 block (cofactor formula); returns the determinant."""
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
