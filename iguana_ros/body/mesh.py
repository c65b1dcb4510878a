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
Tetrahedral mesh of the iguana body: radius-adapted node sampling, Delaunay, carving, sliver repair.

Nodes are rings of surface points on cross-sections along the main body (snout to tail tip) and along
each limb, spaced in proportion to the local body radius, with one axis node half-way between
consecutive rings (a body-centred arrangement: aligned rings plus mid-axis nodes tetrahedralise into
fat tets, where staggered rings give cospherical slivers). Every surface node is projected onto the
implicit surface of `shape.py` (soles land on z = 0). The Delaunay tetrahedralisation is carved to the
tets inside the body and reduced to one face-connected piece; boundary slivers are peeled where the
surface stays manifold, and remaining slivers or surface defects are repaired by small deterministic
random moves of their nodes and re-triangulation, keeping the best mesh found. Where that global repair
stalls (the `fine` density) it only fixes the topology, and `improve_mesh` then removes slivers locally:
3-2/2-3 flips and node moves (surface nodes sliding on the surface), each kept only if it raises the worst
dihedral angle of the tets it touches.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree, Delaunay

from iguana_ros.body.shape import body_field, BodyShape, main_cross_section, project_to_surface, segment_frames

PART_MAIN = 0
"""Part code of nodes generated on the main body (head, trunk, tail)."""
PART_LIMB0 = 1
"""Part code of the first limb's nodes; limb i (shape.LIMBS order) has code PART_LIMB0 + i."""

TET_FACES = np.array([[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]], dtype=np.int64)
"""Faces of a tet (vertex indices, outward for a positively oriented tet), face k opposite vertex k."""
TET_EDGES = np.array([[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]], dtype=np.int64)
"""The six edges of a tet (local vertex indices)."""


@dataclass(frozen=True)
class MeshParams:
    """Sampling density of one named resolution (spacing factors relative to the local body radius)."""

    main_axial: float      # station spacing / sqrt(ry rz) on the main body
    main_ring: float       # ring point spacing / station spacing on the main body
    main_min_ring: int     # fewest points on a main-body ring
    limb_ring: int         # points per limb ring
    limb_axial: float      # limb station spacing / limb radius
    max_spacing: float     # upper bound of the station spacing, m
    min_spacing: float     # lower bound of the station spacing, m
    chord_tolerance: float = 0.15  # carving: how far (x edge length) an edge midpoint may lie outside
    repair_iterations: int = 40  # sliver/topology repair attempts (perturb + re-triangulate)
    fill_rounds: int = 0   # carving: rounds of putting back tets around non-manifold boundary edges
    inner_ring: float = 0.0  # main-body mid-stations wider than this many station spacings get an inner ring
    improve_rounds: int = 0  # rounds of flips and node smoothing after repair (0: repair slivers by jitter)
    improve_deg: float = 12.0  # smoothing/flipping target: all dihedral angles in [this, 180 - this] deg


RESOLUTIONS = {
    'coarse': MeshParams(main_axial=3.5, main_ring=1.1, main_min_ring=3, limb_ring=4, limb_axial=3.5,
                         max_spacing=0.045, min_spacing=0.012, chord_tolerance=0.3, fill_rounds=3),
    'medium': MeshParams(main_axial=2.0, main_ring=1.0, main_min_ring=4, limb_ring=4, limb_axial=2.2,
                         max_spacing=0.03, min_spacing=0.007),
    'fine': MeshParams(main_axial=1.2, main_ring=1.0, main_min_ring=5, limb_ring=6, limb_axial=1.3,
                       max_spacing=0.016, min_spacing=0.004, fill_rounds=3, inner_ring=1.2,
                       improve_rounds=30, improve_deg=15.0),
    'finer': MeshParams(main_axial=0.85, main_ring=1.0, main_min_ring=6, limb_ring=8, limb_axial=1.0,
                        max_spacing=0.011, min_spacing=0.003, fill_rounds=3, inner_ring=1.2,
                        improve_rounds=30, improve_deg=15.0),
}
"""Named resolutions: roughly 150, 400, 1,200 and 2,300 nodes ('finer' is for `iguana bench scale`; scenes take
the first three)."""


