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

"""The planner logs events of every kind, in any order, without rclpy refusing a call site's second severity."""
import pytest
from rclpy.parameter import Parameter

from iguana_ros.nodes.planner_node import PlannerNode
from iguana_ros.stages import PlannerEvent

pytestmark = [pytest.mark.ros]


def test_info_and_warning_events_follow_each_other_in_the_log(ros_context):
    """A run that arrived and then circled crashed the planner: one call site had logged at two severities."""
    node = PlannerNode(context=ros_context, parameter_overrides=[Parameter('scene', value='flat_walk')])
    try:
        kinds = ('waypoint', 'circling', 'recovered', 'stuck', 'arrived', 'circling')
        node.stage.events.extend(PlannerEvent(frame, kind, f'{kind} at {frame}') for frame, kind in enumerate(kinds))
        node.report_events()
        assert node.events_sent == len(node.stage.events)
    finally:
        node.destroy_node()
