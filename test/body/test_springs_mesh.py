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

"""Springs on a hand-made mesh, tet quality measures, flips and smoothing, topology helpers, the body shape."""
import numpy as np
import pytest

from iguana_ros.body.mesh import (boundary_triangles, dihedral_angles, flip_bad_tets, improve_mesh,
                                  orient_positive, radius_ratios, smooth_bad_nodes, surface_topology,
                                  tet_quality, tet_volumes)
from iguana_ros.body.shape import (body_field, iguana_shape, limb_field, main_field, project_to_surface, smooth_min,
                                   SMOOTH_UNION)
from iguana_ros.body.springs import spring_lengths, tet_springs

# three tets fanned around edge (0, 1): A=(0,1,2,3), B=(0,1,3,4), C=(0,1,4,5); A|B share (0,1,3), B|C (0,1,4)
FAN_POINTS = np.array([[0, 0, 0], [0, 0, 1], [1, 0, 0], [0.5, 0.9, 0], [-0.5, 0.9, 0], [-1, 0, 0]], float)
FAN_TETS = np.array([[0, 1, 2, 3], [0, 1, 3, 4], [0, 1, 4, 5]])
FAN_SPRINGS = {(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3),   # tet A
               (0, 4), (1, 4), (3, 4),                            # tet B (new pairs)
               (0, 5), (1, 5), (4, 5),                            # tet C (new pairs)
               (2, 4),                                            # opposite vertices of A|B
               (3, 5)}                                            # opposite vertices of B|C


def test_spring_set_on_hand_made_mesh():
    springs = tet_springs(FAN_TETS)
    assert set(map(tuple, springs.tolist())) == FAN_SPRINGS
    assert len(springs) == len(FAN_SPRINGS)
    assert np.array_equal(springs, np.array(sorted(FAN_SPRINGS)))  # deterministic lexicographic order
    # the tet order in the input does not change the result
    assert np.array_equal(tet_springs(FAN_TETS[::-1, [1, 0, 3, 2]]), springs)


def test_two_separate_tets_get_only_their_edges():
    springs = tet_springs(np.array([[0, 1, 2, 3], [4, 5, 6, 7]]))
    assert len(springs) == 12


def test_spring_lengths():
    springs = np.array([[0, 1], [0, 2], [3, 5]])
    assert np.allclose(spring_lengths(FAN_POINTS, springs), [1.0, 1.0, np.hypot(1.5, 0.9)])


def test_quality_of_regular_and_flat_tets():
    regular = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], float)
    t = orient_positive(regular, np.array([[0, 1, 2, 3]]))
    assert tet_volumes(regular, t)[0] == pytest.approx(8 / 3)
    assert np.allclose(np.degrees(dihedral_angles(regular, t)), np.degrees(np.arccos(1 / 3)))
    assert radius_ratios(regular, t)[0] == pytest.approx(1.0)
    sliver = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 1e-3]], float)
    s = orient_positive(sliver, np.array([[0, 1, 2, 3]]))
    assert dihedral_angles(sliver, s).min() < np.radians(1)
    assert radius_ratios(sliver, s)[0] < 0.01


