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
The recorder asks the topic table's QoS of the package's topics, not the first publisher's.

A stranger's transient-local publisher of goal_pose, seen first, made the recorder ask transient-local; the run's
volatile goal publisher never matched it, and the run waited 60 s for its goal (`iguana bench faults strays`).
"""
from __future__ import annotations

import pytest
from rclpy.qos import DurabilityPolicy, ReliabilityPolicy

from iguana_ros.bag.qos import offer_profile, PLAY_VOLATILE_DEPTH, table_request_profile
from ros_harness import spin_until

pytestmark = pytest.mark.ros


def test_a_table_topic_is_asked_with_the_tables_qos_and_a_foreign_one_is_adapted():
    assert table_request_profile('/goal_pose').durability == DurabilityPolicy.VOLATILE
    assert table_request_profile('/accepted_goals').durability == DurabilityPolicy.TRANSIENT_LOCAL
    assert table_request_profile('/someone_elses_topic') is None


def test_a_strangers_latched_publisher_seen_first_does_not_shut_the_runs_goals_out(tmp_path, make_node, executor):
    from iguana_ros.bag.record import Recorder
    from iguana_ros.bag.storage import BagWriter
    from iguana_ros.ros.endpoints import resolve
    name, cls, qos = resolve('goal_pose')
    latched = qos
    latched.durability = DurabilityPolicy.TRANSIENT_LOCAL
    stranger = make_node('stranger')
    stranger.create_publisher(cls, name, latched)
    node = make_node('iguana_bag_recorder')
    executor.add_node(node)
    writer = BagWriter(tmp_path / 'bag')
    recorder = Recorder(node, writer, ['goal_pose'], log=lambda _m: None)
    try:
        assert spin_until(executor, lambda: (recorder.poll_discovery(), '/goal_pose' in recorder.subscriptions)[1], 30)
        sender = make_node('iguana_goal')
        executor.add_node(sender)
        run_goals = sender.create_publisher(cls, name, resolve('goal_pose')[2])        # volatile, as iguana run's
        assert spin_until(executor, lambda: run_goals.get_subscription_count() >= 1, 30)
    finally:
        writer.close()


def test_replay_offer_keeps_a_latched_depth_and_deepens_a_reliable_volatile_one():
    latched = offer_profile([{'history': 'keep_last', 'depth': 1, 'reliability': 'reliable',
                              'durability': 'transient_local'}])
    assert (latched.depth, latched.durability) == (1, DurabilityPolicy.TRANSIENT_LOCAL)
    volatile = offer_profile([{'history': 'keep_last', 'depth': 10, 'reliability': 'reliable',
                               'durability': 'volatile'}])
    assert (volatile.depth, volatile.reliability) == (PLAY_VOLATILE_DEPTH, ReliabilityPolicy.RELIABLE)
    assert offer_profile([{'depth': 500, 'reliability': 'reliable', 'durability': 'volatile'}]).depth == 500
    best_effort = offer_profile([{'depth': 5, 'reliability': 'best_effort', 'durability': 'volatile'}])
    assert (best_effort.depth, best_effort.reliability) == (5, ReliabilityPolicy.BEST_EFFORT)
