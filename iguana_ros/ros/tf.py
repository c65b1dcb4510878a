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
The iguana's TF frames (REP 105) and their tf2_msgs/TFMessage messages on /tf and /tf_static.

`world` → `odom` (static identity: the terrain is the map) → `base_link` (the simulated root, as iguana_state);
beside base_link, children of `odom`: `reference/<bone>` (the terrain-adapted reference skeleton's bones, as
reference_pose) and `foot/<fl|fr|hl|hr>` (the simulated sole centroids, as foot_positions). Every frame but `world`
carries the nodes' `frame_prefix` (e.g. 'iguana1/'). Stamps are simulated time (the frame's, as every message).
"""
from __future__ import annotations

from dataclasses import dataclass
import re

import numpy as np

from iguana_ros.body.skeleton import FEET
from iguana_ros.constants import BASE_FRAME, ODOM_FRAME, WORLD_FRAME
from iguana_ros.errors import InputError
from iguana_ros.ros.cdr import tf_message_cdr
from iguana_ros.ros.conversions import frame_stamp

PREFIX_PATTERN = re.compile(r'([A-Za-z][A-Za-z0-9_]*/)*')
"""A frame prefix: empty, or names of letters, digits and underscores, each ending with '/' (e.g. 'zoo/iguana1/')."""


@dataclass(frozen=True)
class TfFrames:
    """Names of the iguana's frames: odom, base_link, the reference bones `(n_bones,)` and the feet `(4,)`."""

    odom: str
    base: str
    bones: tuple
    feet: tuple


def tf_frames(prefix: str, bone_names: tuple = ()) -> TfFrames:
    """Return the frame names under `prefix` ('' or e.g. 'iguana1/'); InputError naming a malformed prefix."""
    if not PREFIX_PATTERN.fullmatch(prefix):
        raise InputError(f"frame_prefix {prefix!r}: expected '' or names of letters, digits and underscores, each "
                         "ending with '/' (e.g. 'iguana1/')")
    return TfFrames(prefix + ODOM_FRAME, prefix + BASE_FRAME, tuple(f'{prefix}reference/{b}' for b in bone_names),
                    tuple(f'{prefix}foot/{f.removeprefix("foot_")}' for f in FEET))


def _stamp(frame: int) -> tuple[int, int]:
    """(sec, nanosec) of the start of `frame`."""
    stamp = frame_stamp(frame)
    return stamp.sec, stamp.nanosec


def static_tf_to_cdr(frames: TfFrames | list[TfFrames]) -> bytes:
    """Return the /tf_static message: world → odom of each body's `frames`, identity, stamped 0 (valid always)."""
    bodies = frames if isinstance(frames, list) else [frames]
    rotations = np.zeros((len(bodies), 4))
    rotations[:, 3] = 1.0
    return tf_message_cdr((0, 0), [WORLD_FRAME] * len(bodies), [f.odom for f in bodies], np.zeros((len(bodies), 3)),
                          rotations)


def body_tf_to_cdr(frames: TfFrames, root: np.ndarray, orientation: np.ndarray, soles: np.ndarray,
                   frame: int) -> bytes:
    """Return the simulator's /tf of `frame`: odom → base_link (root `(3,)`, xyzw `(4,)`), odom → feet `(4, 3)`."""
    translations = np.concatenate([np.reshape(root, (1, 3)), np.reshape(soles, (len(FEET), 3))])
    rotations = np.zeros((1 + len(FEET), 4))
    rotations[0] = orientation
    rotations[1:, 3] = 1.0
    children = [frames.base, *frames.feet]
    return tf_message_cdr(_stamp(frame), [frames.odom] * len(children), children, translations, rotations)


def bones_tf_to_cdr(frames: TfFrames, joints: np.ndarray, rotations: np.ndarray, frame: int) -> bytes:
    """Return the adaptation's /tf message of `frame`: odom → every reference bone (`(n_bones, 3)`, `(n_bones, 4)`)."""
    return tf_message_cdr(_stamp(frame), [frames.odom] * len(frames.bones), list(frames.bones), joints, rotations)
