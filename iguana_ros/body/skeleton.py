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
Skeleton of an adult green iguana (0.85 m snout to tail tip) and vectorised forward kinematics.

Axes: x forward (snout), y left, z up (REP 103). At rest every bone frame is aligned with the world axes,
so a bone's rest offset is the vector from its parent's joint to its own joint in world axes. Joint rotations
are 3-DOF; limits are box bounds on the rotation-vector components (x roll, y pitch, z yaw) of the local
rotation relative to the parent, in radians.

A pose is `root_position (..., 3)` plus `local_rotations (..., n_bones, 4)` (xyzw quaternions), where the
root entry is the root's world orientation.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from iguana_ros.constants import BODY_LENGTH
from iguana_ros.geometry import quat_identity, quat_mul, quat_rotate

ROOT_HEIGHT = 0.075
"""Height of the pelvis joint above flat ground in the rest pose, m."""

FEET = ('foot_fl', 'foot_fr', 'foot_hl', 'foot_hr')
"""The foot bones, in the order every per-foot figure and message uses (fl, fr, hl, hr); the model tags each foot's
sole nodes with its name."""

FOOT_PIVOTS = ('wrist_fl', 'wrist_fr', 'ankle_hl', 'ankle_hr')
"""The bone of each foot (order fl, fr, hl, hr) whose joint a planted foot pivots about and whose rotation
sets the sole's orientation (the sole nodes are skinned to it and to the foot bone below it)."""


def _deg(roll: float, pitch: float, yaw: float) -> tuple:
    """Symmetric joint limits in degrees -> ((lo, hi) x 3) in radians."""
    return tuple((-np.radians(a), np.radians(a)) for a in (roll, pitch, yaw))


def _leg(side: str, front: bool) -> list:
    """Bone rows of one leg: shoulder/hip, elbow/knee, wrist/ankle, foot (sprawling lizard posture)."""
    s = 1.0 if side == 'l' else -1.0
    tag = ('f' if front else 'h') + side
    if front:  # humerus sideways, forearm down, hand forward-out
        rows = [
            (f'shoulder_{tag}', 'spine_5', (0.0, 0.032 * s, -0.008), _deg(70, 80, 80)),
            (f'elbow_{tag}', f'shoulder_{tag}', (0.0, 0.050 * s, 0.0), _deg(45, 100, 40)),
            (f'wrist_{tag}', f'elbow_{tag}', (0.008, 0.008 * s, -0.058), _deg(40, 60, 40)),
            (f'foot_{tag}', f'wrist_{tag}', (0.022, 0.010 * s, -0.006), _deg(30, 45, 30)),
        ]
    else:  # femur sideways, shank down, long-toed foot out and slightly back
        rows = [
            (f'hip_{tag}', 'pelvis', (-0.005, 0.030 * s, -0.010), _deg(70, 80, 80)),
            (f'knee_{tag}', f'hip_{tag}', (0.0, 0.068 * s, 0.0), _deg(45, 110, 40)),
            (f'ankle_{tag}', f'knee_{tag}', (-0.005, 0.010 * s, -0.057), _deg(40, 60, 40)),
            (f'foot_{tag}', f'ankle_{tag}', (0.015, 0.022 * s, -0.006), _deg(30, 45, 30)),
        ]
    return rows


def _bone_rows() -> list:
    """(name, parent, rest offset (m), limits) for every bone, parents before children."""
    trunk = 0.185 / 5  # pelvis to shoulder girdle in five segments (lateral bending lives here)
    # tail_1 sits just behind the vent; tail_2..tail_8 and the tip taper (tail ~0.55 m, 2/3 of the body)
    tail_offsets = (0.020, 0.095, 0.085, 0.076, 0.068, 0.061, 0.055, 0.050, 0.035)
    rows = [('pelvis', None, (0.0, 0.0, ROOT_HEIGHT), _deg(180, 180, 180))]
    parent = 'pelvis'
    for i in range(1, 6):
        rows.append((f'spine_{i}', parent, (trunk, 0.0, 0.0), _deg(10, 12, 16)))
        parent = f'spine_{i}'
    rows += [
        ('neck', 'spine_5', (0.025, 0.0, 0.004), _deg(15, 30, 35)),
        ('head', 'neck', (0.030, 0.0, 0.004), _deg(15, 30, 30)),
        ('snout', 'head', (0.0, 0.0, 0.0), _deg(0, 0, 0)),  # end site, placed below
    ]
    parent = 'pelvis'
    for i, length in enumerate(tail_offsets[:-1], start=1):
        rows.append((f'tail_{i}', parent, (-length, 0.0, -0.002 * (i > 1)), _deg(8, 20, 30)))
        parent = f'tail_{i}'
    rows.append(('tail_tip', 'tail_8', (-tail_offsets[-1], 0.0, 0.0), _deg(0, 0, 0)))
    for front in (True, False):
        for side in ('l', 'r'):
            rows += _leg(side, front)
    return _place_snout(rows)


