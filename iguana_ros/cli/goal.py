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

"""`iguana goal X Y`: publish one PoseStamped on the goal topic and wait until the planner has accepted it."""
from __future__ import annotations

import argparse
import math


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the `goal` sub-command."""
    parser = subparsers.add_parser(
        'goal', help='send a walking goal (geometry_msgs/PoseStamped) once and wait until the planner accepts it')
    parser.add_argument('x', type=float, help='goal x in the frame, m')
    parser.add_argument('y', type=float, help='goal y in the frame, m')
    parser.add_argument('--yaw', type=float, default=None, metavar='DEG',
                        help="heading to arrive in, degrees about +z (honoured within the planner's yaw tolerance; "
                             'default: any heading)')
    parser.add_argument('--frame', default=None, help='frame_id (default: the world frame)')
    parser.add_argument('--at', type=float, default=0.0, metavar='S',
                        help='simulated time at which the planner adopts the goal (default 0: at once)')
    parser.add_argument('--timeout', type=float, default=10.0, metavar='S',
                        help='give up if the planner has not accepted the goal within S s (default 10)')
    parser.set_defaults(func=run)


def _check_finite(args: argparse.Namespace) -> None:
    """`InputError` naming the first non-finite number."""
    from iguana_ros.errors import InputError
    for name in ('x', 'y', 'yaw', 'at'):
        value = getattr(args, name)
        if value is not None and not math.isfinite(value):
            raise InputError(f'goal {name} is {value}; expected a finite number')
    if not (args.timeout > 0 and math.isfinite(args.timeout)):
        raise InputError(f'--timeout is {args.timeout}; expected a positive number of seconds')
    if args.at < 0:
        raise InputError(f'--at is {args.at}; expected a time >= 0 s')


def run(args: argparse.Namespace) -> int:
    """
    Publish the goal once the planner listens, wait until it lists the goal on accepted_goals.

    Exit 1 if it does not (no planner, or the goal rejected) within the timeout.
    """
    _check_finite(args)
    from iguana_ros.constants import WORLD_FRAME
    from iguana_ros.doctor.checks import require_ros

    require_ros()  # before rclpy is imported: a bad ROS environment is one line naming it, not rcl's or Fast DDS's
    from iguana_ros.nodes.goal_sender import goal_message, send_goals

    msg = goal_message(args.x, args.y, args.yaw, args.at, args.frame or WORLD_FRAME)
    delivery = send_goals([msg], min_subscribers=1, timeout=args.timeout)
    heading = 'any heading' if args.yaw is None else f'yaw={args.yaw:g} deg'
    print(f'goal accepted by the planner on {delivery.topic}: x={args.x:g} y={args.y:g} {heading} '
          f'frame={msg.header.frame_id} ({delivery.subscribers} subscribers acknowledged)', flush=True)
    return 0
