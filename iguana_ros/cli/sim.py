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

"""`iguana sim pause|resume|step N|reset`: call the running simulator's control services."""
from __future__ import annotations

import argparse
import math
import sys

from iguana_ros.cli.argtypes import add_namespace

MAX_STEP_FRAMES = 108_000
"""Most frames one `iguana sim step` asks for (an hour of simulated time)."""


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the `sim` sub-command."""
    parser = subparsers.add_parser(
        'sim', help='pause, resume, step or reset the running simulation (its sim/* services, std_srvs)')
    parser.add_argument('action', choices=('pause', 'resume', 'step', 'reset'), metavar='{pause,resume,step,reset}',
                        help='pause: hold the body; resume: go on; step N: advance N frames (1/30 s) and hold; '
                             "reset: the body back at the scene's start (simulated time goes on)")
    parser.add_argument('frames', nargs='?', type=int, default=None, metavar='N',
                        help='frames to step (step only; default 1)')
    parser.add_argument('--timeout', type=float, default=10.0, metavar='S',
                        help='give up if no simulator answers within S s (default 10; a step waits as long again '
                             'per 30 frames)')
    add_namespace(parser, 'to control')
    parser.set_defaults(func=run)


def _check(args: argparse.Namespace) -> int:
    """Return the frames to step; `InputError` naming what is wrong with the arguments."""
    from iguana_ros.errors import InputError
    if args.frames is not None and args.action != 'step':
        raise InputError(f'`iguana sim {args.action}` takes no frame count (only `step N` does)')
    frames = 1 if args.frames is None else args.frames
    if not 1 <= frames <= MAX_STEP_FRAMES:
        raise InputError(f'step {frames} frames: expected 1 to {MAX_STEP_FRAMES}')
    if not (args.timeout > 0 and math.isfinite(args.timeout)):
        raise InputError(f'--timeout is {args.timeout}; expected a positive number of seconds')
    return frames


def run(args: argparse.Namespace) -> int:
    """Call the service, print its answer; exit 1 if the simulator refused."""
    frames = _check(args)
    from iguana_ros.doctor.checks import require_ros

    require_ros()
    from iguana_ros.nodes.sim_control import call_sim

    timeout = args.timeout * (1 + frames / 30.0) if args.action == 'step' else args.timeout
    reply = call_sim(args.action, frames, timeout, namespace=args.namespace)
    if not reply.success:
        print(f'error: {reply.message}', file=sys.stderr)
        return 1
    print(reply.message, flush=True)
    return 0
