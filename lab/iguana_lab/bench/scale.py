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
Simulator speed at scale (issue 34): ms per step against the body's mesh and against the number of bodies.

Every run is the gait scene of `iguana bench sim` (lateral-bend gait on the benchmark hills) in a fresh spawned
process, so its peak RSS is its own (the interpreter, NumPy and the compiled code included; `baseline_rss_mb` is the
peak before any model is built). N bodies are N independent `SoftBodySimulator`s of one model in one process, each
driven by the same gait, a frame of all of them stepped side by side on the process's cores as `world.BodyWorld` steps
bodies apart (`physics.side_by_side`; the crowd bench times whole worlds with planners). Runs are interleaved (every
configuration once, then again) so a drift of the machine's speed moves them alike; the 1-body run of the bodies'
mesh serves both tables.
"""
from __future__ import annotations

from concurrent.futures import ProcessPoolExecutor
import math
import multiprocessing
import os
import time

import numpy as np

from iguana_lab.bench.sim import cpu_model, make_scene, peak_rss_mb, warm_up
from iguana_lab.bench.workload import run_gaits, STAND_IN_CELLS
from iguana_ros.errors import IguanaError, InputError
from iguana_ros.physics.errors import SimulationDiverged
from iguana_ros.physics.side_by_side import default_workers, SideBySide

MESHES = ('coarse', 'medium', 'fine', 'finer')
"""The meshes `bench_scale` times by default (about 170, 400, 1,200 and 2,300 nodes)."""
BODIES = (1, 2, 4, 8)
"""The body counts `bench_scale` times by default."""
MEDIANS = ('ms_per_step', 'cpu_ms_per_step', 'realtime_factor', 'realtime_factor_cpu', 'cpu_s_per_character_s',
           'peak_rss_mb')
"""The figures of a configuration that are medians of its runs (wall ms per step, CPU ms per step, ...)."""
BODIES_NOTE = ('N independent SoftBodySimulators in one process, each driven by the same gait, a frame of all of '
               'them stepped side by side on the cores as a world steps bodies apart (physics.side_by_side)')


def world_run(resolution: str, n_bodies: int, seconds: float, preset: str = 'balanced') -> dict:
    """Time `n_bodies` gait scenes of `resolution` advanced in turn in this process; sizes, speed, CPU and memory."""
    baseline = peak_rss_mb()
    scenes = [make_scene(resolution, preset) for _ in range(n_bodies)]
    sims, gait = [scene[0] for scene in scenes], scenes[0][1]
    compile_s = sum(warm_up(sim, gait) for sim in sims)
    threads = SideBySide(min(default_workers(), n_bodies))
    cpu0 = time.process_time()
    try:
        timing = run_gaits(sims, gait, seconds, threads)
    except SimulationDiverged as exc:
        raise IguanaError(f'{resolution} x{n_bodies}: the simulation diverged ({exc})') from None
    finally:
        threads.close()
    cpu_s = time.process_time() - cpu0 - timing['gait_wall_s']
    sim = sims[0]
    steps = sim.stats['steps']
    return {'model': scenes[0][2], 'nodes': len(sim.rest_positions), 'tets': len(sim.model.tets),
            'springs': len(sim.desired_lengths_rest), 'dt': sim.fidelity.dt, 'bodies': n_bodies,
            'simulated_s': sim.time, 'steps_per_body': steps, 'steps': sum(s.stats['steps'] for s in sims),
            'wall_s': timing['sim_wall_s'], 'cpu_s': cpu_s, 'ms_per_step': 1e3 * timing['sim_wall_s'] / steps,
            'cpu_ms_per_step': 1e3 * cpu_s / steps,
            'realtime_factor': sim.time / timing['sim_wall_s'], 'realtime_factor_cpu': sim.time / cpu_s,
            'cpu_s_per_character_s': cpu_s / (n_bodies * sim.time),
            'peak_rss_mb': peak_rss_mb(), 'baseline_rss_mb': baseline, 'compile_s': compile_s,
            'model_build_s': scenes[0][3]}


def in_fresh_process(fn, *args):
    """Return `fn(*args)` run in a new spawned process of its own."""
    with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context('spawn')) as pool:
        return pool.submit(fn, *args).result()


def check_scale_args(meshes: tuple, bodies: tuple, bodies_mesh: str, seconds: float, repeats: int) -> None:
    """Raise InputError (one line) unless the arguments of `bench_scale` make a benchmark."""
    unknown = [m for m in (*meshes, bodies_mesh) if m not in STAND_IN_CELLS]
    if unknown:
        raise InputError(f'unknown mesh {unknown[0]!r}; expected one of: {", ".join(STAND_IN_CELLS)}')
    if not meshes and not bodies:
        raise InputError('nothing to measure: give at least one mesh or one body count')
    if any(not isinstance(n, int) or n < 1 for n in bodies):
        raise InputError(f'body counts must be integers >= 1, got {list(bodies)}')
    if not 0 < seconds < math.inf or repeats < 1:
        raise InputError(f'need seconds > 0 and repeats >= 1, got {seconds!r} and {repeats!r}')


def bench_scale(meshes: tuple = MESHES, bodies: tuple = BODIES, bodies_mesh: str = 'medium', seconds: float = 2.0,
                preset: str = 'balanced', repeats: int = 3, run=None) -> dict:
    """
    Return ms per step against the mesh (1 body) and against the number of bodies (on `bodies_mesh`), JSON-able.

    Each configuration runs `repeats` times, `seconds` simulated each, every run in a fresh process (`run`, default
    `in_fresh_process`, calls `world_run`); the figures are medians of the runs, which are listed.
    """
    meshes, bodies = tuple(dict.fromkeys(meshes)), tuple(dict.fromkeys(bodies))
    check_scale_args(meshes, bodies, bodies_mesh, seconds, repeats)
    run = run or in_fresh_process
    configs = list(dict.fromkeys([(m, 1) for m in meshes] + [(bodies_mesh, n) for n in bodies]))
    load_before = os.getloadavg()
    runs = {config: [] for config in configs}
    for _ in range(repeats):
        for config in configs:
            runs[config].append(run(world_run, *config, seconds, preset))
    mesh_rows = [mesh_row(m, runs[(m, 1)]) for m in meshes]
    body_rows = body_table([runs[(bodies_mesh, n)] for n in bodies])
    return {'preset': preset, 'seconds': seconds, 'repeats': repeats, 'meshes': mesh_rows,
            'mesh_growth': mesh_growth(mesh_rows), 'bodies_mesh': bodies_mesh, 'bodies': body_rows,
            'bodies_note': BODIES_NOTE, 'measured_in': 'a fresh spawned process per run',
            'cpu_model': cpu_model(), 'cpus_available': len(os.sched_getaffinity(0)),
            'load_average_before': list(load_before), 'load_average_after': list(os.getloadavg())}


def _median(runs: list, key: str) -> float:
    """Median of `key` over `runs`."""
    return float(np.median([r[key] for r in runs]))


def _speed(runs: list) -> dict:
    """Return the runs' figures and the medians of MEDIANS over them."""
    fields = MEDIANS + ('steps', 'wall_s', 'cpu_s', 'baseline_rss_mb', 'compile_s')
    return {'runs': [{k: r[k] for k in fields} for r in runs], **{k: _median(runs, k) for k in MEDIANS},
            'steps': runs[0]['steps'], 'steps_per_body': runs[0]['steps_per_body'],
            'simulated_s': runs[0]['simulated_s'], 'dt': runs[0]['dt']}


