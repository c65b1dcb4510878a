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
`iguana bench faults scenes`.

Seeded random mutations of the shipped scenes, each loaded (valid Scene or one SceneError line naming file and field,
quickly, in bounded memory) and a sample run through `iguana simulate` in subprocesses (exit 1 with one line for an
invalid scene, no traceback, peak RSS measured).
"""
from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

from iguana_ros.cli.argtypes import count


def register(suites: argparse._SubParsersAction) -> None:
    """Add the `scenes` suite to `iguana bench faults`."""
    parser = suites.add_parser('scenes', help='random mutations of the shipped scenes: load and iguana simulate')
    parser.add_argument('--trials', type=count(1), default=300, help='mutations to load (default 300)')
    parser.add_argument('--seed', type=int, default=12, help='seed of the mutations (default 12)')
    parser.add_argument('--cli-sample', type=count(0), default=40, metavar='N',
                        help='mutations also run through `iguana simulate` in subprocesses (default 40)')
    parser.add_argument('--cli-all', action='store_true', help='run every mutation through `iguana simulate`')
    parser.add_argument('--workers', type=count(1), default=os.cpu_count() or 1,
                        help='parallel `iguana simulate` subprocesses (default: all cores)')
    parser.add_argument('--keep', type=Path, default=None, metavar='DIR', help='write the mutated files here')
    parser.add_argument('--json', action='store_true', help='print one JSON object')
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run the suite, print its figures (and every failure); exit status 1 if any trial failed."""
    from iguana_lab.faults.scene_files import run_suite

    result = run_suite(args.trials, args.seed, -1 if args.cli_all else args.cli_sample, args.workers, args.keep)
    if args.json:
        print(json.dumps(result, indent=1))
    else:
        for line in summary_lines(result):
            print(line)
    return 0 if not (result['failures'] or result['cli_failures']) else 1


def summary_lines(result: dict) -> list[str]:
    """Human-readable lines of a suite result: totals, per kind, the CLI sample, failures."""
    lines = [f"scene mutations (seed {result['seed']}): {result['trials']} trials, {result['survived']} survived; "
             f"{result['valid']} valid, {result['rejected']} rejected with one line "
             f"({result['field_named']} naming a field), {result['crashed']} crashed; "
             f"slowest load {1e3 * result['max_load_s']:.1f} ms, largest heap peak "
             f"{result['max_load_peak_mb']:.1f} MB",
             f"  {'kind':16s} {'trials':>6s} {'valid':>6s} {'rejected':>8s} {'failed':>6s}"]
    for kind, c in result['by_kind'].items():
        lines.append(f"  {kind:16s} {c['trials']:6d} {c['valid']:6d} {c['rejected']:8d} {c['problems']:6d}")
    lines.append(f"iguana simulate --duration 0.1: {result['cli_trials']} runs ({result['cli_rejected']} of invalid "
                 f"scenes), {result['cli_survived']} survived; peak RSS at most "
                 f"{result['cli_max_peak_rss_mb']:.0f} MB, slowest {result['cli_max_wall_s']:.1f} s; "
                 f"wall {result['wall_s']:.1f} s")
    for f in result['failures']:
        lines.append(f"FAILED load #{f['index']} {f['kind']} of {f['base']} ({f['note']}): {'; '.join(f['problems'])}"
                     f" -- {f['message'][:200]}")
    for f in result['cli_failures']:
        lines.append(f"FAILED simulate #{f['index']} {f['kind']}: {'; '.join(f['problems'])} -- {f['stderr'][:2]}")
    return lines
