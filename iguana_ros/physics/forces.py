"""Force kernels of `M p̈ = f_x + f_s + f_e + f_d` (paper Section V), compiled with numba.

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

from iguana_ros.terrain.heightfield import bilinear_height_gradient

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
@numba.njit(cache=True)
def quat_to_matrix(q, r):
    """Write the rotation matrix of unit quaternion `q (4,)` (x, y, z, w) into `r (3, 3)`."""
    x, y, z, w = q[0], q[1], q[2], q[3]
    r[0, 0] = 1 - 2 * (y * y + z * z)
    r[0, 1] = 2 * (x * y - z * w)
    r[0, 2] = 2 * (x * z + y * w)
    r[1, 0] = 2 * (x * y + z * w)
    r[1, 1] = 1 - 2 * (x * x + z * z)
    r[1, 2] = 2 * (y * z - x * w)
    r[2, 0] = 2 * (x * z - y * w)
    r[2, 1] = 2 * (y * z + x * w)
    r[2, 2] = 1 - 2 * (x * x + y * y)


@numba.njit(cache=True)
def extract_rotation(a, q, r, max_iter):
    """Rotation `r (3, 3)` maximising tr(rᵀa) (Müller et al. 2016), warm-started from and written to `q (4,)`."""
    for _ in range(max_iter):
        quat_to_matrix(q, r)
        ox = 0.0
        oy = 0.0
        oz = 0.0
        dot = 0.0
        for c in range(3):  # Σ_c r_c × a_c and Σ_c r_c · a_c over the columns
            ox += r[1, c] * a[2, c] - r[2, c] * a[1, c]
            oy += r[2, c] * a[0, c] - r[0, c] * a[2, c]
            oz += r[0, c] * a[1, c] - r[1, c] * a[0, c]
            dot += r[0, c] * a[0, c] + r[1, c] * a[1, c] + r[2, c] * a[2, c]
        inv = 1.0 / (abs(dot) + 1e-9)
        ox *= inv
        oy *= inv
        oz *= inv
        angle2 = ox * ox + oy * oy + oz * oz
        if angle2 < 1e-16:                           # converged to 1e-8 rad
            break
        if angle2 < 1e-4:                            # small step: first-order quaternion (normalised below)
            dx, dy, dz, dw = 0.5 * ox, 0.5 * oy, 0.5 * oz, 1.0
        else:
            angle = np.sqrt(angle2)
            s = np.sin(0.5 * angle) / angle
            dx, dy, dz, dw = ox * s, oy * s, oz * s, np.cos(0.5 * angle)
        x, y, z, w = q[0], q[1], q[2], q[3]
        nx = dw * x + dx * w + dy * z - dz * y
        ny = dw * y - dx * z + dy * w + dz * x
        nz = dw * z + dx * y - dy * x + dz * w
        nw = dw * w - dx * x - dy * y - dz * z
        norm = np.sqrt(nx * nx + ny * ny + nz * nz + nw * nw)
        q[0], q[1], q[2], q[3] = nx / norm, ny / norm, nz / norm, nw / norm
    quat_to_matrix(q, r)


# ---------------------------------------------------------------------------------------- elastic force
@numba.njit(cache=True)
def corotated_elastic_forces(x, tets, grads, volume, mu, lam, quats, polar_iters, forces, blocks, tet_blocks, scale):
    """Add corotated linear FEM forces of `tets (n_tets, 4)` at `x (n, 3)`; update `quats (n_tets, 4)`; stiffness."""
    f_def = np.empty((3, 3))
    r = np.empty((3, 3))
    p = np.empty((3, 3))
    rg = np.empty((4, 3))
    xl = np.empty((4, 3))
    for t in range(tets.shape[0]):
        g = grads[t]
        for a in range(4):                          # gather the 4 node positions
            node = tets[t, a]
            xl[a, 0] = x[node, 0]
            xl[a, 1] = x[node, 1]
            xl[a, 2] = x[node, 2]
        for i in range(3):                          # deformation gradient F = Σ_a x_a ⊗ ∇φ_a
            for j in range(3):
                f_def[i, j] = xl[0, i] * g[0, j] + xl[1, i] * g[1, j] + xl[2, i] * g[2, j] + xl[3, i] * g[3, j]
        extract_rotation(f_def, quats[t], r, polar_iters)
        tr = 0.0
        for i in range(3):                          # ε = sym(RᵀF) − I, written into p
            for j in range(3):
                acc = 0.0
                for k in range(3):
                    acc += r[k, i] * f_def[k, j] + r[k, j] * f_def[k, i]
                p[i, j] = 0.5 * acc
            p[i, i] -= 1.0
            tr += p[i, i]
        m2 = 2.0 * mu[t]
        for i in range(3):                          # σ = 2μ ε + λ tr(ε) I
            for j in range(3):
                p[i, j] *= m2
            p[i, i] += lam[t] * tr
        vol = volume[t]
        for a in range(4):                          # f_a = −V R σ ∇φ_a
            s0 = p[0, 0] * g[a, 0] + p[0, 1] * g[a, 1] + p[0, 2] * g[a, 2]
            s1 = p[1, 0] * g[a, 0] + p[1, 1] * g[a, 1] + p[1, 2] * g[a, 2]
            s2 = p[2, 0] * g[a, 0] + p[2, 1] * g[a, 1] + p[2, 2] * g[a, 2]
            node = tets[t, a]
            for i in range(3):
                forces[node, i] -= vol * (r[i, 0] * s0 + r[i, 1] * s1 + r[i, 2] * s2)
        if scale != 0.0:
            _add_tet_stiffness(g, r, vol * scale * mu[t], vol * scale * lam[t], rg, blocks, tet_blocks[t])


@numba.njit(cache=True)
def _add_tet_stiffness(g, r, vmu, vlam, rg, blocks, block_index):
    """Add R K Rᵀ of one tet: block (a, b) = V[μ(∇φ_a·∇φ_b) I + μ r_b r_aᵀ + λ r_a r_bᵀ], r_a = R ∇φ_a."""
    for a in range(4):
        for i in range(3):
            rg[a, i] = r[i, 0] * g[a, 0] + r[i, 1] * g[a, 1] + r[i, 2] * g[a, 2]
    for a in range(4):
        for b in range(a, 4):                        # upper blocks; (b, a) is the transpose
            gg = vmu * (g[a, 0] * g[b, 0] + g[a, 1] * g[b, 1] + g[a, 2] * g[b, 2])
            ab = blocks[block_index[4 * a + b]]
            ba = blocks[block_index[4 * b + a]]
            for i in range(3):
                for j in range(3):
                    k = vmu * rg[b, i] * rg[a, j] + vlam * rg[a, i] * rg[b, j]
                    if i == j:
                        k += gg
                    ab[i, j] += k
                    if a != b:
                        ba[j, i] += k


# ----------------------------------------------------------------------------------------------- springs
@numba.njit(cache=True)
def spring_forces(x, springs, stiffness, desired_lengths, forces, blocks, spring_blocks, scale):
    """Add f = a (l_d − l) along each spring `(n_springs, 2)`; stiffness blocks with the compressive part clamped."""
    for s in range(springs.shape[0]):
        i = springs[s, 0]
        j = springs[s, 1]
        d0 = x[j, 0] - x[i, 0]
        d1 = x[j, 1] - x[i, 1]
        d2 = x[j, 2] - x[i, 2]
        length = np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        if length < 1e-12:
            continue
        u0, u1, u2 = d0 / length, d1 / length, d2 / length
        a = stiffness[s]
        mag = a * (length - desired_lengths[s])       # tension > 0 pulls i toward j
        forces[i, 0] += mag * u0
        forces[i, 1] += mag * u1
        forces[i, 2] += mag * u2
        forces[j, 0] -= mag * u0
        forces[j, 1] -= mag * u1
        forces[j, 2] -= mag * u2
        if scale != 0.0:
            geo = max(0.0, 1.0 - desired_lengths[s] / length)   # clamp: keep the block positive semi-definite
            _add_spring_stiffness(u0, u1, u2, scale * a, geo, blocks, spring_blocks[s])


@numba.njit(cache=True)
def _add_spring_stiffness(u0, u1, u2, a, geo, blocks, idx):
    """Add ±a[u uᵀ + geo (I − u uᵀ)] into the (ii, jj, ij, ji) blocks `idx (4,)`."""
    c = a * (1.0 - geo)
    k00, k11, k22 = c * u0 * u0 + a * geo, c * u1 * u1 + a * geo, c * u2 * u2 + a * geo
    k01, k02, k12 = c * u0 * u1, c * u0 * u2, c * u1 * u2
    for b, sign in ((idx[0], 1.0), (idx[1], 1.0), (idx[2], -1.0), (idx[3], -1.0)):
        blk = blocks[b]
        blk[0, 0] += sign * k00
        blk[1, 1] += sign * k11
        blk[2, 2] += sign * k22
        blk[0, 1] += sign * k01
        blk[1, 0] += sign * k01
        blk[0, 2] += sign * k02
        blk[2, 0] += sign * k02
        blk[1, 2] += sign * k12
        blk[2, 1] += sign * k12


# ----------------------------------------------------------------------------------------------- contact
@numba.njit(cache=True)
def contact_forces(x, v, contact_mass, friction, heights, ox, oy, spacing, kn, cn, kt, ct,
                   anchors, state, forces, diag_k, diag_c):
    """Penalty contact on the height field: normal k·d + c·ḋ (≥ 0), Coulomb friction via stick anchors.

    Per node: `kn, kt` stiffness and `cn, ct` damping per kg of `contact_mass (n,)` (1/s², 1/s);
    `friction (n,)` μ; `anchors (n, 3)`
    and `state (n,)` (CONTACT_*) persist between steps. Adds forces, writes stiffness `diag_k (n, 3, 3)` (N/m) and
    damping `diag_c (n, 3, 3)` (N s/m) of each node's own block.
    Returns `(nodes in contact, deepest node, its depth in m)`.
    """
    n_contact = 0
    deepest = -1
    max_depth = 0.0
    for i in range(x.shape[0]):
        for p in range(3):
            for q in range(3):
                diag_k[i, p, q] = 0.0
                diag_c[i, p, q] = 0.0
        h, gx, gy = bilinear_height_gradient(heights, ox, oy, spacing, x[i, 0], x[i, 1])
        inv = 1.0 / np.sqrt(1.0 + gx * gx + gy * gy)
        n0, n1, n2 = -gx * inv, -gy * inv, inv
        depth = (h - x[i, 2]) * n2                   # distance below the local tangent plane
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


@numba.njit(cache=True)
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


@numba.njit(cache=True)
def _outer_add(blk, n0, n1, n2, k):
    """blk += k n nᵀ."""
    n = (n0, n1, n2)
    for p in range(3):
        for q in range(3):
            blk[p, q] += k * n[p] * n[q]
