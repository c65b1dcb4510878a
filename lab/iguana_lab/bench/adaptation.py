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
Terrain adaptation and DQS spring lengths per frame: median ms of plane fitting, residual fitting, sole alignment.

The poses are the synthetic straight trot (the motion library's generator), played over the hills scene's
terrain (loaded from msg_configs/scenes/hills.yaml) and over a 12-degree tilted plane, warm-started frame to frame
as in a run; the mesh is the chosen model resolution. The first frame (compilation, cold caches) is not counted.
`iguana bench adaptation` (cli/bench_adaptation.py) prints them.
"""
from __future__ import annotations

HILLS_SCENE = 'hills'
"""The scene whose terrain the trot is played over (msg_configs/scenes/hills.yaml)."""
TILT_DEG = 12.0
"""Slope of the second terrain, a tilted plane (degrees)."""


def _trot(n_frames: int) -> tuple:
    """Root positions `(F, 3)`, local rotations `(F, n_bones, 4)`, contacts `(F, 4)` of the synthetic trot."""
    from iguana_ros.motion.dofs import iguana_body_model, local_rotations, root_positions
    from iguana_ros.motion.gait import SYNTHETIC_TAKES, generate_take

    take = generate_take(SYNTHETIC_TAKES[0])
    dofs = iguana_body_model().dofs
    n = min(n_frames + 1, take.n_frames)
    return root_positions(dofs, take.theta)[:n], local_rotations(dofs, take.theta)[:n], take.contacts[:n]


def _terrain_figures(skeleton, terrain, poses, computer) -> dict:
    """Per-frame timings (medians, ms) and accuracy of adaptation + spring lengths on one terrain."""
    import time

    import numpy as np

    from iguana_ros.body.skeleton import FEET
    from iguana_ros.terrain import adaptation as ad

    roots, locals_, contacts = poses
    state = ad.AdaptationState()
    rows = []
    for k in range(len(roots)):
        feet_h, tail_h = ad.residual_heights_of(skeleton, roots[k], locals_[k])
        t0 = time.perf_counter()
        fit = ad.plane_fit(skeleton, terrain, roots[k], locals_[k], feet_h)
        t1 = time.perf_counter()
        out = ad.residual_fit(skeleton, terrain, fit.root_position, fit.local_rotations, feet_h, tail_h,
                              stance=contacts[k], state=state)
        t2 = time.perf_counter()
        aligned = ad.align_soles(skeleton, terrain, out, contacts[k])
        t3 = time.perf_counter()
        computer.lengths_from_bones(aligned.joint_rotations, aligned.joint_positions)
        t4 = time.perf_counter()
        p = out.joint_positions
        feet = p[skeleton.indices(list(FEET))]
        foot_err = np.abs(feet[:, 2] - terrain.height(feet[:, :2]) - feet_h)[contacts[k]]
        rows.append((t1 - t0, t2 - t1, t3 - t2, t4 - t3, state.evaluations, foot_err.max(initial=0.0),
                     np.min(p[:, 2] - terrain.height(p[:, :2]))))
    a = np.array(rows[1:])
    return {'plane_fit_ms': 1e3 * np.median(a[:, 0]), 'residual_fit_ms': 1e3 * np.median(a[:, 1]),
            'residual_fit_p90_ms': 1e3 * np.percentile(a[:, 1], 90), 'align_soles_ms': 1e3 * np.median(a[:, 2]),
            'adaptation_ms': 1e3 * np.median(a[:, :3].sum(axis=1)),
            'adaptation_p90_ms': 1e3 * np.percentile(a[:, :3].sum(axis=1), 90),
            'dqs_spring_lengths_ms': 1e3 * np.median(a[:, 3]),
            'frame_ms': 1e3 * np.median(a[:, :4].sum(axis=1)),
            'evaluations_median': float(np.median(a[:, 4])), 'evaluations_max': int(a[:, 4].max()),
            'stance_foot_error_max_mm': 1e3 * a[:, 5].max(), 'min_joint_clearance_mm': 1e3 * a[:, 6].min()}


def benchmark_adaptation(frames: int = 150, resolution: str = 'medium') -> dict:
    """Return the figures of `iguana bench adaptation` as a dict (also callable from other benchmarks)."""
    from iguana_ros.body.model import build_model
    from iguana_ros.body.spring_lengths import SpringLengthComputer
    from iguana_ros.errors import InputError
    from iguana_ros.scene import load_scene, terrain_from_spec
    from iguana_ros.terrain.heightfield import HeightField

    if frames < 2:
        raise InputError(f'--frames must be at least 2, got {frames}')
    model = build_model(resolution, 'normal')
    computer = SpringLengthComputer(model)
    poses = _trot(frames)
    terrains = {HILLS_SCENE: terrain_from_spec(load_scene(HILLS_SCENE).terrain),
                f'tilted_{TILT_DEG:g}deg': HeightField.tilted_plane(TILT_DEG)}
    result = {'resolution': resolution, 'n_nodes': int(model.n_nodes), 'n_springs': int(computer.n_springs),
              'frames': int(len(poses[0]) - 1)}
    for name, terrain in terrains.items():
        result[name] = _terrain_figures(model.skeleton, terrain, poses, computer)
    return result
