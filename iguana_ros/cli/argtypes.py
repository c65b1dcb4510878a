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

"""argparse value types shared by the `iguana` sub-commands: counts and positive numbers, one error line each."""
from __future__ import annotations

import argparse
import math


def count(minimum: int):
    """`argparse` type: an integer >= `minimum`."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f'expected an integer, got {text!r}') from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f'expected an integer >= {minimum}, got {value}')
        return value
    return parse


def positive(what: str):
    """`argparse` type: a positive, finite number called `what` in the error."""
    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f'{what} must be a number, got {text!r}') from None
        if not 0 < value < math.inf:
            raise argparse.ArgumentTypeError(f'{what} must be a positive number, got {text!r}')
        return value
    return parse


def namespace(text: str) -> str:
    """`argparse` type: a ROS namespace as 'iguana1' or '/zoo/iguana1', returned as '/iguana1' ('' for the root)."""
    from iguana_ros.errors import InputError
    from iguana_ros.topics import check_namespace
    try:
        return check_namespace(text)
    except InputError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def add_namespace(parser: argparse.ArgumentParser, what: str) -> None:
    """Add `--namespace NS` to `parser`: the ROS namespace of the run `what` (e.g. 'to send the goal to')."""
    parser.add_argument('--namespace', type=namespace, default='', metavar='NS',
                        help=f'ROS namespace of the run {what} (as `iguana run --namespace NS`; default: the root)')
