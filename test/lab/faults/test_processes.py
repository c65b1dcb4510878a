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
Process faults (issue 12, items 1, 2 and 10, and the short version of the process fault-injection suite).

Whatever kills `iguana run` or one of its children, no process is left behind, the bag stays readable with every message
recorded before the fault, and `iguana run` ends with one clear line saying how far the run got; a second run on a busy
ROS domain is refused. The long version: `iguana bench faults processes --trials 20`.
"""
from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time

import pytest
import yaml

from iguana_lab.faults.processes import run_trial, TRIAL_SCENE
from ros_harness import IGUANA, REPO, wait_for

pytestmark = [pytest.mark.ros, pytest.mark.slow, pytest.mark.long, pytest.mark.timeout(240)]


def domain() -> str:
    """Return this test run's ROS_DOMAIN_ID (conftest sets it)."""
    return os.environ['ROS_DOMAIN_ID']


def last_stamp(bag) -> float:
    """Stamp (s) of the last iguana_state recorded in `bag`."""
    from iguana_ros.bag.trajectory import read_root_trajectory
    times, _ = read_root_trajectory(bag)
    return float(times[-1])


def test_sigterm_of_iguana_run_finalises_the_bag_and_a_second_run_is_refused(tmp_path):
    second = {}

    def start_a_second_run(folder):
        scene = folder / 'second.yaml'
        scene.write_text(yaml.safe_dump(TRIAL_SCENE))
        second['bag'] = folder / 'second_bag'
        second['result'] = subprocess.run([*IGUANA, 'run', str(scene), '--record', str(second['bag'])], cwd=REPO,
                                          capture_output=True, text=True, timeout=60)

    trial = run_trial(0, 'iguana run', signal.SIGTERM, 0.0, tmp_path, under_way=True,
                      before_fault=start_a_second_run)
    assert trial.hit and trial.survived, trial.line()
    assert trial.exit_code == 128 + signal.SIGTERM, trial.line()
    assert re.fullmatch(r'iguana run: run stopped by SIGTERM after \d+\.\d\d of 20\.00 s simulated; '
                        r'bag finalised, \d+ messages on \d+ topics at .*', trial.last_line), trial.last_line
    assert trial.bag_finalised and trial.bag_messages >= trial.before_fault > 0, trial.line()
    # the second run on the same domain said why in one line and started nothing
    result = second['result']
    assert result.returncode == 1, result.stdout + result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f'iguana run: error: ROS_DOMAIN_ID {domain()} is in use: '
                                                   'processes of another iguana run: '), result.stderr
    assert '(planner_node)' in lines[0] and '(simulator_node)' in lines[0] and '(bag record)' in lines[0]
    assert not second['bag'].exists()


def test_sigkill_of_iguana_run_takes_every_child_along(tmp_path):
    trial = run_trial(0, 'iguana run', signal.SIGKILL, 0.0, tmp_path, under_way=True)
    assert trial.hit and trial.survived, trial.line()
    assert trial.exit_code == -signal.SIGKILL and trial.orphans == [], trial.line()
    # the recorder got SIGTERM when its parent died: the bag is finalised with everything read before the kill
    assert trial.bag_finalised and trial.lost == {} and trial.bag_messages >= trial.before_fault > 0, trial.line()


def test_a_killed_node_ends_the_run_with_how_far_it_got(tmp_path):
    trial = run_trial(0, 'spring_length_node', signal.SIGKILL, 0.0, tmp_path, under_way=True)
    assert trial.hit and trial.survived, trial.line()
    assert trial.exit_code == 1, trial.line()
    found = re.fullmatch(r'iguana run: error: run failed after (\d+\.\d\d) of 20\.00 s simulated: '
                         r'spring_length_node exited with status -9 \(SIGKILL\); bag finalised, .*', trial.last_line)
    assert found, trial.last_line
    simulated = float(found.group(1))
    assert simulated > 0 and simulated == pytest.approx(last_stamp(tmp_path / 'trial_00' / 'bag'), abs=0.005), \
        trial.last_line
    summary = (tmp_path / 'trial_00' / 'iguana_run.out').read_text()
    assert 'last lines of spring_length_node:' in summary and 'Traceback' not in summary, summary


