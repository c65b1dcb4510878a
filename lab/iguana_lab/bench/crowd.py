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
seconds per simulated character-second and peak memory, medians. With `nodes` the same scene also runs as `iguana
run` (`supervisor.run.run_scene`: a simulator process stepping every body, a process per character) from a fresh
process: the loop's realtime factor, the node processes' CPU per character-second while stepping (the supervisor's
samples; with the recorder and `iguana run` as a second figure) and the sum of the node processes' peak memory
(`ChildMemory`). `crossing_suite`: per seed, 2 to 4 iguanas on a circle of random radius and phase, each walking to
(about) the opposite point, their paths meeting in the middle: whether every one arrives, the frames with body
contact and the deepest contact.
"""
from __future__ import annotations

from concurrent.futures import ProcessPoolExecutor
import multiprocessing
import os
from pathlib import Path
import statistics
import tempfile
import threading
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
NODE_MEDIANS = ('realtime_factor', 'cpu_s_per_character_s', 'cpu_s_per_character_s_all', 'peak_rss_mb', 'wall_s',
                'total_wall_s', 'outside_stepping_s')
"""The figures of a crowd size's node runs that are medians of them."""
SUPERVISION = ('recorder', 'iguana run')
"""Processes of a node run that are not nodes: left out of its node CPU (`cpu_s_per_character_s`), kept in `_all`."""
MEMORY_SAMPLE_S = 0.25
"""Wall seconds between two looks at the node processes' peak memory (`ChildMemory`)."""


def crowd_scene_dict(n: int, resolution: str, seconds: float) -> dict:
    """Return the scene file's content of `crowd_scene` (what `iguana run` reads)."""
    extent = max(10.0, 2.0 * (SPACING_M * n + WALK_M) + 2.0)
    ys = (np.arange(n) - (n - 1) / 2.0) * SPACING_M
    characters = [{'name': f'iguana{i + 1}', 'start': {'x': 0.0, 'y': float(y)},
                   'goals': [{'x': WALK_M, 'y': float(y)}]} for i, y in enumerate(ys)]
    return {'name': f'crowd{n}', 'terrain': {'kind': 'flat', 'extent': extent}, 'duration': float(seconds),
            'model': {'resolution': resolution}, 'characters': characters}


def crowd_scene(n: int, resolution: str, seconds: float):
    """Return a flat scene of `n` iguanas of `resolution` in a row, each walking WALK_M ahead, for `seconds`."""
    from iguana_ros.scene import parse_scene
    return parse_scene(crowd_scene_dict(n, resolution, seconds))


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


def _status_kb(pid: int, key: str) -> int | None:
    """Return the `key` line of /proc/<pid>/status in kB (VmHWM, VmRSS); None if it is gone or has none."""
    try:
        for line in Path(f'/proc/{pid}/status').read_text().splitlines():
            if line.startswith(key + ':'):
                return int(line.split()[1])
    except (OSError, ValueError, IndexError):
        return None
    return None


def _children(parent: int) -> list[int]:
    """Return the pids of the live child processes of `parent` (a scan of /proc; [] where there is none)."""
    from iguana_ros.supervisor.process import stat_fields
    found = []
    for entry in os.listdir('/proc') if os.path.isdir('/proc') else ():
        if entry.isdigit():
            fields = stat_fields(int(entry))
            if fields is not None and len(fields) > 1 and fields[1] == str(parent) and fields[0] != 'Z':
                found.append(int(entry))
    return found


def _process_name(pid: int) -> str | None:
    """Return 'simulator_node', a character's name (its `__ns`), 'recorder' or None from `pid`'s command line."""
    from iguana_ros.executables import NODE_PACKAGE
    try:
        args = Path(f'/proc/{pid}/cmdline').read_bytes().decode(errors='replace').split('\0')
    except OSError:
        return None
    if f'{NODE_PACKAGE}.simulator_node' in args:
        return 'simulator_node'
    if f'{NODE_PACKAGE}.all_nodes' in args:
        return next((a.split(':=/', 1)[1] for a in args if a.startswith('__ns:=/')), 'all_nodes')
    return 'recorder' if 'record' in args and 'bag' in args else None