def _place_snout(rows: list) -> list:
    """Set the snout end site so that snout-to-tail-tip length is exactly BODY_LENGTH."""
    names = [r[0] for r in rows]
    parents = [names.index(r[1]) if r[1] else -1 for r in rows]
    offsets = np.array([r[2] for r in rows], dtype=float)
    x = np.zeros(len(rows))
    for i, p in enumerate(parents):
        x[i] = offsets[i, 0] + (x[p] if p >= 0 else 0.0)
    head_length = BODY_LENGTH - (x[names.index('head')] - x[names.index('tail_tip')])
    i = names.index('snout')
    rows[i] = ('snout', 'head', (head_length, 0.0, -0.006), rows[i][3])
    return rows


@dataclass(frozen=True)
class Skeleton:
    """Bone hierarchy: names `(n_bones,)`, parents `(n_bones,)` (-1 root), offsets and joint limits."""

    names: tuple
    parents: np.ndarray
    offsets: np.ndarray
    limits: np.ndarray

    @property
    def n_bones(self) -> int:
        """Return number of bones (joints), end sites included."""
        return len(self.names)

    def index(self, name: str) -> int:
        """Index of bone `name`; KeyError lists the bone names."""
        try:
            return self.names.index(name)
        except ValueError:
            raise KeyError(f'no bone {name!r}; bones: {", ".join(self.names)}') from None

    def indices(self, names: list) -> np.ndarray:
        """Return indices `(len(names),)` of several bones."""
        return np.array([self.index(n) for n in names], dtype=np.int64)

    def rest_pose(self) -> tuple:
        """(root_position (3,), local_rotations (n_bones, 4)) of the rest pose."""
        return self.offsets[0].copy(), quat_identity((self.n_bones,))

    def children(self, bone: int) -> np.ndarray:
        """Return indices of the direct children of `bone`."""
        return np.flatnonzero(self.parents == bone)


@lru_cache(maxsize=1)
def iguana_skeleton() -> Skeleton:
    """Return the adult green iguana skeleton: trunk of 5, neck, head, tail of 8, four 4-bone legs."""
    rows = _bone_rows()
    names = tuple(r[0] for r in rows)
    parents = np.array([names.index(r[1]) if r[1] else -1 for r in rows], dtype=np.int64)
    offsets = np.array([r[2] for r in rows], dtype=float)
    limits = np.array([r[3] for r in rows], dtype=float)
    for arr in (parents, offsets, limits):
        arr.setflags(write=False)
    return Skeleton(names=names, parents=parents, offsets=offsets, limits=limits)


def forward_kinematics(skeleton: Skeleton, root_position: np.ndarray,
                       local_rotations: np.ndarray) -> tuple:
    """
    World joint positions `(..., n_bones, 3)` and rotations `(..., n_bones, 4)` of poses.

    `root_position (..., 3)`, `local_rotations (..., n_bones, 4)`; leading axes (frames) broadcast.
    """
    root_position = np.asarray(root_position, dtype=float)
    local_rotations = np.asarray(local_rotations, dtype=float)
    lead = np.broadcast_shapes(root_position.shape[:-1], local_rotations.shape[:-2])
    positions = np.empty(lead + (skeleton.n_bones, 3))
    rotations = np.empty(lead + (skeleton.n_bones, 4))
    for b, p in enumerate(skeleton.parents):
        if p < 0:
            positions[..., b, :] = root_position
            rotations[..., b, :] = local_rotations[..., b, :]
            continue
        rotations[..., b, :] = quat_mul(rotations[..., p, :], local_rotations[..., b, :])
        positions[..., b, :] = positions[..., p, :] + quat_rotate(rotations[..., p, :],
                                                                  skeleton.offsets[b])
    return positions, rotations


def rest_joint_positions(skeleton: Skeleton) -> np.ndarray:
    """World joint positions `(n_bones, 3)` of the rest pose."""
    root, local = skeleton.rest_pose()
    return forward_kinematics(skeleton, root, local)[0]


def bone_segments(skeleton: Skeleton, joint_positions: np.ndarray) -> tuple:
    """Segment end points `(n_segments, 2, 3)` and their child bone indices, one per non-root bone."""
    child = np.flatnonzero(skeleton.parents >= 0)
    seg = np.stack([joint_positions[..., skeleton.parents[child], :],
                    joint_positions[..., child, :]], axis=-2)
    return seg, child
