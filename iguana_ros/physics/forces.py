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
Force kernels of `M p̈ = f_x + f_s + f_e + f_d` (paper Section V), compiled with numba.

Conventions: positions/velocities/forces `(n_nodes, 3)` in m, m/s, N. Every kernel *adds* its force into `forces`
and, when `scale != 0`, adds `scale ×` its stiffness blocks `-∂f/∂x` into the block matrix `blocks (n_blocks, 3, 3)`
at the block indices prepared by `iguana_ros.physics.assembly.BlockPattern`.

- `spring_forces`: f = a (l_d − l) along each spring (Eq. 2), stiffness clamped to be positive semi-definite.
- `corotated_elastic_forces`: f_e = −R K (Rᵀp − x) (Eq. 3, Müller 2002 / Nesme 2005), R from a warm-started
  rotation extraction (Müller et al. 2016) that always returns a proper rotation, also for flat/inverted tets.
- `contact_forces`: penalty ground contact on a height field with a stick anchor for static Coulomb friction.
"""
from __future__ import annotations

import numba
import numpy as np

from iguana_ros.jit import FASTMATH
from iguana_ros.terrain.heightfield import above_block_maximum, bilinear_height_gradient

CONTACT_NONE = 0
"""Contact state of a node above the ground."""
CONTACT_STICK = 1
"""Contact state of a node held by static friction (tangential anchor spring)."""
CONTACT_SLIP = 2
"""Contact state of a node sliding (friction force capped at μ f_n)."""


# --------------------------------------------------------------------------------------------- rest shape
def shape_gradients(rest_positions: np.ndarray, tets: np.ndarray) -> tuple:
    """Shape-function gradients `(n_tets, 4, 3)` (1/m) and rest volumes `(n_tets,)` m³ of linear tets."""
    p = rest_positions[tets]
    dm = np.transpose(p[:, 1:] - p[:, :1], (0, 2, 1))       # columns = rest edges
    volume = np.linalg.det(dm) / 6.0
    if np.any(volume <= 0):
        bad = int(np.argmin(volume))
        raise ValueError(f'tetrahedron {bad} has non-positive rest volume {volume[bad]:.3g} m³')
    dm_inv = np.linalg.inv(dm)
    grads = np.empty((len(tets), 4, 3))
    grads[:, 1:] = dm_inv                                      # row a-1 of Dm⁻¹ is ∇φ_a
    grads[:, 0] = -dm_inv.sum(axis=1)
    return np.ascontiguousarray(grads), volume


def lame_parameters(youngs_modulus: np.ndarray, poisson_ratio: float) -> tuple:
    """Lamé `(mu, lam)` arrays (Pa) from Young's modulus `(n_tets,)` Pa and a Poisson ratio."""
    e = np.asarray(youngs_modulus, dtype=np.float64)
    nu = float(poisson_ratio)
    return e / (2.0 * (1.0 + nu)), e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))


# ------------------------------------------------------------------------------------------- rotations
@numba.njit(cache=True, inline='always', fastmath=FASTMATH)
def _quat_rotation(qx, qy, qz, qw):
    """Row-major entries (r00, r01, …, r22) of the rotation matrix of the unit quaternion (x, y, z, w)."""
    return (1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qz * qw), 2 * (qx * qz + qy * qw),
            2 * (qx * qy + qz * qw), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qx * qw),
            2 * (qx * qz - qy * qw), 2 * (qy * qz + qx * qw), 1 - 2 * (qx * qx + qy * qy))


