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
`iguana bench faults environments`.

A table of broken environments (domain ids, RMW, log and cache folders, discovery settings); in each, `iguana doctor`
must name the cause and `iguana goal` stop with one clear line (iguana_lab/faults/environments.py).
"""
from __future__ import annotations

import argparse
import sys

from iguana_lab.cli.bench_faults import suite_domain


def register(suites: argparse._SubParsersAction) -> None:
    """Add the `environments` suite to `iguana bench faults`."""
    parser = suites.add_parser('environments', help='broken environments: the doctor names each cause, iguana goal '
                                                    'stops with one line')
    parser.add_argument('faults', nargs='*', metavar='FAULT', help='rows of the table to run (default: all)')
    parser.add_argument('--domain', type=int, default=None, metavar='ID',
                        help='ROS_DOMAIN_ID of the rows that keep it (default: 1 + pid %% 200, discovery on localhost)')
    parser.add_argument('--json', action='store_true', help='print one JSON object')
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run the rows (one line each as they end), then the counts; exit status 1 if any row failed."""
    from iguana_ros.errors import InputError
    from iguana_lab.faults.environments import environment_suite, select, suite_lines, to_json

    try:
        select(args.faults)
    except ValueError as exc:
        raise InputError(str(exc)) from None
    result = environment_suite(args.faults, suite_domain(args),
                               lambda trial: print(trial.line(), file=sys.stderr if args.json else sys.stdout,
                                                   flush=True))
    print(to_json(result) if args.json else '\n'.join(suite_lines(result)), flush=True)
    return 0 if result['survived'] == result['trials'] else 1
