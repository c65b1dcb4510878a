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
Run one `iguana bench` command on two revisions of this repository in turns and compare the medians.

``python tools/bench_turns.py --base REV [--head REV] [--pairs N] [--json] -- pipeline --seconds 5``

The machine this project is measured on is shared: its speed drifts by 20-50 % within minutes, so a before/after
is only worth something when both run in turns, many times. Each revision is checked out into its own clone (the
head defaults to this working tree, uncommitted edits included), its kernel cache warmed there (`iguana warm`),
and every run starts *inside* its tree: ``python -m`` puts the current directory first on ``sys.path``, so a run
started from another checkout imports that checkout's code whatever PYTHONPATH says — both sides then measure the
same code. Each tree's run is checked to import its own ``iguana_ros`` before anything is measured. Pairs
alternate their order (base first, then head first) so a drift during a pair does not favour one side. Every run
has its own ROS_DOMAIN_ID and discovery stays on this host.

Prints each numeric field of the bench's JSON per run and the medians of both sides (``--json``: one object);
exits 1 with one line if a checkout, the warm-up or a run fails.
"""
from __future__ import annotations

import argparse
import json
import os
from pathlib import Path
import random
import statistics
import subprocess
import sys
import tempfile

REPO = Path(__file__).resolve().parent.parent
WORKTREE = 'worktree'
"""`--head` value meaning this working tree as it is (uncommitted edits included)."""
DOMAIN_IDS = range(150, 230)
"""ROS_DOMAIN_IDs the runs take at random (apart from test/conftest.py's)."""


class TurnsError(RuntimeError):
    """A checkout, warm-up or benchmark run failed; the message is the one line to print."""


def last_line(text: str) -> str:
    """Return the last non-empty line of a process's stderr (what it said when it failed), or 'no output'."""
    lines = [line.strip() for line in text.splitlines() if line.strip()]
    return lines[-1] if lines else 'no output'


def checkout(rev: str, into: Path) -> Path:
    """Clone this repository into `into` at `rev` (or return the working tree for WORKTREE); the tree's root."""
    if rev == WORKTREE:
        return REPO
    done = subprocess.run(['git', 'clone', '--quiet', '--no-checkout', str(REPO), str(into)],
                          capture_output=True, text=True)
    if done.returncode == 0:
        done = subprocess.run(['git', '-C', str(into), 'checkout', '--quiet', rev], capture_output=True, text=True)
    if done.returncode != 0:
        raise TurnsError(f'cannot check out {rev!r}: {last_line(done.stderr)}')
    return into


def run_env(domain_id: int) -> dict:
    """Environment of one run: its own ROS_DOMAIN_ID, discovery on this host only."""
    return {**os.environ, 'ROS_DOMAIN_ID': str(domain_id), 'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST'}


def imported_package(tree: Path, python: str = sys.executable) -> Path:
    """Directory of the `iguana_ros` that a run started in `tree` imports."""
    done = subprocess.run([python, '-c', 'import iguana_ros; print(iguana_ros.__file__)'], cwd=tree,
                          capture_output=True, text=True)
    if done.returncode != 0:
        raise TurnsError(f'python cannot import iguana_ros in {tree}: {last_line(done.stderr)}')
    return Path(done.stdout.strip()).resolve().parent


def prepare(tree: Path, python: str = sys.executable) -> None:
    """Check that runs in `tree` import its own package, then warm its kernel cache."""
    package = imported_package(tree, python)
    if package != (tree / 'iguana_ros').resolve():
        raise TurnsError(f'a run in {tree} imports {package}, not its own iguana_ros')
    done = subprocess.run([python, '-m', 'iguana_ros.cli', 'warm'], cwd=tree, capture_output=True, text=True,
                          env=run_env(random.choice(DOMAIN_IDS)))
    if done.returncode != 0:
        raise TurnsError(f'iguana warm failed in {tree}: {last_line(done.stderr)}')


def bench_once(tree: Path, bench_args: list, python: str = sys.executable) -> dict:
    """Numeric fields of one `iguana bench <bench_args> --json` run started in `tree`."""
    done = subprocess.run([python, '-m', 'iguana_ros.cli', 'bench', *bench_args, '--json'], cwd=tree,
                          capture_output=True, text=True, env=run_env(random.choice(DOMAIN_IDS)))
    if done.returncode != 0:
        raise TurnsError(f'iguana bench {" ".join(bench_args)} failed in {tree}: '
                         f'{last_line(done.stderr)}')
    return numeric_fields(json.loads(done.stdout))


def numeric_fields(result: dict) -> dict:
    """Return the top-level int and float fields of a bench's JSON (booleans and nested values left out)."""
    return {k: float(v) for k, v in result.items() if isinstance(v, (int, float)) and not isinstance(v, bool)}


def pair_order(pair: int) -> tuple:
    """Sides of pair `pair` in the order they run: base first in even pairs, head first in odd ones."""
    return ('base', 'head') if pair % 2 == 0 else ('head', 'base')


def summary(runs: dict) -> dict:
    """Per field: the values of each side in pair order and their medians; `runs` maps side to a list of fields."""
    fields = [f for f in runs['base'][0] if all(f in r for side in runs.values() for r in side)]
    out = {}
    for field in fields:
        base = [r[field] for r in runs['base']]
        head = [r[field] for r in runs['head']]
        out[field] = {'base': base, 'head': head, 'base_median': statistics.median(base),
                      'head_median': statistics.median(head)}
    return out


def report(table: dict, base: str, head: str) -> str:
    """Readable table: one line per field with both sides' runs and medians."""
    lines = [f'base {base}  ->  head {head}  ({len(next(iter(table.values()))["base"])} pairs, in turns)']
    for field, row in table.items():
        runs = ' '.join(f'{b:.3g}/{h:.3g}' for b, h in zip(row['base'], row['head']))
        lines.append(f'  {field:32s} {row["base_median"]:10.4g} -> {row["head_median"]:10.4g}   (base/head: {runs})')
    return '\n'.join(lines)


def parse_args(argv: list) -> argparse.Namespace:
    """Command line (see the module docstring)."""
    parser = argparse.ArgumentParser(prog='bench_turns.py', description=__doc__.strip().splitlines()[0])
    parser.add_argument('--base', required=True, help='revision to compare against (e.g. a commit or HEAD~3)')
    parser.add_argument('--head', default=WORKTREE, help=f'revision measured against it (default {WORKTREE}: '
                                                         'this working tree with its uncommitted edits)')
    parser.add_argument('--pairs', type=int, default=5, help='runs of each side, in turns (default 5)')
    parser.add_argument('--json', action='store_true', help='print one JSON object')
    parser.add_argument('bench_args', nargs=argparse.REMAINDER, help='after --: the `iguana bench` arguments')
    args = parser.parse_args(argv)
    args.bench_args = [a for a in args.bench_args if a != '--'] or ['sim']
    if args.pairs < 1:
        parser.error('--pairs must be at least 1')
    return args


def measure(args: argparse.Namespace, scratch: Path) -> dict:
    """Check out and warm both sides, then run the pairs; the summary table."""
    trees = {'base': checkout(args.base, scratch / 'base'), 'head': checkout(args.head, scratch / 'head')}
    for tree in trees.values():
        prepare(tree)
    runs = {'base': [], 'head': []}
    for pair in range(args.pairs):
        for side in pair_order(pair):
            runs[side].append(bench_once(trees[side], args.bench_args))
    return summary(runs)


def main(argv: list | None = None) -> int:
    """Entry point; exit status 0 or 1 (one line on stderr)."""
    args = parse_args(sys.argv[1:] if argv is None else argv)
    try:
        with tempfile.TemporaryDirectory(prefix='iguana_turns_') as scratch:
            table = measure(args, Path(scratch))
    except TurnsError as exc:
        print(f'bench_turns: {exc}', file=sys.stderr)
        return 1
    print(json.dumps({'base': args.base, 'head': args.head, 'bench': args.bench_args, 'fields': table})
          if args.json else report(table, args.base, args.head))
    return 0


if __name__ == '__main__':
    sys.exit(main())
