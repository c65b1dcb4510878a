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

"""`iguana view [BAG]`: the iguana (or a world's characters) in a web browser, live (default) or from a bag."""
from __future__ import annotations

import argparse
from pathlib import Path

from iguana_ros.cli.argtypes import add_namespace


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the `view` sub-command."""
    parser = subparsers.add_parser(
        'view', help='show the iguana (every character of a world) in a web browser: live (click to set a goal for '
                     'the selected one) or a bag with a timeline')
    parser.add_argument('bag', nargs='?', type=Path, default=None,
                        help='a recorded bag (directory or .mcap) to play with a timeline (default: live)')
    parser.add_argument('--port', type=int, default=8080, help='port of the web page (default 8080; 0 = any free)')
    parser.add_argument('--host', default='127.0.0.1',
                        help='address to serve on (default 127.0.0.1: this machine only; 0.0.0.0 for every interface, '
                             'where anyone who reaches the port can steer unless --token is given)')
    parser.add_argument('--token', default=None, metavar='TOKEN',
                        help='pages must present TOKEN (8-128 of A-Z a-z 0-9 . _ ~ -) to send goals, pushes or '
                             "controls; the printed address carries it as ?token=...; 'auto' makes a random one "
                             '(default: $IGUANA_VIEW_TOKEN, else none: every page may steer)')
    parser.add_argument('--rate', type=float, default=None, metavar='HZ',
                        help='redraws of the page per second (default 20; fewer spare a machine without a GPU)')
    add_namespace(parser, 'to show, live')
    parser.add_argument('--speed', type=float, default=1.0, help='bag mode: playback speed (default 1)')
    parser.add_argument('--loop', action='store_true', help='bag mode: start again at the end')
    parser.add_argument('--paused', action='store_true', help='bag mode: start paused')
    parser.add_argument('--allow-damaged', action='store_true',
                        help='bag mode: show the frames of every intact chunk of a damaged or truncated bag')
    parser.set_defaults(func=view)


def view(args: argparse.Namespace) -> int:
    """Serve the page until Ctrl-C / SIGTERM / SIGHUP; one line on stderr and status 1 for bad input."""
    from iguana_ros.errors import InputError
    from iguana_ros.view.server import check_draw_rate, check_port, resolve_token

    if not args.speed > 0:
        raise InputError(f'--speed is {args.speed}; expected a positive factor')
    check_draw_rate(args.rate)
    check_port(args.host, args.port)
    args.token = resolve_token(args.token)
    return _serve_bag(args) if args.bag is not None else _serve_live(args)


def _defaults() -> tuple[dict, float]:
    """Return (the clip library, to name the planner's clips; the simulator's push duration, s)."""
    from iguana_ros.motion.clips import load_clip_library
    from iguana_ros.parameters import node_parameters
    return load_clip_library(), float(node_parameters('simulator_node')['push_duration'].default)


def _serve_bag(args: argparse.Namespace) -> int:
    """Bag mode: the whole recording on a timeline."""
    from iguana_ros.view.bag_source import load_bag
    from iguana_ros.view.playback import Playback
    from iguana_ros.view.server import ViewerPage

    library, push_duration = _defaults()
    bag = load_bag(args.bag, allow_damaged=args.allow_damaged, library=library, push_duration=push_duration)
    playback = Playback(bag.world.start_time, bag.world.end_time, speed=args.speed, playing=not args.paused,
                        loop=args.loop)
    notes = tuple(([bag.damage] if bag.damage else []) + bag.notes)
    page = ViewerPage(bag.world, args.host, args.port, title=f'iguana view: {Path(args.bag).name}',
                      playback=playback, notes=notes, draw_hz=args.rate, token=args.token)
    cast = bag.world.names
    who = f', {len(cast)} characters: {", ".join(cast)}' if len(cast) > 1 else ''
    _announce(page, f'bag {args.bag}, {playback.end - playback.start:.1f} s{who}', notes)
    return _until_stopped(page)


def _serve_live(args: argparse.Namespace) -> int:
    """Live mode: the running system's topics, goals and pushes sent from the page."""
    from iguana_ros.doctor.checks import require_ros

    require_ros()  # before rclpy is imported: a bad ROS environment is one line naming it, not rcl's or Fast DDS's
    from iguana_ros.supervisor.domain_check import current_domain_id
    from iguana_ros.view.live import LiveSource
    from iguana_ros.view.scene import WorldView
    from iguana_ros.view.server import ViewerPage
    library, push_duration = _defaults()
    world = WorldView(keep_meshes=1)       # a lone iguana's, or each character's of a world as it appears
    live = LiveSource(world, library, push_duration, namespace=args.namespace)
    try:
        page = ViewerPage(world, args.host, args.port, title='iguana view: live', live=live, draw_hz=args.rate,
                          token=args.token)
        where = f' in namespace {args.namespace}' if args.namespace else ''
        _announce(page, f'live on ROS_DOMAIN_ID {current_domain_id()}{where}', ())
        return _until_stopped(page)
    finally:
        live.close()


def _announce(page, what: str, notes: tuple) -> None:
    """
    Print the page's address (and what the bag reader tolerated) on stdout.

    Before it, on stderr, who can steer when the page is served beyond this machine.
    """
    from iguana_ros.view.gate import say
    from iguana_ros.view.server import exposure_lines

    for line in exposure_lines(page.host, page.port, page.token, page.live is not None):
        say(line)
    print(f'iguana view: {page.url} ({what}; Ctrl-C stops)', flush=True)
    for note in notes:
        print(f'iguana view: note: {note}', flush=True)


def _until_stopped(page) -> int:
    """Serve `page` until SIGINT, SIGTERM or SIGHUP, then stop its server; returns 0."""
    import signal
    import threading

    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(sig, lambda _signum, _frame: stop.set())
    try:
        page.serve(stop)
    finally:
        page.close()
    return 0
