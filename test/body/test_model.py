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

"""The tetrahedral iguana model: mass, size, volumes, connectivity, surface, springs, skin weights, tags."""
import numpy as np
import pytest

from iguana_ros.body.markers import marker_positions
from iguana_ros.body.mesh import face_adjacency, surface_topology, tet_volumes
from iguana_ros.body.model import build_model, IguanaModel
from iguana_ros.body.shape import body_field, iguana_shape
from iguana_ros.body.springs import tet_springs
from iguana_ros.body.stiffness import stiffness_preset
from iguana_ros.constants import BODY_LENGTH, BODY_MASS
from iguana_ros.errors import InputError

REQUIRED_TAGS = ('foot_fl', 'foot_fr', 'foot_hl', 'foot_hr', 'feet', 'tail', 'trunk_left', 'trunk_right',
                 'head', 'legs')


MIN_DIHEDRAL_DEG = 8.0
"""Every resolution's worst tet keeps all dihedral angles above this (no slivers)."""


@pytest.fixture(scope='module', params=['coarse', 'medium', 'fine'])
def model(request, tmp_path_factory):
    return build_model(request.param)


def test_mass_sums_to_body_mass(model):
    assert model.node_mass.sum() == pytest.approx(BODY_MASS, rel=1e-12)
    assert np.all(model.node_mass > 0)


def test_surface_nodes_lie_on_the_body_surface(model):
    surface = model.rest_positions[np.unique(model.surface_triangles)]
    f = body_field(iguana_shape(), surface)
    assert np.all(f < 1e-6)                     # none outside the body
    assert np.mean(np.abs(f) < 1e-4) > 0.94     # nearly all on it (a few carved-open interior nodes)


def test_bounding_length(model):
    x = model.rest_positions[:, 0]
    assert x.max() - x.min() == pytest.approx(BODY_LENGTH, abs=0.01)


def test_rest_pose_stands_on_the_ground(model):
    z = model.rest_positions[:, 2]
    assert z.min() >= 0.0
    assert z.min() < 1e-4
    assert np.all(model.rest_positions[model.node_tags['feet'], 2] < 4e-3)


def test_every_tet_has_positive_volume_and_no_sliver(model):
    assert np.all(tet_volumes(model.rest_positions, model.tets) > 0)
    assert model.summary()['min_dihedral_deg'] >= MIN_DIHEDRAL_DEG
    assert model.summary()['max_dihedral_deg'] < 180.0 - MIN_DIHEDRAL_DEG


def test_node_counts_near_the_named_sizes(model):
    target = {'coarse': 150, 'medium': 400, 'fine': 1200}[model.resolution]
    assert 0.8 * target < model.n_nodes < 1.2 * target


def test_mesh_is_one_connected_piece_using_every_node(model):
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    pairs, _, _ = face_adjacency(model.tets)
    n = len(model.tets)
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    assert connected_components(graph, directed=False)[0] == 1
    assert np.array_equal(np.unique(model.tets), np.arange(model.n_nodes))


