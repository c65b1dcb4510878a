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

"""`iguana bench pipeline`: realtime factor of the four-process lockstep run next to the library run."""
from __future__ import annotations

import dataclasses
from pathlib import Path
import tempfile
import time

from iguana_lab.bench.sim import cpu_model
from iguana_ros.constants import FRAME_RATE
from iguana_ros.pipeline import run as run_pipeline
from iguana_ros.scene import load_scene
from iguana_ros.supervisor.run import run_scene, RunOptions


def bench_pipeline(scene_name: str = 'hills', duration: float = 5.0, single_process: bool = False) -> dict:
    """
    Run `scene_name` for `duration` simulated s as a library loop and as lockstep nodes; report both.

    The node overhead is the nodes' wall time per 1/30 s frame less the library loop's (the same frames simulated).
    """
    scene = dataclasses.replace(load_scene(scene_name), duration=float(duration))
    start = time.perf_counter()
    library = run_pipeline(scene)
    library_total = time.perf_counter() - start
    with tempfile.TemporaryDirectory(prefix='iguana_bench_') as tmp:
        start = time.perf_counter()
        summary = run_scene(RunOptions(scene=scene_name, record=Path(tmp) / 'bag', single_process=single_process,
                                       extra_params={'duration': float(duration)}))
        nodes_total = time.perf_counter() - start
    if summary.exit_code != 0:
        from iguana_ros.errors import IguanaError
        raise IguanaError(f'the node run failed: {summary.message}')
    return {
        'scene': scene.name, 'simulated_s': scene.duration,
        'library_realtime_factor': scene.duration / library.wall_seconds,
        'library_wall_s': library.wall_seconds, 'library_total_s': library_total,
        'nodes_realtime_factor': summary.realtime_factor, 'nodes_wall_s': summary.wall_s,
        'nodes_total_s': nodes_total, 'nodes_layout': 'one process' if single_process else 'four processes',
        'nodes_reached_goal': summary.reached_goal,
        'nodes_cpu_ms_per_frame': sum(summary.cpu_ms_per_frame.values()) if summary.cpu_ms_per_frame else None,
        'nodes_cpu_ms_per_frame_by_process': summary.cpu_ms_per_frame,
        'node_overhead_ms_per_frame': 1e3 * (summary.wall_s - library.wall_seconds) / (scene.duration * FRAME_RATE),
        'cpu_model': cpu_model(),
    }