@numba.njit(cache=True, inline='always', fastmath=FASTMATH)
def _rotation_step(q, f):
    """
    Run one Müller et al. (2016) iteration towards the rotation maximising tr(Rᵀf) from the quaternion `q`.

    `q` is a 4-tuple (x y z w) and the 3×3 `f` a 9-tuple (row-major); returns (new quaternion, squared step angle).
    """
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = _quat_rotation(q[0], q[1], q[2], q[3])
    f00, f01, f02, f10, f11, f12, f20, f21, f22 = f
    ox = (r10 * f20 - r20 * f10) + (r11 * f21 - r21 * f11) + (r12 * f22 - r22 * f12)   # Σ_c r_c × f_c
    oy = (r20 * f00 - r00 * f20) + (r21 * f01 - r01 * f21) + (r22 * f02 - r02 * f22)
    oz = (r00 * f10 - r10 * f00) + (r01 * f11 - r11 * f01) + (r02 * f12 - r12 * f02)
    dot = r00 * f00 + r10 * f10 + r20 * f20 + r01 * f01 + r11 * f11 + r21 * f21 + r02 * f02 + r12 * f12 + r22 * f22
    inv = 1.0 / (abs(dot) + 1e-9)
    ox, oy, oz = ox * inv, oy * inv, oz * inv
    angle2 = ox * ox + oy * oy + oz * oz
    if angle2 < 1e-4:                                # small step: first-order quaternion (normalised below)
        dx, dy, dz, dw = 0.5 * ox, 0.5 * oy, 0.5 * oz, 1.0
    else:
        angle = np.sqrt(angle2)
        sn = np.sin(0.5 * angle) / angle
        dx, dy, dz, dw = ox * sn, oy * sn, oz * sn, np.cos(0.5 * angle)
    x, y, z, w = q
    nx = dw * x + dx * w + dy * z - dz * y
    ny = dw * y - dx * z + dy * w + dz * x
    nz = dw * z + dx * y - dy * x + dz * w
    nw = dw * w - dx * x - dy * y - dz * z
    norm = 1.0 / np.sqrt(nx * nx + ny * ny + nz * nz + nw * nw)
    return (nx * norm, ny * norm, nz * norm, nw * norm), angle2


@numba.njit(cache=True, inline='always', fastmath=FASTMATH)
def _extract_quaternion(f, quats, t, max_iter):
    """Warm-started rotation extraction for tet `t`: iterates `quats[t]` on the 3×3 `f` (9-tuple); returns it."""
    q = (quats[t, 0], quats[t, 1], quats[t, 2], quats[t, 3])
    for _ in range(max_iter):
        q, angle2 = _rotation_step(q, f)
        if angle2 < 1e-16:                           # converged to 1e-8 rad
            break
    quats[t, 0], quats[t, 1], quats[t, 2], quats[t, 3] = q
    return q


@numba.njit(cache=True, fastmath=FASTMATH)
def quat_to_matrix(q, r):
    """Write the rotation matrix of unit quaternion `q (4,)` (x, y, z, w) into `r (3, 3)`."""
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = _quat_rotation(q[0], q[1], q[2], q[3])
    r[0, 0], r[0, 1], r[0, 2] = r00, r01, r02
    r[1, 0], r[1, 1], r[1, 2] = r10, r11, r12
    r[2, 0], r[2, 1], r[2, 2] = r20, r21, r22


@numba.njit(cache=True, fastmath=FASTMATH)
def extract_rotation(a, q, r, max_iter):
    """Rotation `r (3, 3)` maximising tr(rᵀa) (Müller et al. 2016), warm-started from and written to `q (4,)`."""
    f = (a[0, 0], a[0, 1], a[0, 2], a[1, 0], a[1, 1], a[1, 2], a[2, 0], a[2, 1], a[2, 2])
    qs = q.reshape(1, 4)
    _extract_quaternion(f, qs, 0, max_iter)
    quat_to_matrix(q, r)


# ---------------------------------------------------------------------------------------- elastic force
@numba.njit(cache=True, inline='always', fastmath=FASTMATH)
def _deformation_gradient(x, tets, grads, t):
    """F = Σ_a x_a ⊗ ∇φ_a of tet `t` as a row-major 9-tuple."""
    f00 = f01 = f02 = f10 = f11 = f12 = f20 = f21 = f22 = 0.0
    for a in range(4):
        node = tets[t, a]
        x0, x1, x2 = x[node, 0], x[node, 1], x[node, 2]
        g0, g1, g2 = grads[t, a, 0], grads[t, a, 1], grads[t, a, 2]
        f00 += x0 * g0
        f01 += x0 * g1
        f02 += x0 * g2
        f10 += x1 * g0
        f11 += x1 * g1
        f12 += x1 * g2
        f20 += x2 * g0
        f21 += x2 * g1
        f22 += x2 * g2
    return f00, f01, f02, f10, f11, f12, f20, f21, f22


