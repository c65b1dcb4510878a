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

"""Dual-quaternion skinning: exact for rigid motions, antipodality-safe, volume-preserving under twist."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from iguana_ros.body.dqs import dual_quaternion_skinning, linear_blend_skinning
from iguana_ros.errors import InputError
from iguana_ros.geometry import quat_from_rotvec, quat_identity

LENGTH, RADIUS = 1.0, 0.1
N_RING, N_STATIONS = 32, 41


def _cylinder():
    """Nodes of a closed cylinder surface along x: rings `(stations, ring)` + 2 cap centres, and triangles."""
    x = np.linspace(0.0, LENGTH, N_STATIONS)
    a = np.linspace(0.0, 2 * np.pi, N_RING, endpoint=False)
    ring = np.stack([np.zeros_like(a), RADIUS * np.cos(a), RADIUS * np.sin(a)], axis=1)
    nodes = (ring[None, :, :] + x[:, None, None] * np.array([1.0, 0, 0])).reshape(-1, 3)
    nodes = np.vstack([nodes, [[0.0, 0, 0], [LENGTH, 0, 0]]])
    tris = []
    for s in range(N_STATIONS - 1):
        for k in range(N_RING):
            a0, a1 = s * N_RING + k, s * N_RING + (k + 1) % N_RING
            b0, b1 = a0 + N_RING, a1 + N_RING
            tris += [(a0, b0, a1), (a1, b0, b1)]
    c0, c1 = len(nodes) - 2, len(nodes) - 1
    last = (N_STATIONS - 1) * N_RING
    for k in range(N_RING):
        tris.append((c0, k, (k + 1) % N_RING))
        tris.append((c1, last + (k + 1) % N_RING, last + k))
    return nodes, np.array(tris)


def _volume(nodes, tris):
    """Enclosed volume of a closed triangle surface (divergence theorem)."""
    p = nodes[tris]
    return abs(np.einsum('ij,ij->i', p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6.0)


def _two_bone_binding(nodes):
    """Bone 0 at the origin, bone 1 at mid-length; weights blend linearly over the middle 40 %."""
    t = np.clip((nodes[:, 0] / LENGTH - 0.3) / 0.4, 0.0, 1.0)
    bones = np.tile([0, 1], (len(nodes), 1))
    weights = np.stack([1.0 - t, t], axis=1)
    rest = (quat_identity((2,)), np.array([[0.0, 0, 0], [0.5 * LENGTH, 0, 0]]))
    return bones, weights, rest


def test_rigid_transform_is_reproduced_exactly():
    rng = np.random.default_rng(0)
    nodes = rng.normal(size=(200, 3))
    n_bones = 5
    rest = (Rotation.random(n_bones, random_state=1).as_quat(), rng.normal(size=(n_bones, 3)))
    bones = rng.integers(0, n_bones, size=(200, 3))
    weights = rng.dirichlet(np.ones(3), size=200)
    q = Rotation.random(random_state=2)
    t = np.array([0.3, -1.2, 0.7])
    pose = ((q * Rotation.from_quat(rest[0])).as_quat(), q.apply(rest[1]) + t)
    pose[0][::2] *= -1.0  # q and -q are the same rotation: antipodality must not matter
    expected = q.apply(nodes) + t
    for skin in (dual_quaternion_skinning, linear_blend_skinning):
        np.testing.assert_allclose(skin(nodes, bones, weights, rest, pose), expected, atol=1e-12)


def test_single_bone_nodes_follow_their_bone_and_rest_pose_is_identity():
    nodes, _ = _cylinder()
    bones, weights, rest = _two_bone_binding(nodes)
    out = dual_quaternion_skinning(nodes, bones, weights, rest, rest)
    np.testing.assert_allclose(out, nodes, atol=1e-14)
    q1 = quat_from_rotvec(np.array([0.0, 0.0, 0.5]))
    pose = (np.stack([quat_identity(), q1]), rest[1])
    out = dual_quaternion_skinning(nodes, bones, weights, rest, pose)
    far = weights[:, 1] == 1.0
    expected = Rotation.from_quat(q1).apply(nodes[far] - rest[1][1]) + rest[1][1]
    np.testing.assert_allclose(out[far], expected, atol=1e-12)
    np.testing.assert_allclose(out[weights[:, 0] == 1.0], nodes[weights[:, 0] == 1.0], atol=1e-14)


def test_twist_keeps_volume_better_than_linear_blending():
    nodes, tris = _cylinder()
    bones, weights, rest = _two_bone_binding(nodes)
    twist = np.stack([quat_identity(), quat_from_rotvec(np.array([0.5 * np.pi, 0.0, 0.0]))])
    pose = (twist, rest[1])
    v0 = _volume(nodes, tris)
    dqs = dual_quaternion_skinning(nodes, bones, weights, rest, pose)
    lbs = linear_blend_skinning(nodes, bones, weights, rest, pose)
    v_dqs, v_lbs = _volume(dqs, tris) / v0, _volume(lbs, tris) / v0
    assert abs(v_dqs - 1.0) < 0.005
    assert v_lbs < 0.95 and abs(v_dqs - 1.0) < 0.1 * abs(v_lbs - 1.0)
    # mid-section (equal weights): LBS shrinks the radius to r cos(45 deg), DQS keeps it
    mid = np.isclose(nodes[:, 0], 0.5 * LENGTH) & (np.linalg.norm(nodes[:, 1:], axis=1) > 0)
    r_dqs = np.linalg.norm(dqs[mid, 1:], axis=1)
    r_lbs = np.linalg.norm(lbs[mid, 1:], axis=1)
    np.testing.assert_allclose(r_dqs, RADIUS, atol=1e-12)
    np.testing.assert_allclose(r_lbs, RADIUS * np.cos(np.pi / 4), atol=1e-12)


def test_bad_binding_raises_input_error():
    nodes = np.zeros((4, 3))
    rest = (quat_identity((2,)), np.zeros((2, 3)))
    with pytest.raises(InputError, match='skin_bones'):
        dual_quaternion_skinning(nodes, np.zeros((4, 2), int), np.ones((3, 2)), rest, rest)
    with pytest.raises(InputError, match='index'):
        dual_quaternion_skinning(nodes, np.full((4, 1), 2), np.ones((4, 1)), rest, rest)
    with pytest.raises(InputError, match='zero total skin weight'):
        dual_quaternion_skinning(nodes, np.zeros((4, 1), int), np.zeros((4, 1)), rest, rest)
