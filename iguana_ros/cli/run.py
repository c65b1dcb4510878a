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

"""`iguana run [SCENE]`: the four nodes as processes, the scene's goals, every topic recorded to MCAP."""
from __future__ import annotations

import argparse
from pathlib import Path

from iguana_ros.cli.argtypes import namespace


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the `run` sub-command."""
    parser = subparsers.add_parser('run', help='run a scene with the four ROS 2 nodes and record a bag')
    parser.add_argument('scene', nargs='?', default='hills',
                        help='scene name under msg_configs/scenes/ or a scene YAML path (default: hills)')
    parser.add_argument('--mode', choices=('lockstep', 'realtime'), default='lockstep',
                        help='lockstep: deterministic, as fast as possible; realtime: paced to the wall clock')
    parser.add_argument('--record', type=Path, default=None, metavar='DIR',
                        help='bag directory (default: bags/<scene>_<date>_<time>)')
    parser.add_argument('--single-process', action='store_true',
                        help='run the four nodes in one process with one executor')
    parser.add_argument('--timeout', type=float, default=None, metavar='S',
                        help='wall-clock limit of the run (default: 120 s + 30 x the scene duration)')
    parser.add_argument('--duration', type=float, default=None, metavar='S',
                        help="simulated seconds to run (default: the scene's duration)")
    parser.add_argument('--paused', action='store_true',
                        help='start paused at frame 0: go on with `iguana sim resume` or `iguana sim step N`')
    parser.add_argument('--namespace', type=namespace, default='', metavar='NS',
                        help='ROS namespace of the nodes and topics (/NS/iguana_state, the clock /NS/clock, TF frames '
                             'NS/base_link); runs in different namespaces share a ROS_DOMAIN_ID (default: the root)')
    add_progress_option(parser)
    parser.add_argument('--view', action='store_true',
                        help='also start `iguana view` (live, in a web browser; it stops with the run)')
    parser.add_argument('--view-port', type=int, default=8080, metavar='PORT',
                        help='port of the viewer page (default 8080; 0 = any free port)')
    parser.add_argument('--view-host', default='127.0.0.1', metavar='HOST',
                        help='address the viewer serves on (default 127.0.0.1; beyond this machine see --view-token)')
    parser.add_argument('--view-token', default=None, metavar='TOKEN',
                        help="the viewer's --token: pages must present it to steer ('auto': a random one; default: "
                             '$IGUANA_VIEW_TOKEN, else none)')
    parser.add_argument('--view-rate', type=float, default=None, metavar='HZ',
                        help='redraws of the viewer page per second (default 20)')
    parser.set_defaults(func=run, takes_ros_args=True)
    parser.epilog = ("--ros-args ... at the end goes to every node after the run's own arguments: remaps (-r "
                     'mesh_marker:=my_mesh), parameters (-p planner_node:goal_radius:=0.3), log levels '
                     '(--log-level simulator_node:=debug)')


def add_progress_option(parser: argparse.ArgumentParser) -> None:
    """--progress-every S: how often the progress line is printed when stdout is not a terminal."""
    parser.add_argument('--progress-every', type=float, default=5.0, metavar='S',
                        help='start-up phases and progress on stdout: a live bar on a terminal, else a line every '
                             'S wall seconds (default 5; 0: none)')


def progress_display(every_s: float):
    """Return the ProgressDisplay on stdout for --progress-every `every_s` (None for 0); InputError if negative."""
    import math
    import sys

    from iguana_ros.errors import InputError
    from iguana_ros.supervisor.progress_display import ProgressDisplay
    if not (every_s >= 0 and math.isfinite(every_s)):
        raise InputError(f'--progress-every is {every_s}; expected a number of seconds >= 0')
    return ProgressDisplay(sys.stdout, every_s) if every_s > 0 else None


def run_and_report(options, prog: str, display=None) -> tuple:
    """
    Run a scene (RunOptions `options`) after `iguana doctor`'s quick checks and print its summary.

    A failed check raises CheckFailed (the failed check's line). Unless the run completed, one line headed `prog` goes
    to stderr. Returns (the RunSummary or None if nothing was started, the exit status: 0 completed, 1 failed, 128 + n
    stopped by signal n, e.g. 143 for SIGTERM); `display` shows the phases and progress meanwhile.
    """
    import sys

    from iguana_ros.doctor.checks import quick_checks, require
    from iguana_ros.supervisor.run import RunInterrupted, run_scene

    require(quick_checks(options.record.parent if options.record is not None else options.bags_dir))
    try:
        summary = run_scene(options, display)
    except RunInterrupted as exc:  # before anything was started
        print(f'{prog}: {exc} before the run started; nothing was started', file=sys.stderr, flush=True)
        return None, 128 + exc.signum
    for line in summary.lines():
        print(line, flush=True)
    if summary.exit_code != 0:
        kind = 'error: ' if summary.outcome == 'failed' else ''
        print(f'{prog}: {kind}{summary.headline()}', file=sys.stderr, flush=True)
    return summary, summary.exit_code


def run(args: argparse.Namespace) -> int:
    """Run the scene and print the summary; one line on stderr and a non-zero status unless it completed."""
    from iguana_ros.errors import InputError
    from iguana_ros.supervisor.run import RunOptions

    if args.duration is not None and not args.duration > 0:
        raise InputError(f'--duration is {args.duration}; expected a positive number of seconds')
    extra = {} if args.duration is None else {'duration': float(args.duration)}
    if args.paused:
        extra['start_paused'] = True
    display = progress_display(args.progress_every)
    view = None
    if args.view:
        from iguana_ros.view.server import check_draw_rate, check_port, resolve_token
        check_port(args.view_host, args.view_port)  # before anything starts: one line, exit 1
        check_draw_rate(args.view_rate, '--view-rate')
        token = resolve_token(args.view_token, flag='--view-token')
        view = ['--port', str(args.view_port), '--host', args.view_host]
        view += [] if args.view_rate is None else ['--rate', repr(float(args.view_rate))]
        view += [] if token is None else ['--token', token]
    return run_and_report(RunOptions(scene=args.scene, mode=args.mode, record=args.record,
                                     single_process=args.single_process, timeout=args.timeout,
                                     extra_params=extra, view=view, ros_args=getattr(args, 'ros_args', ()),
                                     namespace=args.namespace),
                          'iguana run', display)[1]
