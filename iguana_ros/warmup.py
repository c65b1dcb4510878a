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
Compile every numba kernel and build the default body model once, ahead of the first run.

It is run by `iguana warm`, which `make install` calls, so four node processes do not each spend tens of seconds
compiling at start-up.

numba compiles a kernel per argument-type signature; the warm-up drives the real code paths (the library frame
loop over a terrain that needs adaptation, and one rendered frame) with the types a real run uses, so the
signatures it caches are the ones a run asks for. `kernel_signatures` lists them, so a test can check that a
real run needs none beyond them. It also compiles the kernels of the builders (the body's shape field, which a model
of another resolution needs, and the clips' forward kinematics), so every module with kernels is cached: what
`iguana doctor` calls a warm cache (before, it found 9 of 11 after `make install`: the model was already cached, so
the shape field was never called, and no run calls the clips' kinematics).
"""
from __future__ import annotations

from dataclasses import dataclass
import time

import numpy as np

WARM_SCENE = 'hills'
"""Scene whose loop the warm-up runs: hills needs terrain adaptation, so every simulator and IK kernel runs."""

WARM_FRAMES = 3
"""Frames of that loop (the first frame factorises, the later ones reuse the factor and refactorise)."""


@dataclass(frozen=True)
class WarmReport:
    """What a warm-up did: wall seconds of the loop and of the render, kernels compiled or loaded from cache."""

    loop_s: float
    render_s: float
    kernels: int
    signatures: int


def kernel_signatures() -> dict[str, list[str]]:
    """
    Return {'module.kernel': [signature, ...]} of every numba kernel of the package.

    Only the kernels compiled or loaded in this process are listed.
    """
    import sys

    from numba.core.registry import CPUDispatcher

    found: dict[str, list[str]] = {}
    for name, module in list(sys.modules.items()):
        if not name.startswith('iguana_ros.') or module is None:
            continue
        for attr, value in vars(module).items():
            if isinstance(value, CPUDispatcher) and value.signatures and value.__module__ == name:
                found[f'{name}.{attr}'] = sorted(str(s) for s in value.signatures)
    return found


def warm_loop(scene_name: str = WARM_SCENE, frames: int = WARM_FRAMES) -> float:
    """Run `frames` frames of the library loop of `scene_name` (caching its model) and a direct-solver frame; wall s."""
    from iguana_ros.pipeline import run
    from iguana_ros.scene import load_scene

    start = time.perf_counter()
    run(load_scene(scene_name), n_frames=frames)
    warm_direct_solver()
    return time.perf_counter() - start


def warm_direct_solver() -> None:
    """One frame of the simulator with the direct solver (the frame loop steps with CG in one compiled call)."""
    from iguana_ros.body.model import build_model
    from iguana_ros.physics.simulator import SoftBodySimulator
    from iguana_ros.terrain.heightfield import HeightField

    model = build_model('coarse')
    sim = SoftBodySimulator(model, HeightField.flat(), 'balanced', solver='direct')
    sim.advance_frame(model.spring_rest_lengths)             # lengths given: the first frame ramps from rest


def warm_body_contact() -> None:
    """Compile (or load) the body-body contact kernels (a world of several iguanas), on no nodes."""
    from iguana_ros.body.model import build_model
    from iguana_ros.physics.body_contact import ContactBody, load_kernels

    model = build_model('coarse')
    load_kernels(ContactBody.of_model(model), np.ascontiguousarray(model.rest_positions, dtype=np.float64))


def warm_builders() -> None:
    """Call the builders' kernels once: the body's shape field (model building) and the clips' forward kinematics."""
    from iguana_ros.body.shape import body_field, iguana_shape
    from iguana_ros.motion.dofs import iguana_body_model

    body_field(iguana_shape(), np.zeros((2, 3)))
    model = iguana_body_model()
    model.state(np.zeros((1, model.dofs.n_dof)))


def warm_render() -> float:
    """Render one small frame of a synthetic two-frame run through the renderer's kernels; wall seconds."""
    from iguana_ros.render.camera import preset_cameras
    from iguana_ros.render.renderer import Renderer
    from iguana_ros.render.run import RecordedRun

    start = time.perf_counter()
    tri = np.array([[0.0, 0.0, 0.05], [0.2, 0.0, 0.05], [0.0, 0.1, 0.1]], dtype=np.float32)
    colours = np.tile(np.array([0.2, 0.7, 0.3, 1.0], dtype=np.float32), (3, 1))
    ground = np.array([[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [0.0, 1.0, 0.0]])
    positions = np.array([[0.0, 0.0, 0.05], [0.05, 0.0, 0.05]])
    times = np.array([0.0, 1.0 / 30.0])
    recorded = RecordedRun(times=times, mesh_points=[tri, tri], mesh_colors=[colours, colours],
                           root_positions=positions, root_yaws=np.zeros(2), track_times=times,
                           track_positions=positions, terrain_points=ground,
                           terrain_colors=np.tile([0.7, 0.7, 0.6, 1.0], (3, 1)))
    for preset in ('follow', 'top'):
        cameras = preset_cameras(preset, times, positions, recorded.root_yaws, recorded.extent_points(), 1.6)
        Renderer(recorded, 64, 40).frame(1, cameras[1])
    return time.perf_counter() - start


def warm_up(scene_name: str = WARM_SCENE) -> WarmReport:
    """Compile (or load from the cache) every kernel a run and a render use; a WarmReport of what it did."""
    from iguana_ros.jit import ensure_fresh_kernel_cache

    ensure_fresh_kernel_cache()
    loop_s = warm_loop(scene_name)
    warm_body_contact()
    warm_builders()
    render_s = warm_render()
    signatures = kernel_signatures()
    return WarmReport(loop_s, render_s, len(signatures), sum(len(s) for s in signatures.values()))
