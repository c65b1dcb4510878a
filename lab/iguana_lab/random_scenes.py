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

Two suites. `random_scenes`: hills, tilted planes, steps and smooth noise, each with one goal 3 m from the start in a
random direction (also behind the iguana, which starts facing +x), run with and without terrain adaptation.
`steering_scenes`: the steering suite, cycling through STEERING_CATEGORIES: goals near (0.4-1.2 m) and far (2-4.5 m)
in every direction, 3 m straight ahead and behind on the same hills (a pair), across 12-20 deg slopes in every
direction, over step fields, with a heading to arrive in, and routes of 3-5 waypoints; every fourth scene at the `fast`
fidelity preset, every fifth with the `softer` model. ROS-free; used by `iguana bench locomotion`
(iguana_lab.locomotion_bench) and `iguana sweep` (iguana_lab.sweep).
"""
from __future__ import annotations

import dataclasses
import math
from typing import Iterable

import numpy as np

from iguana_ros.errors import InputError
from iguana_ros.scene import GoalSpec, ModelSpec, parse_scene, RESOLUTIONS, Scene, TerrainSpec, WaypointSpec

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

    Lengths are in m, angles in deg.
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


STEERING_CATEGORIES = ('near', 'far', 'ahead', 'behind', 'slope', 'steps', 'heading', 'route', 'near')
"""The steering suite's scene categories, in the order `steering_scenes` cycles through them (near goals twice)."""
YAW_TOLERANCE_DEG = 30.0
"""Heading tolerance of the steering suite's goals, deg."""


def steering_scenes(n_scenes: int, seed: int, resolution: str = 'medium',
                    categories: Iterable[str] = STEERING_CATEGORIES) -> list[Scene]:
    """
    `n_scenes` scenes `steer_<category>_<index>` cycling through `categories` (see the module docstring).

    Scene `i` draws from its own generator `SeedSequence(seed, spawn_key=(i,))` (a 'behind' scene from the 'ahead'
    scene before it, so the pair shares its terrain), so lists are prefix-stable and the same (n, seed) gives the same
    scenes. Scene i uses the `fast` fidelity if i % 4 == 3, the `softer` model if i % 5 == 2 (a 'behind' scene as its
    'ahead' partner). Duration: 15 s plus 8 s
    per metre of the straight way, at most 60 s; goal radius GOAL_RADIUS, yaw tolerance YAW_TOLERANCE_DEG.
    """
    categories = tuple(categories)
    if not categories or any(c not in STEERING_CATEGORIES for c in categories):
        raise InputError(f'categories must be among {", ".join(sorted(set(STEERING_CATEGORIES)))}, '
                         f'got {", ".join(categories) or "none"}')
    _check_counts(n_scenes, seed, resolution)
    scenes = []
    for i in range(n_scenes):
        category = categories[i % len(categories)]
        key = i - 1 if category == 'behind' and i > 0 and categories[(i - 1) % len(categories)] == 'ahead' else i
        rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(key,)))
        terrain, goals, route = _STEERING[category](rng)
        if key != i:                                     # the pair's terrain, the goal mirrored behind the start
            goals = (GoalSpec(x=-goals[0].x, y=goals[0].y),)
        way = _way_length(goals, route)
        scene = Scene(name=f'steer_{category}_{i:03d}',
                      description=f'steering benchmark (seed {seed}): {category}, {way:.2f} m', terrain=terrain,
                      model=ModelSpec(resolution=resolution, stiffness='softer' if key % 5 == 2 else 'normal'),
                      goals=goals, route=route, goal_radius=GOAL_RADIUS, goal_yaw_tolerance_deg=YAW_TOLERANCE_DEG,
                      duration=float(round(min(60.0, 15.0 + 8.0 * way), 1)),
                      fidelity='fast' if key % 4 == 3 else 'balanced', adaptation=True)
        scenes.append(parse_scene(dataclasses.asdict(scene), scene.name))
    return scenes


def scene_category(scene: Scene) -> str:
    """Return the steering category of a `steering_scenes` scene ('' for another scene)."""
    parts = scene.name.split('_')
    return parts[1] if len(parts) == 3 and parts[0] == 'steer' and parts[1] in STEERING_CATEGORIES else ''


def _check_counts(n: int, seed: int, resolution: str) -> None:
    """Raise InputError unless `n` and `seed` are integers >= 0 and `resolution` a mesh resolution."""
    if resolution not in RESOLUTIONS:
        raise InputError(f'mesh resolution must be one of {", ".join(RESOLUTIONS)}, got {resolution!r}')
    for name, value in (('number of scenes', n), ('seed', seed)):
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            raise InputError(f'{name} must be an integer >= 0, got {value!r}')


