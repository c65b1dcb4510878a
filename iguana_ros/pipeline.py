"""The ROS-free frame loop: goal -> clip -> adapted pose -> spring lengths -> 40 simulator steps per frame.

Each box of DESIGN.md's data flow is a stage object here; the ROS 2 nodes wrap the very same stages, so a
lockstep node run and `run(scene)` compute the same numbers in the same order.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from iguana_ros.body.model import build_model
from iguana_ros.body.root_tracking import RootTracker
from iguana_ros.body.spring_lengths import SpringLengthComputer
from iguana_ros.constants import FRAME_RATE
from iguana_ros.geometry import yaw_of
from iguana_ros.motion.motion_graph import AlignedClip, MotionGraph, PolicyParams
from iguana_ros.physics.pushes import region_force
from iguana_ros.physics.simulator import SoftBodySimulator
from iguana_ros.scene import PushSpec, Scene
from iguana_ros.terrain.adaptation import (AdaptationState, adapt_pose, pose_kinematics,
                                           residual_heights_of)
from iguana_ros.terrain.from_scene import terrain_from_spec
from iguana_ros.terrain.heightfield import HeightField
from iguana_ros.terrain.placement import place_on_terrain

STANCE_HEIGHT = 0.006
"""A clip foot lower than this above the capture floor counts as in stance for residual fitting, m."""


# ----------------------------------------------------------------------------------------------- planner

class PlannerStage:
    """Section IV: at each stride end, picks the next clip toward the goal and aligns it to the body."""

    def __init__(self, graph: MotionGraph, params: PolicyParams = PolicyParams()) -> None:
        """Plan over `graph` with policy `params`."""
        self.graph = graph
        self.params = params
        self.goal: np.ndarray | None = None
        self.clip: AlignedClip | None = None
        self.clip_start = 0
        self.history: list[tuple[int, str]] = []
        self._scheduled: list[tuple[float, int, np.ndarray]] = []

    def set_goal(self, goal_xy: np.ndarray | None) -> None:
        """Set the goal `(2,)` (world x, y) used from the next stride on; None = stop."""
        self.goal = None if goal_xy is None else np.asarray(goal_xy, float)[:2].copy()

    def schedule_goal(self, goal_xy: np.ndarray, at: float = 0.0) -> None:
        """Make `goal_xy (2,)` the goal once simulated time reaches `at` s (0 = at the next frame)."""
        entry = (float(at), len(self._scheduled), np.asarray(goal_xy, float)[:2].copy())
        self._scheduled = sorted(self._scheduled + [entry], key=lambda e: (e[0], e[1]))

    def activate_due_goals(self, time: float) -> None:
        """Apply, in time order, every scheduled goal due at simulated `time` s."""
        while self._scheduled and self._scheduled[0][0] <= time + 1e-9:
            self.set_goal(self._scheduled.pop(0)[2])

    def stride_ends_at(self, frame: int) -> bool:
        """Whether a new clip must be chosen at `frame` (no clip yet, or the current one is used up)."""
        return self.clip is None or frame >= self.clip_start + len(self.clip.root_positions) - 1

    def reference_contacts(self, frame: int) -> np.ndarray:
        """The current clip's stance flags `(4,)` (fl, fr, hl, hr) at `frame` (all True before any clip)."""
        if self.clip is None:
            return np.ones(4, bool)
        index = frame - self.clip_start
        return np.asarray(self.clip.contacts[int(np.clip(index, 0, len(self.clip.contacts) - 1))], bool)

    def update(self, frame: int, root_position: np.ndarray, root_orientation: np.ndarray) -> AlignedClip | None:
        """At a stride end, choose and align the next clip from the body's root pose; else None."""
        self.activate_due_goals(frame / FRAME_RATE)
        if not self.stride_ends_at(frame):
            return None
        heading = float(yaw_of(root_orientation))
        current = self.clip.name if self.clip is not None else None
        name = self.graph.choose_next(root_position[:2], heading, self.goal, current, self.params)
        self.clip = self.graph.align(name, root_position[:2], heading, previous=self.clip)
        self.clip_start = frame
        self.history.append((frame, name))
        return self.clip


# -------------------------------------------------------------------------------------------- adaptation

def clip_pose(clip: AlignedClip, index: int) -> tuple:
    """(root (3,), local rotations (n_bones, 4)) of frame `index` of a placed clip (clamped to its length)."""
    i = int(np.clip(index, 0, len(clip.root_positions) - 1))
    return clip.root_positions[i], clip.local_rotations[i]