@numba.njit(cache=True, inline='always', fastmath=FASTMATH)
def _rotated_stress(r, f, two_mu, lam, vol):
    """V R σ (row-major 9-tuple) with σ = 2μ ε + λ tr(ε) I, ε = sym(RᵀF) − I; `r`, `f` row-major 9-tuples."""
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = r
    f00, f01, f02, f10, f11, f12, f20, f21, f22 = f
    s00 = r00 * f00 + r10 * f10 + r20 * f20          # S = RᵀF (its upper triangle and diagonal suffice)
    s11 = r01 * f01 + r11 * f11 + r21 * f21
    s22 = r02 * f02 + r12 * f12 + r22 * f22
    s01 = r00 * f01 + r10 * f11 + r20 * f21
    s10 = r01 * f00 + r11 * f10 + r21 * f20
    s02 = r00 * f02 + r10 * f12 + r20 * f22
    s20 = r02 * f00 + r12 * f10 + r22 * f20
    s12 = r01 * f02 + r11 * f12 + r21 * f22
    s21 = r02 * f01 + r12 * f11 + r22 * f21
    e00, e11, e22 = s00 - 1.0, s11 - 1.0, s22 - 1.0
    lt = lam * (e00 + e11 + e22)
    p00, p11, p22 = vol * (two_mu * e00 + lt), vol * (two_mu * e11 + lt), vol * (two_mu * e22 + lt)
    shear = vol * two_mu * 0.5
    p01, p02, p12 = shear * (s01 + s10), shear * (s02 + s20), shear * (s12 + s21)
    return (r00 * p00 + r01 * p01 + r02 * p02, r00 * p01 + r01 * p11 + r02 * p12, r00 * p02 + r01 * p12 + r02 * p22,
            r10 * p00 + r11 * p01 + r12 * p02, r10 * p01 + r11 * p11 + r12 * p12, r10 * p02 + r11 * p12 + r12 * p22,
            r20 * p00 + r21 * p01 + r22 * p02, r20 * p01 + r21 * p11 + r22 * p12, r20 * p02 + r21 * p12 + r22 * p22)


def corotated_elastic_forces(x, tets, grads, volume, mu, lam, quats, polar_iters, forces, blocks, tet_blocks, scale):
    """
    Add corotated linear FEM forces of `tets (n_tets, 4)` at `x (n, 3)`; update `quats (n_tets, 4)`; stiffness.

    Returns how many tets are inverted or flat (det F <= 0). A Python call of the compiled `corotated_elastic_range`
    over every tet, which the step kernels call directly: a compiled wrapper around it made a freshly compiled step
    loop and the cached one round differently (`test_determinism.py`), as 'contract' did (`jit.FASTMATH`).
    """
    return corotated_elastic_range(x, tets, grads, volume, mu, lam, quats, polar_iters, forces, blocks, tet_blocks,
                                   scale, 0, tets.shape[0])


@numba.njit(cache=True, fastmath=FASTMATH)
def corotated_elastic_range(x, tets, grads, volume, mu, lam, quats, polar_iters, forces, blocks, tet_blocks, scale,
                            first, stop):
    """`corotated_elastic_forces` of the tets first … stop − 1 only; returns how many of them are inverted or flat."""
    rg = np.empty((4, 3))
    inverted = 0
    for t in range(first, stop):
        f = _deformation_gradient(x, tets, grads, t)
        if _det3(f) <= 0.0:
            inverted += 1
        q = _extract_quaternion(f, quats, t, polar_iters)
        r = _quat_rotation(q[0], q[1], q[2], q[3])
        vol = volume[t]
        p = _rotated_stress(r, f, 2.0 * mu[t], lam[t], vol)
        for a in range(4):                           # f_a = −V R σ ∇φ_a
            node = tets[t, a]
            g0, g1, g2 = grads[t, a, 0], grads[t, a, 1], grads[t, a, 2]
            forces[node, 0] -= p[0] * g0 + p[1] * g1 + p[2] * g2
            forces[node, 1] -= p[3] * g0 + p[4] * g1 + p[5] * g2
            forces[node, 2] -= p[6] * g0 + p[7] * g1 + p[8] * g2
        if scale != 0.0:
            for a in range(4):                       # r_a = R ∇φ_a
                g0, g1, g2 = grads[t, a, 0], grads[t, a, 1], grads[t, a, 2]
                rg[a, 0] = r[0] * g0 + r[1] * g1 + r[2] * g2
                rg[a, 1] = r[3] * g0 + r[4] * g1 + r[5] * g2
                rg[a, 2] = r[6] * g0 + r[7] * g1 + r[8] * g2
            _add_tet_stiffness(rg, vol * scale * mu[t], vol * scale * lam[t], blocks, tet_blocks, tets, t)
    return inverted


@numba.njit(cache=True, inline='always', fastmath=FASTMATH)
def _det3(f):
    """Return the determinant of the row-major 3×3 9-tuple `f`."""
    f00, f01, f02, f10, f11, f12, f20, f21, f22 = f
    return f00 * (f11 * f22 - f12 * f21) - f01 * (f10 * f22 - f12 * f20) + f02 * (f10 * f21 - f11 * f20)