def mesh_row(mesh: str, runs: list) -> dict:
    """Return one mesh's sizes, median speed, and cost per node and per spring of a step, µs."""
    row = {'mesh': mesh, 'model': runs[0]['model'], 'nodes': runs[0]['nodes'], 'tets': runs[0]['tets'],
           'springs': runs[0]['springs'], **_speed(runs)}
    row['us_per_node_step'] = 1e3 * row['ms_per_step'] / row['nodes']
    row['us_per_spring_step'] = 1e3 * row['ms_per_step'] / row['springs']
    return row


def mesh_growth(rows: list) -> list:
    """Return, between consecutive meshes, the ratios of ms per step, nodes, tets and springs, and the exponent."""
    out = []
    for a, b in zip(rows, rows[1:]):
        ms, nodes = b['ms_per_step'] / a['ms_per_step'], b['nodes'] / a['nodes']
        out.append({'from': a['mesh'], 'to': b['mesh'], 'ms_per_step_ratio': ms, 'node_ratio': nodes,
                    'tet_ratio': b['tets'] / a['tets'], 'spring_ratio': b['springs'] / a['springs'],
                    'exponent_in_nodes': math.log(ms) / math.log(nodes) if nodes != 1 else None})
    return out


def body_table(runs_per_count: list) -> list:
    """Return one row per body count: median speed of the world, cost per character relative to 1 body (wall, CPU)."""
    rows = [{'bodies': runs[0]['bodies'], **_speed(runs)} for runs in runs_per_count]
    single = next((r for r in rows if r['bodies'] == 1), None)
    for row in rows:
        row['ms_per_character_step'] = row['ms_per_step'] / row['bodies']
        row['cost_per_character_vs_1'] = row['ms_per_character_step'] / single['ms_per_step'] if single else None
        row['cpu_cost_per_character_vs_1'] = (row['cpu_ms_per_step'] / row['bodies'] / single['cpu_ms_per_step']
                                              if single else None)
    return rows


