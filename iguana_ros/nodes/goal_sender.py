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
Publishing goal_pose messages and waiting until the planner has accepted them (`iguana goal`, `iguana run`).

The planner publishes every goal it accepted on the latched `accepted_goals` topic (nav_msgs/Path; empty at its
start-up). A sender reads that list first (so it knows the planner is there and how many goals it had), waits
until every subscription of goal_pose on the graph is matched to its publisher (another subscriber matching first
must not let the goal go out before the planner listens), publishes, and waits until its goals appear in the
list. A goal the planner rejects (off the terrain, non-finite, wrong frame) never appears: the sender says so.
Only subscriptions the sender has discovered can be waited for: one whose process DDS discovery has not reached
yet (it can take an announcement period, ~3 s, under load) misses a volatile goal, so the sender reports how many
subscribers acknowledged it.
"""
from __future__ import annotations

import math
import time
from typing import Callable, NamedTuple

import rclpy
from rclpy.duration import Duration
from rclpy.signals import SignalHandlerOptions

from iguana_ros.constants import WORLD_FRAME
from iguana_ros.errors import IguanaError
from iguana_ros.geometry import quat_from_yaw
from iguana_ros.ros.conversions import pose_stamped_msg
from iguana_ros.ros.endpoints import release_context, resolve, volatile_readers
from iguana_ros.ros.messages import goal_readers_from_msg

POLL_S = 0.02
"""Wall seconds between checks while waiting."""


class GoalDelivery(NamedTuple):
    """Where goals went: the goal topic's resolved name and how many subscriptions acknowledged them."""

    topic: str
    subscribers: int


NO_HEADING = (0.0, 0.0, 0.0, 0.0)
"""The orientation of a goal that asks for no heading (all zeros: not a rotation)."""


def goal_message(x: float, y: float, yaw_deg: float | None = None, at: float = 0.0, frame_id: str = WORLD_FRAME):
    """`PoseStamped` goal at (x, y) heading `yaw_deg` (None: any), stamped `at` s of simulated time (0 = at once)."""
    orientation = NO_HEADING if yaw_deg is None else quat_from_yaw(math.radians(yaw_deg))
    return pose_stamped_msg([x, y, 0.0], orientation, stamp=at, frame_id=frame_id)


def route_message(waypoints: list, yaw_deg: float | None = None, at: float = 0.0, frame_id: str = WORLD_FRAME):
    """
    Return a `nav_msgs/Path` route through `waypoints` ((x, y) m, in order).

    Arriving heading `yaw_deg` (None: any), stamped `at` s of simulated time; every pose carries the route's header.
    """
    from nav_msgs.msg import Path

    last = len(waypoints) - 1
    poses = [goal_message(float(x), float(y), yaw_deg if k == last else None, at, frame_id)
             for k, (x, y) in enumerate(waypoints)]
    route = Path(poses=poses)
    route.header = poses[0].header if poses else goal_message(0.0, 0.0, at=at, frame_id=frame_id).header
    return route


def same_goal(a, b) -> bool:
    """Whether two PoseStamped goals are the same message content (frame, stamp, pose)."""
    pa, pb = a.pose, b.pose
    return (a.header.frame_id == b.header.frame_id and a.header.stamp.sec == b.header.stamp.sec
            and a.header.stamp.nanosec == b.header.stamp.nanosec
            and (pa.position.x, pa.position.y, pa.position.z) == (pb.position.x, pb.position.y, pb.position.z)
            and (pa.orientation.x, pa.orientation.y, pa.orientation.z, pa.orientation.w)
            == (pb.orientation.x, pb.orientation.y, pb.orientation.z, pb.orientation.w))


def accepted_among(goals: list, accepted: list) -> int:
    """How many of `goals` (in order) appear, in order, among `accepted` PoseStamped (a subsequence match)."""
    found = 0
    for msg in accepted:
        if found < len(goals) and same_goal(goals[found], msg):
            found += 1
    return found


def wait_spinning(condition: Callable[[], bool], node, timeout: float, keep_going: Callable[[], None],
                  failure: Callable[[], str]) -> None:
    """Spin `node` until `condition()`; IguanaError(failure()) after `timeout` s. `keep_going()` may raise."""
    from rclpy.executors import SingleThreadedExecutor
    executor = SingleThreadedExecutor(context=node.context)
    executor.add_node(node)
    try:
        deadline = time.monotonic() + timeout
        while not condition():
            keep_going()
            if time.monotonic() > deadline:
                raise IguanaError(failure())
            executor.spin_once(timeout_sec=POLL_S)
    finally:
        executor.remove_node(node)
        executor.shutdown()