@numba.njit(cache=True, inline='always', fastmath=FASTMATH)
def _add_tet_stiffness(rg, vmu, vlam, blocks, tet_blocks, tets, t):
    """
    Add R K Rᵀ of tet `t`.

    Block (a, b) = V[μ(r_a·r_b) I + μ r_b r_aᵀ + λ r_a r_bᵀ] for `rg (4, 3)` = R ∇φ_a, into the stored upper triangle
    (block (b, a) = (a, b)ᵀ when node b < node a).
    """
    for a in range(4):
        a0, a1, a2 = rg[a, 0], rg[a, 1], rg[a, 2]
        for b in range(a, 4):                        # upper blocks; (b, a) is the transpose
            b0, b1, b2 = rg[b, 0], rg[b, 1], rg[b, 2]
            gg = vmu * (a0 * b0 + a1 * b1 + a2 * b2)  # ∇φ_a·∇φ_b = r_a·r_b
            k00 = (vmu + vlam) * a0 * b0 + gg
            k11 = (vmu + vlam) * a1 * b1 + gg
            k22 = (vmu + vlam) * a2 * b2 + gg
            k01 = vmu * b0 * a1 + vlam * a0 * b1
            k10 = vmu * b1 * a0 + vlam * a1 * b0
            k02 = vmu * b0 * a2 + vlam * a0 * b2
            k20 = vmu * b2 * a0 + vlam * a2 * b0
            k12 = vmu * b1 * a2 + vlam * a1 * b2
            k21 = vmu * b2 * a1 + vlam * a2 * b1
            if tets[t, a] < tets[t, b] or a == b:
                _add_block(blocks, tet_blocks[t, 4 * a + b], k00, k01, k02, k10, k11, k12, k20, k21, k22)
            else:                                    # node b < node a: the stored block is (b, a) = (a, b)ᵀ
                _add_block(blocks, tet_blocks[t, 4 * a + b], k00, k10, k20, k01, k11, k21, k02, k12, k22)


@numba.njit(cache=True, inline='always', fastmath=FASTMATH)
def _add_block(blocks, p, k00, k01, k02, k10, k11, k12, k20, k21, k22):
    """blocks[p] += [[k00, k01, k02], [k10, k11, k12], [k20, k21, k22]]."""
    blocks[p, 0, 0] += k00
    blocks[p, 0, 1] += k01
    blocks[p, 0, 2] += k02
    blocks[p, 1, 0] += k10
    blocks[p, 1, 1] += k11
    blocks[p, 1, 2] += k12
    blocks[p, 2, 0] += k20
    blocks[p, 2, 1] += k21
    blocks[p, 2, 2] += k22


# ----------------------------------------------------------------------------------------------- springs
@numba.njit(cache=True, fastmath=FASTMATH)
def spring_forces(x, springs, stiffness, desired_lengths, forces, blocks, spring_blocks, scale):
    """Add f = a (l_d − l) along each spring `(n_springs, 2)`; stiffness blocks with the compressive part clamped."""
    for s in range(springs.shape[0]):
        u0, u1, u2, length = _spring_pull(x, springs, stiffness, desired_lengths, forces, s)
        if length < 1e-12:
            continue
        if scale != 0.0:
            geo = max(0.0, 1.0 - desired_lengths[s] / length)   # clamp: keep the block positive semi-definite
            _add_spring_stiffness(u0, u1, u2, scale * stiffness[s], geo, blocks, spring_blocks, s)


@numba.njit(cache=True, inline='always', fastmath=FASTMATH)
def _spring_pull(x, springs, stiffness, desired_lengths, forces, s):
    """Add spring `s`'s force a (l − l_d) u to its ends; return its direction u and length (< 1e-12: no force)."""
    i = springs[s, 0]
    j = springs[s, 1]
    d0 = x[j, 0] - x[i, 0]
    d1 = x[j, 1] - x[i, 1]
    d2 = x[j, 2] - x[i, 2]
    length = np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    if length < 1e-12:
        return 0.0, 0.0, 0.0, length
    u0, u1, u2 = d0 / length, d1 / length, d2 / length
    mag = stiffness[s] * (length - desired_lengths[s])      # tension > 0 pulls i toward j
    forces[i, 0] += mag * u0
    forces[i, 1] += mag * u1
    forces[i, 2] += mag * u2
    forces[j, 0] -= mag * u0
    forces[j, 1] -= mag * u1
    forces[j, 2] -= mag * u2
    return u0, u1, u2, length


