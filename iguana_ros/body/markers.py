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

"""The 15-marker motion-capture set of the paper's Figure 3, each fixed to a bone with an offset."""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from iguana_ros.body.skeleton import forward_kinematics, iguana_skeleton, Skeleton
from iguana_ros.geometry import quat_rotate

# label, bone, offset in the bone frame (m). 4 feet, 3 tail, 1 head, 7 body (3 dorsal + 2 left + 2 right).
MARKER_TABLE = (
    ('FOOT_FL', 'foot_fl', (0.010, 0.004, 0.004)),
    ('FOOT_FR', 'foot_fr', (0.010, -0.004, 0.004)),
    ('FOOT_HL', 'foot_hl', (0.012, 0.006, 0.004)),
    ('FOOT_HR', 'foot_hr', (0.012, -0.006, 0.004)),
    ('TAIL_1', 'tail_2', (0.0, 0.0, 0.024)),
    ('TAIL_2', 'tail_5', (0.0, 0.0, 0.014)),
    ('TAIL_3', 'tail_8', (-0.02, 0.0, 0.007)),
    ('HEAD', 'head', (0.025, 0.0, 0.028)),
    ('BACK_1', 'spine_5', (0.0, 0.0, 0.040)),
    ('BACK_2', 'spine_3', (0.0, 0.0, 0.045)),
    ('BACK_3', 'pelvis', (0.0, 0.0, 0.038)),
    ('SIDE_FL', 'spine_4', (0.0, 0.045, 0.012)),
    ('SIDE_HL', 'spine_1', (0.0, 0.043, 0.012)),
    ('SIDE_FR', 'spine_4', (0.0, -0.045, 0.012)),
    ('SIDE_HR', 'spine_1', (0.0, -0.043, 0.012)),
)


@dataclass(frozen=True)
class MarkerSet:
    """Marker labels `(n_markers,)`, bone indices `(n_markers,)` and offsets in bone frames `(n_markers, 3)`."""

    labels: tuple
    bones: np.ndarray
    offsets: np.ndarray

    def index(self, label: str) -> int:
        """Index of marker `label`; KeyError lists the labels."""
        try:
            return self.labels.index(label)
        except ValueError:
            raise KeyError(f'no marker {label!r}; markers: {", ".join(self.labels)}') from None


@lru_cache(maxsize=1)
def iguana_markers() -> MarkerSet:
    """Return the paper's 15 markers on the iguana skeleton."""
    skeleton = iguana_skeleton()
    bones = skeleton.indices([row[1] for row in MARKER_TABLE])
    offsets = np.array([row[2] for row in MARKER_TABLE], dtype=float)
    bones.setflags(write=False)
    offsets.setflags(write=False)
    return MarkerSet(labels=tuple(row[0] for row in MARKER_TABLE), bones=bones, offsets=offsets)


def marker_positions_from_bones(markers: MarkerSet, joint_positions: np.ndarray,
                                joint_rotations: np.ndarray) -> np.ndarray:
    """World marker positions `(..., n_markers, 3)` from world bone transforms `(..., n_bones, 3|4)`."""
    return (joint_positions[..., markers.bones, :]
            + quat_rotate(joint_rotations[..., markers.bones, :], markers.offsets))


def marker_positions(skeleton: Skeleton, markers: MarkerSet, root_position: np.ndarray,
                     local_rotations: np.ndarray) -> np.ndarray:
    """World marker positions `(..., n_markers, 3)` of poses (see `forward_kinematics`)."""
    pos, rot = forward_kinematics(skeleton, root_position, local_rotations)
    return marker_positions_from_bones(markers, pos, rot)