TARGET = ('medium', 4, 1.5)
"""Issue 34's done-when: 4 medium bodies in one process at >= 1.5x real time (wall) in the library loop."""


def format_scale(result: dict) -> str:
    """Return the readable tables of a `bench_scale` result."""
    lines = [f"gait scene on hills, preset {result['preset']}, {result['seconds']:g} s simulated per run; medians "
             f"of {result['repeats']} runs, each in a fresh process; RTF = realtime factor (wall)"]
    if result['meshes']:
        lines += ['', _mesh_table(result['meshes'], result['mesh_growth'])]
    if result['bodies']:
        lines += ['', _body_table(result)]
    before, after = result['load_average_before'][0], result['load_average_after'][0]
    lines += ['', f"CPU {result['cpu_model']} ({result['cpus_available']} available); 1-min load average "
                  f'{before:.1f} before, {after:.1f} after: wall figures are indicative, CPU ms/step less noisy']
    return '\n'.join(lines)


def _mesh_table(rows: list, growth: list) -> str:
    """Return the 1-body table against the mesh, then the growth between consecutive meshes."""
    out = [f"{'mesh':7s} {'nodes':>6s} {'tets':>6s} {'springs':>7s} {'ms/step':>8s} {'CPU ms':>7s} {'RTF':>6s} "
           f"{'RTF cpu':>7s} {'us/node':>8s} {'us/spring':>9s} {'RSS MB':>7s}"]
    out += [f"{r['mesh']:7s} {r['nodes']:6d} {r['tets']:6d} {r['springs']:7d} {r['ms_per_step']:8.3f} "
            f"{r['cpu_ms_per_step']:7.3f} {r['realtime_factor']:6.2f} {r['realtime_factor_cpu']:7.2f} "
            f"{r['us_per_node_step']:8.3f} {r['us_per_spring_step']:9.3f} {r['peak_rss_mb']:7.0f}" for r in rows]
    out += [f"{g['from']} -> {g['to']}: ms/step x{g['ms_per_step_ratio']:.2f} for nodes x{g['node_ratio']:.2f}, "
            f"tets x{g['tet_ratio']:.2f}, springs x{g['spring_ratio']:.2f} (ms/step ~ nodes^"
            f"{g['exponent_in_nodes']:.2f})" for g in growth if g['exponent_in_nodes'] is not None]
    return '\n'.join(out)


def _body_table(result: dict) -> str:
    """Return the table against the number of bodies, and issue 34's target when it was measured."""
    out = [f"bodies on the {result['bodies_mesh']} mesh, ms/step and RTF of the whole world (every body one step): "
           f"{result['bodies_note']}",
           f"{'bodies':>6s} {'steps':>6s} {'ms/step':>8s} {'CPU ms':>7s} {'RTF':>6s} {'RTF cpu':>7s} "
           f"{'CPU s/char-s':>12s} {'per char vs 1':>13s} {'(CPU)':>6s} {'RSS MB':>7s}"]
    for r in result['bodies']:
        out.append(f"{r['bodies']:6d} {r['steps']:6d} {r['ms_per_step']:8.3f} {r['cpu_ms_per_step']:7.3f} "
                   f"{r['realtime_factor']:6.2f} {r['realtime_factor_cpu']:7.2f} {r['cpu_s_per_character_s']:12.3f} "
                   f"{_ratio(r['cost_per_character_vs_1'], 13)} {_ratio(r['cpu_cost_per_character_vs_1'], 6)} "
                   f"{r['peak_rss_mb']:7.0f}")
    mesh, n, rtf = TARGET
    hit = [r for r in result['bodies'] if r['bodies'] == n and result['bodies_mesh'] == mesh]
    if hit:
        met = 'met' if hit[0]['realtime_factor'] >= rtf else 'not met'
        out.append(f"issue 34 target, {n} {mesh} bodies at >= {rtf:g}x real time: RTF {hit[0]['realtime_factor']:.2f}"
                   f" ({met} on this run's wall clock), {hit[0]['realtime_factor_cpu']:.2f} on CPU time")
    return '\n'.join(out)


def _ratio(value: float | None, width: int) -> str:
    """Return a ratio with two decimals right-aligned in `width`, '-' when there is none."""
    return f'{value:{width}.2f}' if value is not None else '-'.rjust(width)
