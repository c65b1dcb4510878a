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
Linear solvers for the implicit step `A Δv = b`.

Preconditioned CG (numba; block Jacobi, SSOR or a block Cholesky factor) and a direct LU.
"""
from __future__ import annotations

import numba
import numpy as np

from iguana_ros.physics.assembly import block_matvec, BlockPattern
from iguana_ros.physics.cholesky import cholesky_solve, CholeskyArrays, CholeskyFactor, F_ROTATED
from iguana_ros.physics.forces import spring_operator_matvec
from iguana_ros.physics.kernel_data import SpringOperator

PRECONDITIONER_CODES = {'jacobi': 0, 'ssor': 1, 'cholesky': 2}
"""Integer codes of the CG preconditioners in the compiled kernels."""


@numba.njit(cache=True)
def _dot(a, b):
    """Σ a·b over `(n, 3)` arrays."""
    acc = 0.0
    for i in range(a.shape[0]):
        acc += a[i, 0] * b[i, 0] + a[i, 1] * b[i, 1] + a[i, 2] * b[i, 2]
    return acc


@numba.njit(cache=True)
def _precondition(pinv, r, z):
    """`z` = P⁻¹ r with the inverted 3×3 diagonal blocks `pinv (n, 3, 3)`."""
    for i in range(r.shape[0]):
        r0, r1, r2 = r[i, 0], r[i, 1], r[i, 2]
        for k in range(3):
            z[i, k] = pinv[i, k, 0] * r0 + pinv[i, k, 1] * r1 + pinv[i, k, 2] * r2


@numba.njit(cache=True)
def _ssor(row_ptr, cols, blocks, pinv, r, z):
    """
    Compute `z` = M⁻¹ r for the symmetric block Gauss–Seidel preconditioner M = (D + L) D⁻¹ (D + U).

    A is stored as its upper block triangle (L = Uᵀ).
    """
    n = r.shape[0]
    z[:] = r
    for i in range(n):                               # forward: (D + Uᵀ) y = r; y_i final, then pushed to rows j > i
        s0, s1, s2 = z[i, 0], z[i, 1], z[i, 2]
        y0 = pinv[i, 0, 0] * s0 + pinv[i, 0, 1] * s1 + pinv[i, 0, 2] * s2
        y1 = pinv[i, 1, 0] * s0 + pinv[i, 1, 1] * s1 + pinv[i, 1, 2] * s2
        y2 = pinv[i, 2, 0] * s0 + pinv[i, 2, 1] * s1 + pinv[i, 2, 2] * s2
        z[i, 0], z[i, 1], z[i, 2] = y0, y1, y2
        for k in range(row_ptr[i] + 1, row_ptr[i + 1]):
            j = cols[k]
            blk = blocks[k]                          # A_ji = blkᵀ
            z[j, 0] -= blk[0, 0] * y0 + blk[1, 0] * y1 + blk[2, 0] * y2
            z[j, 1] -= blk[0, 1] * y0 + blk[1, 1] * y1 + blk[2, 1] * y2
            z[j, 2] -= blk[0, 2] * y0 + blk[1, 2] * y1 + blk[2, 2] * y2
    for i in range(n - 1, -1, -1):                   # backward: z_i = y_i − D_i⁻¹ Σ_{j>i} A_ij z_j
        s0 = 0.0
        s1 = 0.0
        s2 = 0.0
        for k in range(row_ptr[i] + 1, row_ptr[i + 1]):
            j = cols[k]
            blk = blocks[k]
            s0 += blk[0, 0] * z[j, 0] + blk[0, 1] * z[j, 1] + blk[0, 2] * z[j, 2]
            s1 += blk[1, 0] * z[j, 0] + blk[1, 1] * z[j, 1] + blk[1, 2] * z[j, 2]
            s2 += blk[2, 0] * z[j, 0] + blk[2, 1] * z[j, 1] + blk[2, 2] * z[j, 2]
        for a in range(3):
            z[i, a] -= pinv[i, a, 0] * s0 + pinv[i, a, 1] * s1 + pinv[i, a, 2] * s2


@numba.njit(cache=True)
def _apply_preconditioner(row_ptr, cols, blocks, pinv, chol, r, z, kind):
    """
    `z` = P⁻¹ r: block Jacobi (kind 0), symmetric block Gauss–Seidel (1) or the block Cholesky factor (2).

    The factor is turned by its node rotations while its state says so (`cholesky.F_ROTATED`).
    """
    if kind == 2:
        if chol.state[F_ROTATED]:
            cholesky_solve(chol.pattern, chol.values, chol.diag_inv, r, z, chol.work, chol.rotations)
        else:
            cholesky_solve(chol.pattern, chol.values, chol.diag_inv, r, z, chol.work)
    elif kind == 1:
        _ssor(row_ptr, cols, blocks, pinv, r, z)
    else:
        _precondition(pinv, r, z)


@numba.njit(cache=True)
def _no_factor(n):
    """Return a `chol` argument for the preconditioners that use no factor."""
    e = np.zeros(0, dtype=np.int64)
    return CholeskyFactor(CholeskyArrays(e, e, e, e, e, e, e, e, e, e, e, e, e, e, e), np.zeros((0, 3, 3)),
                          np.zeros((0, 3, 3)), np.zeros((n, 3)), e, np.zeros((0, 3, 3)), np.zeros((0, 3)),
                          np.zeros((0, 4)), np.zeros((0, 3, 3)), np.zeros((0, 3)))


@numba.njit(cache=True)
def _no_operator():
    """Return an inactive SpringOperator: the CG multiplies by the stored blocks."""
    return SpringOperator(np.zeros((0, 2), dtype=np.int64), np.zeros((0, 5)), np.zeros((0, 3, 3)), 0)


@numba.njit(cache=True)
def block_jacobi_pcg(row_ptr, cols, blocks, pinv, b, x, tol, atol, max_iter, work, ssor=False):
    """`preconditioned_cg` on the stored blocks with block Jacobi or, with `ssor`, symmetric block Gauss–Seidel."""
    block_matvec(row_ptr, cols, blocks, x, work[3])
    return preconditioned_cg(row_ptr, cols, blocks, _no_operator(), pinv, _no_factor(b.shape[0]), b, x, tol, atol,
                             max_iter, work, 1 if ssor else 0)


@numba.njit(cache=True)
def _matvec(row_ptr, cols, blocks, operator, x, out):
    """`out` = A x: by the SpringOperator when it is active, else by the stored upper-triangle blocks."""
    if operator.active:
        spring_operator_matvec(operator.springs, operator.coef, operator.node_matrix, x, out)
    else:
        block_matvec(row_ptr, cols, blocks, x, out)


@numba.njit(cache=True)
def preconditioned_cg(row_ptr, cols, blocks, operator, pinv, chol, b, x, tol, atol, max_iter, work, kind):
    """
    Solve A x = b (`x` holds the warm start, `(n, 3)`) to ‖r‖ ≤ max(tol ‖b‖, atol); `work (4, n, 3)`.

    A is stored as its upper block triangle (`iguana_ros.physics.assembly`), or given as an active `operator` (a
    `kernel_data.SpringOperator`; the blocks then serve the preconditioners only). Preconditioner `kind`
    (PRECONDITIONER_CODES): inverted diagonal blocks `pinv (n, 3, 3)` (block Jacobi), symmetric block
    Gauss–Seidel (the diagonal block first in each row, columns ascending), or the block
    Cholesky factor `chol` (a `CholeskyFactor` of `iguana_ros.physics.cholesky`).
    With the factor at least one iteration is done (the warm start is not accepted as it is).
    On entry `work[3]` holds A x of the warm start (the step computes it with its right-hand side, in one pass).
    Returns `(iterations, residual_norm, threshold)`; iterations = −k signals a breakdown (pᵀAp ≤ 0) at step k.
    """
    r, z, p, ap = work[0], work[1], work[2], work[3]
    for i in range(b.shape[0]):
        for k in range(3):
            r[i, k] = b[i, k] - ap[i, k]
    threshold = max(tol * np.sqrt(_dot(b, b)), atol)
    rnorm = np.sqrt(_dot(r, r))
    if rnorm <= threshold and (kind != 2 or rnorm == 0.0):   # with a factor one iteration is cheap and ~exact
        return 0, rnorm, threshold
    _apply_preconditioner(row_ptr, cols, blocks, pinv, chol, r, z, kind)
    p[:] = z
    rz = _dot(r, z)
    for it in range(1, max_iter + 1):
        _matvec(row_ptr, cols, blocks, operator, p, ap)
        pap = _dot(p, ap)
        if not pap > 0.0:
            return -it, rnorm, threshold
        alpha = rz / pap
        rr = 0.0
        for i in range(b.shape[0]):
            for k in range(3):
                x[i, k] += alpha * p[i, k]
                r[i, k] -= alpha * ap[i, k]
                rr += r[i, k] * r[i, k]
        rnorm = np.sqrt(rr)
        if rnorm <= threshold:
            return it, rnorm, threshold
        _apply_preconditioner(row_ptr, cols, blocks, pinv, chol, r, z, kind)
        rz_new = _dot(r, z)
        beta = rz_new / rz
        rz = rz_new
        for i in range(b.shape[0]):
            for k in range(3):
                p[i, k] = z[i, k] + beta * p[i, k]
    return max_iter, rnorm, threshold


class DirectSolver:
    """Sparse LU (scipy `splu`) of the block matrix, refactorised on demand."""

    def __init__(self, pattern: BlockPattern) -> None:
        self._pattern = pattern
        self._lu = None

    def factorize(self, blocks: np.ndarray) -> None:
        """Factorise the matrix with values `blocks (n_blocks, 3, 3)`; raises RuntimeError if singular."""
        from scipy.sparse.linalg import splu

        self._lu = splu(self._pattern.to_scipy(blocks), permc_spec='MMD_AT_PLUS_A')

    def solve(self, rhs: np.ndarray, out: np.ndarray) -> None:
        """`out` `(n, 3)` = A⁻¹ rhs `(n, 3)` with the last factorisation."""
        out[:] = self._lu.solve(rhs.ravel()).reshape(out.shape)
