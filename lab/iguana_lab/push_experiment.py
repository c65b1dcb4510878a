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
The push experiment of paper Section VIII-D (Figure 12).

40 N for 0.1 s to the left of the trunk of a walking iguana, at several phases of a stride, for the normal and the
softer model.

Each model walks straight ahead on flat ground once unpushed and once per push phase. The runs are identical
until the push (the simulation is deterministic), so the push's effect is the pushed run minus the unpushed one:
the peak lateral displacement of the root within `window` s, whether the body walks on (its forward speed over
the `recovery` s after that window, as a fraction of the unpushed speed) and how much its stance feet slide in
the window (slip per foot per stride, from the run's gait figures). ROS-free; `iguana bench pushes` runs it.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
import statistics

import numpy as np

from iguana_ros.constants import FRAME_RATE, PUSH_DURATION, PUSH_FORCE
from iguana_ros.scene import GoalSpec, ModelSpec, PushSpec, Scene, TerrainSpec

STRIDE_FRAMES = 20
"""Frames of one stride of the shipped clips (1.5 Hz trot at 30 Hz)."""
SETTLE = 3.0
"""Walking time (s) before the first push phase: the body is in its steady trot."""


@dataclass(frozen=True)
class PushSettings:
    """
    Experiment settings.

    Push phases per stride, force (N, +y is the iguana's left; the paper pushes its left side, i.e. toward -y), duration
    (s), windows (s) and the mesh.
    """

    phases: int = 6
    force: float = PUSH_FORCE
    duration: float = PUSH_DURATION
    window: float = 1.0
    recovery: float = 2.0
    resolution: str = 'medium'


def push_scene(stiffness: str, at: float | None, settings: PushSettings) -> Scene:
    """Return a straight walk on flat ground (goal 20 m ahead) with one push at `at` s (None: unpushed)."""
    pushes = () if at is None else (PushSpec(at=at, force=(0.0, -settings.force, 0.0), duration=settings.duration,
                                             region='trunk_left'),)
    length = SETTLE + STRIDE_FRAMES / FRAME_RATE + settings.duration + settings.window + settings.recovery
    return Scene(name=f'push_{stiffness}', terrain=TerrainSpec(kind='flat', extent=50.0),
                 model=ModelSpec(resolution=settings.resolution, stiffness=stiffness),
                 goals=(GoalSpec(x=20.0, y=0.0),), pushes=pushes, duration=round(length, 4), adaptation=False)


def push_times(settings: PushSettings) -> list[float]:
    """Push start times `(phases,)` s, spread evenly over one stride after SETTLE (on frame boundaries)."""
    frames = [round(SETTLE * FRAME_RATE) + round(k * STRIDE_FRAMES / settings.phases) for k in range(settings.phases)]
    return [f / FRAME_RATE for f in frames]


def walk_trace(stiffness: str, at: float | None, settings: PushSettings) -> dict:
    """One run (worker task): times, root xy `(F, 2)` and slip per foot per stride in the window after `at`."""
    from iguana_ros.pipeline import run
    from iguana_ros.run_metrics import metrics_of_run

    scene = push_scene(stiffness, at, settings)
    result = run(scene)
    trace = {'stiffness': stiffness, 'at': at, 'times': result.times.tolist(),
             'root_xy': result.root_positions[:, :2].tolist(),
             'fell': bool(metrics_of_run(result, scene).fell)}
    if at is not None:
        frames = (result.times > at) & (result.times <= at + settings.duration + settings.window)
        window = dataclasses.replace(result, **{k: getattr(result, k)[frames] for k in (
            'times', 'root_positions', 'root_orientations', 'node_positions', 'contacts', 'reference_joints',
            'reference_rotations', 'reference_contacts')})
        trace['slip_per_foot'] = metrics_of_run(window, scene).as_dict()['slip_per_foot_per_stride']
    return trace


def push_effect(pushed: dict, unpushed: dict, settings: PushSettings) -> dict:
    """Peak lateral displacement (m), recovered speed fraction and window slip of one pushed trace."""
    t = np.asarray(pushed['times'])
    dy = np.asarray(pushed['root_xy'])[:, 1] - np.asarray(unpushed['root_xy'])[:, 1]
    at = pushed['at']
    window = (t > at) & (t <= at + settings.duration + settings.window)
    late = (t > at + settings.duration + settings.window) & (t <= at + settings.duration + settings.window
                                                             + settings.recovery)
    speed = {}
    for name, trace in (('pushed', pushed), ('unpushed', unpushed)):
        x = np.asarray(trace['root_xy'])[late, 0]
        speed[name] = float((x[-1] - x[0]) / (t[late][-1] - t[late][0])) if len(x) > 1 else float('nan')
    slip = pushed.get('slip_per_foot') or []
    return {'at': at, 'peak_lateral_m': float(np.max(np.abs(dy[window]))) if window.any() else float('nan'),
            'recovered_speed_fraction': speed['pushed'] / speed['unpushed'] if speed['unpushed'] else float('nan'),
            'window_slip_per_foot': slip, 'window_slip_mean': float(np.mean([s for s in slip if s is not None]))
            if slip else float('nan'), 'fell': pushed['fell']}


def run_push_experiment(stiffnesses: tuple = ('normal', 'softer'), settings: PushSettings = PushSettings(),
                        workers: int | None = None, progress=None) -> dict:
    """Every model's unpushed and pushed runs (in parallel), reduced to per-push effects and a summary."""
    from iguana_ros.errors import IguanaError
    from iguana_lab.sweep.engine import parallel_map

    tasks = [(s, at, settings) for s in stiffnesses for at in [None] + push_times(settings)]
    traces = parallel_map(walk_trace, tasks, workers, progress,
                          identity=lambda task: {'stiffness': task[0], 'at': task[1]})
    failed = next((tr for tr in traces if 'error' in tr), None)
    if failed is not None:
        raise IguanaError(f"push run ({failed['stiffness']} model, push at {failed['at']}) failed: {failed['error']}")
    out = {'settings': dataclasses.asdict(settings), 'models': {}}
    for stiffness in stiffnesses:
        mine = [tr for tr in traces if tr['stiffness'] == stiffness]
        unpushed = next(tr for tr in mine if tr['at'] is None)
        effects = [push_effect(tr, unpushed, settings) for tr in mine if tr['at'] is not None]
        out['models'][stiffness] = {'pushes': effects, **summarize_effects(effects)}
    return out


def summarize_effects(effects: list[dict]) -> dict:
    """Median and range of the peak lateral displacement, median recovered speed and window slip, falls."""
    peaks = [e['peak_lateral_m'] for e in effects]
    return {'peak_lateral_median_m': statistics.median(peaks), 'peak_lateral_min_m': min(peaks),
            'peak_lateral_max_m': max(peaks),
            'recovered_speed_fraction_median': statistics.median(e['recovered_speed_fraction'] for e in effects),
            'window_slip_mean_m': statistics.fmean(e['window_slip_mean'] for e in effects),
            'fell': sum(bool(e['fell']) for e in effects)}
