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
`iguana sweep SPEC`: every task of a sweep spec (iguana_lab.sweep.spec) on a Dask cluster, one results table.

A local cluster of `--workers` processes by default, or the workers of `--scheduler ADDRESS`. A progress bar with
the ETA goes to stderr; each finished task is logged in OUT/rows.jsonl at once, so `--resume` runs only what is
missing; at the end OUT/results.csv, OUT/results.json and the spec's plots are written and one line names them.
"""
from __future__ import annotations

import argparse
from pathlib import Path
import sys
import time

from iguana_ros.cli.argtypes import count

DEFAULT_ROOT = Path('sweeps')
"""Where results go without -o: sweeps/<spec name>/."""


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the `sweep` sub-command."""
    parser = subparsers.add_parser('sweep', help='run a parameter sweep (scenes x overrides, or a benchmark) on a '
                                                 'Dask cluster; results table CSV + JSON and plots')
    parser.add_argument('spec', metavar='SPEC', help='sweep spec: a YAML path or a name under iguana_lab/sweeps/')
    parser.add_argument('-o', '--output', type=Path, default=None, metavar='DIR',
                        help='results folder (default sweeps/<spec name>/)')
    where = parser.add_mutually_exclusive_group()
    where.add_argument('--workers', type=count(1), default=None,
                       help='worker processes of the local cluster (default: one per core)')
    where.add_argument('--scheduler', default=None, metavar='ADDRESS',
                       help='run on the workers of this Dask scheduler (e.g. tcp://10.0.0.5:8786)')
    parser.add_argument('--memory-limit', default=None, metavar='SIZE',
                        help='memory limit of each local worker, e.g. 2GiB; 0 = none (default 3GiB)')
    parser.add_argument('--resume', action='store_true', help='continue a sweep in DIR: run only unfinished tasks')
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Read the spec (every task validated), run what is not done, write the table and plots."""
    from iguana_lab.sweep.engine import DEFAULT_MEMORY_LIMIT, Cluster, is_engine_failure, run_tasks
    from iguana_lab.sweep.results import ResultLog
    from iguana_lab.sweep.spec import load_sweep

    spec = load_sweep(args.spec)
    out = args.output if args.output is not None else DEFAULT_ROOT / spec.name
    cluster = Cluster(workers=args.workers, scheduler=args.scheduler,
                      memory_limit=_memory_limit(args.memory_limit) if args.memory_limit else DEFAULT_MEMORY_LIMIT)
    tasks = spec.plan.tasks
    with ResultLog(out, args.resume) as log:
        done = {key: result for key, result in log.finished().items() if not is_engine_failure(result)}
        results = [done.get(task.key) for task in tasks]
        todo = [k for k, task in enumerate(tasks) if task.key not in done]
        print(f'{spec.name}: {len(tasks)} tasks, {len(tasks) - len(todo)} done before, {len(todo)} to run on '
              f'{cluster.describe()}', file=sys.stderr, flush=True)
        start = time.perf_counter()

        def arrived(j: int, result) -> None:
            results[todo[j]] = result
            log.append(tasks[todo[j]].key, result)
        run_tasks([tasks[k] for k in todo], cluster, on_result=arrived, progress=True)
        wall = time.perf_counter() - start
    rows = spec.plan.rows(results)
    paths = write_outputs(spec, rows, out)
    failed = sum(bool(row.get('error')) for row in rows)
    print(f'{spec.name}: {len(rows)} rows ({failed} failed) in {wall:.1f} s wall; '
          f'{", ".join(str(p) for p in paths)}')
    return 0


def _memory_limit(text: str):
    """--memory-limit as Dask takes it: bytes, a size such as 2GiB, or 0 (none); InputError if unreadable."""
    from dask.utils import parse_bytes

    from iguana_ros.errors import InputError

    try:
        return parse_bytes(text) if text.strip() != '0' else 0
    except (ValueError, TypeError):
        raise InputError(f'--memory-limit: expected a size such as 2GiB or 500MB, got {text!r}') from None


def write_outputs(spec, rows: list[dict], out: Path) -> list[Path]:
    """Return the results table, the spec's summary (printed too) and plots, and the tradeoff figure; their paths."""
    from iguana_lab.sweep.results import check_plot_columns, plot_columns, plot_path, write_table

    meta = {'sweep': spec.name, 'kind': spec.kind, 'spec': spec.source, 'timing_columns': list(spec.plan.timing)}
    if spec.summary == 'locomotion':
        from iguana_lab.cli.bench_locomotion import format_summary
        from iguana_lab.locomotion_bench import summarize

        meta['summary'] = summarize(rows)
        print(format_summary(meta['summary']))
    paths = write_table(out, rows, meta)
    if spec.kind == 'tradeoff':
        from iguana_lab.bench.sim import plot_tradeoff

        plot_tradeoff(rows, out / 'tradeoff.png')
        paths.append(out / 'tradeoff.png')
    check_plot_columns(rows, spec.plots)
    for plot in spec.plots:
        paths.append(plot_columns(rows, plot, plot_path(out, plot), title=spec.name))
    return paths
