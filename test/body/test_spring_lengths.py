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

"""Desired spring lengths from the DQS-skinned reference mesh (Section VII)."""
import numpy as np
import pytest

from iguana_ros.body.model import build_model
from iguana_ros.body.skeleton import forward_kinematics
from iguana_ros.body.spring_lengths import desired_spring_lengths, SpringLengthComputer
from iguana_ros.errors import IguanaError, InputError
from iguana_ros.geometry import quat_from_rotvec, quat_mul


@pytest.fixture(scope='module')
def computer():
    return SpringLengthComputer(build_model('coarse', 'normal'))


def test_lengths_are_node_distances():
    nodes = np.array([[0.0, 0, 0], [3.0, 4.0, 0], [0, 0, -2.0]])
    springs = np.array([[0, 1], [2, 0], [1, 2]])
    np.testing.assert_allclose(desired_spring_lengths(nodes, springs), [5.0, 2.0, np.sqrt(29.0)])
    with pytest.raises(InputError, match='springs'):
        desired_spring_lengths(nodes, np.array([[0, 3]]))
    with pytest.raises(InputError, match='shape'):
        desired_spring_lengths(nodes, np.array([0, 1]))


def test_rest_pose_gives_rest_lengths_and_rigid_motion_keeps_them(computer):
    skel = computer.skeleton
    root, local = skel.rest_pose()
    model = build_model('coarse', 'normal')
    np.testing.assert_allclose(computer(root, local), model.spring_rest_lengths, atol=1e-12)
    moved = local.copy()
    moved[0] = quat_from_rotvec(np.array([0.2, -0.3, 1.1]))
    lengths = computer(root + np.array([1.5, -2.0, 0.4]), moved)
    np.testing.assert_allclose(lengths, model.spring_rest_lengths, atol=1e-12)


def test_bending_the_tail_changes_only_springs_it_moves(computer):
    skel = computer.skeleton
    root, local = skel.rest_pose()
    bent = local.copy()
    tail = skel.index('tail_3')
    bent[tail] = quat_mul(bent[tail], quat_from_rotvec(np.array([0.0, 0.0, 0.5])))
    lengths = computer(root, bent)
    rest = computer(root, local)
    moved_bones = {tail} | {b for b in range(skel.n_bones) if _descends(skel.parents, b, tail)}
    node_moves = np.isin(computer.skin_bones, list(moved_bones)) & (computer.skin_weights > 0)
    touched = node_moves.any(axis=1)[computer.springs].any(axis=1)
    np.testing.assert_allclose(lengths[~touched], rest[~touched], atol=1e-12)
    assert np.max(np.abs(lengths[touched] - rest[touched])) > 1e-3
    positions, rotations = forward_kinematics(skel, root, bent)
    np.testing.assert_allclose(computer.lengths_from_bones(rotations, positions), lengths, atol=1e-15)


def test_non_finite_pose_is_an_error(computer):
    root, local = computer.skeleton.rest_pose()
    local[5, 0] = np.nan
    with pytest.raises(IguanaError, match='not finite'):
        computer(root, local)
    with pytest.raises(InputError, match='bone transforms'):
        computer.lengths_from_bones(local[:3], np.zeros((3, 3)))


def _descends(parents, bone, ancestor):
    """Return True when `bone` is a (grand-)child of `ancestor`."""
    while parents[bone] >= 0:
        bone = parents[bone]
        if bone == ancestor:
            return True
    return False
