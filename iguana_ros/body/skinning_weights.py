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
Skin weights of mesh nodes to skeleton bones for dual-quaternion skinning of the reference mesh (Section VII).

A bone owns the segments from its joint to its children's joints (a foot owns the segment to its toe tip);
end sites (snout, tail tip) own none and get no weight. A node's weight to a bone falls off smoothly with
its distance d to the bone's segments, w ~ (d + SKIN_SOFTNESS)^-SKIN_POWER; only bones of the part the node
belongs to compete (a leg node: that leg and its girdle bone; a head/trunk/tail node: the axial bones),
the `max_bones` largest are kept and normalised to sum to 1.
"""
from __future__ import annotations

import numpy as np

from iguana_ros.body.mesh import PART_LIMB0, PART_MAIN
from iguana_ros.body.shape import BodyShape
from iguana_ros.body.skeleton import rest_joint_positions

SKIN_SOFTNESS = 0.004
"""Distance offset of the weight falloff, m (how far the blend between neighbouring bones reaches)."""
SKIN_POWER = 4.0
"""Exponent of the inverse-distance weight falloff."""
END_SITES = ('snout', 'tail_tip')
"""Bones with no segment and no skin weight."""


def bone_segments_rest(shape: BodyShape) -> tuple:
    """Rest segments `(n_seg, 2, 3)` and their owning bone `(n_seg,)`: joint -> each child, foot -> toe tip."""
    sk = shape.skeleton
    joints = rest_joint_positions(sk)
    child = np.flatnonzero(sk.parents >= 0)
    segs = [np.stack([joints[sk.parents[child]], joints[child]], axis=1)]
    owner = [sk.parents[child]]
    for limb in shape.limbs:
        segs.append(limb.points[None, -2:])
        owner.append(np.array([sk.index(limb.bones[-1])]))
    return np.concatenate(segs), np.concatenate(owner).astype(np.int64)


def point_segment_distances(points: np.ndarray, segments: np.ndarray) -> np.ndarray:
    """Distances `(n_points, n_seg)` from points `(n_points, 3)` to segments `(n_seg, 2, 3)`."""
    a, b = segments[:, 0], segments[:, 1]
    e = b - a
    q = points[:, None, :] - a[None]
    t = np.clip(np.einsum('nsk,sk->ns', q, e) / np.maximum(np.einsum('sk,sk->s', e, e), 1e-300), 0, 1)
    return np.linalg.norm(q - t[..., None] * e[None], axis=-1)


def allowed_bones(shape: BodyShape, part: np.ndarray) -> np.ndarray:
    """Mask `(n_nodes, n_bones)` of the bones each node may bind to, from its part code `(n_nodes,)`."""
    sk = shape.skeleton
    limb_bones = {name for limb in shape.limbs for name in limb.bones}
    axial = np.array([n not in limb_bones and n not in END_SITES for n in sk.names])
    table = [axial]
    for limb in shape.limbs:
        girdle = sk.names[sk.parents[sk.index(limb.bones[0])]]
        table.append(np.isin(np.array(sk.names), list(limb.bones) + [girdle]))
    table = np.array(table)
    row = np.where(part == PART_MAIN, 0, part - PART_LIMB0 + 1)
    return table[row]


def skin_weights(shape: BodyShape, points: np.ndarray, part: np.ndarray, max_bones: int = 4) -> tuple:
    """(bones `(n_nodes, k)` int64, weights `(n_nodes, k)`) with k = max_bones, weights >= 0 summing to 1."""
    segs, owner = bone_segments_rest(shape)
    dist = point_segment_distances(points, segs)
    n_bones = shape.skeleton.n_bones
    bone_dist = np.full((len(points), n_bones), np.inf)
    for s, b in enumerate(owner):
        bone_dist[:, b] = np.minimum(bone_dist[:, b], dist[:, s])
    w = np.where(allowed_bones(shape, part), (bone_dist + SKIN_SOFTNESS) ** -SKIN_POWER, 0.0)
    bones = np.argsort(-w, axis=1, kind='stable')[:, :max_bones]
    weights = np.take_along_axis(w, bones, axis=1)
    weights /= weights.sum(axis=1, keepdims=True)
    order = np.argsort(bones, axis=1)
    return np.take_along_axis(bones, order, axis=1).astype(np.int64), np.take_along_axis(weights, order, 1)