@numba.njit(cache=True, inline='always', fastmath=FASTMATH)
def _spring_block(u0, u1, u2, a, geo):
    """Entries (xx yy zz xy xz yz) of a spring's stiffness block a[u uᵀ + geo (I − u uᵀ)]."""
    c = a * (1.0 - geo)
    return (c * u0 * u0 + a * geo, c * u1 * u1 + a * geo, c * u2 * u2 + a * geo, c * u0 * u1, c * u0 * u2,
            c * u1 * u2)


@numba.njit(cache=True, inline='always', fastmath=FASTMATH)
def _add_spring_stiffness(u0, u1, u2, a, geo, blocks, spring_blocks, s):
    """Add ±a[u uᵀ + geo (I − u uᵀ)] into spring `s`'s (ii, jj, ij) blocks (symmetric, so either triangle)."""
    k00, k11, k22, k01, k02, k12 = _spring_block(u0, u1, u2, a, geo)
    _add_block(blocks, spring_blocks[s, 0], k00, k01, k02, k01, k11, k12, k02, k12, k22)
    _add_block(blocks, spring_blocks[s, 1], k00, k01, k02, k01, k11, k12, k02, k12, k22)
    _add_block(blocks, spring_blocks[s, 2], -k00, -k01, -k02, -k01, -k11, -k12, -k02, -k12, -k22)


@numba.njit(cache=True, fastmath=FASTMATH)
def spring_forces_operator(x, v, dv, springs, stiffness, desired_lengths, coef, node_work, work, h, rhs, kdv, scale):
    """
    Compute the springs' part of a matrix-free step: each spring's stiffness kept as K_s = c u uᵀ + g I, on the fly.

    With `scale != 0` (a Jacobian refresh) writes `coef (5, n_springs)` = (u, c, g) of scale · K_s, the block of
    `spring_forces` (compressive part clamped); with 0 keeps the held ones. Writes `rhs` = h f_s − K v (the springs'
    forces f_s and stiffness product, the system's right-hand side part) and `kdv` = K dv `(n, 3)` (K = Σ_s K_s on
    (i, i), (j, j), −K_s on (i, j)). Three passes: gather each spring's end differences of (x, v, dv), packed per
    node in `node_work (n, 9)`, into `work (9, n_springs)`; the arithmetic (which the compiler vectorises); scatter
    to the ends in spring order, each run of springs at one first node i summed in registers before it is added.
    """
    _gather_spring_differences(x, v, dv, springs, node_work, work)
    if scale != 0.0:
        _spring_coefficients(stiffness, desired_lengths, coef, work, scale)
    else:
        _held_spring_terms(stiffness, desired_lengths, coef, work)
    rhs[:] = 0.0
    kdv[:] = 0.0
    i_run = -1                                       # springs sharing their first node i in a row (the model's
    r0 = r1 = r2 = e0 = e1 = e2 = 0.0                # springs are sorted so) sum its share in registers
    for s in range(springs.shape[0]):
        i = springs[s, 0]
        j = springs[s, 1]
        if i != i_run:
            if i_run >= 0:
                _add_to(rhs, i_run, r0, r1, r2)
                _add_to(kdv, i_run, -e0, -e1, -e2)
            i_run = i
            r0 = r1 = r2 = e0 = e1 = e2 = 0.0
        t0, t1, t2 = h * work[0, s] + work[3, s], h * work[1, s] + work[4, s], h * work[2, s] + work[5, s]
        r0, r1, r2 = r0 + t0, r1 + t1, r2 + t2
        _add_to(rhs, j, -t0, -t1, -t2)
        e0, e1, e2 = e0 + work[6, s], e1 + work[7, s], e2 + work[8, s]
        _add_to(kdv, j, work[6, s], work[7, s], work[8, s])
    if i_run >= 0:
        _add_to(rhs, i_run, r0, r1, r2)
        _add_to(kdv, i_run, -e0, -e1, -e2)


@numba.njit(cache=True, inline='always', fastmath=FASTMATH)
def _add_to(out, i, t0, t1, t2):
    """out_i += t."""
    out[i, 0] += t0
    out[i, 1] += t1
    out[i, 2] += t2


@numba.njit(cache=True, fastmath=FASTMATH)
def _gather_spring_differences(x, v, dv, springs, node_work, work):
    """`work (9, n_springs)` ← x_j − x_i, v_j − v_i, dv_j − dv_i of every spring (i, j), through `node_work (n, 9)`."""
    for i in range(x.shape[0]):                     # one contiguous row per node: two rows per spring
        for k in range(3):
            node_work[i, k] = x[i, k]
            node_work[i, 3 + k] = v[i, k]
            node_work[i, 6 + k] = dv[i, k]
    for s in range(springs.shape[0]):
        i = springs[s, 0]
        j = springs[s, 1]
        for k in range(9):
            work[k, s] = node_work[j, k] - node_work[i, k]


