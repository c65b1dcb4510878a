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
The `iguana` command: one sub-command per module listed in SUBCOMMANDS, plus those other distributions add.

A distribution adds commands through the `iguana_ros.commands` entry-point group (each entry a module exposing
`register(subparsers)`): the lab (`lab/`, distribution iguana_lab) adds `bench` and `sweep` that way, so they exist
only where the lab is installed.
"""
from __future__ import annotations

import argparse
import importlib
from importlib.metadata import entry_points
import sys

from iguana_ros import package_version
from iguana_ros.errors import IguanaError

SUBCOMMANDS = (
    # (name, module exposing `register(subparsers)`); modules are imported only when listed here.
    ('topics', 'iguana_ros.cli.topics'),
    ('bag', 'iguana_ros.cli.bag'),
    ('goal', 'iguana_ros.cli.goal'),
    ('sim', 'iguana_ros.cli.sim'),
    ('render', 'iguana_ros.cli.render'),
    ('view', 'iguana_ros.cli.view'),
    ('motion', 'iguana_ros.cli.motion'),
    ('model', 'iguana_ros.cli.model'),
    ('simulate', 'iguana_ros.cli.simulate'),
    ('run', 'iguana_ros.cli.run'),
    ('demo', 'iguana_ros.cli.demo'),
    ('warm', 'iguana_ros.cli.warm'),
    ('doctor', 'iguana_ros.cli.doctor'),
    ('layout', 'iguana_ros.cli.layout'),
)

COMMAND_GROUP = 'iguana_ros.commands'
"""Entry-point group through which other distributions (the lab) add sub-commands."""


def added_commands() -> list[tuple[str, str]]:
    """Return (name, module) of the sub-commands installed distributions add, sorted by name."""
    return sorted((ep.name, ep.value) for ep in entry_points(group=COMMAND_GROUP))


def build_parser() -> argparse.ArgumentParser:
    """Parser for every sub-command."""
    parser = argparse.ArgumentParser(
        prog='iguana', description='Soft-body iguana character control for ROS 2 (Kwon et al. 2018).')
    parser.add_argument('--version', action='version', version=f'%(prog)s {package_version()}')
    subparsers = parser.add_subparsers(dest='command', metavar='COMMAND', required=True)
    for _name, module in SUBCOMMANDS:
        importlib.import_module(module).register(subparsers)
    for name, module in added_commands():
        try:
            register = importlib.import_module(module).register
        except Exception as exc:                  # noqa: BLE001 - a broken add-on must not take the core down
            print(f'iguana: the {name!r} command of an installed add-on is unavailable: {module}: {exc}',
                  file=sys.stderr)
            continue
        register(subparsers)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the `iguana` console script; returns the exit status."""
    command = 'iguana'
    argv = sys.argv[1:] if argv is None else list(argv)
    own, ros = split_ros_args(argv)
    try:
        args = build_parser().parse_args(own)
        command = f'iguana {args.command}'
        if ros and not getattr(args, 'takes_ros_args', False):
            raise IguanaError('takes no --ros-args (iguana run passes them to every node)')
        args.ros_args = tuple(ros)
        return int(args.func(args) or 0)
    except IguanaError as exc:
        print(f'{command}: error: {exc}', file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f'{command}: interrupted', file=sys.stderr)
        return 130
    except BrokenPipeError:                   # `iguana bag info BAG | head`: the reader left; say nothing more
        _silence_stdout()
        return 141


def split_ros_args(argv: list[str]) -> tuple[list[str], list[str]]:
    """Return (the command's own arguments, everything from `--ros-args` on) of a command line."""
    if '--ros-args' not in argv:
        return argv, []
    at = argv.index('--ros-args')
    return argv[:at], argv[at:]


def _silence_stdout() -> None:
    """Point stdout at /dev/null so the interpreter's final flush of a closed pipe raises nothing."""
    import os
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, sys.stdout.fileno())
    os.close(devnull)


if __name__ == '__main__':
    sys.exit(main())
