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
`iguana bench faults strays`.

Strangers' subscribers and publishers on every topic while `iguana run` starts (iguana_lab/faults/strays.py): the run
completes as it would alone, or, against publishers of its outputs, refuses the busy domain in one line.
"""
from __future__ import annotations

import argparse
import os

from iguana_lab.cli.bench_faults import add_run_options, run_suite_in, suite_domain
from iguana_ros.cli.argtypes import count


def register(suites: argparse._SubParsersAction) -> None:
    """Add the `strays` suite to `iguana bench faults`."""
    parser = suites.add_parser('strays', help="strangers' subscribers and publishers on every topic at start-up")
    parser.add_argument('--trials', type=count(1), default=50, help='runs (default 50)')
    parser.add_argument('--seed', type=int, default=0, help='seed of the modes and moments (default 0)')
    add_run_options(parser, 'runs')
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run the trials (one line each as they end), then the figures; exit status 1 if any run failed."""
    from iguana_lab.faults.strays import stray_suite, trial_line

    os.environ['ROS_DOMAIN_ID'] = suite_domain(args)
    return run_suite_in(args, 'iguana_strays_', lambda folder, progress: stray_suite(args.trials, args.seed, folder,
                                                                                     progress), trial_line,
                        lambda r: f"strays: {r['survived']}/{r['trials']} runs as expected ({r['refused']} refused the "
                                  f"busy domain in one line), longest run {r['max_run_wall_s']} s, {r['wall_s']:.0f} s "
                                  'wall')
