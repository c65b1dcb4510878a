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
All four nodes in one process with one executor (`iguana run --single-process`), or the ones named before `--ros-args`.

`python -m iguana_ros.nodes.all_nodes planner_node terrain_adaptation_node spring_length_node --ros-args -r
__ns:=/iguana_b` runs one character of a world (its simulator is the world's, in a process of its own).
"""
from __future__ import annotations

import importlib
import sys

from iguana_ros.executables import NODE_EXECUTABLES, NODE_PACKAGE
from iguana_ros.nodes.base import IguanaNode, run_nodes


def node_class(executable: str) -> type[IguanaNode]:
    """Return the node class of node executable `executable`: the IguanaNode of its module whose KIND is its name."""
    module = importlib.import_module(f'{NODE_PACKAGE}.{executable}')
    found = [cls for cls in vars(module).values()
             if isinstance(cls, type) and issubclass(cls, IguanaNode) and cls.KIND == executable]
    if len(found) != 1:
        raise LookupError(f'{module.__name__} defines {len(found)} IguanaNode classes of KIND {executable!r}')
    return found[0]


def chosen_nodes(args: list[str]) -> list[str]:
    """Return the node executables named before `--ros-args` in `args` (argv), every one of NODE_EXECUTABLES if none."""
    given = args[1:args.index('--ros-args')] if '--ros-args' in args else args[1:]
    unknown = [name for name in given if name not in NODE_EXECUTABLES]
    if unknown:
        raise SystemExit(f'error: not node executables: {", ".join(unknown)} '
                         f'(choose from {", ".join(NODE_EXECUTABLES)})')
    return [name for name in NODE_EXECUTABLES if name in given] or list(NODE_EXECUTABLES)


def main(args: list[str] | None = None) -> None:
    """Spin the chosen nodes (default: planner, terrain adaptation, spring lengths, simulator) together."""
    argv = args if args is not None else sys.argv
    sys.exit(run_nodes([node_class(name) for name in chosen_nodes(argv)], argv))


if __name__ == '__main__':
    main()
