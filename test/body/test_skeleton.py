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

"""Skeleton proportions, forward kinematics and the 15-marker set."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from iguana_ros.body.markers import iguana_markers, marker_positions
from iguana_ros.body.skeleton import forward_kinematics, iguana_skeleton, rest_joint_positions
from iguana_ros.constants import BODY_LENGTH, N_MARKERS
from iguana_ros.geometry import quat_from_rotvec, quat_identity


@pytest.fixture(scope='module')
def skel():
    return iguana_skeleton()


def test_chains_and_proportions(skel):
    names = skel.names
    assert sum(n.startswith('spine_') for n in names) >= 5
    assert sum(n.startswith('tail_') and n != 'tail_tip' for n in names) >= 6
    for leg in ('fl', 'fr', 'hl', 'hr'):
        assert f'foot_{leg}' in names
    p = rest_joint_positions(skel)
    length = p[skel.index('snout'), 0] - p[skel.index('tail_tip'), 0]
    assert length == pytest.approx(BODY_LENGTH, abs=1e-9)
    tail = p[skel.index('pelvis'), 0] - p[skel.index('tail_tip'), 0]
    assert 0.6 < tail / BODY_LENGTH < 0.7
    feet = p[skel.indices(['foot_fl', 'foot_fr', 'foot_hl', 'foot_hr']), 2]
    assert np.all(feet < 0.01) and np.all(feet >= 0.0)


def test_parents_precede_children_and_limits_ordered(skel):
    assert skel.parents[0] == -1
    assert all(p < i for i, p in enumerate(skel.parents) if i)
    assert np.all(skel.limits[..., 0] <= skel.limits[..., 1])


def test_fk_vectorised_matches_single_frame_and_rigid_root(skel):
    rng = np.random.default_rng(0)
    rv = rng.normal(scale=0.2, size=(4, skel.n_bones, 3))
    local = quat_from_rotvec(rv)
    root = rng.normal(size=(4, 3))
    pos, rot = forward_kinematics(skel, root, local)
    for f in range(4):
        p1, r1 = forward_kinematics(skel, root[f], local[f])
        assert np.allclose(p1, pos[f]) and np.allclose(r1, rot[f])
    # rotating only the root moves every joint rigidly about the root
    q = Rotation.from_euler('z', 40, degrees=True)
    local = quat_identity((skel.n_bones,))
    local[0] = q.as_quat()
    p_rot, _ = forward_kinematics(skel, np.zeros(3), local)
    p_rest, _ = forward_kinematics(skel, np.zeros(3), quat_identity((skel.n_bones,)))
    assert np.allclose(p_rot, q.apply(p_rest))


def test_bone_lengths_are_pose_invariant(skel):
    local = quat_from_rotvec(np.random.default_rng(1).normal(scale=0.5, size=(skel.n_bones, 3)))
    pos, _ = forward_kinematics(skel, np.zeros(3), local)
    lengths = np.linalg.norm(pos[1:] - pos[skel.parents[1:]], axis=1)
    assert np.allclose(lengths, np.linalg.norm(skel.offsets[1:], axis=1))


def test_markers_sit_where_defined_in_rest_pose(skel):
    markers = iguana_markers()
    assert len(markers.labels) == N_MARKERS == len(set(markers.labels))
    kinds = [lab.split('_')[0] for lab in markers.labels]
    assert kinds.count('FOOT') == 4 and kinds.count('TAIL') == 3 and kinds.count('HEAD') == 1
    assert len(kinds) - 8 == 7
    root, local = skel.rest_pose()
    got = marker_positions(skel, markers, root, local)
    joints = rest_joint_positions(skel)
    assert np.allclose(got, joints[markers.bones] + markers.offsets)


def test_unknown_bone_names_the_bones(skel):
    with pytest.raises(KeyError, match='pelvis'):
        skel.index('wing')