@dataclass(frozen=True)
class Samples:
    """Candidate nodes `(n, 3)`, their target spacing `(n,)` m, part code `(n,)`, surface flag `(n,)`."""

    points: np.ndarray
    spacing: np.ndarray
    part: np.ndarray
    surface: np.ndarray


def _ring(n: int, phase: float) -> np.ndarray:
    """(cos, sin) `(n, 2)` of n equally spaced angles starting at `phase` ring steps."""
    theta = 2.0 * np.pi * (np.arange(n) + phase) / n
    return np.stack([np.cos(theta), np.sin(theta)], axis=1)


def _main_stations(shape: BodyShape, prm: MeshParams) -> np.ndarray:
    """`x` `(n,)` of the main-body cross-sections, from the snout back to the tail tip."""
    x0, x1 = shape.x_range
    xs = [x1]
    while True:
        _, ry, rz = main_cross_section(shape, np.array([xs[-1]]))
        h = np.clip(prm.main_axial * np.sqrt(ry[0] * rz[0]), prm.min_spacing, prm.max_spacing)
        if xs[-1] - 1.5 * h < x0:
            break
        xs.append(xs[-1] - h)
    xs = np.array(xs + [x0])
    return xs


def main_samples(shape: BodyShape, prm: MeshParams) -> Samples:
    """Ring and interior candidate nodes of the main body (head, trunk, tail) and its two cap tips."""
    xs = _main_stations(shape, prm)
    h = np.abs(np.gradient(xs)) if len(xs) > 1 else np.array([prm.max_spacing])
    zc, ry, rz = main_cross_section(shape, xs)
    pts, spc, surf = [], [], []
    for k, x in enumerate(xs):
        perimeter = np.pi * (3 * (ry[k] + rz[k]) - np.sqrt((3 * ry[k] + rz[k]) * (ry[k] + 3 * rz[k])))
        m = max(prm.main_min_ring, int(round(perimeter / (prm.main_ring * h[k]))))
        cs = _ring(m, 0.0)
        ring = np.column_stack([np.full(m, x), ry[k] * cs[:, 0], zc[k] + rz[k] * cs[:, 1]])
        pts.append(ring), spc.append(np.full(m, h[k])), surf.append(np.ones(m, bool))
    # interior nodes half-way between stations (a body-centred arrangement: no cospherical rings)
    xm = 0.5 * (xs[1:] + xs[:-1])
    zm, rym, rzm = main_cross_section(shape, xm)
    for k, x in enumerate(xm):
        inner = _inner_points(x, zm[k], rym[k], rzm[k], h[k], prm.inner_ring)
        pts.append(inner), spc.append(np.full(len(inner), h[k])), surf.append(np.zeros(len(inner), bool))
    x0, x1 = shape.x_range
    for x in (x0, x1):  # cap tips on the axis
        zc_, ry_, rz_ = main_cross_section(shape, np.array([x]))
        cap = min(ry_[0], rz_[0])
        pts.append(np.array([[x + np.sign(x) * cap, 0.0, zc_[0]]]))
        spc.append(np.array([cap])), surf.append(np.array([True]))
    points = np.vstack(pts)
    return Samples(points, np.concatenate(spc), np.full(len(points), PART_MAIN), np.concatenate(surf))


def _inner_points(x: float, zc: float, ry: float, rz: float, h: float, inner_ring: float) -> np.ndarray:
    """
    Interior candidate nodes `(n, 3)` at mid-station x.

    The axis node, plus a half-radius ring of spacing ~h where the section is wider than `inner_ring` * h (0: never).
    """
    axis = np.array([[x, 0.0, zc]])
    if inner_ring <= 0.0 or np.sqrt(ry * rz) <= inner_ring * h:
        return axis
    m = max(3, int(round(np.pi * (ry + rz) / (2.0 * h))))
    cs = _ring(m, 0.5)
    ring = np.column_stack([np.full(m, x), 0.5 * ry * cs[:, 0], zc + 0.5 * rz * cs[:, 1]])
    return np.vstack([axis, ring])