def _way_length(goals: tuple, route: tuple) -> float:
    """Length (m) of the straight way from the start (0, 0) through the route's waypoints or to the goal."""
    points = [(0.0, 0.0)] + [(p.x, p.y) for p in (route or goals)]
    return float(sum(math.hypot(b[0] - a[0], b[1] - a[1]) for a, b in zip(points[:-1], points[1:])))


def _goal_at(rng: np.random.Generator, low: float, high: float, heading: bool = False) -> GoalSpec:
    """Return a goal `low`..`high` m from the start in a uniform direction (with a uniform heading if asked)."""
    distance, direction = rng.uniform(low, high), rng.uniform(0.0, 2.0 * np.pi)
    yaw = round(float(rng.uniform(-180.0, 180.0)), 2) if heading else None
    return GoalSpec(x=round(distance * math.cos(direction), 4), y=round(distance * math.sin(direction), 4),
                    yaw_deg=yaw)


def _gentle(rng: np.random.Generator) -> TerrainSpec:
    """Flat ground or gentle hills (amplitude 2-5 cm), evenly."""
    if rng.uniform() < 0.5:
        return TerrainSpec(kind='flat', extent=TERRAIN_EXTENT)
    return TerrainSpec(kind='hills', amplitude=round(float(rng.uniform(0.02, 0.05)), 4),
                       wavelength=round(float(rng.uniform(0.6, 1.4)), 4), seed=int(rng.integers(0, 1_000_000)),
                       extent=TERRAIN_EXTENT)


def _near(rng):
    """Draw a goal 0.4-1.2 m away on gentle ground."""
    return _gentle(rng), (_goal_at(rng, 0.4, 1.2),), ()


def _far(rng):
    """Draw a goal 2-4.5 m away on hills or noise."""
    return _random_terrain(('hills', 'noise')[int(rng.integers(0, 2))], rng), (_goal_at(rng, 2.0, 4.5),), ()


def _ahead(rng):
    """Draw a goal 3 m ahead (within 15 deg) on hills."""
    terrain = TerrainSpec(kind='hills', amplitude=round(float(rng.uniform(0.03, 0.08)), 4),
                          wavelength=round(float(rng.uniform(0.6, 1.4)), 4), seed=int(rng.integers(0, 1_000_000)),
                          extent=TERRAIN_EXTENT)
    angle = np.radians(rng.uniform(-15.0, 15.0))
    return terrain, (GoalSpec(x=round(3.0 * math.cos(angle), 4), y=round(3.0 * math.sin(angle), 4)),), ()


def _slope(rng):
    """Draw a goal 2-4 m away on a plane tilted 12-20 deg in any direction."""
    terrain = TerrainSpec(kind='tilted', slope_deg=round(float(rng.uniform(12.0, 20.0)), 3),
                          direction_deg=round(float(rng.uniform(0.0, 360.0)), 2), extent=TERRAIN_EXTENT)
    return terrain, (_goal_at(rng, 2.0, 4.0),), ()


def _steps(rng):
    """Draw a goal 2-4 m away over a field of 3-5 cm steps."""
    return _random_terrain('steps', rng), (_goal_at(rng, 2.0, 4.0),), ()


def _heading(rng):
    """Draw a goal 0.4-2.5 m away with a heading, on gentle ground."""
    return _gentle(rng), (_goal_at(rng, 0.4, 2.5, heading=True),), ()


def _route(rng):
    """Draw a route of 3-5 waypoints, legs of 0.6-1.5 m turning up to 120 deg, half the time with a heading."""
    terrain, points, direction = _gentle(rng), [], rng.uniform(0.0, 2.0 * np.pi)
    x = y = 0.0
    for k in range(int(rng.integers(3, 6))):
        direction += rng.uniform(-np.radians(120.0), np.radians(120.0)) if k else 0.0
        leg = rng.uniform(0.6, 1.5)
        x = float(np.clip(x + leg * math.cos(direction), -4.0, 4.0))
        y = float(np.clip(y + leg * math.sin(direction), -4.0, 4.0))
        points.append(WaypointSpec(x=round(x, 4), y=round(y, 4)))
    if rng.uniform() < 0.5:
        points[-1] = dataclasses.replace(points[-1], yaw_deg=round(float(rng.uniform(-180.0, 180.0)), 2))
    return terrain, (), tuple(points)


_STEERING = {'near': _near, 'far': _far, 'ahead': _ahead, 'behind': _ahead, 'slope': _slope, 'steps': _steps,
             'heading': _heading, 'route': _route}
