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
Contact between soft bodies: penalty forces of one body's nodes inside another body's volume, with friction.

As the ground's contact (Section V), but against a body: a node of body A (any node, `ContactBody.contact_nodes`)
inside a tetrahedron of body B is
pushed out along the way to B's nearest surface point, with a force `stiffness x depth` less a normal damping, and
friction against the relative sliding velocity (regularised Coulomb, at most `friction x normal force`). The opposite
force goes to the three nodes of B's surface triangle at that point, split by its barycentric weights, so the pair's
forces sum to zero (momentum is conserved; tested). The forces are explicit: the world steps the bodies in blocks of a
few steps (`coupling_steps`) with them held constant, short enough for the penalty to be stable
(`sqrt(stiffness / node mass) x block period` at most STABLE_OMEGA_DT = 1.2 for the body's mean node mass,
`stiffness_for`; a light surface node is held by the stiff implicit springs and elements around it, which the same
step solves).
"""
from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from iguana_ros.constants import (BODY_CONTACT_DAMPING_RATIO, BODY_CONTACT_PERIOD, BODY_CONTACT_STIFFNESS,
                                  FRICTION_COEFFICIENT)
from iguana_ros.physics.meshes import boundary_triangles


STABLE_OMEGA_DT = 1.2
"""Largest (contact angular frequency x block period) allowed for a node of the body's mean mass; explicit penalty
forces held over a block diverge beyond 2. Long steps (the `fast` preset, 1/200 s) get a softer contact."""


@dataclass(frozen=True)
class ContactBody:
    """
    What contact needs of one body: tetrahedra `(n_tets, 4)`, surface triangles `(n_tri, 3)`, mean node mass kg.

    `contact_nodes` are the nodes tested against other bodies: every node, not only the surface's, so a limb that
    crossed another between their surface nodes is pushed out too.
    """

    tets: np.ndarray
    triangles: np.ndarray
    contact_nodes: np.ndarray
    mean_node_mass: float

    @classmethod
    def of_model(cls, model) -> ContactBody:
        """Return the contact data of an iguana model (`body.model`)."""
        tets = np.ascontiguousarray(model.tets, dtype=np.int64)
        triangles = np.ascontiguousarray(boundary_triangles(model.rest_positions, tets), dtype=np.int64)
        every = np.arange(len(model.rest_positions), dtype=np.int64)
        return cls(tets, triangles, every, float(np.mean(model.node_mass)))


@dataclass(frozen=True)
class BodyContactParams:
    """Penalty stiffness N/m per node, damping ratio (of the mean node mass), friction coefficient, block period s."""

    stiffness: float = BODY_CONTACT_STIFFNESS
    damping_ratio: float = BODY_CONTACT_DAMPING_RATIO
    friction: float = FRICTION_COEFFICIENT
    period: float = BODY_CONTACT_PERIOD

    def coupling_steps(self, dt: float) -> int:
        """Return the simulator steps per block of held contact forces at time step `dt` s (at least 1)."""
        return max(1, int(round(self.period / dt)))

    def stiffness_for(self, body: ContactBody, block: float) -> float:
        """Return the penalty stiffness N/m of `body`'s nodes for blocks of `block` s: at most the stable one."""
        return min(self.stiffness, (STABLE_OMEGA_DT / block) ** 2 * body.mean_node_mass)


@dataclass
class PairContact:
    """Contact of one ordered pair of bodies in one block: nodes of A inside B, deepest m, normal force sum N."""

    a: int
    b: int
    nodes: int
    max_depth: float
    normal_force: float


def near(boxes: np.ndarray, a: int, b: int, margin: float) -> bool:
    """Whether the bounding boxes `(n_bodies, 2, 3)` of bodies `a` and `b` come within `margin` m."""
    return bool(np.all(boxes[a, 0] - margin <= boxes[b, 1]) and np.all(boxes[b, 0] - margin <= boxes[a, 1]))