def limb_samples(shape: BodyShape, prm: MeshParams, index: int) -> Samples:
    """Ring candidate nodes of limb `index` from the girdle joint to the toe tip."""
    limb = shape.limbs[index]
    seg_len = np.linalg.norm(np.diff(limb.points, axis=0), axis=1)
    s_joint = np.concatenate([[0.0], np.cumsum(seg_len)])
    radius = np.sqrt(limb.radii[:, 0] * limb.radii[:, 1])
    s = [0.0]
    while s[-1] < s_joint[-1]:
        s.append(s[-1] + prm.limb_axial * np.interp(s[-1], s_joint, radius))
    s = np.array(s[:-1]) * s_joint[-1] / s[-2] if len(s) > 2 else np.array([0.0])
    s[-1] = s_joint[-1]
    centre = np.column_stack([np.interp(s, s_joint, limb.points[:, k]) for k in range(3)])
    ry = np.interp(s, s_joint, limb.radii[:, 0])
    rz = np.interp(s, s_joint, limb.radii[:, 1])
    tangent = _smooth_tangents(s, s_joint, limb.points)
    d, lat, up = segment_frames(centre - tangent, centre)
    pts, spc = [], []
    for k in range(len(s) - 1):
        cs = _ring(prm.limb_ring, 0.0)
        pts.append(centre[k] + ry[k] * cs[:, :1] * lat[k] + rz[k] * cs[:, 1:] * up[k])
        spc.append(np.full(prm.limb_ring, min(prm.limb_axial * np.sqrt(ry[k] * rz[k]),
                                              2 * np.pi * min(ry[k], rz[k]) / prm.limb_ring)))
    tip = centre[-1] + d[-1] * min(ry[-1], rz[-1])
    pts.append(tip[None]), spc.append(np.array([min(ry[-1], rz[-1])]))
    n_surface = sum(len(p) for p in pts)
    mid = 0.5 * (centre[1:-1] + centre[:-2])  # axis nodes half-way between rings
    pts.append(mid), spc.append(np.sqrt(ry * rz)[1:-1])
    points = np.vstack(pts)
    n = len(points)
    surface = np.arange(n) < n_surface
    return Samples(points, np.concatenate(spc), np.full(n, PART_LIMB0 + index), surface)


def _smooth_tangents(s: np.ndarray, s_joint: np.ndarray, joints: np.ndarray) -> np.ndarray:
    """Return unit tangents `(n, 3)` of a polyline at arclengths `s`, blended near its corners."""
    seg = np.diff(joints, axis=0)
    seg /= np.linalg.norm(seg, axis=1, keepdims=True)
    idx = np.clip(np.searchsorted(s_joint, s, side='right') - 1, 0, len(seg) - 1)
    t = seg[idx].copy()
    half = 0.35 * np.diff(s_joint)
    for j in range(1, len(seg)):
        near = np.abs(s - s_joint[j]) < np.minimum(half[j - 1], half[j])
        w = 0.5 + 0.5 * (s[near] - s_joint[j]) / np.minimum(half[j - 1], half[j])
        t[near] = (1 - w)[:, None] * seg[j - 1] + w[:, None] * seg[j]
    return t / np.linalg.norm(t, axis=1, keepdims=True)


def candidate_nodes(shape: BodyShape, prm: MeshParams) -> Samples:
    """All candidate nodes: surface ones projected to the body surface, buried and crowded ones dropped."""
    parts = [main_samples(shape, prm)] + [limb_samples(shape, prm, i) for i in range(len(shape.limbs))]
    pts = np.vstack([p.points for p in parts])
    spc = np.concatenate([p.spacing for p in parts])
    part = np.concatenate([p.part for p in parts])
    surf = np.concatenate([p.surface for p in parts])
    f = body_field(shape, pts)
    keep = np.where(surf, f > -0.3 * spc, f < -0.25 * spc)
    pts, spc, part, surf = pts[keep], spc[keep], part[keep], surf[keep]
    pts[surf] = project_to_surface(shape, pts[surf])
    keep = _thin(pts, spc)
    return Samples(pts[keep], spc[keep], part[keep], surf[keep])


