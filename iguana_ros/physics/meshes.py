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
Small procedural soft bodies (a single tetrahedron, a box or beam of tetrahedra) for tests and benchmarks.

`SoftBodyMesh` has the attributes the simulator reads from the iguana model (`iguana_ros.body.model`), so
`SoftBodySimulator` accepts either. Springs follow the paper (Section V): every pair of nodes of each
tetrahedron plus the two opposite nodes of every pair of face-adjacent tetrahedra.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from iguana_ros.errors import InputError

DEFAULT_YOUNGS_MODULUS = 5.0e4
"""Young's modulus (Pa) of the procedural meshes unless given (the order of the iguana `normal` preset)."""

DEFAULT_POISSON_RATIO = 0.35
"""Poisson ratio of the procedural meshes unless given."""

DEFAULT_SPRING_STIFFNESS = 200.0
"""Spring stiffness `a` (N/m) of the procedural meshes unless given."""

_KUHN_TETS = np.array([  # the 6 tets of a unit cube along the 0 -> 7 diagonal; cube corner c = x + 2y + 4z
    [0, 1, 3, 7], [0, 1, 5, 7], [0, 2, 3, 7], [0, 2, 6, 7], [0, 4, 5, 7], [0, 4, 6, 7]])


@dataclass(frozen=True)
class SoftBodyMesh:
    """A tetrahedral soft body with the iguana model's attribute names (arrays in SI units)."""

    rest_positions: np.ndarray          # (n_nodes, 3) m
    tets: np.ndarray                    # (n_tets, 4) int64, positive volume
    node_mass: np.ndarray               # (n_nodes,) kg
    springs: np.ndarray                 # (n_springs, 2) int64, i < j
    spring_rest_lengths: np.ndarray     # (n_springs,) m
    spring_stiffness: np.ndarray        # (n_springs,) N/m
    youngs_modulus: np.ndarray          # (n_tets,) Pa
    poisson_ratio: float
    surface_triangles: np.ndarray       # (n_tris, 3) int64, outward
    node_tags: dict = field(default_factory=dict)  # name -> (n_nodes,) bool
    contact_offset: np.ndarray | None = None       # (n_nodes,) m a node touches the ground early; None = 0


