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
The four iguana_ros nodes for colcon users: `ros2 launch iguana_ros iguana.launch.py [scene:=hills]`.

Each node gets the params file `iguana run` gives it (share/iguana_ros/msg_configs/params/iguana.yaml), then the
`scene` launch argument and, for the node that reads its clock (the planner), `use_sim_time`; the launch ends when
the simulator finishes the scene, as `iguana run` does. Unlike `iguana run`, nothing is recorded and no goal is
sent: send goals with `iguana goal X Y` (or IguanaCommander) and record with `iguana bag record`.
"""
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, Shutdown
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import Node
from launch_ros.parameter_descriptions import ParameterValue
from launch_ros.substitutions import FindPackageShare

from iguana_ros.executables import NODE_EXECUTABLES, SIM_TIME_NODES

PACKAGE = 'iguana_ros'
SIMULATOR = 'simulator_node'
"""The node whose end ends the launch."""


def generate_launch_description() -> LaunchDescription:
    """Launch arguments `scene` and `use_sim_time`, and one Node per node executable of iguana_ros."""
    params_file = PathJoinSubstitution([FindPackageShare(PACKAGE), 'msg_configs', 'params', 'iguana.yaml'])
    scene = {'scene': ParameterValue(LaunchConfiguration('scene'), value_type=str)}
    sim_time = {'use_sim_time': ParameterValue(LaunchConfiguration('use_sim_time'), value_type=bool)}
    arguments = [
        DeclareLaunchArgument('scene', default_value='hills',
                              description='scene name under msg_configs/scenes/ or a path to a scene YAML'),
        DeclareLaunchArgument('use_sim_time', default_value='true', choices=['true', 'false'],
                              description="the planner's clock (accepted_goals stamps) follows the simulator's "
                                          '/clock; the other nodes read no clock'),
    ]
    nodes = [Node(package=PACKAGE, executable=name, name=name, output='screen',
                  parameters=[params_file, (scene | sim_time) if name in SIM_TIME_NODES else scene],
                  on_exit=Shutdown(reason='the simulator finished') if name == SIMULATOR else None)
             for name in NODE_EXECUTABLES]
    return LaunchDescription(arguments + nodes)
