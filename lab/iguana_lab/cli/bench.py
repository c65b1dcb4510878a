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
`iguana bench sim|scale|crowd|crossing|tradeoff|stability|pipeline|adaptation|locomotion|statics|pushes|faults`.

Simulator speed, its growth with the mesh and the number of bodies, speed–accuracy trade, stability at the extremes,
the node pipeline's realtime factor next to the library loop (here); terrain adaptation per frame, the randomized
locomotion benchmark, the statics diagnostics of a model variant, the push experiment and the fault suites (their
handlers in cli/bench_*.py).
"""
from __future__ import annotations

import argparse
from fractions import Fraction
import json

from iguana_lab.cli import bench_adaptation, bench_faults, bench_locomotion, bench_pushes, bench_statics
from iguana_ros.cli.argtypes import count, positive
from iguana_ros.errors import InputError
from iguana_ros.physics.fidelity import FACTOR_THREADS, PRECONDITIONERS, REFACTOR_RULES, SOLVERS


def _time_step(text: str) -> float:
    """Return a time step given as seconds or a fraction such as 1/1200."""
    try:
        value = float(Fraction(text))
    except (ValueError, ZeroDivisionError):
        raise argparse.ArgumentTypeError(f'time step must be seconds or a fraction like 1/1200, got {text!r}')
    if value <= 0:
        raise argparse.ArgumentTypeError(f'time step must be positive, got {text!r}')
    return value


def register(subparsers) -> None:
    """Add `bench` with its sub-commands (see the module docstring)."""
    parser = subparsers.add_parser('bench', help='benchmarks: simulator speed, speed-accuracy trade, stability, '
                                                 'node pipeline, randomized locomotion, statics of a model')
    sub = parser.add_subparsers(dest='bench', metavar='BENCH', required=True)
    sim = sub.add_parser('sim', help='simulate the iguana walking (lateral-bend gait) on hills; report speed')
    sim.add_argument('--mesh', choices=('coarse', 'medium', 'fine', 'finer'), default='medium')
    sim.add_argument('--dt', type=_time_step, default=None, help='time step, e.g. 1/1200 (default: the preset)')
    sim.add_argument('--seconds', type=float, default=5.0, help='simulated seconds (default 5)')
    sim.add_argument('--preset', choices=('fast', 'balanced', 'accurate'), default='balanced')
    sim.add_argument('--solver', choices=SOLVERS, default=None)
    sim.add_argument('--preconditioner', choices=PRECONDITIONERS, default=None)
    sim.add_argument('--cg-tol', type=float, default=None)
    sim.add_argument('--jacobian-every', type=int, default=None, help='steps between system-matrix rebuilds')
    sim.add_argument('--factor-every', type=int, default=None,
                     help='steps a Cholesky preconditioner factor is reused at most (1 = refactorise every step)')
    sim.add_argument('--refactor-rule', choices=REFACTOR_RULES, default=None,
                     help="'amortised': also refactorise once the extra CG iterations cost as much as a "
                          "factorisation (default: the preset's)")
    sim.add_argument('--polar-iters', type=int, default=None, help='rotation-extraction iterations per step')
    sim.add_argument('--factor-rotation-every', type=int, default=None,
                     help='steps between updates of the rotations that turn a reused Cholesky factor with the body '
                          "(0 = off; default: the preset's)")
    sim.add_argument('--factor-thread', choices=FACTOR_THREADS, default=None,
                     help='factorise the Cholesky preconditioner on a second thread (default off)')
    sim.add_argument('--profile', action='store_true', help='also time each part of a step')
    sim.add_argument('--json', action='store_true', help='print one JSON object')
    sim.set_defaults(func=run_sim)
    _register_scale(sub)
    _register_crowd(sub)
    trade = sub.add_parser('tradeoff', help='sweep dt, solver settings and mesh; error against the finest run')
    trade.add_argument('--mesh', choices=('coarse', 'medium', 'fine'), default='medium')
    trade.add_argument('--seconds', type=float, default=2.0, help='simulated seconds per run (default 2)')
    trade.add_argument('--plot', default=None, help='write error-vs-speed plot to this PNG')
    trade.add_argument('--workers', type=count(1), default=1,
                       help='worker processes (default 1: each run timed alone on the machine)')
    trade.add_argument('--json', action='store_true')
    trade.set_defaults(func=run_tradeoff)
    stab = sub.add_parser('stability', help='extreme stiffness, E, dt, pushes, drops, slopes, inverted start')
    stab.add_argument('--mesh', choices=('coarse', 'medium', 'fine'), default='coarse')
    stab.add_argument('--seconds', type=float, default=1.5)
    stab.add_argument('--workers', type=count(1), default=None, help='worker processes (default: one per core)')
    stab.add_argument('--json', action='store_true')
    stab.set_defaults(func=run_stability)
    pipe = sub.add_parser('pipeline', help='realtime factor: four-process lockstep node run vs library run')
    pipe.add_argument('--scene', default='hills', help='scene name or YAML path (default: hills)')
    pipe.add_argument('--seconds', type=float, default=5.0, help='simulated seconds (default 5)')
    pipe.add_argument('--single-process', action='store_true', help='run the four nodes in one process')
    pipe.add_argument('--json', action='store_true', help='print one JSON object')
    pipe.set_defaults(func=run_pipeline_bench)
    bench_adaptation.register(sub)
    bench_locomotion.register(sub)
    bench_statics.register(sub)
    bench_pushes.register(sub)
    bench_faults.register(sub)


def run_pipeline_bench(args) -> int:
    """`iguana bench pipeline`."""
    from iguana_lab.bench.pipeline_speed import bench_pipeline
    from iguana_ros.supervisor.cpu import cpu_line

    result = bench_pipeline(args.scene, args.seconds, args.single_process)
    if args.json:
        print(json.dumps(result, indent=1))
        return 0
    print(f"{result['scene']}: {result['simulated_s']:g} s simulated")
    print(f"  library loop:             realtime factor {result['library_realtime_factor']:.2f} "
          f"({result['library_wall_s']:.1f} s wall)")
    print(f"  nodes ({result['nodes_layout']}): realtime factor {result['nodes_realtime_factor']:.2f} "
          f"({result['nodes_wall_s']:.1f} s wall in the loop, {result['nodes_total_s']:.1f} s with start-up)")
    print(f"  node overhead:            {result['node_overhead_ms_per_frame']:.2f} ms per frame (the nodes' wall "
          f"less the library loop's); CPU {result['cpu_model']}")
    if result['nodes_cpu_ms_per_frame_by_process']:
        print('  ' + cpu_line(result['nodes_cpu_ms_per_frame_by_process']))
    return 0


def _held(result: dict) -> str:
    """Return how an explicit FEM is held, for the summary line (empty when it is implicit)."""
    if result['elastic_integration'] != 'explicit':
        return ''
    fast = f", {result['elastic_fast_tets']} tets every step" if result['elastic_fast_tets'] else ''
    return f", held {result['elastic_every']} steps{fast}"


def _amortised(result: dict) -> str:
    """Return the summary's words on the 'amortised' refactorisation rule ('' under the 'age' rule)."""
    budget, every = result['refactor_budget'], result['factor_rotation_every']
    turned = f', turned with the body every {every} steps' if every else ''
    return turned + ('' if budget is None else f' (once the CG iterations beyond one per solve reach {budget:.1f})')


