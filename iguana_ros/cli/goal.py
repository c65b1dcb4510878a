"""`iguana goal X Y`: publish one PoseStamped on the goal topic and wait until a subscriber has it."""
from __future__ import annotations

import argparse
import math

GRACE_S = 0.3
"""Extra time kept alive after publishing when the goal topic is not reliable (nothing to ack)."""


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the `goal` sub-command."""
    parser = subparsers.add_parser(
        'goal', help='send a walking goal (geometry_msgs/PoseStamped) once, like ros2 topic pub --once')
    parser.add_argument('x', type=float, help='goal x in the frame, m')
    parser.add_argument('y', type=float, help='goal y in the frame, m')
    parser.add_argument('--yaw', type=float, default=0.0, metavar='DEG', help='heading about +z, degrees')
    parser.add_argument('--frame', default=None, help='frame_id (default: the world frame)')
    parser.add_argument('--timeout', type=float, default=10.0, metavar='S',
                        help='give up if no subscriber has the goal within S s (default 10)')
    parser.set_defaults(func=run)


def _check_finite(args: argparse.Namespace) -> None:
    """InputError naming the first non-finite number."""
    from iguana_ros.errors import InputError
    for name in ('x', 'y', 'yaw'):
        value = getattr(args, name)
        if not math.isfinite(value):
            raise InputError(f'goal {name} is {value}; expected a finite number')
    if not (args.timeout > 0 and math.isfinite(args.timeout)):
        raise InputError(f'--timeout is {args.timeout}; expected a positive number of seconds')


def run(args: argparse.Namespace) -> int:
    """Publish the goal, wait for a matched subscriber and its acknowledgement; exit 1 on timeout."""
    _check_finite(args)
    import time

    import rclpy
    from rclpy.duration import Duration
    from rclpy.qos import ReliabilityPolicy

    from iguana_ros.constants import WORLD_FRAME
    from iguana_ros.errors import IguanaError
    from iguana_ros.nodes.conversions import pose_stamped_msg, yaw_to_quaternion
    from iguana_ros.nodes.ros_topics import resolve

    name, cls, qos = resolve('goal_pose')
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        node = rclpy.create_node('iguana_goal', context=context)
        publisher = node.create_publisher(cls, name, qos)
        deadline = time.monotonic() + args.timeout
        while publisher.get_subscription_count() == 0:
            if time.monotonic() > deadline:
                raise IguanaError(f'no subscriber on {publisher.topic_name} within {args.timeout:g} s')
            time.sleep(0.02)
        msg = pose_stamped_msg([args.x, args.y, 0.0], yaw_to_quaternion(math.radians(args.yaw)),
                               stamp=node.get_clock().now().to_msg(), frame_id=args.frame or WORLD_FRAME)
        publisher.publish(msg)
        if qos.reliability == ReliabilityPolicy.RELIABLE:
            left = max(deadline - time.monotonic(), 0.1)
            if not publisher.wait_for_all_acked(Duration(seconds=left)):
                raise IguanaError(f'the subscriber on {publisher.topic_name} did not acknowledge '
                                  f'the goal within {args.timeout:g} s')
        else:
            time.sleep(GRACE_S)
        print(f'goal sent on {publisher.topic_name}: x={args.x:g} y={args.y:g} yaw={args.yaw:g} deg '
              f'frame={msg.header.frame_id}', flush=True)
        return 0
    finally:
        rclpy.try_shutdown(context=context)
