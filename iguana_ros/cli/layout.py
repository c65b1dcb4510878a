"""`iguana layout rviz|foxglove`: print the path of the shipped RViz2 config or Foxglove layout, for
`rviz2 -d "$(iguana layout rviz)"` and Foxglove's Layouts > Import from file."""
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