def run_sim(args) -> int:
    """`iguana bench sim`."""
    from iguana_lab.bench.sim import bench_sim

    result = bench_sim(args.mesh, seconds=args.seconds, preset=args.preset, profile=args.profile, dt=args.dt,
                       solver=args.solver, preconditioner=args.preconditioner, cg_tol=args.cg_tol,
                       jacobian_every=args.jacobian_every, factor_every=args.factor_every,
                       polar_iters=args.polar_iters, factor_thread=args.factor_thread,
                       refactor_rule=args.refactor_rule, factor_rotation_every=args.factor_rotation_every)
    if args.json:
        print(json.dumps(result, indent=1))
        return 0
    print(f"{result['model']}: {result['nodes']} nodes, {result['tets']} tets, {result['springs']} springs; "
          f"preset {result['preset']} (dt {result['dt']:.6g} s, {result['solver']}, cg_tol {result['cg_tol']:g}, "
          f"jacobian every {result['jacobian_every']}, {result['preconditioner']} preconditioner refactorised every "
          f"{result['factor_every']} steps or sooner{_amortised(result)}: "
          f"{result['factorisations_per_step']:.2f} per step"
          f"{', on a second thread' if result['factor_thread'] else ''}; FEM {result['elastic_integration']}"
          f'{_held(result)})')
    print(f"realtime factor {result['realtime_factor']:.2f} (wall), {result['realtime_factor_cpu']:.2f} (CPU time); "
          f"{result['ms_per_step']:.3f} ms/step; {result['cg_iterations_per_step']:.1f} CG iterations/step")
    print(f"compile/cache load {result['compile_s']:.2f} s; model build {result['model_build_s']:.2f} s; "
          f"peak RSS {result['peak_rss_mb']:.0f} MB; CPU {result['cpu_model']}")
    for name, us in result.get('profile_us', {}).items():
        print(f'  {name:38s} {us:9.1f} us')
    return 0


