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
The four iguana_ros nodes for colcon users: `ros2 launch iguana_ros iguana.launch.py [scene:=hills] [mode:=...] ...`.

Each node gets the params file `iguana run` gives it (share/iguana_ros/msg_configs/params/iguana.yaml), then the
`scene` launch argument, the simulator `mode` and, for the node that reads its clock (the planner), `use_sim_time`;
all four under `namespace` (default none; its clock is then `<namespace>/clock`, as `iguana run --namespace`
gives it). The launch ends when the simulator finishes the scene, as `iguana run`
does. `record:=DIR` also records every topic of the table with `iguana bag record -o DIR`; `rviz:=true` opens RViz2
with the package's config. Unlike `iguana run`, no goal is sent: send goals with `iguana goal X Y` (or
IguanaCommander).
"""
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, ExecuteProcess, Shutdown
from launch.conditions import IfCondition, UnlessCondition
from launch.substitutions import EqualsSubstitution, LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import Node
from launch_ros.parameter_descriptions import ParameterValue
from launch_ros.substitutions import FindPackageShare

from iguana_ros.executables import CLI_EXECUTABLE, NODE_EXECUTABLES, SIM_TIME_NODES

PACKAGE = 'iguana_ros'
SIMULATOR = 'simulator_node'
"""The node whose end ends the launch."""
RUN_CLOCK_REMAP = ('/clock', 'clock')
"""Every node's clock, relative: /clock in the root namespace, <namespace>/clock in one (as `iguana run
--namespace`), so launches in two namespaces keep two clocks."""


def launch_arguments() -> list:
    """Return the launch arguments: scene, mode, namespace, use_sim_time, record, rviz."""
    return [
        DeclareLaunchArgument('scene', default_value='hills',
                              description='scene name under msg_configs/scenes/ or a path to a scene YAML'),
        DeclareLaunchArgument('mode', default_value='lockstep', choices=['lockstep', 'realtime'],
                              description='lockstep: deterministic, as fast as possible; realtime: paced to the '
                                          'wall clock'),
        DeclareLaunchArgument('namespace', default_value='', description='ROS namespace of the four nodes'),
        DeclareLaunchArgument('use_sim_time', default_value='true', choices=['true', 'false'],
                              description="the planner's clock (accepted_goals stamps) follows the simulator's "
                                          '/clock; the other nodes read no clock'),
        DeclareLaunchArgument('record', default_value='',
                              description='bag directory to record every topic into (default: no recording)'),
        DeclareLaunchArgument('rviz', default_value='false', choices=['true', 'false'],
                              description="open RViz2 with the package's config (rviz/iguana.rviz)"),
    ]


def generate_launch_description() -> LaunchDescription:
    """Launch arguments and one Node per node executable of iguana_ros, the recorder and RViz2 if asked."""
    share = FindPackageShare(PACKAGE)
    params_file = PathJoinSubstitution([share, 'msg_configs', 'params', 'iguana.yaml'])
    scene = {'scene': ParameterValue(LaunchConfiguration('scene'), value_type=str)}
    mode = {'mode': ParameterValue(LaunchConfiguration('mode'), value_type=str)}
    sim_time = {'use_sim_time': ParameterValue(LaunchConfiguration('use_sim_time'), value_type=bool)}
    nodes = [Node(package=PACKAGE, executable=name, name=name, namespace=LaunchConfiguration('namespace'),
                  output='screen', remappings=[RUN_CLOCK_REMAP],
                  parameters=[params_file, scene | (sim_time if name in SIM_TIME_NODES else {})
                              | (mode if name == SIMULATOR else {})],
                  on_exit=Shutdown(reason='the simulator finished') if name == SIMULATOR else None)
             for name in NODE_EXECUTABLES]
    record = LaunchConfiguration('record')
    recorder = ExecuteProcess(cmd=[CLI_EXECUTABLE, 'bag', 'record', '-o', record, '--namespace',
                                   LaunchConfiguration('namespace')], output='screen',
                              condition=UnlessCondition(EqualsSubstitution(record, '')))
    rviz = ExecuteProcess(cmd=['rviz2', '-d', PathJoinSubstitution([share, 'rviz', 'iguana.rviz'])],
                          output='screen', condition=IfCondition(LaunchConfiguration('rviz')))
    return LaunchDescription(launch_arguments() + [recorder] + nodes + [rviz])
