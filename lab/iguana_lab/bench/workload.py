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

"""Benchmark scenes for the simulator: the iguana (or a stand-in) on hills, driven by a lateral-bend gait."""
from __future__ import annotations

from dataclasses import dataclass
import time

import numpy as np

from iguana_ros.constants import FRAME_RATE
from iguana_ros.errors import InputError
from iguana_ros.physics.meshes import box_mesh
from iguana_ros.physics.side_by_side import SideBySide

STAND_IN_CELLS = {'coarse': (16, 2, 2), 'medium': (44, 2, 2), 'fine': (48, 4, 4), 'finer': (64, 6, 4)}
"""Cells of the box stand-in used while `iguana_ros.body.model` is unavailable (153, 405, 1225, 2275 nodes)."""


def bench_model(resolution: str = 'medium', stiffness: str = 'normal'):
    """
    Return `(model, name)`: the iguana model at `resolution`, or a box stand-in if the body model is not installed.

    The stand-in is a 0.85 m box of similar node count.
    """
    if resolution not in STAND_IN_CELLS:
        raise InputError(f'mesh resolution must be one of {sorted(STAND_IN_CELLS)}, got {resolution!r}')
    try:
        from iguana_ros.body.model import build_model
    except ImportError:
        from iguana_ros.constants import BODY_LENGTH, BODY_MASS

        model = box_mesh(size=(BODY_LENGTH, 0.12, 0.06), cells=STAND_IN_CELLS[resolution], total_mass=BODY_MASS)
        return model, f'box stand-in ({resolution})'
    return build_model(resolution=resolution, stiffness=stiffness), f'iguana ({resolution}, {stiffness})'


@dataclass
class LateralBendGait:
    """
    Desired spring lengths of a travelling lateral bend: l_d = l_0 (1 − κ(t, x) y u_x²).

    κ(t, x) = `curvature` sin(2π (`frequency` t − x / `wavelength`)) (1/m); x, y are a spring's rest midpoint
    (forward, left) and u_x its rest direction's forward component: the axial strain of a bent beam.
    """

    rest_positions: np.ndarray
    springs: np.ndarray
    rest_lengths: np.ndarray
    curvature: float = 4.0
    frequency: float = 1.5
    wavelength: float = 0.9

    def __post_init__(self) -> None:
        a = self.rest_positions[self.springs[:, 0]]
        b = self.rest_positions[self.springs[:, 1]]
        mid = 0.5 * (a + b)
        ux = (b[:, 0] - a[:, 0]) / np.maximum(self.rest_lengths, 1e-12)
        self._x = mid[:, 0]
        self._lever = mid[:, 1] * ux ** 2 * self.rest_lengths

    def desired_lengths(self, t: float) -> np.ndarray:
        """Desired spring lengths `(n_springs,)` m at time `t` s."""
        kappa = self.curvature * np.sin(2 * np.pi * (self.frequency * t - self._x / self.wavelength))
        return self.rest_lengths - kappa * self._lever


def gait_for(model, **kwargs) -> LateralBendGait:
    """Return a `LateralBendGait` for `model`."""
    return LateralBendGait(np.asarray(model.rest_positions), np.asarray(model.springs),
                           np.asarray(model.spring_rest_lengths), **kwargs)


def walk_on_hills(model, frames: int, preset: str = 'balanced', **overrides):
    """Return a `SoftBodySimulator` of `model` after `frames` frames of its gait on 3 cm hills, started 3 cm up."""
    from iguana_ros.physics.simulator import SoftBodySimulator
    from iguana_ros.terrain.heightfield import HeightField

    terrain = HeightField.hills(amplitude=0.03, wavelength=0.6, seed=0, extent=3.0)
    sim = SoftBodySimulator(model, terrain, preset, **overrides)
    sim.reset(sim.rest_positions + [0.0, 0.0, 0.03])
    gait = gait_for(model)
    for _ in range(frames):
        sim.advance_frame(gait.desired_lengths(sim.time))
    return sim


def run_gait(sim, gait: LateralBendGait, seconds: float) -> dict:
    """Drive `sim` with `gait` for `seconds` (whole frames); returns wall times of simulation and gait."""
    return run_gaits([sim], gait, seconds)


def run_gaits(sims: list, gait: LateralBendGait, seconds: float, threads: SideBySide | None = None) -> dict:
    """
    Drive each of `sims` with `gait` for `seconds`, a frame of every one at a time; wall times of simulation and gait.

    With `threads` the sims of a frame are stepped side by side (as a world steps bodies apart), else in turn.
    """
    n_frames = int(round(seconds * FRAME_RATE))
    sim_wall = 0.0
    gait_wall = 0.0
    costs = [len(sim.rest_positions) for sim in sims]
    for _ in range(n_frames):  # one Python iteration per 1/30 s frame; the steps run inside one compiled call
        t0 = time.perf_counter()
        lengths = [gait.desired_lengths(sim.time) for sim in sims]
        t1 = time.perf_counter()
        if threads is None:
            for sim, ld in zip(sims, lengths):
                sim.advance_frame(ld)
        else:
            threads.run([lambda sim=sim, ld=ld: sim.advance_frame(ld) for sim, ld in zip(sims, lengths)], costs)
        sim_wall += time.perf_counter() - t1
        gait_wall += t1 - t0
    return {'frames': n_frames, 'sim_wall_s': sim_wall, 'gait_wall_s': gait_wall}