def _thin(points: np.ndarray, spacing: np.ndarray, factor: float = 0.5) -> np.ndarray:
    """Mask `(n,)` keeping points in order unless an earlier kept point is closer than factor*spacing."""
    tree = cKDTree(points)
    keep = np.ones(len(points), bool)
    for i, near in enumerate(tree.query_ball_point(points, factor * spacing)):
        if keep[i]:
            later = [j for j in near if j > i and factor * min(spacing[i], spacing[j]) >
                     np.linalg.norm(points[j] - points[i])]
            keep[later] = False
    return keep


def tet_volumes(points: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """Signed volumes `(n_tets,)` of tets `(n_tets, 4)`, positive for right-handed vertex order."""
    a, b, c, d = (points[tets[:, k]] for k in range(4))
    return np.einsum('nk,nk->n', np.cross(b - a, c - a), d - a) / 6.0


def dihedral_angles(points: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """Return the six interior dihedral angles `(n_tets, 6)` of each tet, radians (edge order TET_EDGES)."""
    p = points[tets]                                            # (n, 4, 3)
    faces = p[:, TET_FACES]                                     # (n, 4, 3, 3)
    normals = np.cross(faces[:, :, 1] - faces[:, :, 0], faces[:, :, 2] - faces[:, :, 0])
    normals /= np.maximum(np.linalg.norm(normals, axis=-1, keepdims=True), 1e-300)
    # edge (i, j) is shared by the faces opposite the other two vertices k, l
    other = np.array([[2, 3], [1, 3], [1, 2], [0, 3], [0, 2], [0, 1]])
    cos = np.einsum('nek,nek->ne', normals[:, other[:, 0]], normals[:, other[:, 1]])
    return np.pi - np.arccos(np.clip(cos, -1.0, 1.0))


def radius_ratios(points: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """Normalised radius ratio 3 r_in / R_circ `(n_tets,)`: 1 for a regular tet, 0 for a flat one."""
    p = points[tets]
    vol = np.abs(tet_volumes(points, tets))
    faces = p[:, TET_FACES]
    area = 0.5 * np.linalg.norm(np.cross(faces[:, :, 1] - faces[:, :, 0],
                                         faces[:, :, 2] - faces[:, :, 0]), axis=-1).sum(axis=1)
    r_in = 3.0 * vol / np.maximum(area, 1e-300)
    a, b, c = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0], p[:, 3] - p[:, 0]
    num = (np.einsum('nk,nk->n', a, a)[:, None] * np.cross(b, c)
           + np.einsum('nk,nk->n', b, b)[:, None] * np.cross(c, a)
           + np.einsum('nk,nk->n', c, c)[:, None] * np.cross(a, b))
    r_circ = np.linalg.norm(num, axis=1) / np.maximum(12.0 * vol, 1e-300)
    return 3.0 * r_in / np.maximum(r_circ, 1e-300)


def orient_positive(points: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """Tets `(n, 4)` with the last two vertices swapped where the signed volume is negative."""
    tets = tets.copy()
    neg = tet_volumes(points, tets) < 0
    tets[neg, 2], tets[neg, 3] = tets[neg, 3], tets[neg, 2].copy()
    return tets


def face_adjacency(tets: np.ndarray) -> tuple:
    """
    Interior face pairs: tet indices `(n_pairs, 2)` and local face indices `(n_pairs, 2)`.

    Also returns the boundary faces as (tet index `(n_b,)`, local face `(n_b,)`).
    """
    faces = np.sort(tets[:, TET_FACES].reshape(-1, 3), axis=1)
    key = faces[:, 0] * (1 << 42) + faces[:, 1] * (1 << 21) + faces[:, 2]
    order = np.argsort(key, kind='stable')
    ks = key[order]
    same = np.flatnonzero(ks[1:] == ks[:-1])
    first, second = order[same], order[same + 1]
    paired = np.zeros(len(key), bool)
    paired[first] = paired[second] = True
    pairs = np.stack([first // 4, second // 4], axis=1)
    local = np.stack([first % 4, second % 4], axis=1)
    lone = np.flatnonzero(~paired)
    return pairs, local, (lone // 4, lone % 4)


def boundary_triangles(tets: np.ndarray) -> np.ndarray:
    """Boundary faces `(n_tris, 3)` of positively oriented tets, counter-clockwise seen from outside."""
    _, _, (t, f) = face_adjacency(tets)
    return tets[t[:, None], TET_FACES[f]]


def largest_component(tets: np.ndarray) -> np.ndarray:
    """Mask `(n_tets,)` of the largest face-connected set of tets."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    pairs, _, _ = face_adjacency(tets)
    n = len(tets)
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, labels = connected_components(graph, directed=False)
    return labels == np.argmax(np.bincount(labels))


def surface_topology(tets: np.ndarray) -> dict:
    """Boundary counts of a tet mesh: vertices, edges, faces, non-manifold edges, Euler characteristic."""
    tris = boundary_triangles(tets)
    edges = np.sort(tris[:, [[0, 1], [1, 2], [2, 0]]].reshape(-1, 2), axis=1)
    _, count = np.unique(edges, axis=0, return_counts=True)
    n_v = len(np.unique(tris))
    return {'vertices': n_v, 'edges': len(count), 'faces': len(tris),
            'nonmanifold_edges': int(np.sum(count != 2)),
            'euler': n_v - len(count) + len(tris)}


def is_sphere_surface(tets: np.ndarray) -> bool:
    """Return True if the boundary of connected `tets` is one closed 2-manifold of genus 0 without pinches."""
    topo = surface_topology(tets)
    return topo['nonmanifold_edges'] == 0 and topo['euler'] == 2


def carve(shape: BodyShape, points: np.ndarray, chord_tolerance: float = 0.15,
          fill_rounds: int = 0) -> np.ndarray:
    """
    Delaunay tets `(n_tets, 4)` (positive) inside the body, largest face-connected piece.

    A tet is kept when its centroid is inside and no edge midpoint is outside by more than
    `chord_tolerance` times that edge's length (so tets bridging concave gaps are dropped). Carved tets
    around a boundary edge shared by more than two boundary triangles are put back (`fill_rounds`).
    """
    tets = orient_positive(points, Delaunay(points).simplices.astype(np.int64))
    tets = tets[tet_volumes(points, tets) > 0]
    ends = points[tets[:, TET_EDGES]]                                       # (n, 6, 2, 3)
    mids = 0.5 * (ends[:, :, 0] + ends[:, :, 1])
    length = np.linalg.norm(ends[:, :, 1] - ends[:, :, 0], axis=-1)
    f_mid = body_field(shape, mids.reshape(-1, 3)).reshape(-1, 6)
    keep = (body_field(shape, points[tets].mean(axis=1)) < 0) & np.all(f_mid < chord_tolerance * length, axis=1)
    for _ in range(fill_rounds):
        part = np.flatnonzero(keep)[largest_component(tets[keep])]
        bad = _nonmanifold_edges(tets[part])
        if len(bad) == 0:
            break
        has = np.zeros(len(tets), bool)
        for a, b in bad:
            has |= np.any(tets == a, axis=1) & np.any(tets == b, axis=1)
        keep |= has
    return tets[np.flatnonzero(keep)[largest_component(tets[keep])]]


def _nonmanifold_edges(tets: np.ndarray) -> np.ndarray:
    """Boundary edges `(n, 2)` not shared by exactly two boundary triangles."""
    tris = boundary_triangles(tets)
    edges = np.sort(tris[:, [[0, 1], [1, 2], [2, 0]]].reshape(-1, 2), axis=1)
    uniq, count = np.unique(edges, axis=0, return_counts=True)
    return uniq[count != 2]


def _peelable(tets: np.ndarray, candidates: np.ndarray) -> np.ndarray:
    """Mask over `candidates` (tet indices) whose removal keeps the boundary a 2-manifold."""
    _, _, (bt, bf) = face_adjacency(tets)
    n_bface = np.bincount(bt, minlength=len(tets))
    bface = np.zeros((len(tets), 4), bool)
    bface[bt, bf] = True
    on_boundary = np.zeros(tets.max() + 1, bool)
    on_boundary[tets[bt[:, None], TET_FACES[bf]].ravel()] = True
    tris = tets[bt[:, None], TET_FACES[bf]]
    bedges = set(map(tuple, np.sort(tris[:, [[0, 1], [1, 2], [2, 0]]].reshape(-1, 2), axis=1).tolist()))
    ok = np.zeros(len(candidates), bool)
    for i, t in enumerate(candidates):
        nb = n_bface[t]
        if nb == 1:
            ok[i] = not on_boundary[tets[t, np.flatnonzero(bface[t])[0]]]
        elif nb == 2:
            opp = tets[t, np.flatnonzero(bface[t])]   # the two vertices opposite the boundary faces
            ok[i] = tuple(sorted(opp.tolist())) not in bedges
        elif nb == 3:
            ok[i] = True
    return ok


def peel_boundary_slivers(points: np.ndarray, tets: np.ndarray, threshold: float,
                          rounds: int = 8) -> np.ndarray:
    """Tets with boundary slivers (min dihedral < `threshold` rad) removed where the surface stays manifold."""
    for _ in range(rounds):
        _, _, (bt, _) = face_adjacency(tets)
        bad = np.unique(bt[dihedral_angles(points, tets[bt]).min(axis=1) < threshold])
        if len(bad) == 0:
            break
        bad = bad[_peelable(tets, bad)]
        if len(bad) == 0:
            break
        # peel one sliver per node neighbourhood per round so the manifold test stays valid
        used = np.zeros(len(points), bool)
        take = []
        for t in bad:
            if not used[tets[t]].any():
                take.append(t)
                used[tets[t]] = True
        keep = np.ones(len(tets), bool)
        keep[take] = False
        tets = tets[keep]
        tets = tets[largest_component(tets)]
    return tets


def _coords_quality(coords: np.ndarray) -> np.ndarray:
    """Quality `(m,)` rad (see `tet_quality`) of tets given by vertex coordinates `(m, 4, 3)`."""
    m = len(coords)
    idx = np.arange(4 * m).reshape(m, 4)
    flat = coords.reshape(-1, 3)
    angles = dihedral_angles(flat, idx)
    q = np.minimum(angles, np.pi - angles).min(axis=1)
    return np.where(tet_volumes(flat, idx) > 0, q, -1.0)


def tet_quality(points: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """
    Angle `(n_tets,)` rad by which each tet's dihedral angles stay off 0 and pi; -1 if not positive.

    Small for slivers, caps and wedges alike (a tet with quality q has all dihedral angles in [q, pi - q]).
    """
    return _coords_quality(points[tets])


def _replace_if_better(points: np.ndarray, tets: np.ndarray, old: np.ndarray, new: list) -> np.ndarray | None:
    """`tets` with tets `old` replaced by `new` if these fill the same volume with a better worst angle."""
    new = orient_positive(points, np.array(new, dtype=np.int64))
    q_new = tet_quality(points, new)
    v_old, v_new = tet_volumes(points, tets[old]), tet_volumes(points, new)
    if q_new.min() <= 0.0 or abs(v_new.sum() - v_old.sum()) > 1e-9 * v_old.sum():
        return None
    if q_new.min() <= tet_quality(points, tets[old]).min() + 1e-9:
        return None
    keep = np.ones(len(tets), bool)
    keep[old] = False
    return np.vstack([tets[keep], new])


def _flip_32(points: np.ndarray, tets: np.ndarray, i: int) -> np.ndarray | None:
    """3-2 flip of an edge of tet i that is surrounded by exactly three tets, if that improves them."""
    for a, b in TET_EDGES:
        u, v = tets[i, a], tets[i, b]
        around = np.flatnonzero(np.any(tets == u, axis=1) & np.any(tets == v, axis=1))
        if len(around) != 3:
            continue
        ring = sorted(set(tets[around].ravel().tolist()) - {u, v})
        if len(ring) == 3:  # a closed ring of three tets: an interior edge
            out = _replace_if_better(points, tets, around, [ring + [u], ring + [v]])
            if out is not None:
                return out
    return None


def _flip_23(points: np.ndarray, tets: np.ndarray, i: int) -> np.ndarray | None:
    """2-3 flip of an interior face of tet i (its two tets become three around a new edge), if better."""
    for f in TET_FACES:
        face = tets[i, f]
        nb = np.flatnonzero(np.isin(tets, face).sum(axis=1) == 3)
        nb = nb[nb != i]
        if len(nb) != 1:
            continue
        d = int(np.setdiff1d(tets[i], face)[0])
        e = int(np.setdiff1d(tets[nb[0]], face)[0])
        a, b, c = face.tolist()
        out = _replace_if_better(points, tets, np.array([i, nb[0]]), [[d, e, a, b], [d, e, b, c], [d, e, c, a]])
        if out is not None:
            return out
    return None


def flip_bad_tets(points: np.ndarray, tets: np.ndarray, threshold: float) -> tuple:
    """
    (tets, flips done): 3-2 and 2-3 flips around tets below `threshold` rad that raise the local worst angle.

    Flips keep the boundary triangles, so the surface is unchanged.
    """
    q = tet_quality(points, tets)
    order = np.argsort(q)
    done = 0
    for bad in np.sort(tets[order[q[order] < threshold]], axis=1):
        hit = np.flatnonzero(np.all(np.sort(tets, axis=1) == bad, axis=1))
        if len(hit) == 0:  # already replaced by an earlier flip
            continue
        out = _flip_32(points, tets, hit[0])
        if out is None:
            out = _flip_23(points, tets, hit[0])
        if out is not None:
            tets, done = out, done + 1
    return tets, done


def smooth_bad_nodes(shape: BodyShape, points: np.ndarray, tets: np.ndarray, sliding: np.ndarray,
                     threshold: float, rng: np.random.Generator, n_trials: int = 32,
                     step: float = 0.25) -> tuple:
    """
    Return (points, nodes moved) after moving the nodes of the tets below `threshold` rad.

    Each node of a tet below `threshold` rad goes to the best of `n_trials` random positions (~`step` x its shortest
    edge away) if that raises the worst quality of its tets.

    Boundary nodes slide on the body surface if `sliding` `(n_nodes,)` marks them, else stay; interior nodes
    stay inside the body.
    """
    points = points.copy()
    on_boundary = np.zeros(len(points), bool)
    on_boundary[boundary_triangles(tets).ravel()] = True
    nodes = np.unique(tets[tet_quality(points, tets) < threshold])
    nodes = nodes[sliding[nodes] | ~on_boundary[nodes]]
    ends = tets[:, TET_EDGES].reshape(-1, 2)
    edge_len = np.linalg.norm(points[ends[:, 1]] - points[ends[:, 0]], axis=1)
    shortest = np.full(len(points), np.inf)
    np.minimum.at(shortest, ends.ravel(), np.repeat(edge_len, 2))
    length = shortest[nodes]
    trials = points[nodes, None] + rng.normal(size=(len(nodes), n_trials, 3)) * (step * length[:, None, None])
    surf = on_boundary[nodes]
    trials[surf] = project_to_surface(shape, trials[surf].reshape(-1, 3)).reshape(-1, n_trials, 3)
    inner = trials[~surf]
    outside = body_field(shape, inner.reshape(-1, 3)).reshape(-1, n_trials) > -0.05 * length[~surf, None]
    inner[outside] = points[nodes[~surf]][:, None].repeat(n_trials, axis=1)[outside]  # no move
    trials[~surf] = inner
    moved = 0
    for v, trial in zip(nodes, trials):
        star = tets[np.any(tets == v, axis=1)]
        coords = np.repeat(points[star][None], n_trials, axis=0)
        coords[:, star == v] = trial[:, None, :]
        q = _coords_quality(coords.reshape(-1, 4, 3)).reshape(n_trials, len(star)).min(axis=1)
        best = int(np.argmax(q))
        if q[best] > tet_quality(points, star).min() + 1e-6:
            points[v] = trial[best]
            moved += 1
    return points, moved


def improve_mesh(shape: BodyShape, points: np.ndarray, tets: np.ndarray, sliding: np.ndarray,
                 threshold: float, rounds: int, peel_threshold: float, seed: int = 0) -> tuple:
    """
    Return the improved (points, tets) after rounds of sliver peeling, flips and node smoothing.

    Boundary slivers (least dihedral < `peel_threshold` rad) are peeled, then flips and smoothing run until every
    tet's `tet_quality` reaches `threshold` rad (or `rounds` are done).

    Flips and moves keep the surface closed and its nodes on the body surface (`sliding` nodes slide on it).
    """
    rng = np.random.default_rng(seed)
    for _ in range(rounds):
        tets = peel_boundary_slivers(points, tets, peel_threshold)
        tets, _ = flip_bad_tets(points, tets, threshold)
        points, _ = smooth_bad_nodes(shape, points, tets, sliding, threshold, rng)
        if tet_quality(points, tets).min() >= threshold:
            break
    return points, tets


@dataclass(frozen=True)
class TetMesh:
    """Nodes `(n_nodes, 3)` m, tets `(n_tets, 4)` positive, node part codes `(n_nodes,)`, surface-sample flags."""

    points: np.ndarray
    tets: np.ndarray
    part: np.ndarray
    sampled_surface: np.ndarray
    iterations: int


def _jitter(shape: BodyShape, samples: Samples, points: np.ndarray, idx: np.ndarray, amplitude: float,
            rng: np.random.Generator) -> np.ndarray:
    """Copy of `points` with nodes `idx` moved randomly by ~amplitude*spacing (surface ones re-projected)."""
    points = points.copy()
    points[idx] += rng.normal(size=(len(idx), 3)) * (amplitude * samples.spacing[idx, None])
    surf = idx[samples.surface[idx]]
    points[surf] = project_to_surface(shape, points[surf])
    inner = idx[~samples.surface[idx]]
    out = body_field(shape, points[inner]) > -0.1 * samples.spacing[inner]
    points[inner[out]] = samples.points[inner[out]]
    return points


def _sliver_score(points: np.ndarray, tets: np.ndarray, n_nodes: int, threshold: float) -> tuple:
    """(score, per-tet min dihedral): lost nodes, surface defects, sliver deficit; lower is better."""
    worst = dihedral_angles(points, tets).min(axis=1)
    lost = n_nodes - len(np.unique(tets))
    deficit = float(np.sum(np.maximum(threshold - worst, 0.0) ** 2))
    topo = surface_topology(tets)
    return (lost, topo['nonmanifold_edges'] + abs(topo['euler'] - 2), deficit), worst


def nonmanifold_edge_nodes(tets: np.ndarray) -> np.ndarray:
    """Nodes of boundary edges not shared by exactly two boundary triangles."""
    return np.unique(_nonmanifold_edges(tets))


def tetrahedralize(shape: BodyShape, samples: Samples, chord_tolerance: float = 0.15, fill_rounds: int = 0,
                   threshold_deg: float = 10.0,
                   max_iterations: int = 25, seed: int = 0, improve_rounds: int = 0,
                   improve_deg: float = 12.0) -> TetMesh:
    """
    Carved Delaunay mesh of the sampled nodes with slivers repaired by peeling and perturbation.

    With `improve_rounds` > 0 the perturbation only repairs the topology (no node lost, closed genus-0
    surface) and `improve_mesh` then raises every tet's least dihedral angle towards `improve_deg`.
    """
    rng = np.random.default_rng(seed)
    thr = np.radians(threshold_deg)
    n = len(samples.points)
    points = samples.points.copy()

    def attempt(pts: np.ndarray) -> tuple:
        tets = peel_boundary_slivers(pts, carve(shape, pts, chord_tolerance, fill_rounds), thr)
        score, worst = _sliver_score(pts, tets, n, thr)
        return tets, score, worst

    tets, score, worst = attempt(points)
    it = 0
    for it in range(1, max_iterations + 1):
        bad = np.unique(tets[worst < thr])
        if score[:2] == (0, 0) if improve_rounds > 0 else (len(bad) == 0 and score[0] == 0):
            break

        if len(bad) == 0:
            bad = np.arange(n)
        trial = _jitter(shape, samples, points, bad, 0.15, rng)
        t2, s2, w2 = attempt(trial)
        if s2 < score:
            points, tets, score, worst = trial, t2, s2, w2
    if improve_rounds > 0:
        points, tets = improve_mesh(shape, points, tets, samples.surface, np.radians(improve_deg),
                                    improve_rounds, thr, seed)
    used = np.unique(tets)
    remap = np.full(n, -1, np.int64)
    remap[used] = np.arange(len(used))
    return TetMesh(points=points[used], tets=remap[tets], part=samples.part[used],
                   sampled_surface=samples.surface[used], iterations=it)
