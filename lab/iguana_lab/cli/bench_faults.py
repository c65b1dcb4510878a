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
`iguana bench faults SUITE`.

The fault-injection suites, one module each (listed in SUITES) adding its sub-command to the `faults` group.
"""
from __future__ import annotations

import argparse
from collections.abc import Callable
import importlib
import json
import os
from pathlib import Path
import shutil
import sys
import tempfile

from iguana_ros.cli.argtypes import count

SUITES = (
    # (name, module exposing `register(suites)`); a suite is imported only when listed here.
    ('scenes', 'iguana_lab.cli.bench_faults_scenes'),
    ('bags', 'iguana_lab.cli.bench_faults_bags'),
    ('crafted', 'iguana_lab.cli.bench_faults_crafted'),
    ('processes', 'iguana_lab.cli.bench_faults_processes'),
    ('topics', 'iguana_lab.cli.bench_faults_topics'),
    ('limits', 'iguana_lab.cli.bench_faults_limits'),
    ('strays', 'iguana_lab.cli.bench_faults_strays'),
    ('environments', 'iguana_lab.cli.bench_faults_environments'),
)


def add_run_options(parser: argparse.ArgumentParser, runs: str = 'runs') -> None:
    """Add the options of a suite that starts ROS processes: --domain, --keep DIR, --json."""
    parser.add_argument('--domain', type=count(0), default=None, metavar='ID',
                        help=f'ROS_DOMAIN_ID of the {runs} (default: 1 + pid %% 200, discovery on localhost)')
    parser.add_argument('--keep', type=Path, default=None, metavar='DIR',
                        help=f'keep every one of the {runs} (scene, bag, logs) under DIR')
    parser.add_argument('--json', action='store_true', help='print one JSON object')


def suite_domain(args: argparse.Namespace) -> str:
    """Return the ROS_DOMAIN_ID of a suite's runs (--domain, else one from the pid), discovery kept on localhost."""
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    return str(args.domain if args.domain is not None else 1 + os.getpid() % 200)


def run_suite_in(args: argparse.Namespace, prefix: str, suite: Callable[[Path, Callable], dict],
                 row_line: Callable[[object], str], figures_line: Callable[[dict], str]) -> int:
    """
    Run `suite(workdir, progress)` in --keep DIR or a temporary folder (removed after); exit 1 unless all survived.

    Each row's line as it ends (stderr with --json), then the figures' line or the result as JSON.
    """
    out = sys.stderr if args.json else sys.stdout
    workdir = args.keep or Path(tempfile.mkdtemp(prefix=prefix))
    try:
        result = suite(workdir, lambda row: print(row_line(row), file=out, flush=True))
    finally:
        if args.keep is None:
            shutil.rmtree(workdir, ignore_errors=True)
    print(json.dumps(result, indent=1) if args.json else figures_line(result))
    return 0 if result['survived'] == result['trials'] else 1


def faults_group(sub: argparse._SubParsersAction) -> argparse._SubParsersAction:
    """
    Return the sub-command action of `iguana bench faults` under the bench sub-commands `sub`, created on first use.

    An existing `faults` group is reused, so suites registered from elsewhere join it.
    """
    parser = sub.choices.get('faults')
    if parser is None:
        parser = sub.add_parser('faults', help='fault-injection suites: bad scenes, damaged bags, killed processes, '
                                               'bad topic messages, broken environments')
        return parser.add_subparsers(dest='suite', metavar='SUITE', required=True)
    return next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))


def register(sub: argparse._SubParsersAction) -> None:
    """Add `faults` with every suite of SUITES to the bench sub-commands `sub`."""
    suites = faults_group(sub)
    for _name, module in SUITES:
        importlib.import_module(module).register(suites)