@numba.njit(cache=True, fastmath=FASTMATH)
def _spring_coefficients(stiffness, desired_lengths, coef, work, scale):
    """From the differences in `work`: `coef` (u, c, g) of scale · K_s; `work` ← the pull on i, K_s w, K_s e."""
    for s in range(work.shape[1]):
        d0, d1, d2 = work[0, s], work[1, s], work[2, s]
        length = np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        if length < 1e-12:
            u0 = u1 = u2 = c = g = mag = 0.0
        else:
            u0, u1, u2 = d0 / length, d1 / length, d2 / length
            mag = stiffness[s] * (length - desired_lengths[s])      # tension > 0 pulls i toward j
            a = scale * stiffness[s]
            g = a * max(0.0, 1.0 - desired_lengths[s] / length)
            c = a - g
        coef[0, s], coef[1, s], coef[2, s], coef[3, s], coef[4, s] = u0, u1, u2, c, g
        work[0, s], work[1, s], work[2, s] = mag * u0, mag * u1, mag * u2
        _spring_products(work, s, u0, u1, u2, c, g)


@numba.njit(cache=True, fastmath=FASTMATH)
def _held_spring_terms(stiffness, desired_lengths, coef, work):
    """`_spring_coefficients` with the held `coef` (between Jacobian refreshes): `work` ← the pull, K_s w, K_s e."""
    for s in range(work.shape[1]):
        d0, d1, d2 = work[0, s], work[1, s], work[2, s]
        length = np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        if length < 1e-12:
            u0 = u1 = u2 = mag = 0.0
        else:
            u0, u1, u2 = d0 / length, d1 / length, d2 / length
            mag = stiffness[s] * (length - desired_lengths[s])
        work[0, s], work[1, s], work[2, s] = mag * u0, mag * u1, mag * u2
        _spring_products(work, s, coef[0, s], coef[1, s], coef[2, s], coef[3, s], coef[4, s])


@numba.njit(cache=True, inline='always', fastmath=FASTMATH)
def _spring_products(work, s, u0, u1, u2, c, g):
    """Replace spring `s`'s differences w = work[3:6, s], e = work[6:9, s] by K_s w, K_s e (K_s = c u uᵀ + g I)."""
    for base in (3, 6):
        w0, w1, w2 = work[base, s], work[base + 1, s], work[base + 2, s]
        p = c * (u0 * w0 + u1 * w1 + u2 * w2)
        work[base, s] = p * u0 + g * w0
        work[base + 1, s] = p * u1 + g * w1
        work[base + 2, s] = p * u2 + g * w2


@numba.njit(cache=True, fastmath=FASTMATH)
def spring_operator_matvec(springs, coef, node_matrix, x, out):
    """`out` = A x `(n, 3)` for A = blockdiag(`node_matrix (n, 3, 3)`) + the springs' K (`coef (5, n_springs)`)."""
    for i in range(x.shape[0]):
        x0, x1, x2 = x[i, 0], x[i, 1], x[i, 2]
        out[i, 0] = node_matrix[i, 0, 0] * x0 + node_matrix[i, 0, 1] * x1 + node_matrix[i, 0, 2] * x2
        out[i, 1] = node_matrix[i, 1, 0] * x0 + node_matrix[i, 1, 1] * x1 + node_matrix[i, 1, 2] * x2
        out[i, 2] = node_matrix[i, 2, 0] * x0 + node_matrix[i, 2, 1] * x1 + node_matrix[i, 2, 2] * x2
    i_run = -1                                       # as in spring_forces_operator: a run of springs at node i
    a0 = a1 = a2 = x0 = x1 = x2 = 0.0
    for s in range(springs.shape[0]):
        i = springs[s, 0]
        j = springs[s, 1]
        if i != i_run:
            if i_run >= 0:
                _add_to(out, i_run, a0, a1, a2)
            i_run = i
            a0 = a1 = a2 = 0.0
            x0, x1, x2 = x[i, 0], x[i, 1], x[i, 2]
        u0, u1, u2, c, g = coef[0, s], coef[1, s], coef[2, s], coef[3, s], coef[4, s]
        w0, w1, w2 = x0 - x[j, 0], x1 - x[j, 1], x2 - x[j, 2]
        p = c * (u0 * w0 + u1 * w1 + u2 * w2)
        t0, t1, t2 = p * u0 + g * w0, p * u1 + g * w1, p * u2 + g * w2
        a0, a1, a2 = a0 + t0, a1 + t1, a2 + t2
        _add_to(out, j, -t0, -t1, -t2)
    if i_run >= 0:
        _add_to(out, i_run, a0, a1, a2)


