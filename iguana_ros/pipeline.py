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
The ROS-free frame loop: goal -> clip -> adapted pose -> spring lengths -> 40 simulator steps per frame.

`build_pipeline` builds the four stages of `iguana_ros.stages` from a scene with the factories the ROS 2 nodes
call too, so a lockstep node run and `run(scene)` compute the same numbers in the same order.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from iguana_ros.body.spring_lengths import SpringLengthComputer
from iguana_ros.constants import FRAME_RATE
from iguana_ros.physics.body_watch import BodyLoss
from iguana_ros.physics.simulator import SoftBodySimulator
from iguana_ros.scene import Scene
from iguana_ros.stages import (adaptation_stage, AdaptationStage, planner_stage, PlannerStage, scene_model,
                               scene_terrain, simulator_stage, SimulatorStage, spring_stage, StrideLookahead)


# ---------------------------------------------------------------------------------------------- the run

@dataclass
class RunResult:
    """Trajectories of a run, one row per frame (F frames, n nodes)."""

    times: np.ndarray                 # (F,) s, simulated time at the end of each frame
    root_positions: np.ndarray        # (F, 3) m
    root_orientations: np.ndarray     # (F, 4) xyzw
    node_positions: np.ndarray        # (F, n, 3) m
    contacts: np.ndarray              # (F, n) bool
    reference_joints: np.ndarray      # (F, n_bones, 3) m, adapted reference pose: joint positions
    reference_rotations: np.ndarray   # (F, n_bones, 4) xyzw, adapted reference pose: bone orientations
    reference_contacts: np.ndarray    # (F, 4) bool, the clip's stance flags per foot (fl, fr, hl, hr)
    clip_history: list = field(default_factory=list)  # (start frame, clip name)
    goals: list = field(default_factory=list)         # (time, x, y)
    wall_seconds: float = 0.0
    events: list = field(default_factory=list)        # stages.PlannerEvent: waypoints, arrival, stuck, recovery
    plan_seconds: list = field(default_factory=list)  # wall time of each search of the motion graph, s
    lost: BodyLoss | None = None      # how the body was lost (left the terrain, fell): the run ended there

    @property
    def outcome(self) -> str:
        """'completed', or the cause of the body's loss that ended the run ('left_terrain', 'fell')."""
        return 'completed' if self.lost is None else self.lost.cause

    def save(self, path: str | Path) -> Path:
        """Write the trajectories to an `.npz` file; returns its path."""
        path = Path(path)
        frames = np.array([f for f, _ in self.clip_history], dtype=np.int64)
        names = np.array([n for _, n in self.clip_history])
        np.savez_compressed(path, times=self.times, root_positions=self.root_positions,
                            root_orientations=self.root_orientations, node_positions=self.node_positions,
                            contacts=self.contacts, reference_joints=self.reference_joints,
                            reference_rotations=self.reference_rotations,
                            reference_contacts=self.reference_contacts, clip_frames=frames, clip_names=names,
                            goals=np.array(self.goals, float),
                            wall_seconds=self.wall_seconds)
        return path


@dataclass
class Pipeline:
    """All four stages for one scene, built once; `step()` runs one frame."""

    scene: Scene
    planner: PlannerStage
    adaptation: AdaptationStage
    springs: SpringLengthComputer
    simulator: SimulatorStage
    lookahead: StrideLookahead
    frame: int = 0

    def step(self) -> tuple:
        """One frame; returns (root position, orientation, adapted joint positions, bone rotations)."""
        root, quat, reference = self.reference()
        self.simulator.advance(reference.lengths)
        self.frame += 1
        return root, quat, reference.joints, reference.rotations

    def reference(self) -> tuple:
        """Run the planner's and adaptation's part of a frame; return (root position, orientation, its reference)."""
        root, quat = self.simulator.root_pose()
        if self.planner.update(self.frame, root, quat) is not None:
            self.lookahead.start(self.planner.clip, self.planner.clip_start)
        return root, quat, self.lookahead.take(self.frame)

    def reset(self) -> None:
        """Put the body back at the scene's start (`SimulatorStage.reset`): the simulator node's reset service."""
        self.simulator.reset()

    def load_kernels(self) -> None:
        """Load every stage's compiled kernels (no state changes), so the first frame runs at the speed of the rest."""
        self.planner.load_kernels()
        self.lookahead.load_kernels()
        self.simulator.load_kernels()

    def close(self) -> None:
        """Stop the lookahead's worker thread and the simulator's factor thread."""
        self.lookahead.close()
        self.simulator.close()


