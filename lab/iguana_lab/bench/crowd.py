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
Several iguanas in one world (issue 33): the cost per character as the crowd grows, and randomized crossings.

`bench_crowd`: N iguanas in one world (`iguana_ros.world`), side by side 1.5 m apart, each walking 2 m ahead; each
run in a fresh spawned process (its own peak memory), the counts interleaved over the repeats; realtime factor, CPU
seconds per simulated character-second and peak memory, medians. `crossing_suite`: per seed, 2 to 4 iguanas on a
circle of random radius and phase, each walking to (about) the opposite point, their paths meeting in the middle:
whether every one arrives, the frames with body contact and the deepest contact.
"""
from __future__ import annotations

from concurrent.futures import ProcessPoolExecutor
import multiprocessing
import statistics
import time

import numpy as np

from iguana_lab.bench.sim import peak_rss_mb
from iguana_ros.errors import InputError

SPACING_M = 1.5
"""Distance between neighbouring iguanas of the crowd (no contact: the cost measured is the crowd's, not a pile's)."""
WALK_M = 2.0
"""How far ahead each iguana of the crowd walks."""
MEDIANS = ('realtime_factor', 'cpu_s_per_character_s', 'peak_rss_mb', 'wall_s')
"""The figures of a crowd size that are medians of its runs."""


def crowd_scene(n: int, resolution: str, seconds: float):
    """Return a flat scene of `n` iguanas of `resolution` in a row, each walking WALK_M ahead, for `seconds`."""
    from iguana_ros.scene import parse_scene
    extent = max(10.0, 2.0 * (SPACING_M * n + WALK_M) + 2.0)
    ys = (np.arange(n) - (n - 1) / 2.0) * SPACING_M
    characters = [{'name': f'iguana{i + 1}', 'start': {'x': 0.0, 'y': float(y)},
                   'goals': [{'x': WALK_M, 'y': float(y)}]} for i, y in enumerate(ys)]
    return parse_scene({'name': f'crowd{n}', 'terrain': {'kind': 'flat', 'extent': extent}, 'duration': seconds,
                        'model': {'resolution': resolution}, 'characters': characters})


def crowd_run(n: int, resolution: str, seconds: float) -> dict:
    """Run the crowd of `n` in this process; its speed, CPU per character-second and peak memory."""
    from iguana_ros.world import run_world
    run_world(crowd_scene(min(n, 2), resolution, 0.1))                 # compile or load the kernels first
    baseline = peak_rss_mb()
    cpu0, wall0 = time.process_time(), time.perf_counter()
    result = run_world(crowd_scene(n, resolution, seconds))
    cpu, wall = time.process_time() - cpu0, time.perf_counter() - wall0
    simulated = float(next(iter(result.characters.values())).times[-1])
    return {'iguanas': n, 'mesh': resolution, 'simulated_s': simulated, 'wall_s': result.wall_seconds,
            'realtime_factor': simulated / result.wall_seconds, 'cpu_s_per_character_s': cpu / (n * simulated),
            'peak_rss_mb': peak_rss_mb(), 'baseline_rss_mb': baseline, 'process_wall_s': wall,
            'body_contact_frames': len(result.contacts), 'outcome': result.outcome}


def _fresh(fn, *args):
    """Return `fn(*args)` run in a new spawned process of its own."""
    with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context('spawn')) as pool:
        return pool.submit(fn, *args).result()


def bench_crowd(counts: tuple[int, ...], resolution: str = 'medium', seconds: float = 2.0, repeats: int = 3) -> dict:
    """Time crowds of `counts` iguanas `repeats` times each (interleaved, fresh processes); medians and each run."""
    if not counts or min(counts) < 1:
        raise InputError(f'--iguanas: expected counts >= 1, got {counts}')
    runs: dict[int, list] = {n: [] for n in counts}
    for _ in range(repeats):
        for n in counts:
            runs[n].append(_fresh(crowd_run, n, resolution, seconds))
    rows = []
    for n in counts:
        row = {key: statistics.median(r[key] for r in runs[n]) for key in MEDIANS}
        rows.append({'iguanas': n, **row, 'runs': runs[n]})
    one = next((r for r in rows if r['iguanas'] == 1), rows[0])
    for row in rows:
        row['cpu_per_character_vs_one'] = row['cpu_s_per_character_s'] / one['cpu_s_per_character_s']
    return {'mesh': resolution, 'seconds': seconds, 'repeats': repeats, 'loop': 'library (iguana_ros.world)',
            'rows': rows}


def format_crowd(result: dict) -> str:
    """Return the crowd table as text."""
    lines = [f"crowd of {result['mesh']} iguanas in one world, {result['loop']} loop, {result['seconds']:g} s "
             f"simulated, medians of {result['repeats']} fresh-process runs",
             f"{'iguanas':>8} {'realtime':>9} {'CPU s per':>10} {'vs one':>7} {'peak MB':>8}",
             f"{'':>8} {'factor':>9} {'char. s':>10} {'':>7} {'':>8}"]
    for row in result['rows']:
        lines.append(f"{row['iguanas']:8d} {row['realtime_factor']:9.2f} {row['cpu_s_per_character_s']:10.3f} "
                     f"{row['cpu_per_character_vs_one']:7.2f} {row['peak_rss_mb']:8.0f}")
    return '\n'.join(lines)


def crossing_scene(seed: int, resolution: str = 'coarse', seconds: float = 20.0):
    """Return seed `seed`'s crossing: 2-4 iguanas on a circle of radius 1-1.6 m walking to about the far side."""
    from iguana_ros.scene import parse_scene
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 5))
    radius = float(rng.uniform(1.0, 1.6))
    phase = float(rng.uniform(0.0, 2.0 * np.pi))
    angles = phase + 2.0 * np.pi * np.arange(n) / n + rng.uniform(-0.2, 0.2, n)
    characters = []
    for i, a in enumerate(angles):
        far = a + np.pi + float(rng.uniform(-0.3, 0.3))
        characters.append({'name': f'iguana{i + 1}',
                           'start': {'x': radius * float(np.cos(a)), 'y': radius * float(np.sin(a)),
                                     'yaw_deg': float(np.degrees(np.arctan2(-np.sin(a), -np.cos(a))))},
                           'goals': [{'x': radius * float(np.cos(far)), 'y': radius * float(np.sin(far))}]})
    return parse_scene({'name': f'crossing_{seed}', 'terrain': {'kind': 'flat'}, 'duration': seconds,
                        'model': {'resolution': resolution}, 'characters': characters})