class ChildMemory:
    """
    Peak resident memory (VmHWM) of each child process of this one, by name, sampled while inside (`with`).

    A look every MEMORY_SAMPLE_S from a thread keeps the largest peak seen of each process (a peak only grows, so
    what is missed is the growth in its last MEMORY_SAMPLE_S); empty where there is no /proc.
    """

    def __init__(self) -> None:
        """Nothing sampled yet."""
        self.peak_kb: dict[str, int] = {}
        self._names: dict[int, str] = {}
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._watch, name='crowd-memory', daemon=True)

    def __enter__(self) -> 'ChildMemory':
        """Start sampling."""
        self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        """Stop sampling (each process's last look was while it ran, at most MEMORY_SAMPLE_S before it ended)."""
        self._stop.set()
        self._thread.join()

    def _watch(self) -> None:
        """Sample until stopped."""
        while not self._stop.wait(MEMORY_SAMPLE_S):
            self.sample()

    def sample(self) -> None:
        """Note the peak memory of every child of this process now (named once it runs its command)."""
        for pid in _children(os.getpid()):
            name = self._names.get(pid) or _process_name(pid)
            peak = _status_kb(pid, 'VmHWM')
            if name is None or peak is None:
                continue
            self._names[pid] = name
            self.peak_kb[name] = max(self.peak_kb.get(name, 0), peak)

    def peak_mb(self) -> dict[str, float]:
        """Return each process's peak resident memory, MB, by name."""
        return {name: kb / 1024.0 for name, kb in self.peak_kb.items()}


def crowd_node_run(n: int, resolution: str, seconds: float) -> dict:
    """Run the crowd of `n` as `iguana run` from this process; its speed, CPU per character-second and memory."""
    import yaml

    from iguana_ros.constants import FRAME_RATE
    from iguana_ros.errors import IguanaError
    from iguana_ros.supervisor.run import run_scene, RunOptions
    with tempfile.TemporaryDirectory(prefix='iguana_crowd_') as tmp:
        path = Path(tmp) / f'crowd{n}.yaml'
        scene = crowd_scene_dict(n, resolution, seconds)
        path.write_text(yaml.safe_dump(scene, sort_keys=False))
        with ChildMemory() as memory:
            summary = run_scene(RunOptions(scene=str(path), record=Path(tmp) / 'bag',
                                           timeout=300.0 + 60.0 * n * seconds))
    if summary.exit_code != 0:
        tail = f' ({summary.failed_node}: {summary.message.strip().splitlines()[-1]})' if summary.message else ''
        raise IguanaError(f'the node run of {n} iguanas: {summary.outcome_text()}{tail}')
    cpu = summary.cpu_ms_per_frame
    names = ['simulator_node', *summary.characters]
    if len(summary.characters) != n or not set(names) <= set(cpu):
        raise IguanaError(f'the node run of {n} iguanas: no CPU figures of ' + ', '.join(sorted(set(names) - set(cpu)))
                          + ' (Linux /proc needed)')
    peaks = memory.peak_mb()
    nodes_ms = sum(ms for name, ms in cpu.items() if name not in SUPERVISION)
    per_second = FRAME_RATE / 1e3 / n               # CPU ms per frame of the world -> CPU s per character-second
    return {'iguanas': n, 'mesh': resolution, 'simulated_s': summary.simulated_s, 'wall_s': summary.wall_s,
            'total_wall_s': summary.total_wall_s, 'outside_stepping_s': summary.total_wall_s - summary.wall_s,
            'realtime_factor': summary.realtime_factor,
            'cpu_s_per_character_s': nodes_ms * per_second,
            'cpu_s_per_character_s_all': sum(cpu.values()) * per_second,
            'cpu_ms_per_frame_by_process': dict(cpu),
            'peak_rss_mb': sum(mb for name, mb in peaks.items() if name not in SUPERVISION),
            'peak_rss_mb_by_process': peaks, 'reached_goal': summary.reached_goal, 'outcome': summary.outcome}


def _fresh(fn, *args):
    """Return `fn(*args)` run in a new spawned process of its own."""
    with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context('spawn')) as pool:
        return pool.submit(fn, *args).result()


