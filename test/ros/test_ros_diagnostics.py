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

"""The health status a node puts on /diagnostics: rates, counts, level, from two samples of its counters."""
from diagnostic_msgs.msg import DiagnosticStatus
import pytest

from iguana_ros.ros.diagnostics import diagnostics_msg, health_status, HealthSample, NodeHealth


def _values(status) -> dict:
    """Return the key/value pairs of a DiagnosticStatus."""
    return {kv.key: kv.value for kv in status.values}


def test_a_quiet_second_is_ok_with_its_rate_and_realtime_factor():
    health = NodeHealth(frames=30, sim_time=1.0)
    since = HealthSample.of(health, 10.0)
    health.frames, health.sim_time = 90, 3.0
    status = health_status('/simulator_node', health, since, HealthSample.of(health, 11.0))
    assert status.level == DiagnosticStatus.OK and status.message == 'running'
    values = _values(status)
    assert float(values['frames_per_s']) == pytest.approx(60.0) and values['frames'] == '90'
    assert float(values['realtime_factor']) == pytest.approx(2.0) and values['simulated_s'] == '3.000'


def test_a_paused_simulator_says_so_with_a_zero_realtime_factor():
    health = NodeHealth(frames=30, sim_time=1.0, paused=True)
    same = HealthSample.of(health, 10.0)
    status = health_status('/simulator_node', health, same, HealthSample.of(health, 11.0))
    assert status.level == DiagnosticStatus.OK and status.message == 'paused'
    assert float(_values(status)['realtime_factor']) == 0.0


def test_rejections_and_stale_inputs_warn_only_in_the_report_they_happened_in():
    health = NodeHealth()
    first = HealthSample.of(health, 0.0)
    health.reject('goal_pose: goal (1e+09, 0) is off the terrain')
    health.reject('push: push force 1e+06 N is above the 1000 N limit')
    health.late += 1
    second = HealthSample.of(health, 1.0)
    warned = health_status('/planner_node', health, first, second)
    assert warned.level == DiagnosticStatus.WARN
    assert warned.message == '2 inputs rejected; 1 stale input dropped in the last report'
    assert _values(warned)['last_rejected'].startswith('push: push force') and 'realtime_factor' not in _values(warned)
    quiet = health_status('/planner_node', health, second, HealthSample.of(health, 2.0))
    assert quiet.level == DiagnosticStatus.OK and _values(quiet)['rejected_inputs'] == '2'


def test_the_array_is_stamped_with_the_wall_clock():
    msg = diagnostics_msg([health_status('/n', NodeHealth(), HealthSample(0.0), HealthSample(1.0))], 1234.5)
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec) == (1234, 500_000_000) and len(msg.status) == 1
