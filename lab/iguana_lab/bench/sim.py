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

"""Simulator benchmarks: speed of the gait scene, where a step's time goes, and the speed–accuracy trade."""
from __future__ import annotations

import os
import platform
import resource
import time
from typing import NamedTuple

import numpy as np

from iguana_lab.bench.workload import bench_model, gait_for, run_gait
from iguana_ros.errors import IguanaError
from iguana_ros.physics.errors import SimulationDiverged
from iguana_ros.physics.simulator import SoftBodySimulator
from iguana_ros.terrain.heightfield import HeightField
from iguana_ros.terrain.placement import place_on_terrain

HILLS = {'amplitude': 0.03, 'wavelength': 0.6, 'seed': 0, 'extent': 3.0}
"""The benchmark terrain: ±3 cm hills of ~0.6 m wavelength."""

START_CLEARANCE = 1e-3
"""Height of the lowest node above the terrain when a benchmark body is set down, m."""


def cpu_model() -> str:
    """Return the CPU model name from /proc/cpuinfo (or the platform's processor string)."""
    try:
        with open('/proc/cpuinfo', encoding='utf-8') as fh:
            for line in fh:
                if line.startswith('model name'):
                    return line.split(':', 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or 'unknown'


def peak_rss_mb() -> float:
    """Peak resident memory of this process, MB."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def make_scene(resolution: str = 'medium', preset='balanced', **overrides) -> tuple:
    """Return (simulator placed on the benchmark hills, gait, model name, model build seconds)."""
    t0 = time.perf_counter()
    model, name = bench_model(resolution)
    build_s = time.perf_counter() - t0
    terrain = HeightField.hills(**HILLS)
    sim = SoftBodySimulator(model, terrain, preset, **overrides)
    sim.reset(place_on_terrain(sim.rest_positions, terrain, clearance=START_CLEARANCE))
    return sim, gait_for(model), name, build_s


def warm_up(sim, gait) -> float:
    """Run one step (JIT compile or cache load) and put `sim` back where it was; returns the seconds it took."""
    start = sim.positions
    t0 = time.perf_counter()
    sim.advance_frame(gait.desired_lengths(0.0), n_steps=1)
    compile_s = time.perf_counter() - t0
    sim.reset(start)
    return compile_s


def bench_sim(resolution: str = 'medium', seconds: float = 5.0, preset='balanced', profile: bool = False,
              **overrides) -> dict:
    """Run the gait scene for `seconds` of simulated time; speed, sizes, memory and compile time."""
    sim, gait, name, build_s = make_scene(resolution, preset, **overrides)
    start = sim.positions
    compile_s = warm_up(sim, gait)
    cpu0 = time.process_time()
    timing = run_gait(sim, gait, seconds)
    cpu_s = time.process_time() - cpu0
    steps = sim.stats['steps']
    fid = sim.fidelity
    result = {
        'model': name, 'nodes': len(sim.rest_positions), 'tets': len(sim.model.tets),
        'springs': len(sim.desired_lengths_rest), 'preset': preset if isinstance(preset, str) else 'custom',
        'dt': fid.dt, 'solver': fid.solver, 'preconditioner': fid.preconditioner, 'cg_tol': fid.cg_tol,
        'jacobian_every': fid.effective_jacobian_every, 'factor_every': fid.factor_every,
        'polar_iters': fid.polar_iters, 'elastic_integration': sim.stats['elastic_integration'],
        'elastic_every': sim.elastic_every, 'elastic_fast_tets': sim.elastic_fast_tets,
        'factor_thread': sim.stats['factor_thread'], 'refactor_rule': fid.refactor_rule,
        'refactor_budget': sim.stats['refactor_budget'], 'factor_rotation_every': sim.stats['factor_rotation_every'],
        'elastic_stiffness_ratio': sim.elastic_ratio, 'simulated_s': sim.time, 'steps': steps,
        'realtime_factor': sim.time / timing['sim_wall_s'],
        'realtime_factor_cpu': sim.time / max(cpu_s - timing['gait_wall_s'], 1e-12),
        'ms_per_step': 1e3 * timing['sim_wall_s'] / steps,
        'gait_ms_per_frame': 1e3 * timing['gait_wall_s'] / max(timing['frames'], 1),
        'cg_iterations_per_step': sim.stats['cg_iterations_per_step'],
        'factorisations_per_step': sim.stats['factorisations'] / max(steps, 1),
        'nodes_in_contact': sim.stats['nodes_in_contact'],
        'com_travel_m': float(np.linalg.norm(sim.center_of_mass()[:2] - (sim.model.node_mass @ start[:, :2])
                                             / sim.model.node_mass.sum())),
        'compile_s': compile_s, 'model_build_s': build_s, 'peak_rss_mb': peak_rss_mb(),
        'cpu_model': cpu_model(), 'cpus_available': len(os.sched_getaffinity(0)),
        'threads': 2 if sim.stats['factor_thread'] else 1,
    }
    if profile:
        result['profile_us'] = profile_step(sim)
    return result


def profile_step(sim, repeats: int = 100) -> dict:
    """
    Microseconds per call of each part of a step, on copies of the simulator's current state, and per step.

    The parts as this simulator runs them (the FEM force with or without its stiffness blocks, the springs'
    blocks, or in a matrix-free step their force with the products K v and K Δv), a whole step, then `per_step_*`:
    each part times how often a step runs it (the FEM every `elastic_every` steps but its fast tets every step, CG
    iterations, factorisations and their matrix assembly per step), `per_step_other` the rest of the whole step
    (diagonal terms, right-hand side, update and checks). The parts are timed in turns, so a drift of the machine's
    speed moves them alike.
    """
    from iguana_ros.physics import integrator as itg
    from iguana_ros.physics.assembly import block_matvec_pair
    from iguana_ros.physics.forces import (contact_forces, corotated_elastic_forces, spring_forces,
                                           spring_forces_operator)

    m = sim._model
    state = sim._state._replace(**{name: a.copy() for name, a in sim._state._asdict().items()})
    x, v, quats, blocks, forces = (state.positions, state.velocities, state.element_rotations, state.matrix_blocks,
                                   state.forces)
    ld = sim.desired_lengths_rest
    fp, ip = sim._fp, sim._ip
    scale = fp[itg.FP_DT] ** 2
    grid = m.terrain_grid
    parts = {
        'elastic_forces': lambda: corotated_elastic_forces(x, m.tets, m.shape_gradients, m.volume, m.mu, m.lam, quats,
                                                           ip[itg.IP_POLAR_ITERS], forces, blocks, m.tet_blocks, 0.0),
        'elastic_forces_and_stiffness': lambda: corotated_elastic_forces(
            x, m.tets, m.shape_gradients, m.volume, m.mu, m.lam, quats, ip[itg.IP_POLAR_ITERS], forces, blocks,
            m.tet_blocks, scale),
        'spring_forces': lambda: spring_forces(x, m.springs, m.spring_stiffness, ld, forces, blocks, m.spring_blocks,
                                               0.0),
        'spring_forces_and_stiffness': lambda: (blocks.fill(0.0), spring_forces(
            x, m.springs, m.spring_stiffness, ld, forces, blocks, m.spring_blocks, scale)),
        'spring_forces_and_products': lambda: spring_forces_operator(
            x, v, state.delta_v, m.springs, m.spring_stiffness, ld, state.spring_coef, state.node_work,
            state.spring_work, fp[itg.FP_DT], state.cg_work[0], state.cg_work[1], scale),
        'contact_forces': lambda: contact_forces(
            x, v, m.contact_mass, m.contact_offset, m.friction, m.heights, m.height_bounds, grid[0], grid[1],
            grid[2], fp[itg.FP_KN], fp[itg.FP_CN], fp[itg.FP_KT], fp[itg.FP_CT], state.friction_anchors,
            state.contact_state, forces, state.contact_stiffness, state.contact_damping),
        'matvec_pair': lambda: block_matvec_pair(m.row_ptr, m.cols, sim._state.matrix_blocks, v, state.delta_v,
                                                 state.cg_work[0], state.cg_work[1]),
        'assemble_matrix': lambda: itg.assemble_system_matrix(m, state),
    }
    if not ip[itg.IP_MATRIX_FREE]:
        del parts['spring_forces_and_products'], parts['assemble_matrix']   # the springs write their blocks
    parts.update(_solver_parts(sim, state))
    parts['step'], counters = _step_on_a_copy(sim)
    out = _time_parts_us(parts, repeats)
    out['cg_iteration'] = out.pop('ten_cg_iterations') / 10.0 + out.get('cholesky_solve', 0.0)
    out['step'] /= sim.steps_per_frame
    return {**out, **_per_step(sim, out, counters)}


def _solver_parts(sim, state) -> dict:
    """Return calls of ten CG iterations as a step runs them and, with a Cholesky preconditioner, its factor, solve."""
    from iguana_ros.physics import integrator as itg

    m, live = sim._model, sim._state
    solution = np.zeros_like(state.delta_v)
    pinv = state.diag_inv
    if sim._ip[itg.IP_MATRIX_FREE]:
        itg.assemble_system_matrix(m, live)
    itg.invert_diagonal(m.diag, live.matrix_blocks, pinv)
    no_factor = sim._chol._replace(state=np.zeros_like(sim._chol.state))
    fp, ip = _ten_iterations(sim._fp, sim._ip)

    def ten_cg_iterations():                         # block Jacobi on the step's matrix (or operator)
        solution[:] = 0.0
        state.cg_work[3][:] = 0.0
        itg.solve_system(m, state._replace(delta_v=solution, diag_inv=pinv, rhs=live.rhs), fp, ip, no_factor)

    parts = {'ten_cg_iterations': ten_cg_iterations}
    if sim.fidelity.preconditioner == 'cholesky':
        from iguana_ros.physics.cholesky import block_cholesky, cholesky_solve

        chol = sim._chol
        values, diag_inv, work = chol.values.copy(), chol.diag_inv.copy(), chol.work.copy()
        parts['cholesky_factor'] = lambda: block_cholesky(chol.pattern, live.matrix_blocks, values, diag_inv)
        parts['cholesky_solve'] = lambda: cholesky_solve(chol.pattern, values, diag_inv, live.rhs, solution, work)
        if sim._ip[itg.IP_FACTOR_ROTATION_EVERY]:
            parts['factor_rotation'] = _factor_rotation_part(sim)
    return parts


def _factor_rotation_part(sim):
    """Return a call that updates (copies of) the corotated preconditioner's rotations for the current positions."""
    from iguana_ros.physics.factor_rotation import CLUSTER_ROTATION_ITERS, cluster_rotations

    m, chol = sim._model, sim._chol
    quats, rotations = chol.cluster_quats.copy(), chol.rotations.copy()
    return lambda: cluster_rotations(sim._state.positions, chol.anchor, m.cluster_ptr, m.cluster_nodes, quats,
                                     rotations, CLUSTER_ROTATION_ITERS)


def _ten_iterations(fp: np.ndarray, ip: np.ndarray) -> tuple:
    """Return copies of the parameters whose CG runs exactly ten block-Jacobi iterations (no tolerance)."""
    from iguana_ros.physics import integrator as itg

    fp, ip = fp.copy(), ip.copy()
    fp[itg.FP_CG_TOL] = fp[itg.FP_CG_ATOL] = 0.0
    ip[itg.IP_CG_MAX_ITER] = 10
    ip[itg.IP_PRECONDITIONER] = 0
    return fp, ip


def _step_on_a_copy(sim):
    """
    Return a call that advances a copy of the simulator's state by one frame of steps, and the copy's counters.

    The lengths are held; the counters (integrator.C_*) count what those steps did. A factor thread's work is done in
    the copy's loop (its part of a step is `cholesky_factor` per factorisation, off the loop's thread in a run).
    """
    from iguana_ros.physics import integrator as itg

    state = sim._state._replace(**{name: a.copy() for name, a in sim._state._asdict().items()})
    chol = sim._chol._replace(**{name: getattr(sim._chol, name).copy() for name in (
        'values', 'diag_inv', 'work', 'state', 'anchor', 'cluster_quats', 'rotations', 'snapshot_anchor')})
    counters, info = sim._counters.copy(), np.zeros(2)
    ip = sim._ip.copy()
    ip[itg.IP_FACTOR_THREAD] = 0
    lengths = np.array(sim._held_lengths if sim._held_lengths is not None else sim.desired_lengths_rest)
    work, external = np.zeros_like(lengths), np.zeros_like(state.positions)

    def frame():
        itg.run_steps_cg(sim._model, state, sim._fp, ip, counters, lengths, lengths, work, external,
                         sim.steps_per_frame, info, chol, 0, 0)
    return frame, counters


def _time_parts_us(parts: dict, repeats: int) -> dict:
    """Median over 5 rounds of the CPU microseconds per call of each of `parts`; each round times them all in turn."""
    for fn in parts.values():
        fn()
    rounds = {name: [] for name in parts}
    for _ in range(5):
        for name, fn in parts.items():
            n = max(repeats // (10 if name in ('ten_cg_iterations', 'step') else 1), 5)
            t0 = time.process_time()
            for _ in range(n):
                fn()
            rounds[name].append((time.process_time() - t0) / n * 1e6)
    return {name: float(np.median(times)) for name, times in rounds.items()}


def _per_step(sim, parts: dict, counters: np.ndarray) -> dict:
    """
    `per_step_*` microseconds: each part as often as the timed steps ran it (see `profile_step`).

    CG iterations and factorisations per step counted by `counters` over the steps of the whole-step timing.
    """
    from iguana_ros.physics import integrator as itg

    ip = sim._ip
    steps = max(int(counters[itg.C_STEP] - sim._counters[itg.C_STEP]), 1)
    iterations = (counters[itg.C_CG_ITERS] - sim._counters[itg.C_CG_ITERS]) / steps
    factorisations = (counters[itg.C_FACTORS] - sim._counters[itg.C_FACTORS]) / steps
    n_tets, n_fast = len(sim._model.tets), ip[itg.IP_FAST_TETS]      # the fast tets every step, the rest held
    elastic = (parts['elastic_forces_and_stiffness'] if ip[itg.IP_ELASTIC_IMPLICIT]
               else parts['elastic_forces'] * (n_fast + (n_tets - n_fast) / ip[itg.IP_ELASTIC_EVERY]) / n_tets)
    per_step = {'per_step_elastic': elastic,
                'per_step_springs': parts.get('spring_forces_and_products', parts['spring_forces_and_stiffness']),
                'per_step_contact': parts['contact_forces'] if sim.terrain is not None else 0.0,
                'per_step_matvec_pair': 0.0 if ip[itg.IP_MATRIX_FREE] else parts['matvec_pair'],
                'per_step_cg': parts['cg_iteration'] * iterations,
                'per_step_cholesky_factor': (parts.get('cholesky_factor', 0.0) + parts.get('assemble_matrix', 0.0))
                * factorisations,
                'per_step_factor_rotation': parts.get('factor_rotation', 0.0) / max(ip[itg.IP_FACTOR_ROTATION_EVERY],
                                                                                    1)}
    per_step['per_step_other'] = parts['step'] - sum(per_step.values())
    return per_step


TRADEOFF_SETTINGS = (
    # (group, label, overrides of the balanced preset); each compared with the finest run of the same mesh
    [('dt', f'dt=1/{n}', {'dt': 1.0 / n}) for n in (4800, 2400, 1200, 600, 300, 120)]
    + [('cg_tol', f'cg_tol={tol:g}', {'cg_tol': tol}) for tol in (1e-2, 1e-3, 1e-4, 1e-6)]
    + [('solver', 'direct', {'solver': 'direct'}),
       ('solver', 'ssor', {'preconditioner': 'ssor'})]
    + [('jacobian_every', f'jacobian_every={k}', {'jacobian_every': k}) for k in (1, 2, 4)]
    + [('factor_every', f'factor_every={k}', {'factor_every': k, 'refactor_rule': 'age'}) for k in (1, 2, 4, 8, 16)]
    + [('factor_every', 'factor_every=16, amortised', {'factor_every': 16, 'refactor_rule': 'amortised'})]
    + [('factor_every', 'factor not turned', {'factor_rotation_every': 0})]
    + [('polar_iters', f'polar_iters={k}', {'polar_iters': k}) for k in (1, 2, 8)]
    + [('elastic', f'elastic={how}', {'elastic_integration': how}) for how in ('implicit', 'explicit')]
    + [('preset', name, {'preset': name}) for name in ('fast', 'balanced', 'accurate')]
)
REFERENCE = {'dt': 1.0 / 4800.0, 'cg_tol': 1e-8, 'cg_max_iter': 1000, 'jacobian_every': 1, 'factor_every': 1,
             'polar_iters': 20, 'elastic_integration': 'implicit'}
"""The finest run every other run is compared with."""


MESH_REFERENCE = {'preset': 'accurate'}
"""The run every mesh is compared with, on the finest mesh (the dt 1/4800 REFERENCE is too slow on `fine`)."""
TRADEOFF_MESHES = ('coarse', 'medium', 'fine')
TRADEOFF_GROUPS = tuple(dict.fromkeys(group for group, _, _ in TRADEOFF_SETTINGS))
"""The groups of settings of the table: dt, cg_tol, solver, jacobian_every, factor_every, polar_iters, preset."""


class TradeoffRun(NamedTuple):
    """
    One run of the speed-accuracy table.

    Its `group`, `label`, `mesh` and fidelity `settings` (with an optional 'preset'), and `reference`, the index of the
    run it is compared with (None: it is a reference).
    """

    group: str
    label: str
    mesh: str
    settings: dict
    reference: int | None


def tradeoff_runs(resolution: str = 'medium', meshes: tuple = TRADEOFF_MESHES,
                  groups: tuple | None = None) -> list[TradeoffRun]:
    """
    Return the runs of the table in order.

    REFERENCE on `resolution`, every TRADEOFF_SETTINGS entry (of `groups`, default all) against it, MESH_REFERENCE on
    the finest of `meshes`, each mesh with `balanced` (against that, centre of mass only; no meshes: no mesh rows).
    """
    runs = [TradeoffRun('reference', 'reference', resolution, dict(REFERENCE), None)]
    runs += [TradeoffRun(group, label, resolution, dict(settings), 0) for group, label, settings in TRADEOFF_SETTINGS
             if groups is None or group in groups]
    if not meshes:
        return runs
    mesh_ref = len(runs)
    runs.append(TradeoffRun('reference', 'mesh reference', meshes[-1], dict(MESH_REFERENCE), None))
    runs += [TradeoffRun('mesh', f'mesh={mesh}', mesh, {'preset': 'balanced'}, mesh_ref) for mesh in meshes]
    return runs


def gait_run(resolution: str, seconds: float, settings: dict) -> dict:
    """
    Run one gait scene and return its outcome.

    The outcome is the final node positions `(n, 3)` and centre of mass `(3,)` as lists (JSON) and the speed, or the
    divergence.
    """
    settings = dict(settings)
    preset = settings.pop('preset', 'balanced')
    sim, gait, _, _ = make_scene(resolution, preset, **settings)
    warm_up(sim, gait)                                              # compile outside the timing
    cpu0 = time.process_time()
    try:
        timing = run_gait(sim, gait, seconds)
    except SimulationDiverged as exc:
        return {'diverged': exc.cause, 'message': str(exc)}
    cpu_s = time.process_time() - cpu0 - timing['gait_wall_s']
    return {'positions': sim.positions.tolist(), 'com': sim.center_of_mass().tolist(),
            'nodes': len(sim.rest_positions),
            'realtime_factor': sim.time / timing['sim_wall_s'], 'realtime_factor_cpu': sim.time / cpu_s,
            'ms_per_step': 1e3 * timing['sim_wall_s'] / sim.stats['steps'],
            'cg_iterations_per_step': sim.stats['cg_iterations_per_step']}


def tradeoff_rows(runs: list[TradeoffRun], results: list) -> list[dict]:
    """
    Return the table rows of the non-reference runs among the first len(`results`) `runs`.

    `results` are the results of `gait_run` in run order, or error rows; a row gives the speed and the error (node RMS,
    COM difference) against the run's reference. Raises SimulationDiverged if a reference diverged, IguanaError if it
    failed.
    """
    rows = []
    for run, result in zip(runs, results):
        if run.reference is None:
            if 'diverged' in result:
                raise SimulationDiverged(result['diverged'], f'tradeoff {run.label} run: ' + result['message'])
            if 'error' in result:
                raise IguanaError(f"tradeoff {run.label} run failed: {result['error']}")
            continue
        rows.append(_row(run.group, run.label, run.mesh, result, results[run.reference],
                         nodes_comparable=run.group != 'mesh'))
    return rows


def _row(group: str, label: str, mesh: str, run: dict, ref: dict, nodes_comparable: bool = True) -> dict:
    """
    Return a table row.

    Errors are None when the run diverged or failed (`error`: why), node RMS when meshes differ.
    """
    row = {'group': group, 'label': label, 'mesh': mesh, 'diverged': run.get('diverged')}
    if row['diverged'] or 'error' in run:
        failed = {'error': run['error'], 'error_type': run.get('error_type')} if 'error' in run else {}
        return {**row, 'realtime_factor': None, 'realtime_factor_cpu': None, 'ms_per_step': None,
                'node_rms_m': None, 'com_error_m': None, 'cg_iterations_per_step': None, **failed}
    rms = (float(np.sqrt(np.mean(np.sum((np.asarray(run['positions']) - np.asarray(ref['positions'])) ** 2,
                                        axis=1))))
           if nodes_comparable and 'positions' in ref else None)
    return {**row, 'realtime_factor': run['realtime_factor'], 'realtime_factor_cpu': run['realtime_factor_cpu'],
            'ms_per_step': run['ms_per_step'],
            'cg_iterations_per_step': run['cg_iterations_per_step'], 'node_rms_m': rms,
            'com_error_m': float(np.linalg.norm(np.asarray(run['com']) - np.asarray(ref['com'])))}


def plot_tradeoff(rows: list, path) -> None:
    """Error against realtime factor (log axes), one marker per group, saved to `path` (PNG)."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.5), dpi=100)
    for group in dict.fromkeys(r['group'] for r in rows):
        pts = [r for r in rows if r['group'] == group and r['realtime_factor_cpu']]
        err = [(r['node_rms_m'] if r['node_rms_m'] is not None else r['com_error_m']) for r in pts]
        ok = [(p, e) for p, e in zip(pts, err) if e and e > 0]
        if not ok:
            continue
        ax.scatter([p['realtime_factor_cpu'] for p, _ in ok], [e for _, e in ok], label=group)
        for p, e in ok:
            ax.annotate(p['label'].split('=')[-1], (p['realtime_factor_cpu'], e), fontsize=7, xytext=(3, 3),
                        textcoords='offset points')
    ax.set_xscale('log')
    ax.set_yscale('log')
    ax.set_xlabel('realtime factor (simulated s per CPU s of this process)')
    ax.set_ylabel('error after run (node RMS; COM for mesh), m')
    ax.grid(True, which='both', alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
