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
A node run whose body leaves the terrain ends there, says so and exits 3 (issue 30, item 1).

The probe's run stalled 60 s blaming the spring-length node (planner and adaptation rejected every state off the
world), and a realtime run 718 m off its terrain ended `run completed`, exit status 0.
"""
from __future__ import annotations

import pytest
import yaml

from iguana_ros.bag.storage import BagReader
from ros_harness import IGUANA, NodeProcess

pytestmark = [pytest.mark.ros, pytest.mark.slow, pytest.mark.timeout(300)]


def test_a_run_thrown_off_its_terrain_ends_with_that_outcome(tmp_path):
    scene = tmp_path / 'edge.yaml'
    scene.write_text(yaml.safe_dump({
        'model': {'resolution': 'coarse'}, 'terrain': {'kind': 'flat'}, 'duration': 6.0,
        'start': {'x': 4.3, 'y': 0.0}, 'goals': [{'x': 4.0, 'y': 0.0}],
        'pushes': [{'at': 0.5, 'force': [140.0, 0.0, 140.0], 'duration': 0.1, 'region': 'all'}]}))   # 4.95 m/s
    bag = tmp_path / 'bag'
    run = NodeProcess([*IGUANA, 'run', str(scene), '--record', str(bag)], 'run', tmp_path).start()
    with run:
        assert run.wait(120) == 3, run.output
    last = [line for line in run.output.splitlines() if line.startswith('iguana run:')]
    assert len(last) == 1 and 'run ended after' in last[0] and 'the iguana left the terrain' in last[0], run.output
    assert 'bag finalised' in last[0] and 'lockstep' not in run.output
    states = [m for m in BagReader(bag).messages() if m.topic == '/iguana_state']
    assert 15 < len(states) < 6.0 * 30                  # ended where it left, not at the scene's end