def tet_volumes(positions: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """Signed volumes `(n_tets,)` in m³ of tetrahedra `tets (n_tets, 4)` at `positions (n_nodes, 3)`."""
    p = positions[tets]
    edges = p[:, 1:] - p[:, :1]
    return np.einsum('ij,ij->i', edges[:, 0], np.cross(edges[:, 1], edges[:, 2])) / 6.0


def paper_springs(tets: np.ndarray) -> np.ndarray:
    """
    Return unique node pairs `(n_springs, 2)` (i < j, sorted).

    Tet edges plus opposite nodes of face-adjacent tets.
    """
    tets = np.asarray(tets, dtype=np.int64)
    a, b = np.triu_indices(4, k=1)
    edges = np.stack([tets[:, a], tets[:, b]], axis=-1).reshape(-1, 2)
    faces = np.stack([np.delete(tets, k, axis=1) for k in range(4)], axis=1)      # (n_tets, 4, 3)
    opposite = tets                                                              # node k is opposite face k
    keys = np.sort(faces, axis=-1).reshape(-1, 3)
    _, inverse, counts = np.unique(keys, axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.ravel()
    order = np.argsort(inverse, kind='stable')
    shared = counts[inverse[order]] == 2
    pair_first = order[shared][0::2]
    pair_second = order[shared][1::2]
    cross = np.stack([opposite.ravel()[pair_first], opposite.ravel()[pair_second]], axis=-1)
    pairs = np.sort(np.concatenate([edges, cross]), axis=1)
    return np.unique(pairs, axis=0)


def boundary_triangles(positions: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """Faces `(n_tris, 3)` used by exactly one tet, ordered counter-clockwise seen from outside."""
    local = np.array([[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]])  # outward for positive-volume tets
    faces = tets[:, local].reshape(-1, 3)
    _, inverse, counts = np.unique(np.sort(faces, axis=1), axis=0, return_inverse=True, return_counts=True)
    return faces[counts[inverse.ravel()] == 1]


def lumped_masses(positions: np.ndarray, tets: np.ndarray, total_mass: float) -> np.ndarray:
    """Node masses `(n_nodes,)` kg: a quarter of each tet's volume share, scaled to `total_mass`."""
    vol = np.abs(tet_volumes(positions, tets))
    mass = np.zeros(len(positions))
    np.add.at(mass, tets.ravel(), np.repeat(vol / 4.0, 4))
    return mass * (total_mass / mass.sum())


def mesh_from_tets(positions: np.ndarray, tets: np.ndarray, total_mass: float = 1.0,
                   youngs_modulus: float = DEFAULT_YOUNGS_MODULUS, poisson_ratio: float = DEFAULT_POISSON_RATIO,
                   spring_stiffness: float = DEFAULT_SPRING_STIFFNESS, node_tags: dict | None = None) -> SoftBodyMesh:
    """
    Return a `SoftBodyMesh` with uniform material from nodes `(n, 3)` and tets `(m, 4)`.

    The tets are reoriented to positive volume.
    """
    positions = np.ascontiguousarray(positions, dtype=np.float64)
    tets = np.array(tets, dtype=np.int64)
    vol = tet_volumes(positions, tets)
    if np.any(np.abs(vol) < 1e-15):
        raise InputError('mesh: a tetrahedron has zero volume')
    tets[vol < 0] = tets[vol < 0][:, [0, 2, 1, 3]]
    springs = paper_springs(tets)
    rest_len = np.linalg.norm(positions[springs[:, 1]] - positions[springs[:, 0]], axis=1)
    return SoftBodyMesh(
        rest_positions=positions, tets=tets, node_mass=lumped_masses(positions, tets, total_mass),
        springs=springs, spring_rest_lengths=rest_len, spring_stiffness=np.full(len(springs), spring_stiffness),
        youngs_modulus=np.full(len(tets), float(youngs_modulus)), poisson_ratio=float(poisson_ratio),
        surface_triangles=boundary_triangles(positions, tets), node_tags=dict(node_tags or {}))


def single_tet(edge: float = 0.1, total_mass: float = 0.1, **material) -> SoftBodyMesh:
    """One right-corner tetrahedron with legs of `edge` m along x, y, z from the origin."""
    nodes = np.array([[0, 0, 0], [edge, 0, 0], [0, edge, 0], [0, 0, edge]], dtype=float)
    return mesh_from_tets(nodes, [[0, 1, 2, 3]], total_mass=total_mass, **material)


def box_mesh(size=(0.3, 0.1, 0.1), cells=(3, 1, 1), total_mass: float = 1.0, **material) -> SoftBodyMesh:
    """
    Return a box of `size` (m) split into `cells` cubes of 6 tets each, resting on z = 0, centred on x = y = 0.

    Tags: 'bottom' (z = 0 nodes, also 'feet'), 'top', 'left' (max y), 'right' (min y), 'front' (max x).
    """
    size = np.asarray(size, dtype=float)
    cells = np.asarray(cells, dtype=np.int64)
    if size.shape != (3,) or cells.shape != (3,) or np.any(size <= 0) or np.any(cells < 1):
        raise InputError(f'box_mesh: size must be 3 positive lengths and cells 3 positive counts, got {size}, {cells}')
    counts = cells + 1
    grid = np.stack(np.meshgrid(*[np.linspace(0, s, c) for s, c in zip(size, counts)], indexing='ij'), axis=-1)
    nodes = grid.reshape(-1, 3) - [size[0] / 2, size[1] / 2, 0.0]
    index = np.arange(np.prod(counts)).reshape(tuple(counts))
    ci, cj, ck = np.meshgrid(*[np.arange(c) for c in cells], indexing='ij')
    corners = np.stack([index[ci + dx, cj + dy, ck + dz] for dz in (0, 1) for dy in (0, 1) for dx in (0, 1)],
                       axis=-1).reshape(-1, 8)
    tets = corners[:, _KUHN_TETS].reshape(-1, 4)
    eps = 1e-9
    tags = {'bottom': nodes[:, 2] < eps, 'top': nodes[:, 2] > size[2] - eps,
            'left': nodes[:, 1] > size[1] / 2 - eps, 'right': nodes[:, 1] < -size[1] / 2 + eps,
            'front': nodes[:, 0] > size[0] / 2 - eps}
    tags['feet'] = tags['bottom'].copy()
    return mesh_from_tets(nodes, tets, total_mass=total_mass, node_tags=tags, **material)