def bounding_boxes(positions: list[np.ndarray]) -> np.ndarray:
    """Return the axis-aligned bounding box `(n_bodies, 2, 3)` (min, max) m of each body's nodes."""
    return np.array([(p.min(axis=0), p.max(axis=0)) for p in positions])


def contact_forces(bodies: list[ContactBody], positions: list[np.ndarray], velocities: list[np.ndarray],
                   params: BodyContactParams, block: float,
                   margin: float = 0.0) -> tuple[list[np.ndarray], list[PairContact]]:
    """
    Return the contact force `(n_nodes_i, 3)` N on each body and the contacts of each touching ordered pair.

    The forces are held for `block` s. Only pairs whose boxes come within `margin` m are examined; positions and
    velocities `(n_nodes_i, 3)` per body.
    """
    forces = [np.zeros_like(p) for p in positions]
    pairs = []
    boxes = bounding_boxes(positions)
    for a in range(len(bodies)):
        for b in range(len(bodies)):
            if a == b or not near(boxes, a, b, margin):
                continue
            out = np.zeros(3)
            _pair_forces(bodies[a].contact_nodes, bodies[a].mean_node_mass, positions[a], velocities[a],
                         bodies[b].tets, bodies[b].triangles, positions[b], velocities[b], boxes[b, 0], boxes[b, 1],
                         params.stiffness_for(bodies[a], block), params.damping_ratio, params.friction, forces[a],
                         forces[b], out)
            if out[0] > 0:
                pairs.append(PairContact(a, b, int(out[0]), float(out[1]), float(out[2])))
    return forces, pairs


def load_kernels(body: ContactBody, positions: np.ndarray) -> None:
    """Compile or load the contact kernels by calling them on no nodes (the first contact then costs no compiling)."""
    box = bounding_boxes([positions])[0]
    none, scratch = np.zeros(0, dtype=np.int64), np.zeros_like(positions)
    _pair_forces(none, body.mean_node_mass, positions, positions, body.tets, body.triangles, positions, positions,
                 box[0], box[1], 1.0, 1.0, 1.0, scratch, scratch, np.zeros(3))
    _depths(positions[:0], body.tets, body.triangles, positions, box[0], box[1], np.zeros(0))


def penetration_depths(body_b: ContactBody, positions_a: np.ndarray, positions_b: np.ndarray) -> np.ndarray:
    """Return how deep m each node `(n_a, 3)` of body A lies inside body B's volume (0 outside), `(n_a,)`."""
    depths = np.zeros(len(positions_a))
    box = bounding_boxes([positions_b])[0]
    _depths(positions_a, body_b.tets, body_b.triangles, positions_b, box[0], box[1], depths)
    return depths


@numba.njit(cache=True)
def _inside(p, tets, x, lo, hi) -> bool:
    """Whether point `p` lies in one of the tetrahedra `tets` of nodes `x` (within the box lo..hi)."""
    for k in range(3):
        if p[k] < lo[k] or p[k] > hi[k]:
            return False
    for t in range(tets.shape[0]):
        a, b, c, d = tets[t, 0], tets[t, 1], tets[t, 2], tets[t, 3]
        skip = False
        for k in range(3):
            m0 = min(min(x[a, k], x[b, k]), min(x[c, k], x[d, k]))
            m1 = max(max(x[a, k], x[b, k]), max(x[c, k], x[d, k]))
            if p[k] < m0 or p[k] > m1:
                skip = True
                break
        if skip:
            continue
        e = np.empty((3, 3))
        r = np.empty(3)
        for k in range(3):
            e[k, 0], e[k, 1], e[k, 2] = x[b, k] - x[a, k], x[c, k] - x[a, k], x[d, k] - x[a, k]
            r[k] = p[k] - x[a, k]
        det = np.linalg.det(e)
        if abs(det) < 1e-18:
            continue
        w = np.linalg.solve(e, r)
        if w[0] >= 0.0 and w[1] >= 0.0 and w[2] >= 0.0 and w[0] + w[1] + w[2] <= 1.0:
            return True
    return False


