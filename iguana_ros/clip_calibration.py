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
Measure what the soft body achieves with every clip of the library (`iguana motion calibrate`).

A scripted tour plays every clip several times (each transition at least once) on level ground and on tilted planes
of two slopes in four directions; at each stride end the body's planar root pose is taken, so every stride gives its
achieved motion in the frame of its start (dx, dy, dyaw), the terrain gradient there in the body frame, and the feet's
slip in contact during it. `motion.tracking.fit_tracking` fits them per clip (level ground plus a gain per unit slope)
and the figures are written next to the library (`iguana_ros/data/clip_tracking.json`), where the planner's search
reads them. The tours run in parallel on a pool of spawned processes (the standard library's; no Dask needed).
"""
from __future__ import annotations

from concurrent.futures import as_completed, ProcessPoolExecutor
import dataclasses
import multiprocessing
import os

import numpy as np

from iguana_ros.body.feet import contact_offsets, foot_groups, foot_probe
from iguana_ros.constants import FRAME_RATE
from iguana_ros.geometry import planar_relative, yaw_of
from iguana_ros.metrics import slip_per_foot
from iguana_ros.motion.clips import load_clip_library
from iguana_ros.motion.tracking import fit_tracking, save_tracking, StrideSample
from iguana_ros.pipeline import build_pipeline
from iguana_ros.scene import ModelSpec, Scene, TerrainSpec
from iguana_ros.stages import PlannerStage

TOUR = ('start', 'walk', 'walk', 'pivot_left', 'pivot_left', 'pivot_left', 'walk', 'pivot_right', 'pivot_right',
        'pivot_right', 'sharp_left', 'sharp_left', 'sharp_left', 'walk', 'sharp_right', 'sharp_right', 'sharp_right',
        'walk', 'walk_to_trot', 'forward', 'forward', 'forward', 'turn_left', 'turn_left', 'turn_left',
        'turn_right', 'turn_right', 'turn_right', 'trot_to_fast', 'fast', 'fast', 'fast', 'fast_left', 'fast_left',
        'fast_left', 'fast_right', 'fast_right', 'fast_right', 'fast_to_trot', 'forward',
        'trot_to_walk', 'walk', 'stop', 'idle', 'start', 'walk_to_trot', 'trot_to_walk', 'stop', 'idle')
"""The scripted clip sequence of one calibration run: every clip of the shipped library, the cyclic ones thrice."""

SLOPES_DEG = (10.0, 20.0)
"""Slopes (deg) of the tilted planes measured, each in four directions."""

DIRECTIONS_DEG = (0.0, 90.0, 180.0, 270.0)
"""Uphill directions (deg, world frame; the iguana starts facing +x) of the tilted planes."""

LEVEL_GRADIENT = 0.02
"""A stride started where the gradient is smaller than this counts as on level ground."""


class ScriptedPlanner(PlannerStage):
    """A planner stage that plays a fixed clip sequence, then comes to rest."""

    def __init__(self, stage: PlannerStage, script: tuple) -> None:
        """Play `script` (clip names) with the graph and search of `stage`."""
        super().__init__(stage.graph, stage.planner, stage.goal_radius, stage.yaw_tolerance)
        self.script = list(script)

    def choose(self, pose: np.ndarray) -> str:
        """Return the next clip of the script, then the way to rest."""
        if self.script:
            return self.script.pop(0)
        return self._toward_rest(self.clip.name if self.clip is not None else None)


def calibration_scenes(fidelity: str = 'balanced', stiffness: str = 'normal') -> list[Scene]:
    """Return the scenes of one calibration: level ground, then each slope in each direction."""
    scenes = [Scene(name='calibrate_level', terrain=TerrainSpec(kind='flat'))]
    scenes += [Scene(name=f'calibrate_slope{slope:g}_dir{direction:g}',
                     terrain=TerrainSpec(kind='tilted', slope_deg=slope, direction_deg=direction))
               for slope in SLOPES_DEG for direction in DIRECTIONS_DEG]
    return [dataclasses.replace(s, model=ModelSpec(stiffness=stiffness), fidelity=fidelity,
                                duration=len(TOUR) * 1.0) for s in scenes]


def terrain_category(gradient: np.ndarray) -> str:
    """'level', 'uphill', 'downhill' or 'cross' for a body-frame gradient `(2,)` (uphill ahead, to the left)."""
    if np.hypot(*gradient) < LEVEL_GRADIENT:
        return 'level'
    angle = abs(np.degrees(np.arctan2(gradient[1], gradient[0])))
    return 'uphill' if angle < 45.0 else 'downhill' if angle > 135.0 else 'cross'


def measure_tour(scene: Scene, script: tuple = TOUR, library: dict | None = None) -> list[dict]:
    """Play `script` on `scene` in the library loop; one plain dict per stride (the fields of StrideSample)."""
    pipe = build_pipeline(scene, library=library)
    pipe.planner = ScriptedPlanner(pipe.planner, script)
    model, terrain = pipe.simulator.model, pipe.planner.planner.terrain
    strides, nodes, contacts, frame = [], [], [], 0
    try:
        while len(pipe.planner.history) <= len(script):      # until the clip after the script is chosen
            root, quat = pipe.simulator.root_pose()
            pose = np.array([root[0], root[1], float(yaw_of(quat))])
            if pipe.planner.stride_ends_at(frame):
                strides.append((frame, pose))
            pipe.step()
            nodes.append(pipe.simulator.sim.positions.copy())
            contacts.append(pipe.simulator.sim.in_contact.copy())
            frame += 1
    finally:
        pipe.close()
    feet = foot_groups(model)
    _, touching, soles = foot_probe(np.array(nodes), np.array(contacts), feet, terrain, contact_offsets(model))
    names = [name for _, name in pipe.planner.history]
    rows, previous = [], ('', (0.0, 0.0, 0.0))
    for k, ((f0, start), (f1, end)) in enumerate(zip(strides[:-1], strides[1:])):
        gradient = pipe.planner.planner.gradient(start)[0]
        slip = float(np.sum(slip_per_foot(soles[f0:f1, :, :2], touching[f0:f1], 1)))
        motion = tuple(map(float, planar_relative(start, end)))
        rows.append(dataclasses.asdict(StrideSample(names[k], tuple(map(float, gradient)), motion, slip,
                                                    terrain_category(gradient), *previous)))
        previous = (names[k], motion)
    return rows


def calibrate(workers: int | None = None, fidelity: str = 'balanced', stiffness: str = 'normal',
              progress=None) -> tuple:
    """(LibraryTracking, every StrideSample) from the tours of `calibration_scenes` run on `workers` processes."""
    library = load_clip_library()
    scenes = calibration_scenes(fidelity, stiffness)
    script = tuple(name for name in TOUR if name in library)
    results = _tours(scenes, script, workers, progress)
    samples = [StrideSample(**{**row, **{k: tuple(row[k]) for k in ('gradient', 'motion', 'previous_motion')}})
               for rows in results for row in rows]
    nominal = {name: (*clip.root_displacement[:2], clip.heading_change) for name, clip in library.items()}
    cyclic = {name for name, clip in library.items() if clip.cyclic}
    return fit_tracking(samples, nominal, cyclic), samples


def _tours(scenes: list, script: tuple, workers: int | None, progress=None) -> list:
    """
    Return `measure_tour(scene, script)` of every scene, in scene order, run on `workers` spawned processes.

    `progress(rows, n_done, n_total)` is called as each tour finishes; a tour that raises stops the calibration with
    a RuntimeError naming its scene.
    """
    n = max(1, min(workers or len(os.sched_getaffinity(0)), len(scenes)))
    results: list = [None] * len(scenes)
    with ProcessPoolExecutor(n, mp_context=multiprocessing.get_context('spawn')) as pool:
        futures = {pool.submit(measure_tour, scene, script): k for k, scene in enumerate(scenes)}
        for done, future in enumerate(as_completed(futures), 1):
            k = futures[future]
            try:
                results[k] = future.result()
            except Exception as exc:
                raise RuntimeError(f'calibration run {scenes[k].name} failed: {exc}') from exc
            if progress is not None:
                progress(results[k], done, len(scenes))
    return results


def write_calibration(path, tracking, samples: list, fidelity: str, stiffness: str) -> None:
    """Save the tracking figures with the conditions they were measured in."""
    conditions = {'fidelity': fidelity, 'stiffness': stiffness, 'resolution': ModelSpec().resolution,
                  'slopes_deg': list(SLOPES_DEG), 'directions_deg': list(DIRECTIONS_DEG), 'tour': list(TOUR),
                  'strides': len(samples), 'frame_rate': FRAME_RATE}
    save_tracking(path, tracking, conditions)