@numba.njit(cache=True, fastmath=FASTMATH)
def assemble_spring_matrix(coef, node_matrix, diag, spring_blocks, node_ptr, node_springs, blocks):
    """
    Write every block of A = blockdiag(`node_matrix`) + the springs' K where each off-diagonal block is one spring's.

    Spring s's stored block −K_s, each node's diagonal block its `node_matrix` plus its springs' K_s, summed over
    `node_springs[node_ptr[i]:node_ptr[i + 1]]` in ascending spring order (no read-modify-write chains, no zeroing).
    """
    for s in range(coef.shape[1]):
        k00, k11, k22, k01, k02, k12 = _coef_block(coef, s)
        _set_block(blocks, spring_blocks[s, 2], -k00, -k11, -k22, -k01, -k02, -k12)
    for n in range(diag.shape[0]):
        s00 = s11 = s22 = s01 = s02 = s12 = 0.0
        for q in range(node_ptr[n], node_ptr[n + 1]):
            k00, k11, k22, k01, k02, k12 = _coef_block(coef, node_springs[q])
            s00 += k00
            s11 += k11
            s22 += k22
            s01 += k01
            s02 += k02
            s12 += k12
        d = diag[n]
        for p in range(3):
            for q in range(3):
                blocks[d, p, q] = node_matrix[n, p, q]
        _add_block(blocks, d, s00, s01, s02, s01, s11, s12, s02, s12, s22)


@numba.njit(cache=True, inline='always', fastmath=FASTMATH)
def _coef_block(coef, s):
    """Entries (xx yy zz xy xz yz) of K_s = c u uᵀ + g I from `coef[:, s]` = (u, c, g)."""
    u0, u1, u2, c, g = coef[0, s], coef[1, s], coef[2, s], coef[3, s], coef[4, s]
    return c * u0 * u0 + g, c * u1 * u1 + g, c * u2 * u2 + g, c * u0 * u1, c * u0 * u2, c * u1 * u2


@numba.njit(cache=True, inline='always', fastmath=FASTMATH)
def _set_block(blocks, p, k00, k11, k22, k01, k02, k12):
    """blocks[p] = the symmetric [[k00, k01, k02], [k01, k11, k12], [k02, k12, k22]]."""
    blocks[p, 0, 0], blocks[p, 0, 1], blocks[p, 0, 2] = k00, k01, k02
    blocks[p, 1, 0], blocks[p, 1, 1], blocks[p, 1, 2] = k01, k11, k12
    blocks[p, 2, 0], blocks[p, 2, 1], blocks[p, 2, 2] = k02, k12, k22


