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
`iguana bench faults bags`.

Seeded random truncations and byte corruptions of a recorded bag's MCAP and damaged metadata.yaml variants, each checked
against mcap's own reader of the undamaged bag (iguana_lab.faults.bag_files).
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path
import sys

from iguana_ros.cli.argtypes import count, positive

RECORD_SCENE = 'flat_walk'
RECORD_SECONDS = 4.0
"""Without BAG, the suite records `iguana run flat_walk --duration 4` (the nodes and the project's recorder)."""


def register(suites: argparse._SubParsersAction) -> None:
    """Add the `bags` suite to `iguana bench faults`."""
    parser = suites.add_parser('bags', help='random truncations and corruptions of a recorded bag, damaged '
                                            'metadata.yaml: no traceback or hang, exit 1, every intact chunk back')
    parser.add_argument('bag', nargs='?', type=Path, default=None, metavar='BAG',
                        help=f'a finished bag directory (default: record `iguana run {RECORD_SCENE} '
                             f'--duration {RECORD_SECONDS:g}` into a temporary directory)')
    parser.add_argument('--truncations', type=count(0), default=100, help='random cuts (default 100)')
    parser.add_argument('--corruptions', type=count(0), default=100,
                        help='random 64-byte overwrites and flipped bytes, half each (default 100)')
    parser.add_argument('--seed', type=int, default=0, help='seed of the faults (default 0)')
    parser.add_argument('--timeout', type=positive('--timeout'), default=60.0, metavar='S',
                        help='a trial running longer is a hang (default 60 s)')
    parser.add_argument('--json', action='store_true', help='print one JSON object')
    parser.set_defaults(func=run)


def _record(directory: Path) -> Path:
    """Record a short node run into `directory`/run with `iguana run`; IguanaError if the run fails."""
    import subprocess

    from iguana_ros.errors import IguanaError

    bag = directory / 'run'
    cmd = [sys.executable, '-c', 'import sys; from iguana_ros.cli import main; sys.exit(main())',
           'run', RECORD_SCENE, '--duration', str(RECORD_SECONDS), '--record', str(bag)]
    print(f'recording {bag} with `iguana run {RECORD_SCENE} --duration {RECORD_SECONDS:g}` ...', file=sys.stderr,
          flush=True)
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0 or not bag.is_dir():
        tail = (done.stderr.strip() or done.stdout.strip()).splitlines()[-1:] or ['no output']
        raise IguanaError(f'recording the bag failed (exit {done.returncode}): {tail[0]}')
    return bag


def run(args: argparse.Namespace) -> int:
    """Run the suite; print its figures and every failed trial; exit 1 if any trial failed."""
    import tempfile

    from iguana_ros.cli import main
    from iguana_lab.faults.bag_files import run_suite

    def progress(row: dict, done: int, total: int) -> None:
        if row['problems'] or done % 25 == 0 or done == total:
            print(f'[{done}/{total}] {row["fault"]}: {"; ".join(row["problems"]) or "ok"}', file=sys.stderr,
                  flush=True)

    with tempfile.TemporaryDirectory(prefix='iguana_faults_bag_') as tmp:
        bag = args.bag if args.bag is not None else _record(Path(tmp))
        figures = run_suite(bag, args.truncations, args.corruptions, args.seed, args.timeout, progress=progress,
                            iguana=main)
    if args.bag is None:
        figures['bag'] = f'iguana run {RECORD_SCENE} --duration {RECORD_SECONDS:g} (temporary)'
    if args.json:
        print(json.dumps(figures, indent=1))
    else:
        print(format_figures(figures))
    return 1 if figures['failures'] else 0


def format_figures(f: dict) -> str:
    """Return the suite's figures as a few lines of text."""
    lines = [f"bag faults on {f['bag']} ({f['bytes']} bytes, {f['chunks']} chunks, {f['messages']} messages, "
             f"data-section CRC {f['data_crc']}; seed {f['seed']})"]
    for kind in ('truncate', 'bytes', 'flip', 'metadata'):
        if kind in f['trials']:
            lines.append(f"  {kind:9s} {f['trials'][kind]:4d} trials, {f['survived'].get(kind, 0):4d} survived")
    lines += [f"  total     {f['trials_total']:4d} trials, {f['survived_total']:4d} survived; exit 0 on damage "
              f"{f['exit_0_on_damage']}, tracebacks {f['tracebacks']}, hangs {f['hangs']}",
              f"  messages of intact chunks: {f['recovered_intact_messages']} recovered of {f['intact_messages']} "
              f"(lost {f['lost_intact_messages']}); wrong {f['wrong_messages']}; salvaged from damaged chunks "
              f"{f['salvaged_messages']}",
              f"  wall {f['wall_s']:.1f} s, slowest trial {f['max_trial_s']:.2f} s"]
    lines += [f"  FAILED {x['fault']}: {'; '.join(x['problems'])}" for x in f['failures']]
    return '\n'.join(lines)
