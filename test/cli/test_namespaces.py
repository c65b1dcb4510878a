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
`--namespace NS` through the tools: two `iguana run`s in two namespaces share one ROS domain.

Names first (ROS-free): what a namespace is, the topics and the clock of a run in one, the node commands, the domain
check's topics, which recorded topic is which. Then real runs: a paused run in /iguana1 and a run in /iguana2 on one
domain; the second completes while the first is held; a third run in /iguana1 is refused naming the namespace;
`iguana goal`, `iguana sim` and `iguana view` reach the first by --namespace; each bag holds its own run only, on its
own simulated clock, with TF frames under the namespace's prefix.
"""
import dataclasses
import subprocess

import numpy as np
import pytest

from iguana_ros.bag.storage import BagReader, summarize
from iguana_ros.bag.trajectory import read_root_trajectory, read_topics, recorded_key
from iguana_ros.config import params_file
from iguana_ros.constants import FRAME_RATE
from iguana_ros.errors import InputError
from iguana_ros.ros.cdr import tf_message_from_cdr
from iguana_ros.scene import load_scene
from iguana_ros.supervisor.domain_check import output_topics
from iguana_ros.supervisor.run import (check_user_ros_args, node_commands, node_params, RUN_PARAMS_FILE,
                                       run_params_yaml, RunOptions)
from iguana_ros.topics import check_namespace, frame_prefix_of, resolve_frame_prefix, topic_name
from ros_harness import IGUANA, NodeProcess, start_scene_run, stop_scene_run, wait_for

SCENE = {'name': 'ns_walk', 'description': 'a short walk for the namespace tests', 'model': {'resolution': 'coarse'},
         'terrain': {'kind': 'flat'}, 'goals': [{'x': 1.0, 'y': 0.0}], 'duration': 2.0}


@pytest.mark.parametrize('text, expected', [('', ''), ('/', ''), ('iguana1', '/iguana1'),
                                            ('/zoo/iguana_2/', '/zoo/iguana_2')])
def test_a_namespace_is_normalised(text, expected):
    assert check_namespace(text) == expected


@pytest.mark.parametrize('text', ['1guana', 'igu-ana', 'a//b', 'a b'])
def test_a_bad_namespace_is_one_line_naming_the_rule(text):
    with pytest.raises(InputError, match='letters, digits and underscores'):
        check_namespace(text)


def test_a_runs_topics_and_clock_go_under_its_namespace_and_tf_stays_shared():
    assert topic_name('iguana_state', '/iguana1') == '/iguana1/iguana_state'
    assert topic_name('clock', '/iguana1') == '/iguana1/clock' and topic_name('clock') == '/clock'
    assert topic_name('tf', '/iguana1') == '/tf' and topic_name('diagnostics', '/iguana1') == '/diagnostics'
    assert frame_prefix_of('/zoo/iguana1') == 'zoo/iguana1/' and frame_prefix_of('') == ''
    assert resolve_frame_prefix('auto', '/iguana1') == 'iguana1/' and resolve_frame_prefix('auto', '/') == ''
    assert resolve_frame_prefix('', '/iguana1') == '' and resolve_frame_prefix('robot/', '/') == 'robot/'
    watched = output_topics(('simulator_node',), '/iguana1')
    assert '/iguana1/iguana_state' in watched and '/iguana1/clock' in watched
    assert '/tf' not in watched and '/diagnostics' not in watched     # every run publishes them


def test_every_node_of_a_namespaced_run_gets_the_namespace_its_clock_and_its_values_in_a_params_file(tmp_path):
    scene_file, run_file = tmp_path / 's.yaml', tmp_path / RUN_PARAMS_FILE
    scene_file.write_text('{}')
    options = RunOptions(scene='flat_walk', namespace='/iguana1', ros_args=('--log-level', 'warn'),
                         extra_params={'start_paused': True})
    params = node_params(options, load_scene('flat_walk'), scene_file)
    run_file.write_text(run_params_yaml(params))
    for single in (False, True):
        commands = node_commands(dataclasses.replace(options, single_process=single), load_scene('flat_walk'),
                                 scene_file, run_file)
        for kind, command in commands.items():
            tail = command[command.index('--ros-args'):]
            assert tail[1:5] == ['--params-file', str(params_file()), '--params-file', str(run_file)], kind
            assert tail[5:] == ['-r', '__ns:=/iguana1', '-r', '/clock:=/iguana1/clock', '--log-level', 'warn'], kind
    # rcl applies a node-qualified -p only in the root namespace, and a plain -p loses to the file's node section:
    # a real node in the namespace reads the run's values from the file
    import rclpy

    from iguana_ros.ros.endpoints import release_context
    context = rclpy.Context()
    rclpy.init(context=context, args=['iguana', *commands['nodes'][commands['nodes'].index('--ros-args'):]])
    try:
        node = rclpy.create_node('simulator_node', context=context,
                                 automatically_declare_parameters_from_overrides=True)
        assert node.get_fully_qualified_name() == '/iguana1/simulator_node'
        assert node.get_parameter('start_paused').value is True and node.get_parameter('scene').value == str(scene_file)
        assert node.get_parameter('frame_prefix').value == 'auto'    # the node takes its namespace's prefix
        node.destroy_node()
    finally:
        release_context(context)
    with pytest.raises(InputError, match='only in the root namespace; in /iguana1 give it as -p goal_radius:=0.3'):
        check_user_ros_args(('-p', 'planner_node:goal_radius:=0.3'), '/iguana1')
    assert check_user_ros_args(('-p', 'goal_radius:=0.3'), '/iguana1') == ('-p', 'goal_radius:=0.3')


def test_recorded_topics_are_matched_in_the_runs_namespace_or_any():
    keys = ('iguana_state', 'clock', 'tf')
    assert recorded_key('/iguana1/iguana_state', keys) == 'iguana_state'
    assert recorded_key('/iguana1/clock', keys) == 'clock' and recorded_key('/tf', keys) == 'tf'
    assert recorded_key('/iguana1/tf', keys) is None                  # /tf is shared, never namespaced
    assert recorded_key('/iguana1/iguana_state', keys, '/iguana2') is None
    assert recorded_key('/iguana2/iguana_state', keys, '/iguana2') == 'iguana_state'
    assert recorded_key('/x-y/iguana_state', keys) is None


def _cli(*args: str, timeout: float = 120.0) -> subprocess.CompletedProcess:
    """Run `iguana ARGS` to its end."""
    return subprocess.run([*IGUANA, *args], capture_output=True, text=True, timeout=timeout)


def _graph_has(node_name: str, namespace: str, timeout: float) -> bool:
    """Whether a node `node_name` shows in `namespace` on the graph within `timeout` s."""
    import rclpy

    from iguana_ros.ros.endpoints import release_context
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        node = rclpy.create_node('ns_probe', context=context)
        return wait_for(lambda: (node_name, namespace) in node.get_node_names_and_namespaces(), timeout, 0.1)
    finally:
        release_context(context)


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.timeout(420)
def test_two_runs_in_two_namespaces_share_a_domain_and_the_tools_reach_each(tmp_path):
    (tmp_path / 'one').mkdir()
    (tmp_path / 'two').mkdir()
    first = start_scene_run(tmp_path / 'one', SCENE, '--namespace', 'iguana1', '--paused', '--progress-every', '0')
    second = None
    try:
        held = _cli('sim', '--namespace', 'iguana1', 'pause', '--timeout', '120')      # up, and held at frame 0
        assert held.returncode == 0 and 'frame 0' in held.stdout, held.stdout + held.stderr + first.process.output
        second = start_scene_run(tmp_path / 'two', SCENE, '--namespace', '/iguana2', '--progress-every', '0')
        assert wait_for(lambda: not second.process.running, 240.0, 0.2), second.process.output[-3000:]
        assert second.process.proc.returncode == 0, second.process.output[-3000:]
        assert first.process.running, first.process.output[-3000:]      # held all along: its own clock

        third = _cli('run', str(first.scene), '--namespace', 'iguana1', '--record', str(tmp_path / 'three'))
        assert third.returncode == 1 and 'namespace /iguana1 of ROS_DOMAIN_ID' in third.stderr, third.stderr
        assert third.stderr.strip().count('\n') == 0 and not (tmp_path / 'three').exists()

        view = NodeProcess([*IGUANA, 'view', '--namespace', 'iguana1', '--port', '0'], 'view', tmp_path)
        with view.start():
            assert _graph_has('iguana_view', '/iguana1', 30.0), view.output

        goal = _cli('goal', '--namespace', 'iguana1', '1.5', '0.2')
        assert goal.returncode == 0, goal.stdout + goal.stderr
        stepped = _cli('sim', '--namespace', '/iguana1', 'step', '3')
        assert stepped.returncode == 0 and 'stepped to frame 3' in stepped.stdout, stepped.stdout + stepped.stderr
        wrong = _cli('sim', '--namespace', 'iguana3', 'resume', '--timeout', '2')
        assert wrong.returncode != 0 and '/iguana3/sim/resume' in wrong.stderr, wrong.stderr
        resumed = _cli('sim', '--namespace', 'iguana1', 'resume')
        assert resumed.returncode == 0, resumed.stdout + resumed.stderr
        assert wait_for(lambda: not first.process.running, 240.0, 0.2), first.process.output[-3000:]
        assert first.process.proc.returncode == 0, first.process.output[-3000:]
    finally:
        for run in (first, second):
            if run is not None:
                stop_scene_run(run.process)

    for run, ns, other in ((first, '/iguana1', '/iguana2'), (second, '/iguana2', '/iguana1')):
        topics = {m.topic for m in BagReader(run.bag).messages()}
        assert {f'{ns}/iguana_state', f'{ns}/clock', f'{ns}/mesh_marker', '/tf'} <= topics, topics
        assert not any(t.startswith(other) for t in topics) and '/clock' not in topics and '/iguana_state' not in topics
        summary = summarize(run.bag)
        assert summary.clock_topic == f'{ns}/clock' and summary.time_base == 'simulated'
        times, roots = read_root_trajectory(run.bag)
        assert np.allclose(times, np.arange(len(times)) / FRAME_RATE) and times[-1] == pytest.approx(2.0)
        assert np.all(np.isfinite(roots)) and roots[-1, 0] > roots[0, 0] + 0.1    # it walked
        frames = {child for data in read_topics(run.bag, ['tf']).messages['tf']
                  for _, _, child, _, _ in tf_message_from_cdr(data)}
        assert f'{ns[1:]}/base_link' in frames and 'base_link' not in frames
    goals = read_topics(first.bag, ['accepted_goals'], '/iguana1').messages['accepted_goals']
    assert goals, 'the goal sent by `iguana goal --namespace iguana1` is not in its bag'
    assert 's of it paused' in first.process.output