class AdaptationStage:
    """Section VI: the clip pose of a frame, adapted to the terrain (plane + residual fitting) if enabled."""

    def __init__(self, skeleton, terrain: HeightField, enabled: bool = True) -> None:
        """Adapt poses of `skeleton` to `terrain`; `enabled=False` (or flat ground) runs no IK at all."""
        self.skeleton = skeleton
        self.terrain = terrain
        self.enabled = bool(enabled) and not terrain.is_flat
        self.state = AdaptationState()

    def reference_pose(self, root_position: np.ndarray, local_rotations: np.ndarray) -> tuple:
        """World bone positions `(n_bones, 3)` and rotations `(n_bones, 4)` of the adapted pose."""
        if not self.enabled:
            return pose_kinematics(self.skeleton, np.asarray(root_position, float),
                                   np.asarray(local_rotations, float))
        feet_h, tail_h = residual_heights_of(self.skeleton, root_position, local_rotations)
        adapted = adapt_pose(self.skeleton, self.terrain, root_position, local_rotations, feet_h, tail_h,
                             stance=feet_h < STANCE_HEIGHT, state=self.state)
        return adapted.joint_positions, adapted.joint_rotations


# ----------------------------------------------------------------------------------------------- pushes

def push_forces(model, pushes: tuple, time: float) -> np.ndarray | None:
    """External forces `(n_nodes, 3)` N of the pushes active at `time` (None when none is active).

    Each push's force is spread over its region's nodes in proportion to their mass (total = the force).
    """
    active = [p for p in pushes if p.at <= time + 1e-9 < p.at + p.duration]
    if not active:
        return None
    forces = np.zeros((model.n_nodes, 3))
    for push in active:  # a handful of pushes per scene, not a loop over nodes
        forces += _push_on_region(model, push)
    return forces


def _push_on_region(model, push: PushSpec) -> np.ndarray:
    """Force field `(n_nodes, 3)` of one push on its tagged region."""
    mask = np.ones(model.n_nodes, bool) if push.region == 'all' else model.node_tags[push.region]
    return region_force(model.node_mass, mask, push.force)


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

    def save(self, path: str | Path) -> Path:
        """Write the trajectories to an `.npz` file; returns its path."""
        path = Path(path)
        frames = np.array([f for f, _ in self.clip_history], dtype=np.int64)
        names = np.array([n for _, n in self.clip_history])
        np.savez_compressed(path, times=self.times, root_positions=self.root_positions,
                            root_orientations=self.root_orientations, node_positions=self.node_positions,
                            contacts=self.contacts, reference_joints=self.reference_joints,
                            reference_rotations=self.reference_rotations,
                            reference_contacts=self.reference_contacts, clip_frames=frames, clip_names=names, goals=np.array(self.goals, float),
                            wall_seconds=self.wall_seconds)
        return path


class SimulatorStage:
    """Section V: the soft body, placed at the scene's start pose on the terrain, advanced frame by frame."""

    def __init__(self, model, terrain: HeightField, fidelity: str, pushes: tuple = (),
                 start_xy: tuple = (0.0, 0.0), start_yaw: float = 0.0) -> None:
        """Build the simulator for `model` on `terrain`; pushes are applied by simulated time."""
        self.model = model
        self.pushes = tuple(pushes)
        self.sim = SoftBodySimulator(model, terrain, fidelity)
        self.sim.reset(positions=place_on_terrain(model.rest_positions, terrain, xy=start_xy, yaw=start_yaw,
                                                  lift_only=True))
        self.tracker = RootTracker(model)
        self.frame = 0

    @property
    def time(self) -> float:
        """Simulated time at the current frame, s."""
        return self.frame / FRAME_RATE

    def root_pose(self) -> tuple:
        """(root position (3,), orientation xyzw (4,)) of the body now."""
        return self.tracker.root_pose(self.sim.positions)

    def advance(self, desired_lengths: np.ndarray | None, extra_forces: np.ndarray | None = None) -> None:
        """Advance one frame (1/30 s) with desired spring lengths `(n_springs,)` (None = rest lengths), the
        scene's active pushes and optional extra forces `(n_nodes, 3)` N."""
        forces = push_forces(self.model, self.pushes, self.time) if self.pushes else None
        if extra_forces is not None:
            forces = extra_forces if forces is None else forces + extra_forces
        self.sim.advance_frame(desired_lengths, forces)
        self.frame += 1


