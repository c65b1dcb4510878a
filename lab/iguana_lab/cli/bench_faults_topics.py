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
`iguana bench faults topics`.

Seeded bad messages (NaN, Inf, huge, negative, wrong length, wrong frame_id, stale, future) on every topic a node
subscribes to while real lockstep runs go on; every run must complete with no node dead, nothing non-finite published
and the library run's trajectory (iguana_lab/faults/topic_fuzz.py).
"""
from __future__ import annotations

import argparse
import os

from iguana_lab.cli.bench_faults import add_run_options, run_suite_in, suite_domain
from iguana_ros.cli.argtypes import count, positive


def register(suites: argparse._SubParsersAction) -> None:
    """Add the `topics` suite to `iguana bench faults`."""
    parser = suites.add_parser('topics', help='bad messages on every subscribed topic during lockstep runs')
    parser.add_argument('--trials', type=count(1), default=4, help='fuzzed runs (default 4)')
    parser.add_argument('--messages', type=count(1), default=400, help='faults per run (default 400)')
    parser.add_argument('--seconds', type=positive('--seconds'), default=6.0,
                        help='simulated seconds per run (default 6)')
    parser.add_argument('--mesh', choices=('coarse', 'medium'), default='coarse', help='model resolution')
    parser.add_argument('--seed', type=int, default=0, help='seed of scenes and faults (default 0)')
    add_run_options(parser, 'runs')
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run the trials (one line each as they end), then the figures; exit status 1 if any run failed."""
    from iguana_lab.faults.topic_fuzz import suite_line, topic_fault_suite, trial_line

    os.environ['ROS_DOMAIN_ID'] = suite_domain(args)
    return run_suite_in(args, 'iguana_topic_faults_', lambda folder, progress: topic_fault_suite(
        args.trials, args.seed, args.messages, args.seconds, args.mesh, folder, progress), trial_line, suite_line)
