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
`iguana bench locomotion`: the randomized locomotion benchmarks (iguana_lab.locomotion_bench) on all cores.

`--suite steering` (default): the steering suite, a table per category, fidelity and stiffness preset (reach rate,
time, path over the straight way, headings within tolerance, routes completed, circling and stuck strides, the
search's time per stride end) and the behind/ahead time ratio. `--suite terrains`: a goal 3 m away on random terrains
with and without adaptation, a table per mode and terrain kind with the with/without-adaptation ratios. A progress line
per finished run goes to stderr; with --json one object {config, summary, rows, wall_s} on stdout.
"""
from __future__ import annotations

import argparse
import json
import sys
import time

from iguana_ros.cli.argtypes import count, positive

KINDS = ('hills', 'tilted', 'steps', 'noise')
CATEGORIES = ('near', 'far', 'ahead', 'behind', 'slope', 'steps', 'heading', 'route')
"""The steering suite's categories (iguana_lab.random_scenes.STEERING_CATEGORIES, without its repeat)."""
"""The benchmark's terrain kinds (iguana_lab.locomotion_bench.BENCH_KINDS, kept here so --help imports little)."""
MODES = {'both': (True, False), 'adapt': (True,), 'no-adapt': (False,)}


def _kinds(text: str) -> tuple:
    """`argparse` type: a comma-separated list of terrain kinds."""
    kinds = tuple(k.strip() for k in text.split(',') if k.strip())
    bad = [k for k in kinds if k not in KINDS]
    if bad or not kinds:
        raise argparse.ArgumentTypeError(f'expected a comma-separated list of {", ".join(KINDS)}, got {text!r}')
    return kinds


def _categories(text: str) -> tuple:
    """`argparse` type: a comma-separated list of steering categories."""
    categories = tuple(c.strip() for c in text.split(',') if c.strip())
    bad = [c for c in categories if c not in CATEGORIES]
    if bad or not categories:
        raise argparse.ArgumentTypeError(f'expected a comma-separated list of {", ".join(CATEGORIES)}, got {text!r}')
    return categories


def register(sub) -> None:
    """Add `locomotion` to the `bench` sub-commands."""
    loco = sub.add_parser('locomotion', help='steering: goals near and far, behind, on slopes and steps, with headings '
                                             'and routes (default); or terrains: a goal 3 m away with and without '
                                             'terrain adaptation')
    loco.add_argument('--suite', choices=('steering', 'terrains'), default='steering', help='which suite (default '
                                                                                            'steering)')
    loco.add_argument('--scenes', type=count(1), default=90, help='steering: number of scenes (default 90)')
    loco.add_argument('--categories', type=_categories, default=None,
                      help=f'steering: categories to cycle (default {",".join(CATEGORIES)},near)')
    loco.add_argument('--terrains', type=count(1), default=30, help='terrains: number of random terrains (default 30)')
    loco.add_argument('--seed', type=count(0), default=0, help='seed of the terrains and goals (default 0)')
    loco.add_argument('--duration', type=positive('duration'), default=40.0,
                      help='simulated seconds per run at most; a run ends 2 s after reaching its goal (default 40)')
    loco.add_argument('--mesh', choices=('coarse', 'medium', 'fine'), default='medium')
    loco.add_argument('--workers', type=count(1), default=None, help='worker processes (default: one per core)')
    loco.add_argument('--modes', choices=tuple(MODES), default='both', help='with and/or without adaptation')
    loco.add_argument('--kinds', type=_kinds, default=KINDS, help=f'terrain kinds to cycle (default {",".join(KINDS)})')
    loco.add_argument('--json', action='store_true', help='print one JSON object (summary and rows) on stdout')
    loco.add_argument('-o', '--output', default=None, help='also write the rows (a JSON list) to this file')
    loco.set_defaults(func=run_locomotion)


def run_locomotion(args: argparse.Namespace) -> int:
    """`iguana bench locomotion`."""
    if args.suite == 'steering':
        return run_steering_suite(args)
    from iguana_lab.locomotion_bench import random_scenes, run_benchmark, summarize

    scenes = random_scenes(args.terrains, args.seed, args.duration, args.mesh, args.kinds)
    modes = MODES[args.modes]
    config = {'terrains': args.terrains, 'seed': args.seed, 'duration': args.duration, 'mesh': args.mesh,
              'workers': args.workers, 'modes': args.modes, 'kinds': list(args.kinds)}
    header = f'{len(scenes)} terrains x {len(modes)} modes, {args.mesh} mesh, up to {args.duration:g} s each'
    return _run_and_report(args, config, header, lambda progress: run_benchmark(scenes, modes, args.workers, progress),
                           _progress_line, summarize, format_summary)


def run_steering_suite(args: argparse.Namespace) -> int:
    """`iguana bench locomotion --suite steering`: run the scenes, print the table (or JSON)."""
    from iguana_lab.locomotion_bench import run_steering, steering_scenes, STEERING_CATEGORIES, summarize_steering

    categories = args.categories or STEERING_CATEGORIES
    scenes = steering_scenes(args.scenes, args.seed, args.mesh, categories)
    config = {'suite': 'steering', 'scenes': args.scenes, 'seed': args.seed, 'mesh': args.mesh,
              'workers': args.workers, 'categories': list(categories)}
    header = f'{len(scenes)} steering scenes (seed {args.seed}), {args.mesh} mesh'
    return _run_and_report(args, config, header, lambda progress: run_steering(scenes, args.workers, progress),
                           _steering_line, summarize_steering, format_steering)


def _run_and_report(args: argparse.Namespace, config: dict, header: str, run, line, summarize, table) -> int:
    """
    Run a suite and report it.

    `run(progress)` gives the rows, a progress line (`line(row)`) per finished run goes to stderr; then the rows to
    -o, and `summarize(rows)` as JSON {config, summary, rows, wall_s} (--json) or as `table(summary)`.
    """
    output = _open_output(args.output)          # before the runs: a bad path fails now, not after an hour
    print(header, file=sys.stderr, flush=True)
    start = time.perf_counter()
    rows = run(lambda row, done, total: print(f'[{done}/{total}] {line(row)}', file=sys.stderr, flush=True))
    wall = time.perf_counter() - start
    summary = summarize(rows)
    if output is not None:
        with output:
            json.dump(rows, output, indent=1)
    if args.json:
        print(json.dumps({'config': config, 'summary': summary, 'rows': rows, 'wall_s': wall}, indent=1))
    else:
        print(table(summary))
        print(f'{len(rows)} runs in {wall:.1f} s wall')
    return 0


def _steering_line(row: dict) -> str:
    """One finished steering run: outcome, time, path ratio, heading, circling and stuck strides."""
    head = f"{row['scene']} ({row.get('fidelity')}, {row.get('stiffness')}):"
    if row.get('error'):
        return f"{head} ERROR {row['error']} ({row['wall_s']:.1f} s wall)"
    if row.get('reached_goal'):
        outcome = f"reached at {_num(row.get('time_to_goal'), '.1f')} s, path x{_num(row.get('path_ratio'), '.2f')}"
        if row.get('heading'):
            outcome += f", heading off {_num(row.get('final_heading_error_deg'), '.0f')} deg at rest"
    else:
        outcome = f"not reached ({_num(row.get('final_goal_distance'), '.2f')} m left)"
    return (f"{head} {outcome}; circling {row.get('circling_strides')}, stuck {row.get('stuck_strides')} strides; "
            f"{row['wall_s']:.1f} s wall")


def format_steering(summary: dict) -> str:
    """Return the readable table of `summarize_steering`'s result: one line per group, then the suite's counts."""
    lines = [f"{'group':20s} {'runs':>4s} {'reached':>12s} {'time s':>7s} {'path':>5s} {'heading':>9s} "
             f"{'routes':>7s} {'circling':>8s} {'stuck':>5s} {'plan ms':>7s} {'errors':>6s}",
             f"{'':20s} {'':4s} {'':12s} {'(med)':>7s} {'(med)':>5s} {'in tol.':>9s} {'done':>7s} {'strides':>8s} "
             f"{'':5s} {'(med)':>7s}"]
    for group, g in summary['groups'].items():
        reached = f"{g['reached']}/{g['n']} {100 * g['reach_rate']:3.0f}%" if g['n'] else '-'
        heading = f"{g['heading_within_tolerance']}/{g['heading_goals']}" if g['heading_goals'] else '-'
        routes = f"{g['routes_completed']}/{g['routes']}" if g['routes'] else '-'
        lines.append(f"{group:20s} {g['n']:4d} {reached:>12s} {_num(g['time_to_goal_median'], '.1f', 7)} "
                     f"{_num(g['path_ratio_median'], '.2f', 5)} {heading:>9s} {routes:>7s} "
                     f"{g['circling_strides']:8d} {g['stuck_strides']:5d} {_num(g['plan_ms_median'], '.2f', 7)} "
                     f"{g['errors']:6d}")
    lines += ['', f"behind / ahead time (median of {summary['pairs']} pairs): "
                  f"{_num(summary['behind_over_ahead'], '.2f')}; near goals {summary['near_goals']}, "
                  f"12-20 deg slopes {summary['slope_scenes']}, fast preset {summary['fast_scenes']}",
              'path: the stride-averaged root path until arrival over the straight way to the goal radius']
    return '\n'.join(lines)


def _open_output(path: str | None):
    """Return the rows file opened for writing (None without -o); InputError (one line) if it cannot be."""
    from iguana_ros.errors import InputError

    if path is None:
        return None
    try:
        return open(path, 'w', encoding='utf-8')
    except OSError as exc:
        raise InputError(f'cannot write the rows to {path}: {exc.strerror}') from None


def _progress_line(row: dict) -> str:
    """One finished run: outcome, slip and speed of the simulation."""
    head = f"{row['scene']} {row['mode']}:"
    if row.get('error'):
        return f"{head} ERROR {row['error']} ({row['wall_s']:.1f} s wall)"
    if row.get('reached_goal'):
        outcome = f"reached the goal at {_num(row.get('time_to_goal'), '.1f')} s"
    else:
        flags = ''.join(f', {flag}' for flag in ('fell', 'stuck') if row.get(flag))
        outcome = f"not reached ({_num(row.get('final_goal_distance'), '.2f')} m left{flags})"
    return (f"{head} {outcome}; slip {_num(row.get('foot_slip_per_stride'), '.3f')} m/stride; "
            f"realtime factor {_num(row.get('realtime_factor'), '.2f')}, {row['wall_s']:.1f} s wall")


def _num(value, fmt: str, width: int = 0) -> str:
    """`value` formatted, or '-' when missing, right-aligned in `width`."""
    return format(value, fmt).rjust(width) if value is not None else '-'.rjust(width)


def format_summary(summary: dict) -> str:
    """Return the readable table of `summarize`'s result: one line per mode and kind, then the ratios."""
    lines = [f"{'mode':9s} {'terrain':8s} {'runs':>4s} {'reached':>12s} {'time s':>7s} {'slip med':>9s} "
             f"{'slip mean':>9s} {'speed':>7s} {'fell':>4s} {'stuck':>5s} {'errors':>6s}",
             f"{'':9s} {'':8s} {'':4s} {'':12s} {'(med)':>7s} {'m/stride':>9s} {'m/stride':>9s} "
             f"{'(med)':>7s}   speed = {summary['speed_key']}"]
    for mode, groups in summary['modes'].items():
        for group, g in groups.items():
            reached = f"{g['reached']}/{g['n']} {100 * g['reach_rate']:3.0f}%" if g['n'] else '-'
            lines.append(f"{mode:9s} {group:8s} {g['n']:4d} {reached:>12s} {_num(g['time_to_goal_median'], '.1f', 7)} "
                         f"{_num(g['foot_slip_per_stride_median'], '.4f', 9)} "
                         f"{_num(g['foot_slip_per_stride_mean'], '.4f', 9)} {_num(g['speed_median'], '.3f', 7)} "
                         f"{g['fell']:4d} {g['stuck']:5d} {g['errors']:6d}")
    if summary['ratios']:
        lines += ['', f"{'with / without adaptation':26s} {'reach rate':>10s} {'slip without/with':>17s} "
                      f"{'time without/with':>17s}  (time: over the scenes both reached)"]
        for group, r in summary['ratios'].items():
            lines.append(f"{group:26s} {_num(r['reach_rate_with_over_without'], '.2f', 10)} "
                         f"{_num(r['slip_without_over_with'], '.2f', 17)} "
                         f"{_num(r['time_without_over_with'], '.2f', 17)}  ({r['both_reached']} scenes)")
    return '\n'.join(lines)
