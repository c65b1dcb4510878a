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

"""`iguana simulate SCENE`: the ROS-free frame loop (pipeline.run) with a progress bar, trajectories to .npz."""
from __future__ import annotations

import argparse
import json
from pathlib import Path
import sys


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the `simulate` sub-command."""
    parser = subparsers.add_parser('simulate', help='run a scene without ROS (library frame loop)')
    parser.add_argument('scene', nargs='?', default='hills', help='scene name or YAML path (default: hills)')
    parser.add_argument('--no-adaptation', action='store_true', help='do not adapt the reference pose to terrain')
    parser.add_argument('-o', '--output', type=Path, default=None, metavar='FILE.npz',
                        help='write trajectories (nodes, root, contacts, clips) to this file')
    parser.add_argument('--duration', type=float, default=None, metavar='S', help='simulated seconds')
    parser.add_argument('--json', action='store_true', help='print the metrics as JSON')
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """
    Run, print locomotion metrics, optionally save trajectories.

    A bad scene or --duration is one error line (the scene is read before the simulator is loaded). A run whose body
    left the terrain or fell ends there: its figures, `outcome`, one line on stderr and exit status 3 or 4.
    """
    from iguana_ros.scene import load_scene, with_duration

    scene = load_scene(args.scene)
    if args.duration is not None:
        scene = with_duration(scene, args.duration)

    from tqdm import tqdm

    from iguana_ros.constants import FRAME_RATE
    from iguana_ros.pipeline import run as run_pipeline
    from iguana_ros.run_metrics import metrics_of_run

    adaptation = False if args.no_adaptation else None
    total = int(round(scene.duration * FRAME_RATE))
    with tqdm(total=total, unit='frame', desc=scene.name, disable=args.json) as bar:
        result = run_pipeline(scene, adaptation=adaptation, progress=lambda done, _n: bar.update(1))
    metrics = {'outcome': result.outcome, **metrics_of_run(result, scene).as_dict()}
    metrics['realtime_factor'] = result.times[-1] / result.wall_seconds if result.wall_seconds and len(result.times) \
        else 0.0
    if args.output is not None:
        metrics['output'] = str(result.save(args.output))
    if args.json:
        print(json.dumps(metrics, indent=2))
    else:
        for key, value in metrics.items():
            print(f'{key:32s} {value:.4g}' if isinstance(value, float) else f'{key:32s} {value}')
    if result.lost is not None:
        print(f'iguana simulate: run ended at t={result.lost.time:.2f} s: {result.lost.message}', file=sys.stderr)
        return result.lost.exit_code
    return 0
