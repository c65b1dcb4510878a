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

"""`iguana demo`: run the default scene with the four nodes, record a bag, render it, say where it all is."""
from __future__ import annotations

import argparse
from pathlib import Path
import subprocess
import sys

from iguana_ros.cli.run import add_progress_option


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the `demo` sub-command."""
    parser = subparsers.add_parser('demo', help='run the default scene (hills), record it and render a GIF')
    parser.add_argument('scene', nargs='?', default='hills', help='scene to run (default: hills)')
    parser.add_argument('--duration', type=float, default=None, metavar='S', help='simulated seconds')
    parser.add_argument('--bags-dir', type=Path, default=Path('bags'), help='where bags go (default: bags/)')
    add_progress_option(parser)
    parser.set_defaults(func=run)


def next_commands(bag: Path, scene: str) -> list[str]:
    """Return the three commands to try after the demo: watch or render its bag, send a goal, run another scene."""
    from iguana_ros.scene import available_scenes
    other = next((name for name in ('goal_sequence', 'push_normal', *available_scenes()) if name != scene), scene)
    return [f'iguana view {bag}                # watch the recorded run in a browser (or: iguana render {bag} '
            f'-o {bag.with_suffix(".mp4")} --camera orbit)',
            'iguana run flat_walk --mode realtime --duration 120   # then, in a second terminal: iguana goal 1.5 0.5',
            f'iguana run {other}                # another scene (all of them: ls msg_configs/scenes/)']


def run(args: argparse.Namespace) -> int:
    """`iguana` run SCENE, then iguana render BAG -o BAG.gif; prints the outputs."""
    from iguana_ros.cli.run import progress_display, run_and_report
    from iguana_ros.errors import IguanaError
    from iguana_ros.supervisor.run import RunOptions

    extra = {} if args.duration is None else {'duration': float(args.duration)}
    print(f'iguana demo: running scene {args.scene!r} with four node processes (lockstep) ...', flush=True)
    summary, code = run_and_report(RunOptions(scene=args.scene, bags_dir=args.bags_dir, extra_params=extra),
                                   'iguana demo', progress_display(args.progress_every))
    if code != 0:
        return code
    video = summary.bag.with_suffix('.gif')
    print(f'iguana demo: rendering {video} ...', flush=True)
    render = subprocess.run([sys.executable, '-m', 'iguana_ros.cli', 'render', str(summary.bag), '-o', str(video)])
    if render.returncode != 0:
        raise IguanaError(f'rendering failed (status {render.returncode}); the bag is at {summary.bag}')
    print('\noutputs:', flush=True)
    print(f'  bag (rosbag2 MCAP, open in Foxglove or `ros2 bag info`): {summary.bag}', flush=True)
    print(f'  rendered run:                                           {video}', flush=True)
    print(f'  node logs:                                              {summary.logs}', flush=True)
    print('\nnext, try:', flush=True)
    for line in next_commands(summary.bag, args.scene):
        print(f'  {line}', flush=True)
    return 0
