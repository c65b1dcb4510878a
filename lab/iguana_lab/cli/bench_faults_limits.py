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
`iguana bench faults limits`.

Pushes and desired spring lengths drawn at random within what the nodes accept (iguana_lab/faults/limits.py): none
may diverge, and no run may be reported completed whose body left the terrain or fell.
"""
from __future__ import annotations

import argparse
import json
import sys

from iguana_ros.cli.argtypes import count


def register(suites: argparse._SubParsersAction) -> None:
    """Add the `limits` suite to `iguana bench faults`."""
    parser = suites.add_parser('limits', help='pushes and spring lengths at random within the accepted limits')
    parser.add_argument('--pushes', type=count(0), default=500, help='push trials (default 500)')
    parser.add_argument('--lengths', type=count(0), default=500, help='length trials (default 500)')
    parser.add_argument('--seed', type=int, default=0, help='seed of the trials (default 0)')
    parser.add_argument('--workers', type=count(1), default=2, help='processes (default 2)')
    parser.add_argument('--json', action='store_true', help='print one JSON object')
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run the trials (one line each as they end), then the figures; exit status 1 if any trial failed."""
    from iguana_lab.faults.limits import limits_suite, trial_line

    result = limits_suite(args.pushes, args.lengths, args.seed, args.workers,
                          lambda r: print(trial_line(r), file=sys.stderr if args.json else sys.stdout, flush=True))
    if args.json:
        print(json.dumps(result, indent=2))
    else:
        for kind in ('push', 'lengths'):
            row = result[kind]
            print(f"{kind:8s} trials {row['trials']}, accepted {row['accepted']}, diverged {row['diverged']}, "
                  f"outcomes {row['outcomes']}, watch vs trajectory disagreements {row['disagreements']}, "
                  f"simulated {row['simulated_s']} s")
    return 0 if result['ok'] else 1
