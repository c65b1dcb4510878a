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


"""tools/sched_trace.py: reading perf's scheduler switches, the walk's window, preemptions and who took the core."""
import pytest

from ros_harness import tool_module

SIM, OTHER, DDS = 100, 200, 300


@pytest.fixture(scope='module')
def trace():
    """Load the tool as a module (tools/ is not a package)."""
    return tool_module('sched_trace')


def _line(cpu, t, prev, state, nxt):
    return (f'[{cpu:03d}] {t:.6f}: sched:sched_switch: prev_comm=python prev_pid={prev} prev_prio=120 '
            f'prev_state={state} ==> next_comm=x y next_pid={nxt} next_prio=120')


def test_perf_script_lines_are_read_in_time_order_and_other_lines_skipped(trace):
    text = '\n'.join([_line(1, 2.0, OTHER, 'S', 0), 'some header', _line(0, 1.5, 0, 'R', SIM)])
    switches = trace.parse_switches(text)
    rows = [(s.cpu, s.time, s.prev, s.state, s.incoming) for s in switches]
    assert rows == [(0, 1.5, 0, 'R', SIM), (1, 2.0, OTHER, 'S', 0)]


def _walk(trace):
    """Return switches of a simulator busy on cpu 0 from 1 s to 3 s, preempted by OTHER (4 ms) and DDS (0.1 ms)."""
    lines = [_line(0, 0.5, 0, 'R', SIM), _line(0, 0.51, SIM, 'S', 0),          # start-up: a short run
             _line(0, 1.0, 0, 'R', SIM),
             _line(0, 1.5, SIM, 'R', OTHER), _line(0, 1.504, OTHER, 'S', SIM),
             _line(0, 2.0, SIM, 'R+', DDS), _line(0, 2.0001, DDS, 'S', SIM),
             _line(0, 2.5, SIM, 'S', 0), _line(0, 2.501, 0, 'R', SIM),        # a wait for input: not a preemption
             _line(0, 3.0, SIM, 'S', 0), _line(1, 3.0, 0, 'R', OTHER), _line(1, 3.2, OTHER, 'S', 0)]
    return trace.parse_switches('\n'.join(lines))


def test_the_walk_is_the_longest_busy_stretch_and_its_preemptions_are_counted_with_their_waits(trace):
    switches = _walk(trace)
    window = trace.busiest_window(trace.run_stretches(switches, SIM))
    assert window[0] == pytest.approx(1.0, abs=0.26) and window[1] == pytest.approx(3.0, abs=0.26)
    waits = trace.preemptions(switches, SIM, window)
    assert set(waits) == {OTHER, DDS}
    assert waits[OTHER] == [pytest.approx(0.004)] and waits[DDS] == [pytest.approx(0.0001)]


def test_analysis_names_threads_and_gives_busy_and_idle_shares(trace):
    roles = {SIM: 'simulator_node', OTHER: 'spring_length_node', DDS: 'recorder/dds.shm.1'}
    result = trace.analyse(_walk(trace), roles)
    assert result['preemptions'] == 2 and result['preempted_wait_s'] == pytest.approx(0.0041)
    assert list(result['preempted_by']) == ['spring_length_node', 'recorder/dds.shm.1']
    assert 0.9 < result['simulator_busy_share'] <= 1.0
    assert result['preempted_by']['spring_length_node']['wait_median_us'] == pytest.approx(4000)
    with pytest.raises(RuntimeError, match='no simulator_node'):
        trace.analyse(_walk(trace), {OTHER: 'planner_node'})


def test_processes_are_named_by_module_and_foreign_ones_left_out(trace):
    assert trace._process_name(['python', '-m', 'iguana_ros.nodes.planner_node', '--ros-args']) == 'planner_node'
    assert trace._process_name(['python', '-m', 'iguana_ros.cli', 'bag', 'record', '-o', 'x']) == 'recorder'
    assert trace._process_name(['/v/bin/python', '/v/bin/iguana', 'run', 'hills']) == 'iguana run'
    assert trace._process_name(['python', '-m', 'http.server']) is None and trace._process_name(['bash']) is None


def test_only_the_traced_runs_processes_are_named(trace):
    """A process belongs to the run when the run's process is among its ancestors (this one's parent is not)."""
    import os
    import subprocess
    import sys

    child = subprocess.Popen([sys.executable, '-c', 'import time; time.sleep(30)'])
    try:
        assert trace._descends_from(child.pid, os.getpid()) and trace._descends_from(os.getpid(), os.getpid())
        assert not trace._descends_from(os.getpid(), child.pid)
        assert trace.thread_roles(child.pid) == {}          # a python process, but not an iguana_ros one
    finally:
        child.kill()
        child.wait()


def test_threads_of_one_name_are_summed(trace):
    """Two threads named alike (e.g. a process's Fast DDS listeners) are one row, not the last one seen."""
    roles = {SIM: 'simulator_node', OTHER: 'recorder/dds.shm', DDS: 'recorder/dds.shm'}
    result = trace.analyse(_walk(trace), roles)
    assert list(result['preempted_by']) == ['recorder/dds.shm']
    assert result['preempted_by']['recorder/dds.shm']['count'] == 2
