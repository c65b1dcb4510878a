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

"""`iguana bag record|play|info`: rosbag2-compatible MCAP recording, replay and inspection."""
from __future__ import annotations

import argparse
import sys

from iguana_ros.cli.argtypes import add_namespace


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the `bag` sub-command with its record, play and info actions."""
    parser = subparsers.add_parser('bag', help='record, replay and inspect rosbag2-compatible MCAP bags')
    actions = parser.add_subparsers(dest='bag_action', metavar='ACTION', required=True)

    rec = actions.add_parser('record', help='record topics to DIR/DIR.mcap (+ metadata.yaml); Ctrl-C stops')
    rec.add_argument('topics', nargs='*', metavar='TOPIC',
                     help='topic names (default: every topic of msg_configs/topics.yaml)')
    rec.add_argument('-o', '--output', required=True, metavar='DIR', help='new bag directory')
    rec.add_argument('-a', '--all', action='store_true', help='record every discovered topic')
    rec.add_argument('--chunk-age', type=float, default=None, metavar='S',
                     help='close a chunk at least every S seconds (default 1)')
    rec.add_argument('--duration', type=float, default=None, metavar='S',
                     help='stop after S seconds (default: until Ctrl-C / SIGTERM)')
    rec.add_argument('--use-sim-time', action='store_true',
                     help='log times from /clock (simulated time), as ros2 bag record --use-sim-time, so the bag '
                          'replays at the simulated pace (default: wall-clock receive times; iguana run always '
                          'records on simulated time)')
    add_namespace(rec, 'to record (its topics /NS/..., its clock /NS/clock, and the shared /tf and /diagnostics)')
    rec.set_defaults(func=run, takes_ros_args=True)
    rec.epilog = '--ros-args ... at the end goes to the recorder node (e.g. the remaps a run gives its nodes)'

    play = actions.add_parser('play', help='republish a bag with its recorded timing and QoS')
    play.add_argument('bag', metavar='BAG', help='bag directory or .mcap file')
    play.add_argument('--rate', type=float, default=1.0, help='playback speed factor (default 1)')
    play.add_argument('--loop', action='store_true', help='start again at the end, until Ctrl-C')
    play.add_argument('--topics', nargs='+', metavar='TOPIC', help='play only these topics')
    play.add_argument('--clock', action='store_true',
                      help='give subscribers with use_sim_time one /clock: the recorded /clock if the bag has one '
                           '(played even if --topics leaves it out), else one from the bag time (40 Hz)')
    play.add_argument('--wait-for-subscribers', type=float, default=0.5, metavar='S',
                      help='wait up to S s for every topic to have a subscriber first (default 0.5)')
    play.add_argument('--start-paused', action='store_true',
                      help='wait, publishers made, until the service /iguana_bag_player/resume (std_srvs/Trigger) '
                           'is called: a subscriber can match them first and miss nothing')
    add_allow_damaged(play, 'play the messages of every intact chunk of a damaged or truncated bag')
    play.set_defaults(func=run)

    info = actions.add_parser('info', help='print duration, topics, types and counts of a bag; every chunk is '
                                           'checked, and a damaged or truncated bag exits 1')
    info.add_argument('bag', metavar='BAG', help='bag directory or .mcap file')
    add_allow_damaged(info, 'exit 0 for a damaged or truncated bag (the report is printed either way)')
    info.set_defaults(func=run)


def add_allow_damaged(parser: argparse.ArgumentParser, what: str) -> None:
    """Add --allow-damaged: without it a command reading a damaged or truncated bag exits 1 with one line."""
    parser.add_argument('--allow-damaged', action='store_true', help=what)


def run(args: argparse.Namespace) -> int:
    """Dispatch to record, play or info."""
    if args.bag_action == 'info':
        from iguana_ros.bag.info import bag_info
        from iguana_ros.bag.storage import accept
        text, summary = bag_info(args.bag)
        print(text, flush=True)
        accept(summary, args.allow_damaged)
        return 0
    from iguana_ros.doctor.checks import environment_checks, require, require_ros
    if args.bag_action == 'play':
        require_ros()   # before rclpy is imported (an RMW that is not installed ends the process at import)
        from iguana_ros.bag.play import play
        play(args.bag, rate=args.rate, loop=args.loop, topics=args.topics, clock=args.clock,
             wait_for_subscribers_s=args.wait_for_subscribers, allow_damaged=args.allow_damaged,
             start_paused=args.start_paused)
        return 0
    require(environment_checks())  # the rclpy probe is left out: `iguana run` starts a recorder after its own checks
    from iguana_ros.bag.record import default_topic_names, names_in, record
    from iguana_ros.bag.storage import CHUNK_AGE_S
    from iguana_ros.errors import InputError
    if args.all and args.topics:
        raise InputError('give either TOPIC names or --all, not both')
    if args.chunk_age is not None and not 0 < args.chunk_age < float('inf'):
        raise InputError(f'--chunk-age must be a positive number of seconds, got {args.chunk_age}')
    topics = None if args.all else (names_in(args.topics, args.namespace) or default_topic_names(args.namespace))
    from iguana_ros.bag.storage import BagWriteError, DISK_FULL_EXIT
    try:
        record(args.output, topics, chunk_age_s=args.chunk_age or CHUNK_AGE_S, duration_s=args.duration,
               use_sim_time=args.use_sim_time, ros_args=getattr(args, 'ros_args', ()), namespace=args.namespace)
    except BagWriteError as exc:                      # a full disk: one line, the bag finalised from what was written
        print(f'iguana bag record: error: {exc}', file=sys.stderr, flush=True)
        return DISK_FULL_EXIT
    return 0
