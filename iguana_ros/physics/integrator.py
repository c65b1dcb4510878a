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
Linearised backward Euler (Baraff & Witkin 1998) for `M p̈ = f_x + f_s + f_e + f_d`, compiled with numba.

Per step of length h, with K = −∂f/∂x (springs + FEM = K_int, contact = K_c), Rayleigh damping C = αM + βK_int
and contact damping C_c:

    A Δv = b,   A = M(1 + hα) + h C_c + (hβ + h²) K_int + h² K_c,   b = h (f − αMv) − [(hβ + h²) K_int + h² K_c] v

with `f` every force except the Rayleigh terms; then v ← v + Δv, x ← x + h v. K_int holds the springs' stiffness
and, unless the simulator evaluates the FEM force explicitly (`Fidelity.elastic_integration`), the FEM's. A (and
the CG preconditioner) is rebuilt every `jacobian_every` steps; the block Cholesky factor of A, when that is the
preconditioner, every `factor_every` steps or sooner (see `run_steps_cg`); forces are always evaluated at the
current state.
Where every off-diagonal block is one spring's (FEM explicit, CG with the Cholesky preconditioner:
`IP_MATRIX_FREE`) the step is matrix-free: the springs' pass keeps each K_s = c u uᵀ + g I and computes K v and
K Δv, CG multiplies by A on the fly (`kernel_data.SpringOperator`), and the blocks are assembled only for a
factorisation.
`run_steps_cg` advances many steps in one compiled call; `prepare_step` / `finish_step` split a step around an
external (direct) linear solve. The kernels take the body as named structs (`physics.kernel_data.KernelModel`,
`KernelState`, `physics.cholesky.CholeskyFactor`).
"""
from __future__ import annotations

import numba
import numpy as np

from iguana_ros.physics.assembly import block_matvec_pair, invert_3x3
from iguana_ros.physics.cholesky import block_cholesky, F_ROTATED
from iguana_ros.physics.factor_rotation import anchor_factor, CLUSTER_ROTATION_ITERS, cluster_rotations
from iguana_ros.physics.forces import (assemble_spring_matrix, contact_forces, corotated_elastic_range,
                                       spring_forces, spring_forces_operator)
from iguana_ros.physics.kernel_data import SpringOperator
from iguana_ros.physics.solver import preconditioned_cg

# indices of the float parameter vector `fp`
FP_DT, FP_ALPHA, FP_BETA, FP_GX, FP_GY, FP_GZ, FP_KN, FP_CN, FP_KT, FP_CT, FP_CG_TOL, FP_CG_ATOL, \
    FP_MAX_SPEED, FP_MAX_DEPTH, FP_CG_FAIL, FP_REFACTOR_BUDGET = range(16)
N_FP = 16
# indices of the integer parameter vector `ip`
IP_CG_MAX_ITER, IP_JACOBIAN_EVERY, IP_POLAR_ITERS, IP_HAS_GROUND, IP_PRECONDITIONER, IP_FACTOR_EVERY, \
    IP_REFACTOR_ITERS, IP_ELASTIC_IMPLICIT, IP_ELASTIC_EVERY, IP_MATRIX_FREE, IP_FACTOR_THREAD, \
    IP_FACTOR_LAG, IP_FAST_TETS, IP_FACTOR_ROTATION_EVERY = range(14)
N_IP = 14
# indices of the counter vector `counters`
C_STEP, C_CG_ITERS, C_REFRESHES, C_CONTACTS, C_FACTOR_FAILS, C_FACTORS, C_INVERTED = range(7)
N_COUNTERS = 7

STATUS_OK = 0
STATUS_NAN = 1
STATUS_SPEED = 2
STATUS_PENETRATION = 3
STATUS_SOLVER = 4
STATUS_FACTOR_REQUEST = 5    # not a failure: a snapshot of the matrix waits to be factorised beside the step loop
STATUS_FACTOR_SWAP = 6       # not a failure: the factor of the last snapshot is due before this step


@numba.njit(cache=True)
def prepare_step(model, state, fp, ip, counters, desired_lengths, external, info):
    """
    Compute the forces, (maybe) the system matrix, and the right-hand side of one step.

    `model` is a KernelModel and `state` a KernelState; returns (status, refreshed).
    """
    mass, terrain = model.mass, model.terrain_grid
    x, v, forces, blocks = state.positions, state.velocities, state.forces, state.matrix_blocks
    dextra, pinv = state.diag_mass_damping, state.diag_inv
    diag_k, diag_c = state.contact_stiffness, state.contact_damping
    h = fp[FP_DT]
    alpha = fp[FP_ALPHA]
    refresh = counters[C_STEP] % ip[IP_JACOBIAN_EVERY] == 0
    n = x.shape[0]
    for i in range(n):
        m = mass[i]
        forces[i, 0] = m * (fp[FP_GX] - alpha * v[i, 0]) + external[i, 0]
        forces[i, 1] = m * (fp[FP_GY] - alpha * v[i, 1]) + external[i, 1]
        forces[i, 2] = m * (fp[FP_GZ] - alpha * v[i, 2]) + external[i, 2]
    scale = h * fp[FP_BETA] + h * h if refresh else 0.0
    matrix_free = ip[IP_MATRIX_FREE] != 0            # the springs' stiffness applied on the fly, blocks on demand
    if refresh and not matrix_free:
        blocks[:] = 0.0
    _elastic_forces(model, state, ip, counters, forces, scale)
    rhs, warm = state.rhs, state.cg_work[3]
    if matrix_free:                                  # rhs ← h f_s − K v, warm ← K Δv (the springs; the rest below)
        spring_forces_operator(x, v, state.delta_v, model.springs, model.spring_stiffness, desired_lengths,
                               state.spring_coef, state.node_work, state.spring_work, h, rhs, warm, scale)
    else:
        spring_forces(x, model.springs, model.spring_stiffness, desired_lengths, forces, blocks, model.spring_blocks,
                      scale)
    if ip[IP_HAS_GROUND]:
        n_contact, deepest, depth = contact_forces(
            x, v, model.contact_mass, model.contact_offset, model.friction, model.heights, model.height_bounds,
            terrain[0], terrain[1], terrain[2], fp[FP_KN], fp[FP_CN], fp[FP_KT], fp[FP_CT], state.friction_anchors,
            state.contact_state, forces, diag_k, diag_c)
        counters[C_CONTACTS] = n_contact
        if depth > fp[FP_MAX_DEPTH]:
            info[0] = deepest
            info[1] = depth
            return STATUS_PENETRATION, refresh
    if matrix_free:
        _matrix_free_rhs(mass, state, diag_k, diag_c, h, alpha, ip[IP_HAS_GROUND] != 0)
        counters[C_REFRESHES] += refresh
        return STATUS_OK, refresh
    diag, in_a = model.diag, state.contact_in_matrix
    if refresh:
        _finish_matrix(mass, diag, blocks, dextra, diag_k, diag_c, in_a, h, alpha, ip[IP_HAS_GROUND] != 0)
        if ip[IP_PRECONDITIONER] != 2:               # the Cholesky path inverts only if its factor fails
            invert_diagonal(diag, blocks, pinv)
        counters[C_REFRESHES] += 1
    elif ip[IP_HAS_GROUND]:
        _update_contact_blocks(mass, diag, blocks, dextra, pinv, diag_k, diag_c, in_a, h, alpha)
    # rhs = A v ((A − dextra) v is the stiffness part) and, in the same pass, cg_work[3] = A Δv: the CG's warm start
    block_matvec_pair(model.row_ptr, model.cols, blocks, v, state.delta_v, rhs, warm)
    for i in range(n):
        for k in range(3):
            dv_k = dextra[i, k, 0] * v[i, 0] + dextra[i, k, 1] * v[i, 1] + dextra[i, k, 2] * v[i, 2]
            rhs[i, k] = h * forces[i, k] - (rhs[i, k] - dv_k)
    return STATUS_OK, refresh


@numba.njit(cache=True)
def _matrix_free_rhs(mass, state, diag_k, diag_c, h, alpha, has_ground):
    """
    Finish a matrix-free step's system: `node_matrix` = M(1 + hα) + h C_c + h² K_c, rhs = h f − K v − h² K_c v.

    It also computes the warm start's product cg_work[3] = A Δv, from the springs' part `spring_forces_operator` left in
    rhs (h f_s − K v; `state.forces` holds every other force) and cg_work[3] (K Δv).
    """
    v, dv, forces, rhs = state.velocities, state.delta_v, state.forces, state.rhs
    warm, node_matrix = state.cg_work[3], state.node_matrix
    h2 = h * h
    for i in range(mass.shape[0]):
        m = mass[i] * (1.0 + h * alpha)
        for p in range(3):
            kv = 0.0
            adv = 0.0
            for q in range(3):
                k = h2 * diag_k[i, p, q] if has_ground else 0.0
                a = k + (h * diag_c[i, p, q] if has_ground else 0.0) + (m if p == q else 0.0)
                node_matrix[i, p, q] = a
                kv += k * v[i, q]
                adv += a * dv[i, q]
            rhs[i, p] += h * forces[i, p] - kv
            warm[i, p] += adv


@numba.njit(cache=True)
def _elastic_forces(model, state, ip, counters, forces, scale):
    """
    Add the corotated FEM force: implicit, or explicit with its held part (`Fidelity.elastic_integration`).

    Implicit: every tet, with its stiffness blocks times `scale` added to `state.matrix_blocks` (none when `scale` is
    0). Explicit: evaluated anew every `elastic_every` steps (at the step's start) and held in between in
    `state.elastic_forces (n, 3)`, without blocks; the first `ip[IP_FAST_TETS]` tets (the few a mode the springs
    hardly hold runs through, `physics.elastic_rates`) are evaluated every step. While any tet is inverted or flat
    (`counters[C_INVERTED]`, from the last evaluation) every tet is evaluated every step: holding is for the small
    strains the springs carry, an inverted element recovers through its FEM force alone.
    """
    held, x, n_tets = state.elastic_forces, state.positions, model.tets.shape[0]
    implicit = ip[IP_ELASTIC_IMPLICIT] != 0
    n_fast = n_tets if implicit else ip[IP_FAST_TETS]
    refresh = not implicit and (counters[C_STEP] % ip[IP_ELASTIC_EVERY] == 0 or counters[C_INVERTED] > 0)
    inverted = 0                                     # (explicit, not refreshing: none was inverted)
    for part in range(2):                            # the fast tets into the forces, then (maybe) the held ones
        first, stop, out = (0, n_fast, forces) if part == 0 else (n_fast, n_tets, held)
        if part == 1:
            if not refresh:
                break
            held[:] = 0.0
        if stop > first:                             # one call site: with two, a freshly compiled step loop and
            inverted += corotated_elastic_range(     # the cached one rounded differently (test_determinism.py)
                x, model.tets, model.shape_gradients, model.volume, model.mu, model.lam, state.element_rotations,
                ip[IP_POLAR_ITERS], out, state.matrix_blocks, model.tet_blocks, scale if implicit else 0.0, first,
                stop)
    if implicit:
        return
    counters[C_INVERTED] = inverted
    for i in range(forces.shape[0]):
        forces[i, 0] += held[i, 0]
        forces[i, 1] += held[i, 1]
        forces[i, 2] += held[i, 2]


@numba.njit(cache=True)
def invert_diagonal(diag, blocks, pinv):
    """pinv[i] = A_ii⁻¹ `(n, 3, 3)` for the block Jacobi preconditioner (`diag (n,)`: indices of the A_ii)."""
    for i in range(diag.shape[0]):
        invert_3x3(blocks[diag[i]], pinv[i])


@numba.njit(cache=True)
def _finish_matrix(mass, diag, blocks, dextra, diag_k, diag_c, in_a, h, alpha, has_ground):
    """Add the diagonal terms M(1 + hα) + h C_c + h² K_c to the system matrix."""
    h2 = h * h
    for i in range(mass.shape[0]):                  # in-place indices, no array views (measured faster)
        k = diag[i]
        m = mass[i] * (1.0 + h * alpha)
        for p in range(3):
            for q in range(3):
                dex = h * diag_c[i, p, q] if has_ground else 0.0
                con = dex + (h2 * diag_k[i, p, q] if has_ground else 0.0)
                in_a[i, p, q] = con
                dextra[i, p, q] = dex + (m if p == q else 0.0)
                blocks[k, p, q] += con + (m if p == q else 0.0)


@numba.njit(cache=True)
def _update_contact_blocks(mass, diag, blocks, dextra, pinv, diag_k, diag_c, in_a, h, alpha):
    """Between Jacobian refreshes keep the contact terms h C_c + h² K_c of the diagonal blocks current."""
    h2 = h * h
    for i in range(mass.shape[0]):
        c = in_a[i]
        changed = False
        for p in range(3):
            for q in range(3):
                new = h * diag_c[i, p, q] + h2 * diag_k[i, p, q]
                if new != c[p, q]:
                    changed = True
        if not changed:
            continue
        blk = blocks[diag[i]]
        d = dextra[i]
        for p in range(3):
            for q in range(3):
                new = h * diag_c[i, p, q] + h2 * diag_k[i, p, q]
                blk[p, q] += new - c[p, q]
                c[p, q] = new
                d[p, q] = h * diag_c[i, p, q]
            d[p, p] += mass[i] * (1.0 + h * alpha)
        invert_3x3(blk, pinv[i])


@numba.njit(cache=True)
def finish_step(state, fp, counters, info):
    """`v` ← v + Δv, x ← x + h v; checks for NaN/Inf and the speed bound. Returns a STATUS_* code."""
    x, v, dv = state.positions, state.velocities, state.delta_v
    h = fp[FP_DT]
    max_speed2 = fp[FP_MAX_SPEED] * fp[FP_MAX_SPEED]
    status = STATUS_OK
    for i in range(x.shape[0]):
        s2 = 0.0
        for k in range(3):
            v[i, k] += dv[i, k]
            x[i, k] += h * v[i, k]
            s2 += v[i, k] * v[i, k]
        if status == STATUS_OK:
            if not (np.isfinite(s2) and np.isfinite(x[i, 0] + x[i, 1] + x[i, 2])):
                status = STATUS_NAN
                info[0] = i
                info[1] = s2
            elif s2 > max_speed2:
                status = STATUS_SPEED
                info[0] = i
                info[1] = np.sqrt(s2)
    counters[C_STEP] += 1
    return status


# entries of the factor state `chol.state` (7,) int64 of the block Cholesky preconditioner (a CholeskyFactor):
# whether the factor is valid, the step of the matrix it factorises, the CG iterations of the last solve, (factor
# thread) whether a snapshot is out for factorisation and the step of its matrix, and the CG iterations beyond one per
# solve since the factorisation, and (cholesky.F_ROTATED) whether its node rotations turn it
F_VALID, F_STEP, F_LAST_ITERS, F_PENDING, F_PENDING_STEP, F_EXTRA_ITERS = range(6)


@numba.njit(cache=True)
def _factor_is_due(fp, ip, counters, factor_state):
    """
    Whether the Cholesky preconditioner must be refactorised before this step's solve.

    There is none, it is `factor_every` steps old, the last solve needed more than `refactor_iters` CG iterations,
    or (the 'amortised' rule) the iterations its solves needed beyond one each add up to `FP_REFACTOR_BUDGET`, the
    iterations a factorisation costs (infinite under the 'age' rule).
    """
    return (factor_state[F_VALID] <= 0 or counters[C_STEP] - factor_state[F_STEP] >= ip[IP_FACTOR_EVERY]
            or factor_state[F_LAST_ITERS] > ip[IP_REFACTOR_ITERS]
            or factor_state[F_EXTRA_ITERS] >= fp[FP_REFACTOR_BUDGET])


@numba.njit(cache=True)
def _refactor(model, state, ip, counters, chol):
    """
    Factorise the current system matrix into `chol`; counts it (and a failure, which leaves no factor).

    A matrix-free step assembles the matrix's blocks first.
    """
    if ip[IP_MATRIX_FREE]:
        assemble_system_matrix(model, state)
    factor_state = chol.state
    factor_state[F_VALID] = block_cholesky(chol.pattern, state.matrix_blocks, chol.values, chol.diag_inv)
    factor_state[F_STEP] = counters[C_STEP]
    factor_state[F_EXTRA_ITERS] = 0
    counters[C_FACTORS] += 1
    if not factor_state[F_VALID]:
        counters[C_FACTOR_FAILS] += 1
    factor_state[F_ROTATED] = 0
    if ip[IP_FACTOR_ROTATION_EVERY] > 0:
        anchor_factor(state.positions, chol)


@numba.njit(cache=True)
def _rotate_factor(model, state, ip, counters, chol):
    """
    Update the corotated preconditioner's rotations every `IP_FACTOR_ROTATION_EVERY` steps of the factor's age.

    The factor is then applied turned by its node clusters' rotations since its matrix (`physics.factor_rotation`).
    """
    every = ip[IP_FACTOR_ROTATION_EVERY]
    age = counters[C_STEP] - chol.state[F_STEP]
    if every <= 0 or chol.state[F_VALID] <= 0 or age <= 0 or age % every != 0:
        return
    cluster_rotations(state.positions, chol.anchor, model.cluster_ptr, model.cluster_nodes, chol.cluster_quats,
                      chol.rotations, CLUSTER_ROTATION_ITERS)
    chol.state[F_ROTATED] = 1


@numba.njit(cache=True)
def assemble_system_matrix(model, state):
    """Write the blocks of a matrix-free step's system matrix into `state.matrix_blocks` (for a factorisation)."""
    assemble_spring_matrix(state.spring_coef, state.node_matrix, model.diag, model.spring_blocks,
                           model.node_spring_ptr, model.node_springs, state.matrix_blocks)


@numba.njit(cache=True)
def _snapshot_for_thread(model, state, ip, counters, chol):
    """
    Copy the current system matrix into `chol.snapshot` for the factor thread and mark it pending.

    A matrix-free step assembles it there directly (its `matrix_blocks` are not kept current).
    """
    if ip[IP_MATRIX_FREE]:
        assemble_spring_matrix(state.spring_coef, state.node_matrix, model.diag, model.spring_blocks,
                               model.node_spring_ptr, model.node_springs, chol.snapshot)
    else:
        chol.snapshot[:] = state.matrix_blocks
    if ip[IP_FACTOR_ROTATION_EVERY] > 0:
        chol.snapshot_anchor[:] = state.positions
    chol.state[F_PENDING] = 1
    chol.state[F_PENDING_STEP] = counters[C_STEP]


@numba.njit(cache=True)
def _swap_is_due(ip, counters, factor_state):
    """Whether the factor thread's factor of the pending snapshot replaces the current one before this step."""
    return (ip[IP_FACTOR_THREAD] != 0 and factor_state[F_PENDING] != 0
            and counters[C_STEP] - factor_state[F_PENDING_STEP] >= ip[IP_FACTOR_LAG])


@numba.njit(cache=True)
def solve_system(model, state, fp, ip, chol):
    """
    Preconditioned CG on the prepared system; returns (iterations (< 0: breakdown), residual, threshold).

    `state.cg_work[3]` holds A Δv of the warm start (`prepare_step` computed it). With no valid Cholesky factor
    the preconditioner is block Jacobi.
    """
    kind = ip[IP_PRECONDITIONER]
    step_kind = kind
    if kind == 2 and not chol.state[F_VALID]:       # no factor: block Jacobi
        step_kind = 0
        invert_diagonal(model.diag, state.matrix_blocks, state.diag_inv)
    operator = SpringOperator(model.springs, state.spring_coef, state.node_matrix, ip[IP_MATRIX_FREE])
    return preconditioned_cg(model.row_ptr, model.cols, state.matrix_blocks, operator, state.diag_inv, chol,
                             state.rhs, state.delta_v, fp[FP_CG_TOL], fp[FP_CG_ATOL], ip[IP_CG_MAX_ITER],
                             state.cg_work, step_kind)


@numba.njit(cache=True)
def ramp_lengths(ld_from, ld_to, out, fraction):
    """`out` = ld_from + fraction (ld_to − ld_from): the desired lengths `(n_springs,)` part-way through a ramp."""
    for s in range(out.shape[0]):
        out[s] = ld_from[s] + fraction * (ld_to[s] - ld_from[s])


@numba.njit(cache=True, nogil=True)   # the GIL is free while a frame steps: a lookahead thread adapts poses
def run_steps_cg(model, state, fp, ip, counters, ld_from, ld_to, ld_work, external, n_steps, info, chol,
                 ramp_offset, ramp_steps):
    """
    Advance `n_steps` steps with preconditioned CG; stops at the first failure. Returns (status, steps done).

    Desired lengths ramp linearly from `ld_from` to `ld_to` `(n_springs,)`: step k of the call uses the
    fraction (ramp_offset + k + 1) / ramp_steps (capped at 1), written into `ld_work`; `ramp_steps` <= 0
    holds `ld_to` throughout.

    `chol` is the CholeskyFactor of the block Cholesky preconditioner (`model` a KernelModel, `state` a
    KernelState). The system matrix is current every step; its factor is reused for up to `factor_every`
    steps (CG absorbs the difference in a few iterations) and refactorised early after a slow solve, once the
    iterations beyond one per solve have cost as much as a factorisation (`FP_REFACTOR_BUDGET`), or when a solve
    with a stale factor fails (then the solve is repeated). A failed factorisation falls back to block Jacobi for
    that step.

    With `ip[IP_FACTOR_THREAD]` a factor due by its age or the budget alone is not computed here: the step copies
    its matrix into `chol.snapshot` and the call returns STATUS_FACTOR_REQUEST after it; the caller factorises the
    snapshot beside the next steps and, when this returns STATUS_FACTOR_SWAP (`ip[IP_FACTOR_LAG]` steps after the
    snapshot, before that step), puts that factor in place. Which factor each step uses depends on the step and CG
    iteration counts alone, never on timing.
    """
    kind = ip[IP_PRECONDITIONER]
    factor_state = chol.state
    desired_lengths = ld_to
    for step in range(n_steps):
        if kind == 2 and _swap_is_due(ip, counters, factor_state):
            return STATUS_FACTOR_SWAP, step
        if ramp_steps > 0:
            ramp_lengths(ld_from, ld_to, ld_work, min(1.0, (ramp_offset + step + 1) / ramp_steps))
            desired_lengths = ld_work
        status, refreshed = prepare_step(model, state, fp, ip, counters, desired_lengths, external, info)
        if status != STATUS_OK:
            return status, step
        requested = False
        if kind == 2 and refreshed and _factor_is_due(fp, ip, counters, factor_state):
            if (ip[IP_FACTOR_THREAD] != 0 and factor_state[F_VALID] > 0
                    and factor_state[F_LAST_ITERS] <= ip[IP_REFACTOR_ITERS]):   # age or budget: on the thread
                if factor_state[F_PENDING] == 0:
                    _snapshot_for_thread(model, state, ip, counters, chol)
                    requested = True
            else:
                _refactor(model, state, ip, counters, chol)
        if kind == 2:
            _rotate_factor(model, state, ip, counters, chol)
        iters, res, threshold = solve_system(model, state, fp, ip, chol)
        failed = iters < 0 or not np.isfinite(res) or res > fp[FP_CG_FAIL] * threshold
        if failed and kind == 2 and factor_state[F_STEP] != counters[C_STEP]:
            counters[C_CG_ITERS] += abs(iters)
            _refactor(model, state, ip, counters, chol)   # a stale factor: refactorise and solve again
            state.delta_v[:] = 0.0
            state.cg_work[3][:] = 0.0                       # A Δv of the zero start
            iters, res, threshold = solve_system(model, state, fp, ip, chol)
            failed = iters < 0 or not np.isfinite(res) or res > fp[FP_CG_FAIL] * threshold
        counters[C_CG_ITERS] += abs(iters)
        factor_state[F_LAST_ITERS] = abs(iters)
        factor_state[F_EXTRA_ITERS] += max(abs(iters) - 1, 0)
        if failed:
            info[0] = iters
            info[1] = res / threshold if threshold > 0 else np.inf
            return STATUS_SOLVER, step
        status = finish_step(state, fp, counters, info)
        if status != STATUS_OK:
            return status, step + 1
        if requested:
            return STATUS_FACTOR_REQUEST, step + 1
    return STATUS_OK, n_steps