@numba.njit(cache=True)
def _closest_on_triangle(p, a, b, c, out):
    """Closest point to `p` on triangle abc: writes (u, v, w) barycentric weights to `out`; returns the point."""
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = np.dot(ab, ap), np.dot(ac, ap)
    if d1 <= 0.0 and d2 <= 0.0:
        out[0], out[1], out[2] = 1.0, 0.0, 0.0
        return a.copy()
    bp = p - b
    d3, d4 = np.dot(ab, bp), np.dot(ac, bp)
    if d3 >= 0.0 and d4 <= d3:
        out[0], out[1], out[2] = 0.0, 1.0, 0.0
        return b.copy()
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        v = d1 / (d1 - d3)
        out[0], out[1], out[2] = 1.0 - v, v, 0.0
        return a + v * ab
    cp = p - c
    d5, d6 = np.dot(ab, cp), np.dot(ac, cp)
    if d6 >= 0.0 and d5 <= d6:
        out[0], out[1], out[2] = 0.0, 0.0, 1.0
        return c.copy()
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        w = d2 / (d2 - d6)
        out[0], out[1], out[2] = 1.0 - w, 0.0, w
        return a + w * ac
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        out[0], out[1], out[2] = 0.0, 1.0 - w, w
        return b + w * (c - b)
    denom = 1.0 / (va + vb + vc)
    v, w = vb * denom, vc * denom
    out[0], out[1], out[2] = 1.0 - v - w, v, w
    return a + ab * v + ac * w


@numba.njit(cache=True)
def _nearest_surface(p, triangles, x, weights):
    """Return (index of the surface triangle nearest to `p`, that point `(3,)`); its weights go to `weights`."""
    best, best_d2 = -1, np.inf
    point = np.zeros(3)
    w = np.zeros(3)
    for t in range(triangles.shape[0]):
        q = _closest_on_triangle(p, x[triangles[t, 0]], x[triangles[t, 1]], x[triangles[t, 2]], w)
        d2 = np.sum((q - p) ** 2)
        if d2 < best_d2:
            best, best_d2, point = t, d2, q
            weights[:] = w
    return best, point


@numba.njit(cache=True)
def _pair_forces(nodes_a, mass_a, xa, va, tets_b, triangles_b, xb, vb, lo, hi, stiffness, zeta, mu, fa, fb, out):
    """Add the contact forces of A's surface `nodes_a` inside B to `fa` and the reactions to `fb`; tally in `out`."""
    weights = np.zeros(3)
    for i in range(nodes_a.shape[0]):
        n = nodes_a[i]
        p = xa[n]
        if not _inside(p, tets_b, xb, lo, hi):
            continue
        t, q = _nearest_surface(p, triangles_b, xb, weights)
        gap = q - p
        depth = np.sqrt(np.sum(gap ** 2))
        if t < 0 or depth < 1e-12:
            continue
        normal = gap / depth
        tri = triangles_b[t]
        vq = weights[0] * vb[tri[0]] + weights[1] * vb[tri[1]] + weights[2] * vb[tri[2]]
        rel = va[n] - vq
        vn = np.dot(rel, normal)
        damping = 2.0 * zeta * np.sqrt(stiffness * mass_a)
        fn = max(0.0, stiffness * depth - damping * vn)
        force = fn * normal
        slide = rel - vn * normal
        speed = np.sqrt(np.sum(slide ** 2))
        if speed > 1e-12 and mu > 0.0:
            force -= min(mu * fn, damping * speed) / speed * slide
        fa[n] += force
        for k in range(3):
            fb[tri[k]] -= weights[k] * force
        out[0] += 1.0
        out[1] = max(out[1], depth)
        out[2] += fn


@numba.njit(cache=True)
def _depths(xa, tets_b, triangles_b, xb, lo, hi, depths):
    """Write the depth inside B of each node of `xa` (0 outside) to `depths`."""
    weights = np.zeros(3)
    for n in range(xa.shape[0]):
        if _inside(xa[n], tets_b, xb, lo, hi):
            _, q = _nearest_surface(xa[n], triangles_b, xb, weights)
            depths[n] = np.sqrt(np.sum((q - xa[n]) ** 2))
