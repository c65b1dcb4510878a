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

"""All four nodes in one process with one executor (`iguana run --single-process`)."""
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


def main(args: list[str] | None = None) -> None:
    """Spin every node of NODE_EXECUTABLES (planner, terrain adaptation, spring lengths, simulator) together."""
    sys.exit(run_nodes([node_class(name) for name in NODE_EXECUTABLES], args if args is not None else sys.argv))


if __name__ == '__main__':
    main()