# ----------------------------------------------------------------------------------------------- contact
@numba.njit(cache=True, fastmath=FASTMATH)
def contact_forces(x, v, contact_mass, contact_offset, friction, heights, bounds, ox, oy, spacing, kn, cn, kt, ct,
                   anchors, state, forces, diag_k, diag_c):
    """
    Penalty contact on the height field: normal k·d + c·ḋ (≥ 0), Coulomb friction via stick anchors.

    Per node: `kn, kt` stiffness and `cn, ct` damping per kg of `contact_mass (n,)` (1/s², 1/s); a node touches
    the terrain `contact_offset (n,)` m before its position reaches it (the sole pad of a foot node);
    `friction (n,)` μ; `anchors (n, 3)`
    and `state (n,)` (CONTACT_*) persist between steps. Adds forces, writes stiffness `diag_k (n, 3, 3)` (N/m) and
    damping `diag_c (n, 3, 3)` (N s/m) of each node's own block; a node out of contact (CONTACT_NONE) keeps zero
    blocks, so only the others' are cleared. A node above the highest grid height of its block (`bounds`,
    `heightfield.block_maxima`) is out of contact without interpolating the terrain.
    Returns `(nodes in contact, deepest node, its depth in m)`.
    """
    n_contact = 0
    deepest = -1
    max_depth = 0.0
    for i in range(x.shape[0]):
        if state[i] != CONTACT_NONE:
            for p in range(3):
                for q in range(3):
                    diag_k[i, p, q] = 0.0
                    diag_c[i, p, q] = 0.0
        if above_block_maximum(heights, bounds, ox, oy, spacing, x[i, 0], x[i, 1], x[i, 2] - contact_offset[i]):
            state[i] = CONTACT_NONE
            continue
        h, gx, gy = bilinear_height_gradient(heights, ox, oy, spacing, x[i, 0], x[i, 1])
        inv = 1.0 / np.sqrt(1.0 + gx * gx + gy * gy)
        n0, n1, n2 = -gx * inv, -gy * inv, inv
        depth = (h + contact_offset[i] - x[i, 2]) * n2   # distance below the (offset) local tangent plane
        if depth <= 0.0:
            state[i] = CONTACT_NONE
            continue
        n_contact += 1
        if depth > max_depth:
            max_depth = depth
            deepest = i
        m = contact_mass[i]
        vn = v[i, 0] * n0 + v[i, 1] * n1 + v[i, 2] * n2
        fn = m * (kn * depth - cn * vn)
        if state[i] == CONTACT_NONE:                 # touch-down: anchor at the surface point below the node
            anchors[i, 0] = x[i, 0] + depth * n0
            anchors[i, 1] = x[i, 1] + depth * n1
            anchors[i, 2] = x[i, 2] + depth * n2
        if fn <= 0.0:                                # separating: never pull the body into the ground
            state[i] = CONTACT_SLIP
            continue
        forces[i, 0] += fn * n0
        forces[i, 1] += fn * n1
        forces[i, 2] += fn * n2
        _outer_add(diag_k[i], n0, n1, n2, m * kn)
        _outer_add(diag_c[i], n0, n1, n2, m * cn)
        state[i] = _friction(x, v, i, n0, n1, n2, m * kt, m * ct, friction[i] * fn, anchors, forces, diag_k, diag_c)
    return n_contact, deepest, max_depth


@numba.njit(cache=True, inline='always', fastmath=FASTMATH)
def _friction(x, v, i, n0, n1, n2, kt, ct, limit, anchors, forces, diag_k, diag_c):
    """Tangential anchor spring-damper capped at `limit` = μ f_n; slides the anchor when capped. Returns state."""
    e0 = x[i, 0] - anchors[i, 0]
    e1 = x[i, 1] - anchors[i, 1]
    e2 = x[i, 2] - anchors[i, 2]
    en = e0 * n0 + e1 * n1 + e2 * n2
    e0, e1, e2 = e0 - en * n0, e1 - en * n1, e2 - en * n2
    vn = v[i, 0] * n0 + v[i, 1] * n1 + v[i, 2] * n2
    w0, w1, w2 = v[i, 0] - vn * n0, v[i, 1] - vn * n1, v[i, 2] - vn * n2
    f0 = -kt * e0 - ct * w0
    f1 = -kt * e1 - ct * w1
    f2 = -kt * e2 - ct * w2
    mag = np.sqrt(f0 * f0 + f1 * f1 + f2 * f2)
    if mag <= limit:
        forces[i, 0] += f0
        forces[i, 1] += f1
        forces[i, 2] += f2
        n = (n0, n1, n2)
        for p in range(3):                           # tangential stiffness/damping kt (I − n nᵀ)
            for q in range(3):
                t = (1.0 if p == q else 0.0) - n[p] * n[q]
                diag_k[i, p, q] += kt * t
                diag_c[i, p, q] += ct * t
        return CONTACT_STICK
    s = limit / mag
    forces[i, 0] += s * f0
    forces[i, 1] += s * f1
    forces[i, 2] += s * f2
    speed = np.sqrt(w0 * w0 + w1 * w1 + w2 * w2)       # sliding: the capped force's damping derivative
    c_slip = min(ct, limit / speed) if speed > 0.0 else ct
    n = (n0, n1, n2)
    for p in range(3):
        for q in range(3):
            diag_c[i, p, q] += c_slip * ((1.0 if p == q else 0.0) - n[p] * n[q])
    elen = np.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
    if elen > 0.0:                                   # slide the anchor so its spring alone carries μ f_n
        keep = min(1.0, limit / (kt * elen))
        anchors[i, 0] = x[i, 0] - en * n0 - keep * e0
        anchors[i, 1] = x[i, 1] - en * n1 - keep * e1
        anchors[i, 2] = x[i, 2] - en * n2 - keep * e2
    return CONTACT_SLIP


@numba.njit(cache=True, inline='always', fastmath=FASTMATH)
def _outer_add(blk, n0, n1, n2, k):
    """`blk` += k n nᵀ."""
    n = (n0, n1, n2)
    for p in range(3):
        for q in range(3):
            blk[p, q] += k * n[p] * n[q]
