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


"""`iguana bench pipeline`: a real library loop and a four-process node run, the node overhead derived from both."""
import json
import math
import os
import subprocess
import sys
import time

import pytest


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.timeout(240)
def test_bench_pipeline_reports_both_runs_and_the_node_overhead_per_frame():
    """Every figure finite and within what this test measures of the command itself (its own wall clock)."""
    started = time.monotonic()
    out = subprocess.run([sys.executable, '-m', 'iguana_ros.cli', 'bench', 'pipeline', '--seconds', '1', '--json'],
                         capture_output=True, text=True, timeout=220, env=dict(os.environ))
    elapsed = time.monotonic() - started
    assert out.returncode == 0, out.stderr[-2000:]
    result = json.loads(out.stdout)
    assert result['simulated_s'] == 1.0 and result['nodes_layout'] == 'four processes'
    for key in ('library_realtime_factor', 'nodes_realtime_factor', 'library_wall_s', 'nodes_wall_s'):
        assert math.isfinite(result[key]) and result[key] > 0, key
    assert math.isfinite(result['node_overhead_ms_per_frame'])
    # the two runs happened inside this command, one after the other: their walls cannot add up to more than it took
    assert result['nodes_wall_s'] <= result['nodes_total_s']
    assert result['library_wall_s'] + result['nodes_total_s'] < elapsed
    nodes = {'simulator_node', 'terrain_adaptation_node', 'spring_length_node', 'planner_node'}
    assert set(result['nodes_cpu_ms_per_frame_by_process']) >= nodes
    assert result['cpu_model'] and result['cpu_model'] != 'unknown'
