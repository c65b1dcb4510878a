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

"""supervisor/cpu.py: a process's CPU per simulated frame, from /proc, over the frames it was sampled at."""
import os
import subprocess
import sys
import time

import pytest

from iguana_ros.supervisor.cpu import cpu_line, CpuWindow, process_cpu_s

pytestmark = pytest.mark.skipif(not os.path.isdir('/proc/self'), reason='no /proc here')


def _burn(seconds: float) -> None:
    end = time.process_time() + seconds
    while time.process_time() < end:
        pass


def test_process_cpu_counts_this_process_and_nothing_for_a_gone_one():
    """CPU seconds grow by the work done (within a clock tick or two); a reaped child has none."""
    before = process_cpu_s(os.getpid())
    _burn(0.3)
    after = process_cpu_s(os.getpid())
    assert 0.25 <= after - before <= 0.6
    child = subprocess.Popen([sys.executable, '-c', 'pass'])
    child.wait()
    assert process_cpu_s(child.pid) is None


def test_window_gives_ms_per_frame_over_the_window_chosen_afterwards():
    """CPU rate inside [start, end] times the window's seconds per frame; outside samples and single ones ignored."""
    window = CpuWindow()
    window.sample({'me': os.getpid()}, now=100.0)            # before the window: ignored
    _burn(0.2)
    window.sample({'me': os.getpid(), 'gone': 2 ** 22 + 7}, now=101.0)
    _burn(0.3)
    window.sample({'me': os.getpid(), 'once': os.getpid()}, now=102.0)   # 'once': one sample, not reported
    got = window.ms_per_frame(101.0, 102.0, 10)
    assert list(got) == ['me']
    assert 25.0 <= got['me'] <= 60.0                         # 0.3 s over 10 frames: 30 ms per frame
    assert window.ms_per_frame(101.0, 101.0, 10) == {} and window.ms_per_frame(101.0, 102.0, 0) == {}
    short = window.ms_per_frame(101.4, 101.6, 2)             # no sample inside: the rate between 101 and 102
    assert list(short) == ['me'] and 25.0 <= short['me'] <= 60.0   # 0.3 CPU s per s, 0.1 s per frame
    assert window.ms_per_frame(102.5, 103.0, 5) == {}        # nothing sampled after it: left out
    line = cpu_line({'planner_node': 1.9, 'simulator_node': 13.4})
    assert line == 'CPU per frame while stepping: 15.3 ms (simulator_node 13.4, planner_node 1.9)'
    assert cpu_line({}) == ''
