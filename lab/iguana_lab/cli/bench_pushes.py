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

"""`iguana bench pushes`: the Section VIII-D push experiment (iguana_lab.push_experiment) on all cores."""
from __future__ import annotations

import argparse
import json
import sys

from iguana_ros.cli.argtypes import count, positive


def register(subparsers) -> None:
    """Add the `pushes` sub-command to `iguana bench`."""
    parser = subparsers.add_parser('pushes', help='40 N, 0.1 s pushes on the left trunk at several stride phases, '
                                                  'normal vs softer model (paper Section VIII-D)')
    parser.add_argument('--phases', type=count(1), default=6, help='push phases per stride (default 6)')
    parser.add_argument('--mesh', choices=('coarse', 'medium', 'fine'), default='medium')
    parser.add_argument('--force', type=positive('force'), default=None, metavar='N', help='push force (default 40 N)')
    parser.add_argument('--workers', type=count(1), default=None, help='worker processes (default: all cores)')
    parser.add_argument('--json', action='store_true', help='print one JSON object')
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run the experiment and print a table per model (or JSON)."""
    import dataclasses

    from iguana_lab.push_experiment import PushSettings, run_push_experiment

    settings = PushSettings(phases=args.phases, resolution=args.mesh)
    if args.force is not None:
        settings = dataclasses.replace(settings, force=args.force)

    def progress(_trace, done, total):
        print(f'[{done}/{total}] runs done', file=sys.stderr, flush=True)
    result = run_push_experiment(settings=settings, workers=args.workers, progress=progress)
    if args.json:
        print(json.dumps(result, indent=1))
        return 0
    for name, model in result['models'].items():
        print(f"{name}: peak lateral displacement median {100 * model['peak_lateral_median_m']:.1f} cm "
              f"(range {100 * model['peak_lateral_min_m']:.1f}-{100 * model['peak_lateral_max_m']:.1f} cm), "
              f"speed after {model['recovered_speed_fraction_median']:.2f} of unpushed, stance-foot slip in the "
              f"second after a push {100 * model['window_slip_mean_m']:.1f} cm per foot per stride, "
              f"fell {model['fell']}")
        for push in model['pushes']:
            print(f"  push at {push['at']:.3f} s: {100 * push['peak_lateral_m']:.1f} cm, speed after "
                  f"{push['recovered_speed_fraction']:.2f}, slip {100 * push['window_slip_mean']:.1f} cm")
    return 0
