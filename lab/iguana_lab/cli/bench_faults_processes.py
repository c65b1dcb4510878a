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
`iguana bench faults processes`.

Kill `iguana run` or one of its children (SIGKILL, SIGTERM, SIGINT) at seeded random moments; every trial must leave no
process behind, a readable bag with every message recorded before the fault, and one clear line
(iguana_lab/faults/processes.py).
"""
from __future__ import annotations

import argparse
import sys

from iguana_lab.cli.bench_faults import add_run_options, suite_domain
from iguana_ros.cli.argtypes import count


def register(suites: argparse._SubParsersAction) -> None:
    """Add the `processes` suite to `iguana bench faults`."""
    parser = suites.add_parser('processes', help='kill iguana run and its children at random moments')
    parser.add_argument('--trials', type=count(1), default=36,
                        help='faults to inject, one run each (default 36: every target x signal x phase once)')
    parser.add_argument('--seed', type=int, default=12, help='seed of targets, signals and moments (default 12)')
    add_run_options(parser, 'trials')
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run the trials (one line each as they end), then the figures; exit status 1 if any trial failed."""
    from iguana_lab.faults.processes import Trial, fault_suite, suite_line, to_json

    domain = suite_domain(args)

    def progress(trial: Trial) -> None:
        print(trial.line(), file=sys.stderr if args.json else sys.stdout, flush=True)

    result = fault_suite(args.trials, args.seed, args.keep, domain, progress)
    if args.json:
        print(to_json(result))
    else:
        print(suite_line(result))
    return 0 if result['survived'] == result['trials'] else 1
