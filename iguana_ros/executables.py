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
The package's executables, listed once.

setup.py reads this file without importing the package (plain literals only: `ast.literal_eval`), so keep it
free of imports and code. setup.py installs the node executables (lib/iguana_ros/, for `ros2 run`) and the
CLI (bin/); the supervisor, the single-process runner, the launch file and the tests take their names from here.
"""

NODE_EXECUTABLES = ('planner_node', 'terrain_adaptation_node', 'spring_length_node', 'simulator_node')
"""The four node processes of the design card, in start order; each is also its node's default name and its
section in msg_configs/parameters.yaml and params/iguana.yaml."""

SIM_TIME_NODES = ('planner_node',)
"""The nodes that read their clock (the planner stamps accepted_goals with it) and so get use_sim_time: the others
stamp with frames and time with the steady clock, and a /clock subscription would cost each a wake per frame."""

NODE_PACKAGE = 'iguana_ros.nodes'
"""Python package of the node modules: executable `name` runs `NODE_PACKAGE.name:main`."""

CLI_EXECUTABLE = 'iguana'
"""The command-line tool (on PATH after pip or colcon install)."""

CLI_ENTRY_POINT = 'iguana_ros.cli:main'
"""Entry point of the command-line tool."""

VIEW_URL_PREFIX = 'iguana view: http'
"""How the line of `iguana view` naming its page's address starts (`iguana run --view` starts the viewer as a
child and waits for that line; cli/view.py prints it)."""