def test_summary_is_read_from_the_bag_not_from_a_log(tmp_path):
    """A run whose simulator printed nothing still reports how far it got and how long its loop took."""
    from iguana_ros.bag.schema import message_definition
    from iguana_ros.bag.storage import BagWriter
    from iguana_ros.ros.conversions import odometry_msg
    from iguana_ros.supervisor.run import RunOptions, SceneRun
    from iguana_ros.topics import topic
    from rclpy.serialization import serialize_message

    scene = tmp_path / 'faults.yaml'
    scene.write_text(yaml.safe_dump(TRIAL_SCENE))
    run = SceneRun(RunOptions(scene=str(scene), record=tmp_path / 'bag'))
    writer = BagWriter(run.bag)
    spec = topic('iguana_state')
    channel = writer.add_topic('/iguana_state', spec.type, message_definition(spec.type), '', '')
    t0 = time.time_ns()
    for frame in range(46):  # frames 0..45: 1.5 s simulated, received over 0.9 s of wall time
        msg = odometry_msg([0.01 * frame, 0.0, 0.1], [0, 0, 0, 1], [0, 0, 0], [0, 0, 0], frame / 30.0)
        writer.write(channel, serialize_message(msg), t0 + frame * 20_000_000)
    writer.close()
    summary = run.summary()
    assert summary.simulated_s == pytest.approx(1.5) and summary.wall_s == pytest.approx(0.9)
    assert summary.outcome == 'failed' and summary.exit_code == 1
    assert summary.lines()[1] == ('run failed after 1.50 of 20.00 s simulated: the simulator stopped before the end '
                                  'of the run')
    assert summary.bag_note == 'finalised, 46 messages on 1 topics'


def test_a_foreign_publisher_of_a_run_topic_is_refused(tmp_path, make_node):
    from iguana_ros.ros.endpoints import resolve
    from iguana_ros.supervisor.domain_check import DomainInUse
    from iguana_ros.supervisor.run import RunOptions, run_scene

    name, cls, qos = resolve('iguana_state')
    make_node('stray_simulator').create_publisher(cls, name, qos)
    scene = tmp_path / 'faults.yaml'
    scene.write_text(yaml.safe_dump(TRIAL_SCENE))
    with pytest.raises(DomainInUse, match=rf'^ROS_DOMAIN_ID {domain()} is in use: publishers of /iguana_state '
                                          r'\(stray_simulator\); stop them or run with another ROS_DOMAIN_ID '
                                          r'or in a --namespace$'):
        run_scene(RunOptions(scene=str(scene), record=tmp_path / 'bag', domain_check_s=8.0))
    assert not (tmp_path / 'bag').exists()


def test_a_child_gets_sigterm_when_its_parent_is_killed(tmp_path):
    """`NodeProcess` children get the parent-death signal, however the parent dies."""
    from iguana_ros.supervisor.process import processes_with_env
    sleeper = '[sys.executable, "-c", "import time; time.sleep(60)"]'
    script = ('import sys, time\n'
              'from iguana_ros.supervisor.process import NodeProcess\n'
              f'child = NodeProcess({sleeper}, "child", {str(tmp_path)!r})\n'
              'child.start()\n'
              'print(child.pid, flush=True)\n'
              'time.sleep(60)\n')
    marker = f'{os.getpid()}-{time.time_ns()}'
    parent = subprocess.Popen([sys.executable, '-c', script], stdout=subprocess.PIPE, text=True, cwd=REPO,
                              env={**os.environ, 'IGUANA_TEST_MARKER': marker})
    try:
        child_pid = int(parent.stdout.readline())
        both = {parent.pid, child_pid}                 # a process in execve shows no environment for a moment
        assert wait_for(lambda: {p.pid for p in processes_with_env('IGUANA_TEST_MARKER', marker)} == both, 5.0), \
            f'not both of {both} seen: {processes_with_env("IGUANA_TEST_MARKER", marker)}'
        parent.kill()
        parent.wait()
        assert wait_for(lambda: not processes_with_env('IGUANA_TEST_MARKER', marker), 10.0), \
            'the child outlived its SIGKILLed parent'
    finally:
        parent.kill()
        for proc in processes_with_env('IGUANA_TEST_MARKER', marker):
            os.kill(proc.pid, signal.SIGKILL)
