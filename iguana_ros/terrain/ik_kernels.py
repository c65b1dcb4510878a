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
The compiled kernels of terrain adaptation (Section VI): forward kinematics and residual fitting's bounded Gauss–Newton.

`fk_kernel` gives a pose's world joint positions and rotations; `gauss_newton_system` the objective of residual
fitting (feet and tail tip to their terrain targets, joints above the terrain, the pose near the plane-fitted one),
its gradient and its Gauss–Newton matrix, reading the height field directly; `bounded_gauss_newton` minimises it
inside the joint limits (Levenberg–Marquardt with an active set). terrain/adaptation.py calls them.
"""
from __future__ import annotations

import numba
import numpy as np

from iguana_ros.terrain.heightfield import bilinear_height_gradient


@numba.njit(cache=True)
def fk_kernel(root_position, local_rotations, parents, offsets, positions, rotations):
    """Quaternion (xyzw) forward kinematics of one pose into `positions (n, 3)`, `rotations (n, 4)`."""
    for b in range(parents.shape[0]):
        p = parents[b]
        if p < 0:
            positions[b] = root_position
            rotations[b] = local_rotations[b]
            continue
        ax, ay, az, aw = rotations[p]
        bx, by, bz, bw = local_rotations[b]
        rotations[b, 0] = aw * bx + ax * bw + ay * bz - az * by
        rotations[b, 1] = aw * by - ax * bz + ay * bw + az * bx
        rotations[b, 2] = aw * bz + ax * by - ay * bx + az * bw
        rotations[b, 3] = aw * bw - ax * bx - ay * by - az * bz
        v = offsets[b]  # rotate v by the parent: v + 2w (u x v) + 2 u x (u x v)
        tx = 2.0 * (ay * v[2] - az * v[1])
        ty = 2.0 * (az * v[0] - ax * v[2])
        tz = 2.0 * (ax * v[1] - ay * v[0])
        positions[b, 0] = positions[p, 0] + v[0] + aw * tx + ay * tz - az * ty
        positions[b, 1] = positions[p, 1] + v[1] + aw * ty + az * tx - ax * tz
        positions[b, 2] = positions[p, 2] + v[2] + aw * tz + ax * ty - ay * tx


@numba.njit(cache=True)
def _skew_terms(r):
    """Angle and the two Rodrigues/left-Jacobian coefficient triples of a rotation vector."""
    th2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2]
    th = np.sqrt(th2)
    if th < 1e-4:
        a = 1.0 - th2 / 6.0
        b = 0.5 - th2 / 24.0
        c = 1.0 / 6.0 - th2 / 120.0
    else:
        a = np.sin(th) / th
        b = (1.0 - np.cos(th)) / th2
        c = (th - np.sin(th)) / (th2 * th)
    return a, b, c


@numba.njit(cache=True)
def _rotation_and_jacobian(r, rot, jac):
    """Fill rotation matrix `rot (3, 3)` = exp(r) and left Jacobian `jac (3, 3)` of rotation vector `r`."""
    a, b, c = _skew_terms(r)
    th2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2]
    k = ((0.0, -r[2], r[1]), (r[2], 0.0, -r[0]), (-r[1], r[0], 0.0))
    for i in range(3):
        for j in range(3):
            k2 = r[i] * r[j] - (th2 if i == j else 0.0)  # [r]x^2 = r r^T - |r|^2 I
            eye = 1.0 if i == j else 0.0
            rot[i, j] = eye + a * k[i][j] + b * k2
            jac[i, j] = eye + b * k[i][j] + c * k2


@numba.njit(cache=True)
def _mat_mul(a, b, out):
    """`out` = a @ b for 3x3 matrices (no BLAS call)."""
    for i in range(3):
        for j in range(3):
            out[i, j] = a[i, 0] * b[0, j] + a[i, 1] * b[1, j] + a[i, 2] * b[2, j]


@numba.njit(cache=True)
def _forward(x, var_bones, root_position, local_mats, parents, offsets, lift_scale, local, jacs, world,
             positions):
    """FK of solution `x`: fills local/world rotations `(n_bones, 3, 3)`, Jacobians and joint positions."""
    nv = var_bones.shape[0]
    local[:] = local_mats
    for k in range(nv):
        _rotation_and_jacobian(x[3 * k:3 * k + 3], local[var_bones[k]], jacs[k])
    for b in range(parents.shape[0]):
        p = parents[b]
        if p < 0:
            world[b] = local[b]
            positions[b] = root_position
            positions[b, 2] += x[3 * nv] * lift_scale
            continue
        _mat_mul(world[p], local[b], world[b])
        for i in range(3):
            positions[b, i] = positions[p, i] + (world[p, i, 0] * offsets[b, 0] + world[p, i, 1] * offsets[b, 1]
                                                 + world[p, i, 2] * offsets[b, 2])


@numba.njit(cache=True)
def _add_bone_rows(e, weight, d, pen_normal, var_of, parents, positions, world, jacs, lift_scale, row, nz, hess,
                   grad):
    """
    Add one bone's rows to the Gauss–Newton system: J_eᵀ W J_e to `hess`, J_eᵀ W r to `grad`.

    A position residual `d (3,)` of joint `e` (its three rows), or, when `pen_normal` is given as (gx, gy, −1), the
    one penetration row s with ∂s/∂x = (gx, gy, −1) · ∂p_e/∂x and residual `d[0]` = s. x_k rotates joint `e` about
    the joint of var bone b_k, an ancestor: ∂p_e/∂x_k = −[p_e − p_{b_k}]× R_parent(b_k) J_l(x_k).
    """
    n_rows = 1 if pen_normal[2] != 0.0 else 3
    lift = row.shape[1] - 1
    for c in range(n_rows):
        count = 0
        a = parents[e]
        while a >= 0:
            k = var_of[a]
            if k >= 0:
                ex = positions[e, 0] - positions[a, 0]
                ey = positions[e, 1] - positions[a, 1]
                ez = positions[e, 2] - positions[a, 2]
                r = world[parents[a]]
                for i in range(3):                    # column 3k + i: −(p_e − p_a) × (R_p J_l)[:, i]
                    u0 = r[0, 0] * jacs[k, 0, i] + r[0, 1] * jacs[k, 1, i] + r[0, 2] * jacs[k, 2, i]
                    u1 = r[1, 0] * jacs[k, 0, i] + r[1, 1] * jacs[k, 1, i] + r[1, 2] * jacs[k, 2, i]
                    u2 = r[2, 0] * jacs[k, 0, i] + r[2, 1] * jacs[k, 1, i] + r[2, 2] * jacs[k, 2, i]
                    d0 = u1 * ez - u2 * ey            # u × (p_e − p_a) = ∂p_e/∂x_{k,i}
                    d1 = u2 * ex - u0 * ez
                    d2 = u0 * ey - u1 * ex
                    if n_rows == 1:
                        v = pen_normal[0] * d0 + pen_normal[1] * d1 - d2
                    else:
                        v = d0 if c == 0 else (d1 if c == 1 else d2)
                    row[0, 3 * k + i] = v
                    nz[count] = 3 * k + i
                    count += 1
            a = parents[a]
        row[0, lift] = -lift_scale if n_rows == 1 else (lift_scale if c == 2 else 0.0)
        nz[count] = lift
        count += 1
        res = d[c]
        for p in range(count):
            i = nz[p]
            wi = weight * row[0, i]
            grad[i] += wi * res
            for q in range(count):
                hess[i, nz[q]] += wi * row[0, nz[q]]


@numba.njit(cache=True)
def gauss_newton_system(x, var_bones, var_of, root_position, local_mats, parents, offsets, eff_bones, eff_targets,
                        eff_weights, x_ref, pose_weight, lift_weight, clearance, pen_weight, inv_scale2,
                        lift_scale, heights, ox, oy, spacing, positions, hess, grad):
    """
    Residual-fitting objective f at `x`, its Gauss–Newton matrix JᵀWJ and half gradient JᵀWr (∇f = 2 JᵀWr).

    f = Σ_effectors w ‖p_e − target‖² / ℓ² + w_pen Σ_joints max(0, terrain + clearance − z)² / ℓ²
    + w_pose ‖x − x_ref‖² + w_lift lift², over x = rotation vectors of `var_bones` (3 each, rad) followed by the root
    lift (in units of `lift_scale` = ℓ m).

    Fills `hess (n_x, n_x)`, `grad (n_x,)` (∇f = 2 grad) and the world joint `positions (n_bones, 3)`.
    """
    n = parents.shape[0]
    nv = var_bones.shape[0]
    n_x = x.shape[0]
    local = np.empty((n, 3, 3))
    world = np.empty((n, 3, 3))
    jacs = np.empty((nv, 3, 3))
    _forward(x, var_bones, root_position, local_mats, parents, offsets, lift_scale, local, jacs, world, positions)
    hess[:] = 0.0
    grad[:] = 0.0
    row = np.zeros((1, n_x))
    nz = np.empty(n_x, dtype=np.int64)
    d = np.empty(3)
    position_rows = np.zeros(3)
    f = 0.0
    for i in range(eff_bones.shape[0]):
        b = eff_bones[i]
        w = eff_weights[i] * inv_scale2
        for c in range(3):
            d[c] = positions[b, c] - eff_targets[i, c]
            f += w * d[c] * d[c]
        _add_bone_rows(b, w, d, position_rows, var_of, parents, positions, world, jacs, lift_scale, row, nz, hess,
                       grad)
    w = pen_weight * inv_scale2
    normal = np.empty(3)
    for b in range(n):
        h, gx, gy = bilinear_height_gradient(heights, ox, oy, spacing, positions[b, 0], positions[b, 1])
        s = h + clearance[b] - positions[b, 2]
        if s > 0.0:
            f += w * s * s
            d[0] = s
            normal[0], normal[1], normal[2] = gx, gy, -1.0
            _add_bone_rows(b, w, d, normal, var_of, parents, positions, world, jacs, lift_scale, row, nz, hess,
                           grad)
    for i in range(3 * nv):
        dx = x[i] - x_ref[i]
        f += pose_weight * dx * dx
        grad[i] += pose_weight * dx
        hess[i, i] += pose_weight
    f += lift_weight * x[3 * nv] ** 2
    grad[3 * nv] += lift_weight * x[3 * nv]
    hess[3 * nv, 3 * nv] += lift_weight
    return f


@numba.njit(cache=True)
def _damped_step(hess, grad, free, mu, step):
    """
    `step` = −(H_FF + μ diag(H_FF))⁻¹ g_F on the free variables, 0 on the others (dense Cholesky).

    Returns False if the damped matrix is not positive definite.
    """
    index = np.flatnonzero(free)
    m = index.shape[0]
    a = np.empty((m, m))
    for p in range(m):
        for q in range(m):
            a[p, q] = hess[index[p], index[q]]
        a[p, p] *= 1.0 + mu
    for j in range(m):                                # in place: lower triangle of a = L
        s = a[j, j]
        for k in range(j):
            s -= a[j, k] * a[j, k]
        if not s > 0.0:
            return False
        a[j, j] = np.sqrt(s)
        for i in range(j + 1, m):
            s = a[i, j]
            for k in range(j):
                s -= a[i, k] * a[j, k]
            a[i, j] = s / a[j, j]
    y = np.empty(m)
    for i in range(m):                                # L y = −g_F
        s = -grad[index[i]]
        for k in range(i):
            s -= a[i, k] * y[k]
        y[i] = s / a[i, i]
    for i in range(m - 1, -1, -1):                    # Lᵀ δ = y
        s = y[i]
        for k in range(i + 1, m):
            s -= a[k, i] * y[k]
        y[i] = s / a[i, i]
    step[:] = 0.0
    for p in range(m):
        step[index[p]] = y[p]
    return True


@numba.njit(cache=True)
def bounded_gauss_newton(x0, lo, hi, max_iter, gtol, ftol, var_bones, var_of, root_position, local_mats, parents,
                         offsets, eff_bones, eff_targets, eff_weights, x_ref, pose_weight, lift_weight, clearance,
                         pen_weight, inv_scale2, lift_scale, heights, ox, oy, spacing, positions):
    """
    Minimise the residual-fitting objective over the box [lo, hi] from `x0 (n_x,)`: projected Levenberg–Marquardt.

    Each iteration solves the Gauss–Newton system on the variables not held at a bound by their gradient, clips the
    step into the box and accepts it if the objective decreases (else raises the damping μ and retries). Stops when
    the projected gradient is below `gtol`, the relative decrease below `ftol` (as L-BFGS-B's tests) or after
    `max_iter` iterations. Returns (x, f, iterations, evaluations); `positions` hold the joints of x.
    """
    n = x0.shape[0]
    x = np.minimum(np.maximum(x0, lo), hi)
    hess, grad = np.empty((n, n)), np.empty(n)
    trial_hess, trial_grad = np.empty((n, n)), np.empty(n)
    trial, step = np.empty(n), np.empty(n)
    free = np.empty(n, dtype=np.bool_)
    best_positions = np.empty_like(positions)
    args = (var_bones, var_of, root_position, local_mats, parents, offsets, eff_bones, eff_targets, eff_weights,
            x_ref, pose_weight, lift_weight, clearance, pen_weight, inv_scale2, lift_scale, heights, ox, oy, spacing)
    f = gauss_newton_system(x, *args, positions, hess, grad)
    best_positions[:] = positions
    evaluations, iterations, mu, grow = 1, 0, 0.0, 2.0
    while iterations < max_iter:
        projected = 0.0
        for i in range(n):
            g = 2.0 * grad[i]
            projected = max(projected, abs(min(max(x[i] - g, lo[i]), hi[i]) - x[i]))
            free[i] = not ((x[i] <= lo[i] and grad[i] > 0.0) or (x[i] >= hi[i] and grad[i] < 0.0))
        if projected <= gtol:
            break
        f_trial, gain = np.inf, 0.0
        while mu < 1e10:
            if _damped_step(hess, grad, free, mu, step):
                trial[:] = np.minimum(np.maximum(x + step, lo), hi)
                predicted = 0.0                       # f − model(x + δ) = −2 gᵀδ − δᵀHδ for the clipped δ
                for i in range(n):
                    d = trial[i] - x[i]
                    hd = 0.0
                    for j in range(n):
                        hd += hess[i, j] * (trial[j] - x[j])
                    predicted -= d * (2.0 * grad[i] + hd)
                f_trial = gauss_newton_system(trial, *args, positions, trial_hess, trial_grad)
                evaluations += 1
                gain = (f - f_trial) / predicted if predicted > 0.0 else -1.0
                if f_trial < f and gain > 0.0:
                    break
            mu = max(1e-4, grow * mu)                 # rejected: damp more (Nielsen 1999)
            grow *= 2.0
        if not (f_trial < f and gain > 0.0):
            break                                     # no decrease even along the (scaled) gradient: converged
        iterations += 1
        decrease = (f - f_trial) / max(abs(f), abs(f_trial), 1.0)
        x[:] = trial
        f = f_trial
        hess, trial_hess = trial_hess, hess
        grad, trial_grad = trial_grad, grad
        best_positions[:] = positions
        mu *= max(1.0 / 3.0, 1.0 - (2.0 * gain - 1.0) ** 3)
        grow = 2.0
        if mu < 1e-4:
            mu = 0.0
        if decrease <= ftol:
            break
    positions[:] = best_positions
    return x, f, iterations, evaluations
