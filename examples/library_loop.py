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
Example 1: the library loop, without ROS — run a scene, compute its locomotion metrics, plot the walk.

The four stages of `iguana_ros.pipeline` (planner, terrain adaptation, spring lengths, soft-body simulator) run
frame by frame in this process, exactly as the four ROS 2 nodes run them in `iguana run` (a lockstep node run
gives the same numbers, bit for bit).

    python examples/library_loop.py                                # hills, 25 s, medium mesh
    python examples/library_loop.py flat_walk --duration 4 --mesh coarse -o walk.png
"""
from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import numpy as np

from iguana_ros.constants import FRAME_RATE
from iguana_ros.pipeline import run, RunResult
from iguana_ros.run_metrics import metrics_of_run
from iguana_ros.scene import load_scene, Scene, with_duration


def scene_for(name: str, duration: float | None, mesh: str | None) -> Scene:
    """
    Return the scene `name`, shortened to `duration` s, on mesh resolution `mesh`.

    `name` is a shipped scene or a YAML path.
    """
    scene = load_scene(name)
    if duration is not None:
        scene = with_duration(scene, duration)
    if mesh is not None:
        scene = dataclasses.replace(scene, model=dataclasses.replace(scene.model, resolution=mesh))
    return scene


def forward_speed(result: RunResult) -> np.ndarray:
    """Horizontal root speed `(F,)` m/s per frame (central differences of the root path)."""
    xy = result.root_positions[:, :2]
    return np.linalg.norm(np.gradient(xy, 1.0 / FRAME_RATE, axis=0), axis=1) if len(xy) > 1 else np.zeros(len(xy))


def plot(result: RunResult, scene: Scene, path: Path) -> Path:
    """Save a figure of the root path (top view, with the goals) and the root speed over time."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    fig, (top, speed) = plt.subplots(1, 2, figsize=(10, 4))
    top.plot(result.root_positions[:, 0], result.root_positions[:, 1], color='tab:orange', label='root')
    for goal in scene.goals:
        top.add_patch(plt.Circle((goal.x, goal.y), scene.goal_radius, color='tab:blue', alpha=0.4))
        top.plot(goal.x, goal.y, 'o', color='tab:blue', label='goal')
    top.set(xlabel='x (m)', ylabel='y (m)', title=f'{scene.name}: root path from above', aspect='equal')
    top.legend(loc='best')
    speed.plot(result.times, forward_speed(result), color='tab:green')
    speed.set(xlabel='simulated time (s)', ylabel='root speed (m/s)', title='speed')
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def main(argv: list[str] | None = None) -> int:
    """Run the scene, print the metrics, save the plot."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('scene', nargs='?', default='hills', help='scene name or YAML path (default: hills)')
    parser.add_argument('--duration', type=float, default=None, help='simulated seconds (default: the scene)')
    parser.add_argument('--mesh', choices=('coarse', 'medium', 'fine'), default=None, help='mesh resolution')
    parser.add_argument('-o', '--output', type=Path, default=Path('library_loop.png'), help='plot (PNG)')
    args = parser.parse_args(argv)

    scene = scene_for(args.scene, args.duration, args.mesh)
    print(f'running {scene.name} for {scene.duration:g} s on the {scene.model.resolution} mesh ...', flush=True)
    result = run(scene)
    metrics = metrics_of_run(result, scene)
    print(f'simulated {result.times[-1]:.2f} s in {result.wall_seconds:.1f} s wall '
          f'(realtime factor {result.times[-1] / result.wall_seconds:.2f})')
    when = f'at t={metrics.time_to_goal:.2f} s' if metrics.reached_goal else \
        f'not reached, {metrics.final_goal_distance:.2f} m short'
    print(f'goal {when}; walked {metrics.path_length:.2f} m at {metrics.mean_forward_speed:.3f} m/s over '
          f'{metrics.strides} strides; slip {metrics.foot_slip_per_stride * 100:.1f} cm per foot per stride; '
          f'fell: {"yes" if metrics.fell else "no"}')
    print(f'plot: {plot(result, scene, args.output)}')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
