"""Publishing goal_pose messages and waiting until every subscriber has them (`iguana goal`, `iguana run`)."""
from __future__ import annotations

import math
import time
from typing import Callable

import rclpy
from rclpy.duration import Duration
from rclpy.signals import SignalHandlerOptions

from iguana_ros.constants import WORLD_FRAME
from iguana_ros.errors import IguanaError
from iguana_ros.geometry import quat_from_yaw
from iguana_ros.nodes.conversions import pose_stamped_msg
from iguana_ros.nodes.ros_topics import resolve


def goal_message(x: float, y: float, yaw_deg: float = 0.0, at: float = 0.0, frame_id: str = WORLD_FRAME):
    """PoseStamped goal at (x, y) heading `yaw_deg`, stamped `at` s of simulated time (0 = at once)."""
    return pose_stamped_msg([x, y, 0.0], quat_from_yaw(math.radians(yaw_deg)), stamp=at, frame_id=frame_id)


def _wait_for_subscribers(pub, count: int, timeout: float, keep_going: Callable[[], None]) -> None:
    """Block until `pub` has `count` matched subscriptions; IguanaError after `timeout` s."""
    deadline = time.monotonic() + timeout
    while pub.get_subscription_count() < count:
        keep_going()
        if time.monotonic() > deadline:
            have = pub.get_subscription_count()
            if have == 0:
                raise IguanaError(f'no subscriber on {pub.topic_name} within {timeout:g} s')
            raise IguanaError(f'only {have} of {count} subscribers on {pub.topic_name} within {timeout:g} s')
        time.sleep(0.02)


def send_goals(goals: list, min_subscribers: int = 1, timeout: float = 10.0,
               keep_going: Callable[[], None] = lambda: None) -> str:
    """Publish PoseStamped `goals` once `min_subscribers` listen and wait until all are acknowledged.

    Returns the topic name. `keep_going()` is called while waiting (it may raise to give up early).
    """
    context = rclpy.Context()
    rclpy.init(context=context, signal_handler_options=SignalHandlerOptions.NO)
    try:
        node = rclpy.create_node('iguana_goal', context=context)
        name, cls, qos = resolve('goal_pose')
        pub = node.create_publisher(cls, name, qos)
        _wait_for_subscribers(pub, min_subscribers, timeout, keep_going)
        for msg in goals:
            pub.publish(msg)
        if not pub.wait_for_all_acked(Duration(seconds=timeout)):
            raise IguanaError(f'the subscribers on {pub.topic_name} did not acknowledge the goal within '
                              f'{timeout:g} s')
        return pub.topic_name
    finally:
        rclpy.try_shutdown(context=context)
