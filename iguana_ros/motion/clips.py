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
Stride-long motion clips (Section IV) and the clip library the planner uses.

A clip of a stride of N frames holds N + 1 poses: frame 0 is the touchdown of the FL+HR diagonal pair that
starts the stride, frame N the next such touchdown, which is the pose the following clip's frame 0 is aligned
to (so playing a clip advances N frames). Poses are in a canonical frame: frame 0's root (pelvis) at x = y = 0,
facing +x (its yaw is zero; heights kept). Clips are cyclic-ready: frame N equals frame 0 moved by
(`root_displacement`, `heading_change`), and the last frames are blended so velocity is continuous across the
seam. A transition clip (start, stop, a change of gait) is not cyclic: its first pose is of the gait it leaves
(`entry_gait`), its last of the gait it enters (`exit_gait`), and the motion graph lets it follow only clips that end
in its entry gait. Foot order everywhere: fl, fr, hl, hr.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

import numpy as np

from iguana_ros.body.skeleton import FEET, forward_kinematics
from iguana_ros.constants import FRAME_RATE
from iguana_ros.errors import InputError
from iguana_ros.geometry import quat_from_yaw, quat_mul
from iguana_ros.motion.cleanup import clean_footskate, flat_soles, stride_transform, support_tail, TAIL_TIP_HEIGHT
from iguana_ros.motion.dofs import BodyModel, iguana_body_model, local_rotations, root_positions

CLIP_LIBRARY_FILE = 'clips.npz'
"""Package-data file of the clip library (`iguana_ros/data/clips.npz`)."""
REQUIRED_CLIPS = ('forward', 'turn_left', 'turn_right', 'idle')
"""Clips every library must hold."""
ANY_GAIT = ''
"""The entry or exit gait of a clip that may follow or precede any clip (a library without gaits: a complete graph)."""


@dataclass(frozen=True)
class Clip:
    """
    One stride.

    Root positions `(N+1, 3)`, local rotations `(N+1, n_bones, 4)` (root entry = world root orientation; the wrist/ankle
    entries keep stance soles flat, `motion.cleanup.flat_soles`), contacts `(N+1, 4)`, per-stride
    `root_displacement (2,)` (m, start heading frame) and `heading_change` (rad), `residual_heights` {'feet':
    `(N+1, 4)`, 'tail_tip': `(N+1,)`} (m above the capture floor, Section VI-A), `duty_factor`, `stride_length` (m),
    active DOFs `theta (N+1, n_dof)`; the gait it starts in (`entry_gait`) and ends in (`exit_gait`), and whether it is
    cyclic (frame N = frame 0 moved by the stride) or a transition.
    """

    name: str
    frame_rate: float
    root_positions: np.ndarray
    local_rotations: np.ndarray
    contacts: np.ndarray
    root_displacement: np.ndarray
    heading_change: float
    residual_heights: dict
    duty_factor: float
    stride_length: float
    theta: np.ndarray
    source: str = ''
    metadata: dict = field(default_factory=dict)
    entry_gait: str = ANY_GAIT
    exit_gait: str = ANY_GAIT
    cyclic: bool = True

    @property
    def n_frames(self) -> int:
        """Frames the clip advances when played (N); it stores N + 1 poses."""
        return int(self.root_positions.shape[0]) - 1

    @property
    def duration(self) -> float:
        """Duration of one stride, s."""
        return self.n_frames / self.frame_rate


def planar_transform(theta: np.ndarray, origin: np.ndarray, target: np.ndarray, dofs) -> np.ndarray:
    """Poses `(F, n_dof)` moved rigidly in the plane so the root of `origin (n_dof,)` lands on `target`'s."""
    ix, iy, iyaw = dofs.index('root_x'), dofs.index('root_y'), dofs.index('root_yaw')
    turn = target[iyaw] - origin[iyaw]
    c, s = np.cos(turn), np.sin(turn)
    out = np.array(theta, dtype=float, copy=True)
    dx, dy = out[:, ix] - origin[ix], out[:, iy] - origin[iy]
    out[:, ix] = target[ix] + c * dx - s * dy
    out[:, iy] = target[iy] + s * dx + c * dy
    out[:, iyaw] = out[:, iyaw] + turn
    return out


