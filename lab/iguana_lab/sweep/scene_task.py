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
One sweep task on a scene.

The library loop (`pipeline.run`) with the task's options, reduced to one row of what ran and its locomotion metrics.
"""
from __future__ import annotations

from dataclasses import dataclass
import time

from iguana_ros.scene import Scene

KIND_FIELDS = {'hills': ('amplitude', 'wavelength', 'seed'), 'tilted': ('slope_deg', 'direction_deg'),
               'steps': ('block_size', 'step_min', 'step_max', 'seed'), 'noise': ('amplitude', 'wavelength', 'seed'),
               'heightmap': ('file', 'scale')}
"""The TerrainSpec fields each terrain kind reads (copied into every row as `terrain`)."""
MODE_NAMES = {True: 'adapt', False: 'no_adapt'}
"""Row name of a run with (True) and without (False) terrain adaptation."""
IDENTITY_ALIASES = {'model.resolution': 'resolution', 'terrain.kind': 'kind'}
"""Overrides that `scene_identity` already shows under another name."""
TIMING_COLUMNS = ('wall_s', 'realtime_factor', 'plan_ms_median', 'plan_ms_max')
"""Row fields that measure the machine, not the run: they differ between runs of the same task."""


@dataclass(frozen=True)
class RunOptions:
    """
    How a scene task runs besides its scene.

    Adaptation (None = the scene's), `stop_after_goal` (s after the root first reaches the last goal; None = the whole
    duration) and `simulator`, sorted (name, value) pairs of SoftBodySimulator keywords (fidelity fields such as `dt`,
    and `friction`).
    """

    adaptation: bool | None = None
    stop_after_goal: float | None = None
    simulator: tuple = ()

    def simulator_options(self) -> dict:
        """Return the SoftBodySimulator keywords (a friction given per node tag as pairs becomes a mapping)."""
        return {name: dict(value) if name == 'friction' and isinstance(value, tuple) else value
                for name, value in self.simulator}


def scene_identity(scene: Scene, adaptation: bool | None = None) -> dict:
    """
    Return the row fields that say what ran.

    They are the scene, terrain kind and its parameters, last goal, mesh, duration and adaptation (`adaptation` or the
    scene's) with its mode name.
    """
    adapt = scene.adaptation if adaptation is None else bool(adaptation)
    return {'scene': scene.name, 'kind': scene.terrain.kind,
            'terrain': {k: getattr(scene.terrain, k) for k in KIND_FIELDS.get(scene.terrain.kind, ())},
            'goal': [scene.destination.x, scene.destination.y] if scene.destination else None,
            'resolution': scene.model.resolution, 'duration': scene.duration,
            'adaptation': adapt, 'mode': MODE_NAMES[adapt]}


def run_scene(scene: Scene, options: RunOptions, identity: dict) -> dict:
    """
    Run `scene` with `options`.

    The row `identity` + `wall_s` (build, run and metrics), `simulated_s`, `realtime_factor` (simulated over the frame
    loop's wall time) and every LocomotionMetrics field.

    Raises what the run raises (SimulationDiverged, InputError, ...): the engine makes that an error row.
    """
    from iguana_ros import pipeline
    from iguana_ros.run_metrics import metrics_of_run

    start = time.perf_counter()
    result = pipeline.run(scene, adaptation=options.adaptation, stop_after_goal=options.stop_after_goal,
                          simulator_options=options.simulator_options())
    metrics = metrics_of_run(result, scene).as_dict()
    simulated = float(result.times[-1]) if len(result.times) else 0.0
    loop = float(result.wall_seconds)
    plans = sorted(result.plan_seconds)
    return {**identity, 'wall_s': time.perf_counter() - start, 'simulated_s': simulated,
            'realtime_factor': simulated / loop if loop > 0 else None,
            'plan_ms_median': 1e3 * plans[len(plans) // 2] if plans else None,
            'plan_ms_max': 1e3 * plans[-1] if plans else None, **metrics}