def crossing_run(seed: int, resolution: str = 'coarse', seconds: float = 20.0) -> dict:
    """Run seed `seed`'s crossing; whether every iguana arrived, the contact frames and the deepest contact."""
    from iguana_ros.metrics import goal_arrival
    from iguana_ros.world import run_world
    scene = crossing_scene(seed, resolution, seconds)
    result = run_world(scene)
    scenes = dict(scene.character_scenes())
    arrived = {}
    for name, run in result.characters.items():
        goal = scenes[name].goals[-1]
        arrived[name] = bool(goal_arrival(run.times, run.root_positions[:, :2], np.array([goal.x, goal.y]),
                                          scene.goal_radius)[0])
    depths = [p.max_depth for frame in result.contacts for p in frame.pairs]
    return {'seed': seed, 'iguanas': len(arrived), 'all_arrived': all(arrived.values()), 'arrived': arrived,
            'contact_frames': len(result.contacts), 'max_depth_mm': 1e3 * max(depths, default=0.0),
            'outcome': result.outcome}


def crossing_suite(seeds: tuple[int, ...], resolution: str = 'coarse', seconds: float = 20.0) -> dict:
    """Run the crossings of `seeds`; each one's figures and the totals."""
    runs = [crossing_run(seed, resolution, seconds) for seed in seeds]
    return {'mesh': resolution, 'seconds': seconds, 'runs': runs,
            'all_arrived': sum(r['all_arrived'] for r in runs), 'scenes': len(runs),
            'without_contact': sum(r['contact_frames'] == 0 for r in runs),
            'max_depth_mm': max((r['max_depth_mm'] for r in runs), default=0.0)}


def format_crossings(result: dict) -> str:
    """Return the crossing suite as text."""
    lines = [f"{'seed':>6} {'iguanas':>8} {'arrived':>8} {'contact frames':>15} {'deepest mm':>11}"]
    for r in result['runs']:
        lines.append(f"{r['seed']:6d} {r['iguanas']:8d} {sum(r['arrived'].values()):4d}/{r['iguanas']:<3d} "
                     f"{r['contact_frames']:15d} {r['max_depth_mm']:11.2f}")
    lines.append(f"every iguana arrived in {result['all_arrived']} of {result['scenes']} scenes; "
                 f"{result['without_contact']} without body contact; deepest {result['max_depth_mm']:.2f} mm")
    return '\n'.join(lines)
