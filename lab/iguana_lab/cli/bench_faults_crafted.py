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
`iguana bench faults crafted`.

Bags with valid CRCs that lie: a channel id defined twice, decompression bombs (iguana_lab/faults/bag_crafts.py),
read by `bag info`, `bag play --allow-damaged` and the viewer's reader in child processes whose peak memory is measured.
"""
from __future__ import annotations

import argparse
import os

from iguana_lab.cli.bench_faults import add_run_options, run_suite_in, suite_domain


def register(suites: argparse._SubParsersAction) -> None:
    """Add the `crafted` suite to `iguana bench faults`."""
    parser = suites.add_parser('crafted', help='bags with a channel defined twice and decompression bombs')
    add_run_options(parser, 'readers')
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Read every crafted bag with every reader (one line each), then the figures; exit status 1 if any failed."""
    from iguana_lab.faults.bag_crafts import crafted_suite, PEAK_LIMIT_MB, trial_line

    env = {**os.environ, 'ROS_DOMAIN_ID': suite_domain(args)}
    return run_suite_in(args, 'iguana_crafted_', lambda folder, progress: crafted_suite(folder, env, progress),
                        trial_line, lambda r: f"crafted bags: {r['survived']}/{r['trials']} readings as expected, peak "
                                              f"memory {r['peak_mb']:.0f} MB (limit {PEAK_LIMIT_MB} MB)")