def test_surface_is_closed_and_outward(model):
    tris = model.surface_triangles
    # closed: every directed edge appears once and its reverse once (consistent orientation)
    directed = tris[:, [[0, 1], [1, 2], [2, 0]]].reshape(-1, 2)
    as_set = set(map(tuple, directed.tolist()))
    assert len(as_set) == len(directed)
    assert all((b, a) in as_set for a, b in as_set)
    topo = surface_topology(model.tets)
    assert topo['nonmanifold_edges'] == 0 and topo['euler'] == 2
    # outward: the enclosed volume by the divergence theorem is positive and equals the tets' volume
    p = model.rest_positions[tris]
    enclosed = np.einsum('nk,nk->n', p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6.0
    assert enclosed == pytest.approx(tet_volumes(model.rest_positions, model.tets).sum(), rel=1e-9)
    # and each triangle's normal points away from the body (field grows along it)
    centroid = p.mean(axis=1)
    normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    shape = iguana_shape()
    step = 1e-3
    assert np.mean(body_field(shape, centroid + step * normal) > body_field(shape, centroid - step * normal)) > 0.9


def test_springs_are_unique_sorted_and_positive(model):
    s = model.springs
    assert s.dtype == np.int64 and np.all(s[:, 0] < s[:, 1])
    assert len(np.unique(s, axis=0)) == len(s)
    assert np.array_equal(s, tet_springs(model.tets))
    length = np.linalg.norm(model.rest_positions[s[:, 1]] - model.rest_positions[s[:, 0]], axis=1)
    assert np.allclose(model.spring_rest_lengths, length)
    assert np.all(model.spring_stiffness > 0)


def test_legs_are_stiffer_than_body(model):
    legs = model.node_tags['legs']
    both = legs[model.springs].all(axis=1)
    none = ~legs[model.springs].any(axis=1)
    per_strain = model.spring_stiffness * model.spring_rest_lengths
    factor = stiffness_preset(model.stiffness).leg_factor
    assert factor > 1.0
    assert np.median(per_strain[both]) == pytest.approx(factor * np.median(per_strain[none]), rel=1e-6)


def test_skin_weights_nonnegative_and_normalised(model):
    w, b = model.skin_weights, model.skin_bones
    assert w.shape == b.shape and w.shape[1] <= 4
    assert np.all(w >= 0) and np.allclose(w.sum(axis=1), 1.0)
    assert b.min() >= 0 and b.max() < model.skeleton.n_bones


def test_leg_and_tail_nodes_bind_to_their_own_bones(model):
    names = np.array(model.skeleton.names)
    heavy = model.skin_bones[np.arange(model.n_nodes), np.argmax(model.skin_weights, axis=1)]
    tail_bones = np.char.startswith(names[heavy[model.node_tags['tail']]], 'tail_')
    assert tail_bones.mean() > 0.9
    sole = model.node_tags['foot_hl']
    assert set(names[heavy[sole]]) <= {'foot_hl', 'ankle_hl', 'knee_hl'}
    assert np.all(np.char.endswith(names[model.skin_bones[sole]], '_hl'))


def test_tags(model):
    tags = model.node_tags
    for key in REQUIRED_TAGS:
        assert tags[key].shape == (model.n_nodes,) and tags[key].dtype == bool
    for foot in REQUIRED_TAGS[:4]:
        assert tags[foot].sum() >= 2
        assert np.all(tags['legs'][tags[foot]])
    assert np.array_equal(tags['feet'], tags['foot_fl'] | tags['foot_fr'] | tags['foot_hl'] | tags['foot_hr'])
    p = model.rest_positions
    assert np.all(p[tags['trunk_left'], 1] > 0) and np.all(p[tags['trunk_right'], 1] < 0)
    assert tags['trunk_left'].sum() >= 4 and tags['trunk_right'].sum() >= 4
    assert np.all(p[tags['tail'], 0] < p[tags['head'], 0].min())
    assert not np.any(tags['head'] & tags['tail'])


def test_markers_lie_on_the_body_surface(model):
    sk = model.skeleton
    root, local = sk.rest_pose()
    markers = marker_positions(sk, model.markers, root, local)
    assert np.all(np.abs(body_field(iguana_shape(), markers)) < 1.5e-3)
    # every marker is near the mesh surface too (within a fraction of the local mesh size)
    surf = model.rest_positions[np.unique(model.surface_triangles)]
    nearest = np.min(np.linalg.norm(markers[:, None] - surf[None], axis=-1), axis=1)
    assert np.all(nearest < 0.04)


def test_arrays_are_read_only_and_model_is_frozen(model):
    assert isinstance(model, IguanaModel)
    with pytest.raises(ValueError):
        model.rest_positions[0, 0] = 1.0
    with pytest.raises(AttributeError):
        model.resolution = 'x'
    assert model.tets.dtype == np.int64 and model.surface_triangles.dtype == np.int64


def test_unknown_names_raise_input_error():
    with pytest.raises(InputError, match='coarse, medium, fine'):
        build_model('huge')
    with pytest.raises(InputError, match='normal, softer'):
        build_model('coarse', 'rubber')


def test_softer_preset_only_changes_stiffness():
    normal, softer = build_model('coarse', 'normal'), build_model('coarse', 'softer')
    assert np.array_equal(normal.springs, softer.springs)
    from iguana_ros.body.stiffness import PRESETS
    ratio = PRESETS['softer'].spring_a / PRESETS['normal'].spring_a
    assert ratio < 1.0
    assert np.allclose(softer.spring_stiffness, ratio * normal.spring_stiffness)
    assert np.all(softer.youngs_modulus < normal.youngs_modulus)


def test_sole_pads_put_every_sole_node_on_the_sole_plane(model):
    """contact_offset is each sole node's rest height (so all touch the ground at z = 0 together), zero elsewhere."""
    sole = model.node_tags['feet']
    offset = model.contact_offset
    assert offset.shape == (model.n_nodes,) and np.all(offset[~sole] == 0.0)
    np.testing.assert_allclose(offset[sole], np.maximum(model.rest_positions[sole, 2], 0.0))
    assert 0.0 < offset.max() < 0.004
