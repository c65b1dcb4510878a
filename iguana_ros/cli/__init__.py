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

"""The `iguana` command: one sub-command per module listed in SUBCOMMANDS."""
from __future__ import annotations

import argparse
import importlib
import sys

from iguana_ros import package_version
from iguana_ros.errors import IguanaError

SUBCOMMANDS = (
    # (name, module exposing `register(subparsers)`); modules are imported only when listed here.
    ('topics', 'iguana_ros.cli.topics'),
    ('bag', 'iguana_ros.cli.bag'),
    ('goal', 'iguana_ros.cli.goal'),
    ('render', 'iguana_ros.cli.render'),
    ('view', 'iguana_ros.cli.view'),
    ('motion', 'iguana_ros.cli.motion'),
    ('model', 'iguana_ros.cli.model'),
    ('bench', 'iguana_ros.cli.bench'),
    ('bench-adaptation', 'iguana_ros.cli.bench_adaptation'),
    ('simulate', 'iguana_ros.cli.simulate'),
    ('sweep', 'iguana_ros.cli.sweep'),
    ('run', 'iguana_ros.cli.run'),
    ('demo', 'iguana_ros.cli.demo'),
    ('warm', 'iguana_ros.cli.warm'),
    ('doctor', 'iguana_ros.cli.doctor'),
    ('layout', 'iguana_ros.cli.layout'),
)


def build_parser() -> argparse.ArgumentParser:
    """Parser for every sub-command."""
    parser = argparse.ArgumentParser(
        prog='iguana', description='Soft-body iguana character control for ROS 2 (Kwon et al. 2018).')
    parser.add_argument('--version', action='version', version=f'%(prog)s {package_version()}')
    subparsers = parser.add_subparsers(dest='command', metavar='COMMAND', required=True)
    for _name, module in SUBCOMMANDS:
        importlib.import_module(module).register(subparsers)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the `iguana` console script; returns the exit status."""
    command = 'iguana'
    try:
        args = build_parser().parse_args(argv)
        command = f'iguana {args.command}'
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


def _silence_stdout() -> None:
    """Point stdout at /dev/null so the interpreter's final flush of a closed pipe raises nothing."""
    import os
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, sys.stdout.fileno())
    os.close(devnull)


if __name__ == '__main__':
    sys.exit(main())