def build_pipeline(scene: Scene, adaptation: bool | None = None, library: dict | None = None,
                   blend_frames: int | None = None, simulator_options: dict | None = None,
                   lookahead: bool = True) -> Pipeline:
    """
    Build only what `scene` needs.

    Terrain, model, motion graph (`blend_frames`, default the planner's declared parameter), the four stages (adaptation
    as the scene says unless `adaptation` is given; off on flat ground; `simulator_options` to the SoftBodySimulator),
    and the scene's goals scheduled as `iguana run` sends them. With `lookahead`, a stride's reference frames are
    computed on a second thread while the body steps.
    """
    terrain, model = scene_terrain(scene), scene_model(scene)
    planner = planner_stage(scene, library, blend_frames, terrain=terrain)
    schedule_scene_goals(planner, scene)
    adapt, springs = adaptation_stage(scene, adaptation, model.skeleton, terrain), spring_stage(scene, model)
    pipe = Pipeline(scene=scene, planner=planner, adaptation=adapt, springs=springs,
                    simulator=simulator_stage(scene, model=model, terrain=terrain, options=simulator_options),
                    lookahead=StrideLookahead(adapt, springs, threaded=lookahead))
    pipe.load_kernels()
    return pipe


def schedule_scene_goals(planner: PlannerStage, scene: Scene) -> None:
    """Schedule the scene's goals at their times and its route at 0 s, as `iguana run` sends them."""
    for goal in scene.goals:
        planner.schedule_goal(np.array([goal.x, goal.y]), goal.at, _radians(goal.yaw_deg))
    if scene.route:
        planner.schedule_route(planner.route_targets([(w.x, w.y, _radians(w.yaw_deg)) for w in scene.route]))


def _radians(degrees: float | None) -> float | None:
    """Return an angle in rad, None for none."""
    return None if degrees is None else float(np.radians(degrees))


def run(scene: Scene, adaptation: bool | None = None, n_frames: int | None = None,
        progress: Callable[[int, int], None] | None = None, stop_after_goal: float | None = None,
        simulator_options: dict | None = None) -> RunResult:
    """
    Run `scene` for its duration (or `n_frames`) and return the trajectories.

    With `stop_after_goal` (s), the run ends that long after the planner reached the scene's last goal or the end of
    its route (`PlannerStage.finished`; the arrays then hold only the frames simulated). `simulator_options`:
    SoftBodySimulator keywords (fidelity fields, `friction`) that no scene file names; a sweep's knobs.
    """
    import time as _time

    pipe = build_pipeline(scene, adaptation, simulator_options=simulator_options)
    total = int(round(scene.duration * FRAME_RATE)) if n_frames is None else int(n_frames)
    model = pipe.simulator.model
    rows = allocate_rows(total, model.n_nodes, model.skeleton.n_bones)
    stop_frame = total
    start = _time.perf_counter()
    try:
        for f in range(total):
            _, _, joints, rotations = pipe.step()
            root, quat = pipe.simulator.root_pose()
            store_frame(rows, f, root, quat, pipe.simulator.sim, (joints, rotations),
                        pipe.planner.reference_contacts(f))
            if progress is not None:
                progress(f + 1, total)
            if stop_after_goal is not None and stop_frame == total and pipe.planner.finished:
                stop_frame = min(total, f + 1 + int(round(stop_after_goal * FRAME_RATE)))
            if f + 1 >= stop_frame or pipe.simulator.lost is not None:
                break
    finally:
        pipe.close()
    wall = _time.perf_counter() - start
    done = f + 1 if total else 0
    rows = {k: v[:done] for k, v in rows.items()}
    goals = [(g.at, g.x, g.y) for g in scene.goals]
    return RunResult(times=(np.arange(done) + 1) / FRAME_RATE, clip_history=list(pipe.planner.history),
                     goals=goals, wall_seconds=wall, events=list(pipe.planner.events),
                     plan_seconds=list(pipe.planner.plan_seconds), lost=pipe.simulator.lost, **rows)


def allocate_rows(n_frames: int, n_nodes: int, n_bones: int) -> dict:
    """Preallocated trajectory arrays."""
    return {'root_positions': np.zeros((n_frames, 3)), 'root_orientations': np.zeros((n_frames, 4)),
            'node_positions': np.zeros((n_frames, n_nodes, 3)), 'contacts': np.zeros((n_frames, n_nodes), bool),
            'reference_joints': np.zeros((n_frames, n_bones, 3)),
            'reference_rotations': np.zeros((n_frames, n_bones, 4)),
            'reference_contacts': np.zeros((n_frames, 4), bool)}


def store_frame(rows: dict, f: int, root, quat, sim: SoftBodySimulator, reference: tuple,
                reference_contacts: np.ndarray) -> None:
    """Record frame `f`."""
    rows['root_positions'][f] = root
    rows['root_orientations'][f] = quat
    rows['node_positions'][f] = sim.positions
    rows['contacts'][f] = sim.in_contact
    rows['reference_joints'][f], rows['reference_rotations'][f] = reference
    rows['reference_contacts'][f] = reference_contacts
