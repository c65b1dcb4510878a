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
`iguana goal X Y`: send a goal through the planner's go_to_pose action; say whether it was accepted or refused and why.

`--wait` prints its feedback and result (exit 0 reached, 1 not); `iguana goal --cancel` cancels the running goals.
"""
from __future__ import annotations

import argparse
import math

from iguana_ros.cli.argtypes import add_namespace


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the `goal` sub-command."""
    parser = subparsers.add_parser(
        'goal', help="send a walking goal through the planner's go_to_pose action (accepted, or refused with the "
                     'reason); --wait follows it to its result, --cancel cancels the running goals')
    parser.add_argument('x', type=float, nargs='?', help='goal x in the frame, m')
    parser.add_argument('y', type=float, nargs='?', help='goal y in the frame, m')
    parser.add_argument('--yaw', type=float, default=None, metavar='DEG',
                        help="heading to arrive in, degrees about +z (honoured within the planner's yaw tolerance; "
                             'default: any heading)')
    parser.add_argument('--frame', default=None, help='frame_id (default: the world frame)')
    parser.add_argument('--at', type=float, default=0.0, metavar='S',
                        help='simulated time at which the planner adopts the goal (default 0: at once)')
    parser.add_argument('--tolerance', type=float, default=0.0, metavar='M',
                        help="how close counts as arrived, m (default 0: the planner's goal_radius)")
    parser.add_argument('--yaw-tolerance', type=float, default=0.0, metavar='DEG',
                        help="heading tolerance, degrees (default 0: the planner's yaw_tolerance)")
    parser.add_argument('--wait', action='store_true',
                        help='print the feedback at every stride end and the result; exit 0 only if reached')
    parser.add_argument('--cancel', action='store_true', help='cancel the running goals (X and Y not given)')
    parser.add_argument('--timeout', type=float, default=10.0, metavar='S',
                        help='give up if the planner has not answered within S s (default 10); with --wait, the '
                             'result is awaited without a limit')
    add_namespace(parser, 'to send the goal to')
    parser.set_defaults(func=run)


def _check_args(args: argparse.Namespace) -> None:
    """`InputError` naming the first missing or non-finite number."""
    from iguana_ros.errors import InputError
    if args.cancel != (args.x is None):
        raise InputError('expected X and Y, or --cancel without them')
    for name in ('x', 'y', 'yaw', 'at', 'tolerance', 'yaw_tolerance'):
        value = getattr(args, name)
        if value is not None and not math.isfinite(value):
            raise InputError(f'goal {name} is {value}; expected a finite number')
    if args.x is not None and args.y is None:
        raise InputError('expected X and Y')
    if not (args.timeout > 0 and math.isfinite(args.timeout)):
        raise InputError(f'--timeout is {args.timeout}; expected a positive number of seconds')
    if args.at < 0:
        raise InputError(f'--at is {args.at}; expected a time >= 0 s')


def run(args: argparse.Namespace) -> int:
    """Send the goal (or the cancel request) to the planner; with --wait, follow it to its result."""
    _check_args(args)
    from iguana_ros.doctor.checks import require_ros

    require_ros()  # before rclpy is imported: a bad ROS environment is one line naming it, not rcl's or Fast DDS's
    import rclpy
    from rclpy.signals import SignalHandlerOptions

    from iguana_ros.ros.endpoints import release_context

    context = rclpy.Context()
    rclpy.init(context=context, signal_handler_options=SignalHandlerOptions.NO)
    try:
        node = rclpy.create_node('iguana_goal', namespace=args.namespace, context=context,
                                 start_parameter_services=False)
        return _cancel(node, args) if args.cancel else _send(node, args)
    finally:
        release_context(context)


def _cancel(node, args: argparse.Namespace) -> int:
    """Cancel every running goal of the planner's action; print how many."""
    from iguana_ros.nodes.go_to_pose import GoToPoseClient

    count = GoToPoseClient(node).cancel_all(args.timeout)
    print(f'cancelled {count} goal{"" if count == 1 else "s"}' if count else 'no running goal to cancel', flush=True)
    return 0


def _send(node, args: argparse.Namespace) -> int:
    """Send the goal; print accepted (or raise 'refused: <reason>'); with --wait, its feedback and result."""
    from iguana_ros.constants import WORLD_FRAME
    from iguana_ros.nodes.go_to_pose import goal_request, GoToPoseClient
    from iguana_ros.nodes.goal_sender import goal_message

    msg = goal_message(args.x, args.y, args.yaw, args.at, args.frame or WORLD_FRAME)
    client = GoToPoseClient(node)
    client.send(goal_request(msg, args.tolerance, math.radians(args.yaw_tolerance)), args.timeout)
    heading = 'any heading' if args.yaw is None else f'yaw={args.yaw:g} deg'
    print(f'goal accepted by the planner on {client.name}: x={args.x:g} y={args.y:g} {heading} '
          f'frame={msg.header.frame_id}', flush=True)
    if not args.wait:
        return 0
    client.on_feedback = _print_feedback                # the feedback from now on, after the one that came first
    if client.latest is not None:
        _print_feedback(client.latest)
    result = client.result(math.inf)
    print(f'{"reached" if result.reached else "not reached"} ({result.outcome}): {result.reason}; '
          f'{result.distance_remaining:.2f} m from the goal after {result.time_elapsed:.1f} s', flush=True)
    return 0 if result.reached else 1


def _print_feedback(feedback) -> None:
    """Print one feedback line."""
    print(f't={feedback.time_elapsed:.1f} s strides={feedback.strides} distance={feedback.distance_remaining:.2f} m '
          f'at ({feedback.position[0]:.2f}, {feedback.position[1]:.2f}): {feedback.status}', flush=True)