def _register_scale(sub) -> None:
    """Add `scale`; its values are checked by `run_scale` (a bad one: one line, exit 1)."""
    scale = sub.add_parser('scale', help='ms/step and realtime factor against the mesh and the number of bodies')
    scale.add_argument('--meshes', nargs='+', default=None, metavar='MESH',
                       help='meshes of the 1-body table (default: coarse medium fine finer)')
    scale.add_argument('--bodies', nargs='+', default=None, metavar='N',
                       help='body counts of the bodies table (default: 1 2 4 8)')
    scale.add_argument('--bodies-mesh', default='medium', help='mesh of the bodies table (default medium)')
    scale.add_argument('--seconds', default='2', help='simulated seconds per run (default 2)')
    scale.add_argument('--repeats', default='3', help='runs per configuration, each in a fresh process (default 3)')
    scale.add_argument('--json', action='store_true', help='print one JSON object')
    scale.set_defaults(func=run_scale)


def _value(parse, option: str, text: str):
    """Return `parse(text)`; InputError naming `option` if it fails."""
    try:
        return parse(text)
    except argparse.ArgumentTypeError as exc:
        raise InputError(f'{option}: {exc}') from None


def _register_crowd(sub) -> None:
    """Add `crowd` and `crossing` (several iguanas in one world)."""
    crowd = sub.add_parser('crowd', help='several iguanas in one world: realtime factor, CPU per character, memory')
    crowd.add_argument('--iguanas', nargs='+', default=['1', '2', '4', '8'], metavar='N',
                       help='crowd sizes (default 1 2 4 8)')
    crowd.add_argument('--mesh', choices=('coarse', 'medium', 'fine'), default='medium')
    crowd.add_argument('--seconds', default='2', help='simulated seconds per run (default 2)')
    crowd.add_argument('--repeats', default='3', help='runs per size, each in a fresh process (default 3)')
    crowd.add_argument('--nodes', action='store_true',
                       help='also run each crowd as iguana run (a simulator process and one per character; about '
                            '10 s of start-up per run): realtime factor, CPU per character, memory of the nodes')
    crowd.add_argument('--json', action='store_true', help='print one JSON object')
    crowd.set_defaults(func=run_crowd)
    crossing = sub.add_parser('crossing', help='randomized crossings of 2-4 iguanas: arrivals and body contacts')
    crossing.add_argument('--seeds', nargs='+', default=[str(s) for s in range(1, 11)], metavar='SEED')
    crossing.add_argument('--mesh', choices=('coarse', 'medium', 'fine'), default='coarse')
    crossing.add_argument('--seconds', default='20', help='simulated seconds per scene (default 20)')
    crossing.add_argument('--json', action='store_true', help='print one JSON object')
    crossing.set_defaults(func=run_crossing)


def run_crowd(args) -> int:
    """`iguana bench crowd`."""
    from iguana_lab.bench.crowd import bench_crowd, format_crowd

    result = bench_crowd(tuple(_value(count(1), '--iguanas', n) for n in args.iguanas), args.mesh,
                         _value(positive('seconds'), '--seconds', args.seconds),
                         _value(count(1), '--repeats', args.repeats), nodes=args.nodes)
    print(json.dumps(result, indent=1) if args.json else format_crowd(result))
    return 0