def make_cyclic(theta: np.ndarray, start: int, end: int, dofs, blend: int | None = None) -> np.ndarray:
    """
    Return poses `(end-start+1, n_dof)` of take frames start..end with the last `blend` frames bent to close the stride.

    The last `blend` frames are bent so that frame `end` is frame `start` moved by the stride and frame `end-1` is frame
    `start-1` moved likewise.
    """
    segment = np.array(theta[start:end + 1], dtype=float, copy=True)
    n = end - start
    blend = max(2, min(n, blend or n // 2))
    ghost = planar_transform(theta[max(start - 1, 0):start + 1], theta[start], theta[end], dofs)
    e0 = ghost[-1] - segment[-1]
    e1 = ghost[0] - segment[-2] if start > 0 else e0
    tau = (np.arange(blend + 1) / blend)[:, None]
    slope = (e0 - e1) * blend
    hermite = e0 * (3 * tau ** 2 - 2 * tau ** 3) + slope * (tau ** 3 - tau ** 2)
    segment[-blend - 1:] += hermite
    return segment


def canonical(theta: np.ndarray, dofs) -> np.ndarray:
    """Poses `(F, n_dof)` moved so that frame 0's root is at x = y = 0 with zero yaw."""
    target = np.array(theta[0], dtype=float, copy=True)
    target[[dofs.index('root_x'), dofs.index('root_y'), dofs.index('root_yaw')]] = 0.0
    return planar_transform(theta, theta[0], target, dofs)


def clip_from_theta(name: str, theta: np.ndarray, contacts: np.ndarray, frame_rate: float = FRAME_RATE,
                    source: str = '', model: BodyModel | None = None, metadata: dict | None = None,
                    entry_gait: str = ANY_GAIT, exit_gait: str = ANY_GAIT, cyclic: bool = True) -> Clip:
    """Return a Clip from canonical poses `theta (N+1, n_dof)` (cyclic unless `cyclic`), contacts `(N+1, 4)`."""
    model = model or iguana_body_model()
    d = model.dofs
    theta = np.asarray(theta, dtype=float)
    contacts = np.asarray(contacts, dtype=bool)
    if theta.ndim != 2 or theta.shape[1] != d.n_dof or len(theta) < 2 or contacts.shape != (len(theta), 4):
        raise InputError(f'clip {name!r}: theta must be (N+1, {d.n_dof}) and contacts (N+1, 4), '
                         f'got {theta.shape} and {contacts.shape}')
    yaw = d.index('root_yaw')
    displacement = theta[-1, [d.index('root_x'), d.index('root_y')]] - theta[0, [d.index('root_x'),
                                                                                 d.index('root_y')]]
    c, s = np.cos(theta[0, yaw]), np.sin(theta[0, yaw])
    displacement = np.array([c * displacement[0] + s * displacement[1], -s * displacement[0] + c * displacement[1]])
    turn = float(theta[-1, yaw] - theta[0, yaw])
    roots = root_positions(d, theta)
    rotations = flat_soles(model.skeleton, roots, local_rotations(d, theta), contacts, turn if cyclic else None)
    joints = forward_kinematics(model.skeleton, roots, rotations)[0]
    heights = {'feet': joints[:, model.skeleton.indices(list(FEET)), 2],
               'tail_tip': joints[:, model.skeleton.index('tail_tip'), 2]}
    return Clip(name=name, frame_rate=float(frame_rate), root_positions=roots,
                local_rotations=rotations, contacts=contacts,
                root_displacement=displacement, heading_change=turn,
                residual_heights=heights, duty_factor=float(contacts[:-1].mean()),
                stride_length=float(np.hypot(*displacement)), theta=theta, source=source,
                metadata=dict(metadata or {}), entry_gait=str(entry_gait), exit_gait=str(exit_gait),
                cyclic=bool(cyclic))


def cut_clip(name: str, theta: np.ndarray, contacts: np.ndarray, start: int, end: int,
             frame_rate: float = FRAME_RATE, source: str = '', model: BodyModel | None = None,
             clean: bool = True, cyclic: bool = True, entry_gait: str = ANY_GAIT,
             exit_gait: str = ANY_GAIT, tail_tip: float = TAIL_TIP_HEIGHT) -> Clip:
    """
    Return the canonical clip of take frames start..end (poses `(F, n_dof)`, contacts `(F, 4)`).

    Cyclic-ready unless `cyclic` is False (a transition from gait `entry_gait` to gait `exit_gait`: cut as it is,
    cleaned in a window of a stride more of the take on each side). With `clean`, its tail rests on the floor and its
    stance feet are planted on it with swings lifted (`motion.cleanup`), the tail tip `tail_tip` m over it.
    """
    model = model or iguana_body_model()
    if not 0 <= start < end < len(theta):
        raise InputError(f'clip {name!r}: frames {start}..{end} are outside the take (0..{len(theta) - 1})')
    if cyclic:
        segment = canonical(make_cyclic(theta, start, end, model.dofs), model.dofs)
        clip_contacts = np.array(contacts[start:end + 1], dtype=bool, copy=True)
        clip_contacts[-1] = clip_contacts[0]
        if clean:
            segment, clip_contacts = clean_footskate(support_tail(segment, model, tail_tip), clip_contacts, model)
    else:
        segment, clip_contacts = _transition_segment(theta, contacts, start, end, model, clean, tail_tip)
    return clip_from_theta(name, segment, clip_contacts, frame_rate, source, model,
                           {'start_frame': int(start), 'end_frame': int(end)}, entry_gait, exit_gait, cyclic)


def _transition_segment(theta: np.ndarray, contacts: np.ndarray, start: int, end: int, model: BodyModel,
                        clean: bool, tail_tip: float) -> tuple:
    """(canonical poses `(N+1, n_dof)`, contacts `(N+1, 4)`) of take frames start..end, cleaned in a wider window."""
    pad = end - start
    first, last = max(start - pad, 0), min(end + pad, len(theta) - 1)
    window = np.array(theta[first:last + 1], dtype=float, copy=True)
    window_contacts = np.array(contacts[first:last + 1], dtype=bool, copy=True)
    if clean:
        window, window_contacts = clean_footskate(support_tail(window, model, tail_tip), window_contacts, model,
                                                  cyclic=False)
    crop = slice(start - first, end - first + 1)
    return canonical(window[crop], model.dofs), window_contacts[crop]


def repeated_clip(clip: Clip, repeat: int) -> tuple:
    """
    Return (root positions `(n*N+1, 3)`, local rotations `(n*N+1, n_bones, 4)`) of `clip` played `repeat` = n times.

    The strides follow each other, each moved by the clip's own stride motion (the poses the planner would play).
    """
    dofs = iguana_body_model().dofs
    stride = stride_transform(clip.theta, dofs)
    roots, rotations = [clip.root_positions], [clip.local_rotations]
    turn = quat_from_yaw(stride.turn)
    for _ in range(repeat - 1):
        roots.append(stride.apply(roots[-1][1:]))
        last = rotations[-1][1:].copy()
        last[:, 0] = quat_mul(turn, last[:, 0])
        rotations.append(last)
    return np.concatenate(roots), np.concatenate(rotations)


def save_clip_library(path: str | Path, clips: dict, extra: dict | None = None) -> None:
    """Write clips (name -> Clip) and optional extra arrays to a compressed .npz."""
    arrays = {'clip_names': np.array(list(clips))}
    for name, clip in clips.items():
        arrays[f'clip/{name}/theta'] = clip.theta
        arrays[f'clip/{name}/contacts'] = clip.contacts
        arrays[f'clip/{name}/frame_rate'] = np.array(clip.frame_rate)
        arrays[f'clip/{name}/source'] = np.array(clip.source)
        arrays[f'clip/{name}/frames'] = np.array([clip.metadata.get('start_frame', -1),
                                                  clip.metadata.get('end_frame', -1)])
        arrays[f'clip/{name}/gaits'] = np.array([clip.entry_gait, clip.exit_gait])
        arrays[f'clip/{name}/cyclic'] = np.array(clip.cyclic)
    arrays.update(extra or {})
    np.savez_compressed(path, **arrays)


def default_library_path() -> Path:
    """Path of the clip library shipped as package data."""
    return Path(str(resources.files('iguana_ros').joinpath('data', CLIP_LIBRARY_FILE)))


def load_clip_library(path: str | Path | None = None) -> dict:
    """Return the clip library: name -> Clip (at least forward, turn_left, turn_right, idle)."""
    path = Path(path) if path is not None else default_library_path()
    if not path.is_file():
        raise InputError(f'clip library {path} does not exist (run `iguana motion build`)')
    with np.load(path, allow_pickle=False) as data:
        names = [str(n) for n in data['clip_names']]
        missing = [n for n in REQUIRED_CLIPS if n not in names]
        if missing:
            raise InputError(f'clip library {path} lacks clips {", ".join(missing)}')
        library = {}
        for name in names:
            start, end = (int(v) for v in data[f'clip/{name}/frames'])
            gaits = data.get(f'clip/{name}/gaits', np.array([ANY_GAIT, ANY_GAIT]))
            library[name] = clip_from_theta(
                name, data[f'clip/{name}/theta'], data[f'clip/{name}/contacts'],
                float(data[f'clip/{name}/frame_rate']), str(data[f'clip/{name}/source']),
                metadata={'start_frame': start, 'end_frame': end}, entry_gait=str(gaits[0]),
                exit_gait=str(gaits[1]),
                cyclic=bool(data.get(f'clip/{name}/cyclic', True)))
    return library


def load_take_motions(path: str | Path | None = None) -> dict:
    """Full-body IK of each capture take stored with the library: name -> poses `theta (F, n_dof)`."""
    path = Path(path) if path is not None else default_library_path()
    if not path.is_file():
        raise InputError(f'clip library {path} does not exist (run `iguana motion build`)')
    with np.load(path, allow_pickle=False) as data:
        return {key.split('/')[1]: np.asarray(data[key], dtype=float)
                for key in data.files if key.startswith('take/') and key.endswith('/theta')}
