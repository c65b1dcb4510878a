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
`iguana doctor`.

Is this machine ready to run iguana_ros? One ✓/✗ line per check, the fix under each ✗, exit status 1 if anything a run
needs is missing. The DDS checks are tried only when the ROS environment (domain id, log directory, discovery range,
static peers) and rclpy pass: a domain id beyond 232 would end the process inside Fast DDS.
"""
from __future__ import annotations

import argparse
import os
from pathlib import Path


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the `doctor` sub-command."""
    parser = subparsers.add_parser(
        'doctor', help='check Python, the ROS environment (domain id, log directory, discovery), rclpy/RMW, DDS '
                       'between processes, the ROS domain, caches, bag folder, ffmpeg')
    parser.add_argument('--bags-dir', type=Path, default=Path('bags'), help='bag folder to check (default: bags/)')
    parser.add_argument('--resolution', default='medium', help='model resolution whose cache to check')
    parser.add_argument('--timeout', type=float, default=None, metavar='S',
                        help='wall seconds the DDS loopback may take (default 15)')
    parser.set_defaults(func=run)


def environment_line() -> str:
    """'ROS_DOMAIN_ID 42, RMW_IMPLEMENTATION unset, ROS_AUTOMATIC_DISCOVERY_RANGE LOCALHOST'."""
    names = ('ROS_DOMAIN_ID', 'RMW_IMPLEMENTATION', 'ROS_AUTOMATIC_DISCOVERY_RANGE')
    return ', '.join(f'{name} {os.environ.get(name) or "unset"}' for name in names)


def run(args: argparse.Namespace) -> int:
    """Print every check; 1 if a needed one failed."""
    print(f'iguana doctor: {environment_line()}', flush=True)
    from iguana_ros.doctor import all_checks

    checks = all_checks(args.timeout, args.resolution, args.bags_dir)
    for check in checks:
        for line in check.lines():
            print(line, flush=True)
    failed = [c for c in checks if c.needed and not c.ok]
    optional = [c for c in checks if not c.needed and not c.ok]
    extra = f' ({len(optional)} optional missing: {", ".join(c.name for c in optional)})' if optional else ''
    if failed:
        print(f'iguana doctor: {len(failed)} of {len(checks)} checks failed: {", ".join(c.name for c in failed)}'
              f'{extra}', flush=True)
        return 1
    print(f'iguana doctor: ready ({len(checks) - len(optional)} of {len(checks)} checks passed{extra})', flush=True)
    return 0
