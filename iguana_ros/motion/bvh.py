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
BVH export (viewable in Blender) of clips and whole takes, and a reader for checking files.

BVH axes are Y up with the character facing +Z: BVH (X, Y, Z) = iguana (y, z, x), a proper rotation, so
Blender's default BVH import (forward -Z, up Y) shows the iguana upright. Units are metres. Every joint has
`Zrotation Xrotation Yrotation` channels (R = Rz Rx Ry in BVH axes); the root also has positions. Bones with
no children (snout, tail_tip, the feet) are written as End Sites.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from iguana_ros.body.skeleton import Skeleton
from iguana_ros.errors import InputError
from iguana_ros.geometry import matrix_to_euler, quat_from_euler, quat_mul, quat_rotate, quat_to_matrix

_PERM = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
"""Maps iguana vectors (x fwd, y left, z up) to BVH vectors (X, Y up, Z fwd)."""


def _to_bvh_rotations(local_rotations: np.ndarray) -> np.ndarray:
    """Euler angles `(F, n_bones, 3)` in degrees (Z, X, Y order, intrinsic) in BVH axes."""
    shape = local_rotations.shape[:-1]
    mats = _PERM @ quat_to_matrix(local_rotations.reshape(-1, 4)) @ _PERM.T
    return np.degrees(matrix_to_euler(mats, 'ZXY')).reshape(shape + (3,))


def write_bvh(path: str | Path, skeleton: Skeleton, root_positions: np.ndarray, local_rotations: np.ndarray,
              frame_rate: float) -> None:
    """Write poses `root_positions (F, 3)`, `local_rotations (F, n_bones, 4)` as a BVH file."""
    root_positions = np.asarray(root_positions, dtype=float)
    local_rotations = np.asarray(local_rotations, dtype=float)
    if local_rotations.shape[1:] != (skeleton.n_bones, 4) or root_positions.shape != (len(local_rotations), 3):
        raise InputError(f'BVH export needs root (F, 3) and rotations (F, {skeleton.n_bones}, 4), '
                         f'got {root_positions.shape} and {local_rotations.shape}')
    lines = ['HIERARCHY']
    order = []
    _write_joint(skeleton, 0, 0, lines, order)
    euler = _to_bvh_rotations(local_rotations)
    root = root_positions @ _PERM.T
    lines += ['MOTION', f'Frames: {len(root)}', f'Frame Time: {1.0 / frame_rate:.8f}']
    for f in range(len(root)):
        values = [root[f]] + [euler[f, b] for b in order]
        lines.append(' '.join(f'{v:.6f}' for v in np.concatenate(values)))
    Path(path).write_text('\n'.join(lines) + '\n')


def _write_joint(skeleton: Skeleton, bone: int, depth: int, lines: list, order: list) -> None:
    """Append the hierarchy text of `bone` and its subtree; `order` collects bones with channels."""
    pad = '  ' * depth
    offset = _PERM @ skeleton.offsets[bone]
    children = skeleton.children(bone)
    if bone == 0:
        lines += [f'ROOT {skeleton.names[0]}', '{', '  OFFSET 0.000000 0.000000 0.000000',
                  '  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation']
    elif len(children) == 0:
        lines += [f'{pad}End Site', f'{pad}{{', f'{pad}  OFFSET {offset[0]:.6f} {offset[1]:.6f} {offset[2]:.6f}',
                  f'{pad}}}']
        return
    else:
        lines += [f'{pad}JOINT {skeleton.names[bone]}', f'{pad}{{',
                  f'{pad}  OFFSET {offset[0]:.6f} {offset[1]:.6f} {offset[2]:.6f}',
                  f'{pad}  CHANNELS 3 Zrotation Xrotation Yrotation']
    order.append(bone)
    for child in children:
        _write_joint(skeleton, int(child), depth + 1, lines, order)
    lines.append(f'{pad}}}')


def read_bvh_positions(path: str | Path) -> tuple:
    """(joint and end-site names, world positions `(F, n, 3)` in iguana axes) of a BVH written here."""
    text = Path(path).read_text().split('\n')
    names, parents, offsets, channels = [], [], [], []
    stack, i = [], 0
    while not text[i].startswith('MOTION'):
        words = text[i].split()
        if words and words[0] in ('ROOT', 'JOINT', 'End'):
            names.append(words[1] if words[0] != 'End' else f'{names[stack[-1]]}_end')
            parents.append(stack[-1] if stack else -1)
            channels.append(0)
            stack.append(len(names) - 1)
        elif words and words[0] == 'OFFSET':
            offsets.append([float(v) for v in words[1:4]])
        elif words and words[0] == 'CHANNELS':
            channels[-1] = int(words[1])
        elif words and words[0] == '}':
            stack.pop()
        i += 1
    motion = np.array([[float(v) for v in line.split()] for line in text[i + 3:] if line.strip()])
    positions = np.zeros((len(motion), len(names), 3))
    rotations = [None] * len(names)
    col = 0
    for j, (parent, count) in enumerate(zip(parents, channels)):
        if count == 6:
            positions[:, j] = motion[:, col:col + 3]
            col += 3
        else:
            positions[:, j] = positions[:, parent] + quat_rotate(rotations[parent], offsets[j])
        if count:
            local = quat_from_euler(np.radians(motion[:, col:col + 3]), 'ZXY')
            rotations[j] = local if parent < 0 else quat_mul(rotations[parent], local)
            col += 3
    return tuple(names), positions @ _PERM