def bench_crowd(counts: tuple[int, ...], resolution: str = 'medium', seconds: float = 2.0, repeats: int = 3,
                nodes: bool = False) -> dict:
    """
    Time crowds of `counts` iguanas `repeats` times each (interleaved, fresh processes); medians and each run.

    With `nodes` each library run is followed by a node run of the same crowd (`crowd_node_run`), its figures under
    the row's 'nodes'.
    """
    if not counts or min(counts) < 1:
        raise InputError(f'--iguanas: expected counts >= 1, got {counts}')
    runs: dict[int, list] = {n: [] for n in counts}
    node_runs: dict[int, list] = {n: [] for n in counts}
    for _ in range(repeats):
        for n in counts:
            runs[n].append(_fresh(crowd_run, n, resolution, seconds))
            if nodes:
                node_runs[n].append(_fresh(crowd_node_run, n, resolution, seconds))
    rows = []
    for n in counts:
        row = {key: statistics.median(r[key] for r in runs[n]) for key in MEDIANS}
        rows.append({'iguanas': n, **row, 'runs': runs[n]})
        if nodes:
            rows[-1]['nodes'] = {**{key: statistics.median(r[key] for r in node_runs[n]) for key in NODE_MEDIANS},
                                 'runs': node_runs[n]}
    one = next((r for r in rows if r['iguanas'] == 1), rows[0])
    for row in rows:
        row['cpu_per_character_vs_one'] = row['cpu_s_per_character_s'] / one['cpu_s_per_character_s']
        if nodes:
            row['nodes']['cpu_per_character_vs_one'] = (row['nodes']['cpu_s_per_character_s']
                                                        / one['nodes']['cpu_s_per_character_s'])
    result = {'mesh': resolution, 'seconds': seconds, 'repeats': repeats, 'loop': 'library (iguana_ros.world)',
              'rows': rows}
    if nodes:
        result['nodes_loop'] = ('iguana run (a simulator process of every body, a process per character); CPU of the '
                                'node processes while stepping (cpu_s_per_character_s), with the recorder and iguana '
                                "run (cpu_s_per_character_s_all); peak_rss_mb: the sum of the node processes' peaks")
    return result


def format_crowd(result: dict) -> str:
    """Return the crowd table as text (with the node runs' columns after the library's when there are any)."""
    nodes = 'nodes_loop' in result
    lines = [f"crowd of {result['mesh']} iguanas in one world, {result['loop']} loop, {result['seconds']:g} s "
             f"simulated, medians of {result['repeats']} fresh-process runs",
             f"{'iguanas':>8} {'realtime':>9} {'CPU s per':>10} {'vs one':>7} {'peak MB':>8}",
             f"{'':>8} {'factor':>9} {'char. s':>10} {'':>7} {'':>8}"]
    if nodes:
        lines[1:1] = ['right of |: the same crowd as iguana run, a simulator process and one per character;',
                      "  CPU s: the node processes' while stepping (CPU all: with the recorder and iguana run);",
                      "  peak MB: the sum of the node processes' peaks; start s: wall s of the run outside the "
                      'stepping']
        lines[4] += f" | {'realtime':>9} {'CPU s per':>10} {'vs one':>7} {'CPU all':>8} {'peak MB':>8} {'start s':>8}"
        lines[5] += f" | {'factor':>9} {'char. s':>10} {'':>7} {'':>8} {'':>8} {'':>8}"
    for row in result['rows']:
        line = (f"{row['iguanas']:8d} {row['realtime_factor']:9.2f} {row['cpu_s_per_character_s']:10.3f} "
                f"{row['cpu_per_character_vs_one']:7.2f} {row['peak_rss_mb']:8.0f}")
        if nodes:
            one = row['nodes']
            line += (f" | {one['realtime_factor']:9.2f} {one['cpu_s_per_character_s']:10.3f} "
                     f"{one['cpu_per_character_vs_one']:7.2f} {one['cpu_s_per_character_s_all']:8.3f} "
                     f"{one['peak_rss_mb']:8.0f} {one['outside_stepping_s']:8.1f}")
        lines.append(line)
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
