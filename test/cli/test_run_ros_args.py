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

"""`iguana run ... --ros-args ...`: the user's ROS arguments reach every node (issue 32 item 5)."""
import pytest
import yaml

from iguana_ros.cli import split_ros_args
from iguana_ros.errors import InputError
from iguana_ros.executables import NODE_EXECUTABLES
from iguana_ros.scene import load_scene, scene_path
from iguana_ros.supervisor.run import check_user_ros_args, node_commands, RunOptions
from ros_harness import IGUANA, NodeProcess, spin_until


def test_the_ros_arguments_are_split_off_the_command_line():
    own, ros = split_ros_args(['run', 'hills', '--ros-args', '-r', 'a:=b', '--log-level', 'debug'])
    assert own == ['run', 'hills'] and ros == ['--ros-args', '-r', 'a:=b', '--log-level', 'debug']
    assert split_ros_args(['run', 'hills']) == (['run', 'hills'], [])


def test_every_node_gets_them_after_the_runs_own():
    user = check_user_ros_args(('--ros-args', '-r', 'mesh_marker:=my_mesh', '-p', 'planner_node:goal_radius:=0.3',
                                '--'))
    assert user == ('-r', 'mesh_marker:=my_mesh', '-p', 'planner_node:goal_radius:=0.3')
    for single in (False, True):
        commands = node_commands(RunOptions(scene='flat_walk', single_process=single, ros_args=user),
                                 load_scene('flat_walk'), scene_path('flat_walk'))
        assert list(commands) == (['nodes'] if single else list(NODE_EXECUTABLES))
        for command in commands.values():
            assert command[-len(user):] == list(user) and command.count('--ros-args') == 1


@pytest.mark.parametrize('remap', ['__node:=other', 'simulator_node:__node:=x', '__ns:=/iguana1'])
def test_renaming_the_nodes_is_refused_with_one_line(remap):
    with pytest.raises(InputError, match='finds its nodes by name'):
        check_user_ros_args(('-r', remap))


def test_a_command_that_starts_no_node_refuses_them(cli):
    status, out, err = cli(['simulate', 'flat_walk', '--ros-args', '-r', 'a:=b'])
    assert status == 1 and out == '' and err.strip() == ('iguana simulate: error: takes no --ros-args (iguana run '
                                                         'passes them to every node)')


@pytest.mark.ros
@pytest.mark.timeout(240)
def test_a_remap_moves_a_topic_of_a_real_run(tmp_path, make_node, executor):
    """With `-r mesh_marker:=iguana_mesh` the mesh goes out (and is recorded) on /iguana_mesh, none on /mesh_marker."""
    from iguana_ros.bag.storage import BagReader
    from iguana_ros.ros.endpoints import resolve, resolve_service
    _, cls, qos = resolve('mesh_marker')
    node = make_node('remap_probe')
    got = {'/iguana_mesh': 0, '/mesh_marker': 0}
    for name in got:
        node.create_subscription(cls, name, lambda _msg, name=name: got.__setitem__(name, got[name] + 1), qos)
    executor.add_node(node)
    scene = tmp_path / 'short.yaml'
    scene.write_text(yaml.safe_dump({'model': {'resolution': 'coarse'}, 'terrain': {'kind': 'flat'},
                                     'goals': [{'x': 1.0, 'y': 0.0}], 'duration': 2.0}))
    bag = tmp_path / 'bag'
    run = NodeProcess([*IGUANA, 'run', str(scene), '--record', str(bag), '--paused', '--ros-args', '-r',
                       'mesh_marker:=iguana_mesh'], 'run', tmp_path)
    with run.start():
        # held at frame 0 until this probe lists the remapped publisher (its reader has matched it: the run waits
        # for its recorder, not for a probe, and a lockstep run of 2 s may end before a late match)
        assert spin_until(executor, lambda: node.count_publishers('/iguana_mesh') > 0, 120), run.output
        name, srv_type = resolve_service('sim_resume')
        client = node.create_client(srv_type, '/' + name)
        assert spin_until(executor, client.service_is_ready, 60), run.output
        future = client.call_async(srv_type.Request())
        assert spin_until(executor, future.done, 30) and future.result().success, run.output
        assert spin_until(executor, lambda: not run.running, 200), run.output
    assert run.wait(10) == 0, run.output
    spin_until(executor, lambda: False, 0.5)        # whatever is still in flight
    assert got['/iguana_mesh'] > 0 and got['/mesh_marker'] == 0, got
    recorded = {m.topic for m in BagReader(bag).messages()}
    assert '/iguana_mesh' in recorded and '/mesh_marker' not in recorded and '/iguana_state' in recorded