def send_goals(goals: list, min_subscribers: int = 1, timeout: float = 10.0,
               keep_going: Callable[[], None] = lambda: None, confirm: bool = True,
               topic_key: str = 'goal_pose', readers: frozenset = frozenset(), namespace: str = '') -> GoalDelivery:
    """
    Publish PoseStamped `goals` (or, with `topic_key` 'route', Path routes) once `min_subscribers` listen.

    The topics are those of ROS `namespace` ('' the root).

    With `confirm`, it also waits until the planner's accepted_goals list has arrived and every goal_pose subscription
    on the graph is matched, and as many as the planner sees on planner_status; and it waits until the nodes named in
    `readers` have subscriptions on the graph. Then it waits until the subscribers acknowledge the goals and (with
    `confirm`) until the planner lists them as accepted. Returns the topic name and how many subscriptions acknowledged
    the goals.

    IguanaError in one line when a step does not happen within `timeout` s (each step has the whole timeout).
    `keep_going()` is called while waiting (it may raise to give up early).
    """
    context = rclpy.Context()
    rclpy.init(context=context, signal_handler_options=SignalHandlerOptions.NO)
    try:
        node = rclpy.create_node('iguana_goal', namespace=namespace, context=context)
        return publish_goals(node, goals, min_subscribers, timeout, keep_going, confirm, topic_key, readers)
    finally:
        release_context(context)


def publish_goals(node, goals: list, min_subscribers: int = 1, timeout: float = 10.0,
                  keep_going: Callable[[], None] = lambda: None, confirm: bool = True,
                  topic_key: str = 'goal_pose', readers: frozenset = frozenset()) -> GoalDelivery:
    """`send_goals` on an existing rclpy `node` (its publisher and subscription are removed afterwards)."""
    name, cls, qos = resolve(topic_key)
    expected = list(goals) if topic_key == 'goal_pose' else [pose for route in goals for pose in route.poses]
    pub = node.create_publisher(cls, name, qos)
    accepted_sub = status_sub = None
    try:
        lists: list = []
        topic = pub.topic_name
        if confirm:
            a_name, a_cls, a_qos = resolve('accepted_goals')
            accepted_sub = node.create_subscription(a_cls, a_name, lists.append, a_qos)
            accepted_topic = accepted_sub.topic_name

        seen: dict = {}
        if confirm:
            s_name, s_cls, s_qos = resolve('planner_status')
            status_sub = node.create_subscription(s_cls, s_name, lambda m: seen.update(goal_readers_from_msg(m)),
                                                  s_qos)

        def wanted() -> int:
            """
            Subscriptions the goals must reach (-1: not yet known).

            The minimum, the nodes named in `readers` among them, or (confirming) every one on the graph that can match
            this volatile publisher, the planners' among them, and as many as the planner sees (planner_status: its
            long-settled view names a bag recorder that this sender's fresh view may not list yet).
            """
            subs = node.get_subscriptions_info_by_topic(topic)
            names = {(s.node_name, s.node_namespace) for s in subs}
            if not readers <= {name for name, _ in names}:
                return -1
            if not confirm:
                return min_subscribers
            planners = {(p.node_name, p.node_namespace) for p in node.get_publishers_info_by_topic(accepted_topic)}
            if not lists or not planners <= names or topic_key not in seen:
                return -1
            return max(min_subscribers, volatile_readers(node, topic), seen[topic_key])

        def listening() -> bool:
            need = wanted()
            return need >= 0 and pub.get_subscription_count() >= need

        def why_not() -> str:
            have = pub.get_subscription_count()
            if confirm and not lists:
                return (f'no planner on {topic} within {timeout:g} s (nothing published {accepted_topic}); '
                        'is planner_node running on this ROS_DOMAIN_ID?')
            missing = readers - {s.node_name for s in node.get_subscriptions_info_by_topic(topic)}
            if missing:
                return f'no subscription of {", ".join(sorted(missing))} on {topic} within {timeout:g} s'
            if confirm and wanted() < 0:
                return f'the planner publishing {accepted_topic} has no subscription on {topic} within {timeout:g} s'
            if have == 0:
                return f'no subscriber on {topic} within {timeout:g} s'
            return f'only {have} of {max(wanted(), min_subscribers)} subscribers on {topic} within {timeout:g} s'
        wait_spinning(listening, node, timeout, keep_going, why_not)
        before = len(lists[-1].poses) if lists else 0
        for msg in goals:
            pub.publish(msg)
        delivered = pub.get_subscription_count()
        deadline = time.monotonic() + timeout
        while not pub.wait_for_all_acked(Duration(seconds=POLL_S)):   # short waits, so keep_going can give up
            keep_going()
            if time.monotonic() > deadline:
                raise IguanaError(f'the subscribers on {topic} did not acknowledge the goal within {timeout:g} s')
        if confirm:
            def accepted() -> bool:
                return accepted_among(expected, list(lists[-1].poses)[before:]) == len(expected)
            wait_spinning(accepted, node, timeout, keep_going, lambda: (
                f'the planner did not accept {"the goal" if len(goals) == 1 else "every goal"} within {timeout:g} s '
                f'(rejected: see the planner log for "rejected goal_pose", e.g. a goal off the terrain)'))
        return GoalDelivery(topic, delivered)
    finally:
        node.destroy_publisher(pub)
        for sub in (accepted_sub, status_sub):
            if sub is not None:
                node.destroy_subscription(sub)
