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
`iguana layout rviz|foxglove`.

Print the path of the shipped RViz2 config or Foxglove layout, for `rviz2 -d "$(iguana layout rviz)"` and Foxglove's
Layouts > Import from file.
"""
from __future__ import annotations

import argparse

LAYOUTS = {'rviz': ('rviz', 'iguana.rviz'), 'foxglove': ('foxglove', 'iguana_layout.json')}
"""Shipped display layouts: name -> path under share/iguana_ros/."""


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the `layout` sub-command."""
    parser = subparsers.add_parser('layout', help='print the path of the RViz2 config or the Foxglove layout')
    parser.add_argument('which', choices=sorted(LAYOUTS), help='rviz: rviz/iguana.rviz; foxglove: '
                        'foxglove/iguana_layout.json')
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Print the layout's absolute path; one error line if it is not installed."""
    from iguana_ros.config import shared_path
    from iguana_ros.errors import IguanaError
    try:
        path = shared_path(*LAYOUTS[args.which])
    except FileNotFoundError as exc:
        raise IguanaError(str(exc)) from None
    if not path.is_file():
        raise IguanaError(f'{path} is missing from the installation; reinstall iguana_ros')
    print(path)
    return 0
