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
Seeded random scenes of the locomotion benchmark.

Hills, tilted planes, steps and smooth noise, each with one goal 3 m from the start in a random direction (also behind
the iguana, which starts facing +x). ROS-free; used by `iguana bench locomotion` (iguana_ros.locomotion_bench) and
`iguana sweep` (iguana_ros.sweep).
"""
from __future__ import annotations

import dataclasses
import math
from typing import Iterable

import numpy as np

from iguana_ros.errors import InputError
from iguana_ros.scene import GoalSpec, ModelSpec, parse_scene, RESOLUTIONS, Scene, TerrainSpec

BENCH_KINDS = ('hills', 'tilted', 'steps', 'noise')
"""Terrain kinds of the benchmark, in the order `random_scenes` cycles through them."""
GOAL_DISTANCE = 3.0
"""Distance (m) of each scene's goal from the start (0, 0)."""
GOAL_RADIUS = 0.2
TERRAIN_EXTENT = 10.0
"""Side (m) of every benchmark terrain, centred on the start."""


def _random_terrain(kind: str, rng: np.random.Generator) -> TerrainSpec:
    """
    Return a TerrainSpec of `kind` with parameters drawn from the benchmark's ranges.

    (lengths in m, angles in deg).
    """
    seed = int(rng.integers(0, 1_000_000))
    if kind == 'hills':
        params = {'amplitude': rng.uniform(0.03, 0.12), 'wavelength': rng.uniform(0.5, 1.4), 'seed': seed}
    elif kind == 'tilted':
        params = {'slope_deg': rng.uniform(5.0, 15.0), 'direction_deg': rng.uniform(0.0, 360.0)}
    elif kind == 'steps':
        params = {'block_size': 0.3, 'step_min': 0.03, 'step_max': 0.05, 'seed': seed}
    else:
        params = {'amplitude': rng.uniform(0.03, 0.10), 'wavelength': rng.uniform(0.4, 1.2), 'seed': seed}
    params = {k: v if isinstance(v, int) else round(float(v), 4) for k, v in params.items()}
    return TerrainSpec(kind=kind, extent=TERRAIN_EXTENT, **params)


def random_scenes(n_terrains: int, seed: int, duration: float = 40.0, resolution: str = 'medium',
                  kinds: Iterable[str] = BENCH_KINDS) -> list[Scene]:
    """
    `n_terrains` scenes `bench_<kind>_<index>` cycling through `kinds`, each with one goal 3 m away.

    Scene `i` draws its terrain parameters and goal direction (uniform over the full circle) from its own
    generator, `SeedSequence(seed, spawn_key=(i,))`: the same (n, seed) always gives the same scenes, and the
    first scenes of a longer list are those of a shorter one. Model `resolution`, fidelity 'balanced',
    `duration` s, goal radius 0.2 m, terrain 10 m square. Raises InputError on a bad argument.
    """
    kinds = tuple(kinds)
    if not kinds or any(k not in BENCH_KINDS for k in kinds):
        raise InputError(f'terrain kinds must be among {", ".join(BENCH_KINDS)}, got {", ".join(kinds) or "none"}')
    if resolution not in RESOLUTIONS:
        raise InputError(f'mesh resolution must be one of {", ".join(RESOLUTIONS)}, got {resolution!r}')
    if isinstance(n_terrains, bool) or not isinstance(n_terrains, int) or n_terrains < 0:
        raise InputError(f'number of terrains must be an integer >= 0, got {n_terrains!r}')
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise InputError(f'seed must be an integer >= 0, got {seed!r}')
    if not (math.isfinite(duration) and duration > 0):
        raise InputError(f'duration must be a positive number of seconds, got {duration!r}')
    scenes = []
    for i in range(n_terrains):
        rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(i,)))
        kind = kinds[i % len(kinds)]
        terrain = _random_terrain(kind, rng)
        heading = rng.uniform(0.0, 2.0 * np.pi)
        goal = GoalSpec(x=round(GOAL_DISTANCE * math.cos(heading), 4), y=round(GOAL_DISTANCE * math.sin(heading), 4))
        name = f'bench_{kind}_{i:03d}'
        scene = Scene(name=name, description=f'locomotion benchmark (seed {seed}): {kind} terrain, goal 3 m away',
                      terrain=terrain, model=ModelSpec(resolution=resolution), goals=(goal,), goal_radius=GOAL_RADIUS,
                      duration=float(duration), fidelity='balanced', adaptation=True)
        scenes.append(parse_scene(dataclasses.asdict(scene), name))     # the scene file rules hold for these too
    return scenes