def run_crossing(args) -> int:
    """`iguana bench crossing`: exit 1 unless every iguana of every scene arrived."""
    from iguana_lab.bench.crowd import crossing_suite, format_crossings

    result = crossing_suite(tuple(_value(count(0), '--seeds', s) for s in args.seeds), args.mesh,
                            _value(positive('seconds'), '--seconds', args.seconds))
    print(json.dumps(result, indent=1) if args.json else format_crossings(result))
    return 0 if result['all_arrived'] == result['scenes'] else 1


def run_scale(args) -> int:
    """`iguana bench scale`."""
    from iguana_lab.bench.scale import BODIES, bench_scale, format_scale, MESHES

    bodies = tuple(_value(count(1), '--bodies', n) for n in args.bodies) if args.bodies else BODIES
    result = bench_scale(tuple(args.meshes or MESHES), bodies, args.bodies_mesh,
                         _value(positive('seconds'), '--seconds', args.seconds),
                         repeats=_value(count(1), '--repeats', args.repeats))
    print(json.dumps(result, indent=1) if args.json else format_scale(result))
    return 0


def run_tradeoff(args) -> int:
    """`iguana bench tradeoff`."""
    import sys

    from iguana_lab.bench.sim import plot_tradeoff
    from iguana_lab.sweep.benchmarks import tradeoff_plan
    from iguana_lab.sweep.engine import Cluster, row_stream, run_tasks

    out = sys.stderr if args.json else sys.stdout      # with --json the progress table goes to stderr

    def show(row):
        print(_format_row(row), file=out, flush=True)

    print(f"{'setting':22s} {'mesh':7s} {'RTF':>7s} {'RTF cpu':>7s} {'ms/step':>8s} {'CG/step':>7s} "
          f"{'node RMS m':>11s} {'COM err m':>10s}", file=out)
    plan = tradeoff_plan(args.mesh, seconds=args.seconds)
    rows = plan.rows(run_tasks(plan.tasks, Cluster(workers=args.workers), on_result=row_stream(plan, show)))
    if args.plot:
        plot_tradeoff(rows, args.plot)
    if args.json:
        print(json.dumps(rows, indent=1))
    return 0


def _format_row(row: dict) -> str:
    """One line of the tradeoff table."""
    if row['diverged']:
        return f"{row['label']:22s} {row['mesh']:7s} diverged ({row['diverged']})"
    if row.get('error'):
        return f"{row['label']:22s} {row['mesh']:7s} failed ({row['error_type']}: {row['error']})"

    def num(v, fmt):
        return format(v, fmt) if v is not None else '-'
    return (f"{row['label']:22s} {row['mesh']:7s} {num(row['realtime_factor'], '7.2f')} "
            f"{num(row['realtime_factor_cpu'], '7.2f')} "
            f"{num(row['ms_per_step'], '8.3f')} {num(row['cg_iterations_per_step'], '7.1f')} "
            f"{num(row['node_rms_m'], '11.2e')} {num(row['com_error_m'], '10.2e')}")


def run_stability(args) -> int:
    """`iguana bench stability`."""
    from iguana_lab.bench.workload import bench_model
    from iguana_lab.sweep.benchmarks import stability_plan
    from iguana_lab.sweep.engine import Cluster, row_stream, run_tasks

    _, name = bench_model(args.mesh)

    def show(r):
        if args.json:
            return
        if r.get('error'):
            print(f"{r['scenario']:40s} FAILED    ({r['error_type']}) {r['error']}", flush=True)
        elif r['outcome'] == 'stable':
            print(f"{r['scenario']:40s} stable    max speed {r['max_speed']:6.2f} m/s, end depth "
                  f"{1e3 * r['final_max_depth']:5.1f} mm, inverted tets {r['inverted_tets_at_start']}"
                  f" -> {r['inverted_tets_at_end']} ({r['inverted_tets_persisting']} all through the last 0.2 s)",
                  flush=True)
        else:
            print(f"{r['scenario']:40s} DIVERGED  ({r['cause']}) {r['message']}", flush=True)

    if not args.json:
        print(f'{name}, {args.seconds:g} s per scenario')
    plan = stability_plan(args.mesh, args.seconds)
    rows = plan.rows(run_tasks(plan.tasks, Cluster(workers=args.workers), on_result=row_stream(plan, show)))
    if args.json:
        print(json.dumps({'model': name, 'rows': rows}, indent=1))
    return 0