def test_boundary_of_fan_is_closed_sphere_and_outward():
    tets = orient_positive(FAN_POINTS, FAN_TETS)
    tris = boundary_triangles(tets)
    assert len(tris) == 3 * 4 - 2 * 2
    topo = surface_topology(tets)
    assert topo['nonmanifold_edges'] == 0 and topo['euler'] == 2
    p = FAN_POINTS[tris]
    enclosed = np.einsum('nk,nk->n', p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6.0
    assert enclosed == pytest.approx(tet_volumes(FAN_POINTS, tets).sum())


def test_body_field_matches_reference_and_marks_inside():
    shape = iguana_shape()
    rng = np.random.default_rng(3)
    p = rng.uniform([-0.6, -0.2, -0.01], [0.35, 0.2, 0.15], (3000, 3))
    ref = main_field(shape, p)
    for limb in shape.limbs:
        ref = smooth_min(ref, limb_field(limb, p), SMOOTH_UNION)
    ref = np.maximum(ref, -p[:, 2])
    assert np.allclose(body_field(shape, p), ref, atol=1e-12)
    inside = np.array([[0.1, 0.0, 0.08], [-0.3, 0.0, 0.067], [0.25, 0.0, 0.085], [0.19, 0.09, 0.04]])
    outside = np.array([[0.1, 0.0, 0.2], [0.1, 0.0, 0.01], [0.0, 0.3, 0.05], [-0.6, 0, 0.06]])
    assert np.all(body_field(shape, inside) < 0) and np.all(body_field(shape, outside) > 0)


def test_project_to_surface_lands_on_zero_level():
    shape = iguana_shape()
    p = np.array([[0.1, 0.0, 0.2], [0.1, 0.02, 0.08], [-0.2, 0.05, 0.07], [0.22, 0.1, 0.02]])
    q = project_to_surface(shape, p, iterations=12)
    assert np.all(np.abs(body_field(shape, q)) < 2e-4)


def _bipyramid(h: float) -> np.ndarray:
    """Unit-circumradius triangle (nodes 0-2) in z = 0 with apexes 3 (z = h) and 4 (z = -h)."""
    tri = [[1, 0, 0], [-0.5, np.sqrt(3) / 2, 0], [-0.5, -np.sqrt(3) / 2, 0]]
    return np.array(tri + [[0, 0, h], [0, 0, -h]], float)


def _surface_set(tets: np.ndarray) -> set:
    return {tuple(sorted(t)) for t in boundary_triangles(tets).tolist()}


@pytest.mark.parametrize('h, n_before, n_after', [(0.2, 2, 3), (1.5, 3, 2)])
def test_flips_replace_worse_tets_and_keep_the_boundary(h, n_before, n_after):
    p = _bipyramid(h)
    two = orient_positive(p, np.array([[0, 1, 2, 3], [0, 1, 2, 4]]))
    three = orient_positive(p, np.array([[3, 4, 0, 1], [3, 4, 1, 2], [3, 4, 2, 0]]))
    before, after = (two, three) if n_before == 2 else (three, two)
    q_before, q_after = tet_quality(p, before).min(), tet_quality(p, after).min()
    assert q_after > q_before  # h = 0.2: 21.8 -> 43.6 deg (2-3); h = 1.5: 34.8 -> 69.5 deg (3-2)
    flipped, done = flip_bad_tets(p, before, threshold=q_before + 1e-3)
    assert done == 1 and len(flipped) == n_after
    assert tet_quality(p, flipped).min() == pytest.approx(q_after)
    assert tet_volumes(p, flipped).sum() == pytest.approx(tet_volumes(p, before).sum())
    assert _surface_set(flipped) == _surface_set(before)
    # nothing below the threshold: nothing flipped
    assert flip_bad_tets(p, before, threshold=q_before - 1e-3)[1] == 0


def _star_in_trunk(offset: np.ndarray) -> tuple:
    """Octahedron of six fixed nodes (1 cm) around a free centre node moved by `offset`, inside the trunk."""
    c = np.array([0.1, 0.0, 0.08])
    axes = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)
    p = np.vstack([c + offset, c + 0.01 * axes])
    tets = [[0, 1 + i, 3 + j, 5 + k] for i in (0, 1) for j in (0, 1) for k in (0, 1)]
    return p, orient_positive(p, np.array(tets))


def test_smoothing_moves_a_free_node_out_of_a_flat_star():
    p, tets = _star_in_trunk(np.array([0.0096, 0.0, 0.0]))  # centre almost on the +x vertex: caps
    shape = iguana_shape()
    sliding = np.zeros(len(p), bool)
    q0 = tet_quality(p, tets).min()
    assert np.degrees(q0) < 5
    moved, n = smooth_bad_nodes(shape, p, tets, sliding, np.radians(40), np.random.default_rng(0))
    assert n == 1 and np.array_equal(moved[1:], p[1:])  # only the free centre moves
    assert tet_quality(moved, tets).min() > q0
    better, _ = improve_mesh(shape, p, tets, sliding, np.radians(52), rounds=40, peel_threshold=0.0)
    assert np.degrees(tet_quality(better, tets).min()) > 50  # the centred star: 90 and 54.7 deg
    assert np.linalg.norm(better[0] - p[1:].mean(axis=0)) < 2e-3
    assert tet_volumes(better, tets).sum() == pytest.approx(tet_volumes(p, tets).sum())