@dataclass
class Pipeline:
    """All four stages for one scene, built once; `step()` runs one frame."""

    scene: Scene
    planner: PlannerStage
    adaptation: AdaptationStage
    springs: SpringLengthComputer
    simulator: SimulatorStage
    frame: int = 0

    def step(self) -> tuple:
        """One frame; returns (root position, orientation, adapted joint positions, bone rotations)."""
        root, quat = self.simulator.root_pose()
        self.planner.update(self.frame, root, quat)
        ref_root, ref_local = clip_pose(self.planner.clip, self.frame - self.planner.clip_start)
        joints, rotations = self.adaptation.reference_pose(ref_root, ref_local)
        lengths = self.springs.lengths_from_bones(rotations, joints)
        self.simulator.advance(lengths)
        self.frame += 1
        return root, quat, joints, rotations


def build_pipeline(scene: Scene, adaptation: bool | None = None, library: dict | None = None) -> Pipeline:
    """Build only what `scene` needs: terrain, model, motion graph, stages (adaptation off on flat ground)."""
    terrain = terrain_from_spec(scene.terrain)
    model = build_model(scene.model.resolution, scene.model.stiffness)
    if library is None:
        from iguana_ros.motion.clips import load_clip_library
        library = load_clip_library()
    graph = MotionGraph(library)
    use_adaptation = scene.adaptation if adaptation is None else adaptation
    planner = PlannerStage(graph, PolicyParams(goal_radius=scene.goal_radius))
    for goal in scene.goals:
        planner.schedule_goal(np.array([goal.x, goal.y]), goal.at)
    return Pipeline(
        scene=scene,
        planner=planner,
        adaptation=AdaptationStage(model.skeleton, terrain, enabled=use_adaptation),
        springs=SpringLengthComputer(model),
        simulator=SimulatorStage(model, terrain, scene.fidelity, scene.pushes if scene.needs_pushes else (),
                                 (scene.start.x, scene.start.y), np.radians(scene.start.yaw_deg)),
    )


def run(scene: Scene, adaptation: bool | None = None, n_frames: int | None = None,
        progress: Callable[[int, int], None] | None = None, stop_after_goal: float | None = None) -> RunResult:
    """Run `scene` for its duration (or `n_frames`) and return the trajectories.

    With `stop_after_goal` (s), the run ends that long after the root first comes within the goal radius of the
    scene's last goal (the arrays then hold only the frames simulated).
    """
    import time as _time

    pipe = build_pipeline(scene, adaptation)
    total = int(round(scene.duration * FRAME_RATE)) if n_frames is None else int(n_frames)
    model = pipe.simulator.model
    rows = _allocate(total, model.n_nodes, model.skeleton.n_bones)
    last_goal = np.array([scene.goals[-1].x, scene.goals[-1].y]) if scene.goals else None
    stop_frame = total
    start = _time.perf_counter()
    for f in range(total):
        _, _, joints, rotations = pipe.step()
        root, quat = pipe.simulator.root_pose()
        _store(rows, f, root, quat, pipe.simulator.sim, (joints, rotations), pipe.planner.reference_contacts(f))
        if progress is not None:
            progress(f + 1, total)
        if (stop_after_goal is not None and last_goal is not None and stop_frame == total
                and np.hypot(*(root[:2] - last_goal)) <= scene.goal_radius):
            stop_frame = min(total, f + 1 + int(round(stop_after_goal * FRAME_RATE)))
        if f + 1 >= stop_frame:
            break
    wall = _time.perf_counter() - start
    done = f + 1 if total else 0
    rows = {k: v[:done] for k, v in rows.items()}
    goals = [(g.at, g.x, g.y) for g in scene.goals]
    return RunResult(times=(np.arange(done) + 1) / FRAME_RATE, clip_history=list(pipe.planner.history),
                     goals=goals, wall_seconds=wall, **rows)


def _allocate(n_frames: int, n_nodes: int, n_bones: int) -> dict:
    """Preallocated trajectory arrays."""
    return {'root_positions': np.zeros((n_frames, 3)), 'root_orientations': np.zeros((n_frames, 4)),
            'node_positions': np.zeros((n_frames, n_nodes, 3)), 'contacts': np.zeros((n_frames, n_nodes), bool),
            'reference_joints': np.zeros((n_frames, n_bones, 3)),
            'reference_rotations': np.zeros((n_frames, n_bones, 4)),
            'reference_contacts': np.zeros((n_frames, 4), bool)}


def _store(rows: dict, f: int, root, quat, sim: SoftBodySimulator, reference: tuple,
           reference_contacts: np.ndarray) -> None:
    """Record frame `f`."""
    rows['root_positions'][f] = root
    rows['root_orientations'][f] = quat
    rows['node_positions'][f] = sim.positions
    rows['contacts'][f] = sim.in_contact
    rows['reference_joints'][f], rows['reference_rotations'][f] = reference
    rows['reference_contacts'][f] = reference_contacts
