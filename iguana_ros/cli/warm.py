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

"""`iguana warm`: compile the kernels and build the default model once (run by `make install`)."""
from __future__ import annotations

import argparse


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the `warm` sub-command."""
    parser = subparsers.add_parser('warm', help='compile every numba kernel and cache the default body model, so '
                                                'the first run does not pay for it')
    parser.add_argument('--scene', default='hills', help='scene whose loop drives the kernels (default: hills)')
    parser.add_argument('--json', action='store_true', help='print the figures as JSON')
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Warm up and print how long it took and how many kernels are cached."""
    import dataclasses
    import json

    from iguana_ros.warmup import warm_up

    report = warm_up(args.scene)
    if args.json:
        print(json.dumps(dataclasses.asdict(report)))
    else:
        print(f'iguana warm: {report.kernels} kernels ({report.signatures} signatures) ready; frame loop '
              f'{report.loop_s:.1f} s, render {report.render_s:.1f} s')
    return 0
