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
    if scene.characters:
        return _simulate_world(scene, adaptation, total, args)
    with tqdm(total=total, unit='frame', desc=scene.name, disable=args.json) as bar:
        result = run_pipeline(scene, adaptation=adaptation, progress=lambda done, _n: bar.update(1))
    metrics = {'outcome': result.outcome, **metrics_of_run(result, scene).as_dict()}
    metrics['realtime_factor'] = _realtime_factor(result.times, result.wall_seconds)
    if args.output is not None:
        metrics['output'] = str(result.save(args.output))
    _print(metrics, args.json)
    return _lost_status(result.lost)


def _realtime_factor(times, wall_seconds: float) -> float:
    """Return simulated over wall seconds of a run (0 for an empty one)."""
    return float(times[-1] / wall_seconds) if wall_seconds and len(times) else 0.0


def _print(metrics: dict, as_json: bool) -> None:
    """Print the metrics as JSON or one `name value` line each (a character's under `name.`)."""
    if as_json:
        print(json.dumps(metrics, indent=2))
        return
    for key, value in _flat(metrics):
        print(f'{key:32s} {value:.4g}' if isinstance(value, float) else f'{key:32s} {value}')


def _flat(metrics: dict, prefix: str = '') -> list[tuple[str, object]]:
    """Return (dotted name, value) of `metrics` with nested mappings flattened."""
    rows = []
    for key, value in metrics.items():
        rows += _flat(value, f'{prefix}{key}.') if isinstance(value, dict) else [(f'{prefix}{key}', value)]
    return rows


def _lost_status(lost, name: str = '') -> int:
    """Print why a lost body's run ended (one line) and return its exit status; 0 when none was lost."""
    if lost is None:
        return 0
    who = f' ({name})' if name else ''
    print(f'iguana simulate: run ended at t={lost.time:.2f} s{who}: {lost.message}', file=sys.stderr)
    return lost.exit_code


def _simulate_world(scene, adaptation, total: int, args: argparse.Namespace) -> int:
    """Run a scene of several characters in one world; their metrics under `characters`, keyed by name."""
    from tqdm import tqdm

    from iguana_ros.run_metrics import metrics_of_run
    from iguana_ros.world import run_world

    if args.output is not None:
        from iguana_ros.errors import InputError
        raise InputError('-o is for a scene of one iguana; a scene with characters has no single trajectory file')
    with tqdm(total=total, unit='frame', desc=scene.name, disable=args.json) as bar:
        result = run_world(scene, adaptation=adaptation, progress=lambda done, _n: bar.update(1))
    scenes = dict(scene.character_scenes())
    characters = {name: {'outcome': run.outcome, **metrics_of_run(run, scenes[name]).as_dict()}
                  for name, run in result.characters.items()}
    first = next(iter(result.characters.values()))
    contacts = [p for frame in result.contacts for p in frame.pairs]
    metrics = {'outcome': result.outcome, 'realtime_factor': _realtime_factor(first.times, result.wall_seconds),
               'body_contact_frames': len(result.contacts),
               'body_contact_max_depth': max((p.max_depth for p in contacts), default=0.0),
               'characters': characters}
    _print(metrics, args.json)
    return next((_lost_status(run.lost, name) for name, run in result.characters.items() if run.lost), 0)
