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
The four stages of the frame loop, each built from a scene by one factory (ROS-free).

goal -> `PlannerStage` (Section IV: a clip per stride) -> `AdaptationStage` (Section VI: the clip pose on the
terrain) -> spring lengths (Section VII: `SpringLengthComputer`) -> `SimulatorStage` (Section V: the soft body,
one frame of steps per call). `planner_stage`, `adaptation_stage`, `spring_stage` and `simulator_stage` build them
from a `Scene` (and the options a node's parameters may set); `pipeline.build_pipeline` and the four nodes call
the same factories, so a lockstep node run and `pipeline.run(scene)` compute the same numbers in the same order.
"""
from __future__ import annotations

from concurrent.futures import Future, ThreadPoolExecutor, wait
import dataclasses
from typing import Callable

import numpy as np

from iguana_ros.body.model import build_model
from iguana_ros.body.root_tracking import RootTracker
from iguana_ros.body.skeleton import iguana_skeleton
from iguana_ros.body.spring_lengths import SpringLengthComputer
from iguana_ros.constants import FRAME_RATE, MAX_SCHEDULE_AHEAD
from iguana_ros.geometry import yaw_of
from iguana_ros.motion.motion_graph import AlignedClip, MotionGraph, PolicyParams
from iguana_ros.parameters import node_parameters
from iguana_ros.physics.pushes import region_force
from iguana_ros.physics.simulator import SoftBodySimulator
from iguana_ros.scene import PushSpec, Scene
from iguana_ros.scene import terrain_from_spec
from iguana_ros.terrain.adaptation import adapt_pose, AdaptationState, pose_kinematics, residual_heights_of
from iguana_ros.terrain.heightfield import HeightField
from iguana_ros.terrain.placement import place_on_terrain

STANCE_HEIGHT = 0.006
"""A clip foot lower than this above the capture floor counts as in stance for residual fitting, m."""


def scene_model(scene: Scene):
    """Return the scene's soft-body model (resolution and stiffness preset; cached by `build_model`)."""
    return build_model(scene.model.resolution, scene.model.stiffness)


def scene_terrain(scene: Scene) -> HeightField:
    """Return the scene's terrain as a height field."""
    return terrain_from_spec(scene.terrain)


# ----------------------------------------------------------------------------------------------- planner

def stride_ended(clip_start: int, clip_points: int, frame: int) -> bool:
    """
    Whether a clip of `clip_points` poses started at frame `clip_start` is used up at `frame`.

    (its last pose is the next clip's first: a new clip is chosen there).
    """
    return frame >= clip_start + clip_points - 1


class PlannerStage:
    """Section IV: at each stride end, picks the next clip toward the goal and aligns it to the body."""

    def __init__(self, graph: MotionGraph, params: PolicyParams = PolicyParams()) -> None:
        """Plan over `graph` with policy `params`."""
        self.graph = graph
        self.params = params
        self.goal: np.ndarray | None = None
        self.clip: AlignedClip | None = None
        self.clip_start = 0
        self.frame = -1
        self.history: list[tuple[int, str]] = []
        self._scheduled: list[tuple[float, int, np.ndarray]] = []

    def set_goal(self, goal_xy: np.ndarray | None) -> None:
        """Set the goal `(2,)` (world x, y) used from the next stride on; None = stop."""
        self.goal = None if goal_xy is None else np.asarray(goal_xy, float)[:2].copy()

    def schedule_goal(self, goal_xy: np.ndarray, at: float = 0.0) -> None:
        """Make `goal_xy (2,)` the goal once simulated time reaches `at` s (0 = at the next frame)."""
        entry = (float(at), len(self._scheduled), np.asarray(goal_xy, float)[:2].copy())
        self._scheduled = sorted(self._scheduled + [entry], key=lambda e: (e[0], e[1]))

    def accept_goal(self, goal_xy: np.ndarray, at: float) -> float:
        """
        Schedule a received goal `(2,)` stamped `at` s.

        A stamp more than MAX_SCHEDULE_AHEAD past the frame planned last is a wall-clock stamp and adopted now (0).
        Returns the adoption time used, s.
        """
        if at > max(self.frame, 0) / FRAME_RATE + MAX_SCHEDULE_AHEAD:
            at = 0.0
        self.schedule_goal(goal_xy, at)
        return at

    def activate_due_goals(self, time: float) -> None:
        """Apply, in time order, every scheduled goal due at simulated `time` s."""
        while self._scheduled and self._scheduled[0][0] <= time + 1e-9:
            self.set_goal(self._scheduled.pop(0)[2])

    def stride_ends_at(self, frame: int) -> bool:
        """Whether a new clip must be chosen at `frame` (no clip yet, or the current one is used up)."""
        return self.clip is None or stride_ended(self.clip_start, len(self.clip.root_positions), frame)

    def reference_contacts(self, frame: int) -> np.ndarray:
        """Return the current clip's stance flags `(4,)` (fl, fr, hl, hr) at `frame` (all True before any clip)."""
        if self.clip is None:
            return np.ones(4, bool)
        index = frame - self.clip_start
        return np.asarray(self.clip.contacts[int(np.clip(index, 0, len(self.clip.contacts) - 1))], bool)

    def update(self, frame: int, root_position: np.ndarray, root_orientation: np.ndarray) -> AlignedClip | None:
        """At a stride end, choose and align the next clip from the body's root pose; else None."""
        self.frame = frame
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


def motion_graph(library: dict | None = None, blend_frames: int | None = None) -> MotionGraph:
    """
    Return the motion graph over `library` (default: the shipped clip library).

    blending `blend_frames` frames at each transition (default: the planner's declared `blend_frames` parameter).
    """
    if library is None:
        from iguana_ros.motion.clips import load_clip_library
        library = load_clip_library()
    if blend_frames is None:
        blend_frames = node_parameters('planner_node')['blend_frames'].default
    return MotionGraph(library, blend_frames=blend_frames)


def planner_stage(scene: Scene, library: dict | None = None, blend_frames: int | None = None,
                  goal_radius: float = 0.0) -> PlannerStage:
    """
    Return the planner of `scene`.

    Its motion graph (`motion_graph`) and the scene's goal radius unless `goal_radius` (m) > 0. The scene's goals are
    not scheduled here: the library loop schedules them, a node receives them.
    """
    return PlannerStage(motion_graph(library, blend_frames), PolicyParams(goal_radius=goal_radius or scene.goal_radius))


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

    def load_kernels(self) -> None:
        """Adapt the rest pose once on a scratch warm start: a process's first frame then loads no compiled code."""
        kept, self.state = self.state, AdaptationState()
        try:
            self.reference_pose(*self.skeleton.rest_pose())
        finally:
            self.state = kept


def adaptation_stage(scene: Scene, enabled: bool | None = None, skeleton=None,
                     terrain: HeightField | None = None) -> AdaptationStage:
    """
    Return the terrain adaptation of `scene` (on as the scene says unless `enabled` is given; never on flat ground).

    for `skeleton` (default the iguana's); the terrain is built only when adaptation runs (or taken from `terrain`).
    """
    needed = (scene if enabled is None else dataclasses.replace(scene, adaptation=bool(enabled))).needs_adaptation
    if not needed:
        terrain = HeightField.flat()
    elif terrain is None:
        terrain = scene_terrain(scene)
    return AdaptationStage(iguana_skeleton() if skeleton is None else skeleton, terrain, enabled=needed)


# ------------------------------------------------------------------------------------- stride lookahead

@dataclasses.dataclass(frozen=True)
class ReferenceFrame:
    """
    One frame's controller output.

    Adapted joint positions `(n_bones, 3)` m, bone rotations `(n_bones, 4)` xyzw, and desired spring lengths
    `(n_springs,)` m (None when no spring stage was given).
    """

    joints: np.ndarray
    rotations: np.ndarray
    lengths: np.ndarray | None


class StrideLookahead:
    """
    The reference frames of a placed clip's stride.

    computed in frame order, the first by the caller and the rest on one worker thread while the simulator steps (its
    kernel releases the GIL), so the two cores work at once.

    A frame's adapted pose depends only on the clip and the adaptation's warm start from the frame before, never
    on the simulated body, so computing a stride ahead gives the same numbers in the same order as computing each
    frame on demand. A stride's frames are `start … start + len(clip) − 2`: its last pose is the next clip's first.
    """

    def __init__(self, adaptation: AdaptationStage, springs=None, threaded: bool = True) -> None:
        """
        Look ahead with `adaptation`.

        (and `springs`, a SpringLengthComputer) on a worker thread unless `threaded` is False (then each frame is
        computed when asked for).
        """
        self.adaptation = adaptation
        self.springs = springs
        self._executor = ThreadPoolExecutor(1, thread_name_prefix='lookahead') if threaded else None
        self._clip: AlignedClip | None = None
        self._start = 0
        self._pending: dict[int, Future] = {}

    def compute(self, clip: AlignedClip, index: int) -> ReferenceFrame:
        """Return the reference frame of pose `index` of `clip` (advances the adaptation's warm start)."""
        joints, rotations = self.adaptation.reference_pose(*clip_pose(clip, index))
        lengths = None if self.springs is None else self.springs.lengths_from_bones(rotations, joints)
        return ReferenceFrame(joints, rotations, lengths)

    def load_kernels(self) -> None:
        """Load the compiled kernels of the adaptation and the spring lengths (see `AdaptationStage.load_kernels`)."""
        self.adaptation.load_kernels()
        if self.springs is not None:
            self.springs.load_kernels()

    def start(self, clip: AlignedClip, start: int, on_ready: Callable[[], None] | None = None) -> None:
        """
        Begin the stride of `clip` placed at frame `start` (frames of an earlier stride not taken are dropped).

        The stride's first frame is computed here, on the calling thread (the simulator waits for it at a stride end;
        a hand-over to the worker and back cost a node ~6 ms), the others on the worker. `on_ready` (optional) is
        called on the worker thread each time one of those is computed.
        """
        self._drop_pending()
        self._clip, self._start = clip, int(start)
        if self._executor is None:
            return
        first = Future()                             # the caller waits for it: no hand-over to the worker and back
        try:
            first.set_result(self.compute(clip, 0))
        except Exception as exc:                     # raised again by `take`, as a worker's failure would be
            first.set_exception(exc)
        self._pending[self._start] = first
        for frame in self.frames[1:]:
            self._pending[frame] = self._executor.submit(self.compute, clip, frame - self._start)
            if on_ready is not None:
                self._pending[frame].add_done_callback(lambda _future: on_ready())

    def _drop_pending(self) -> None:
        """Cancel the frames not yet started and wait for the one the worker is computing (the warm start is shared)."""
        for future in self._pending.values():
            if not future.cancel():
                wait([future])
        self._pending.clear()

    @property
    def frames(self) -> range:
        """Return the frames of the current stride (`start … start + len(clip) − 2`; empty before any clip)."""
        if self._clip is None:
            return range(0)
        return range(self._start, self._start + max(len(self._clip.root_positions) - 1, 1))

    def ready(self, frame: int) -> bool:
        """Whether `frame` of the current stride can be taken without waiting (computed, or computed on demand)."""
        if frame not in self.frames:
            return False
        future = self._pending.get(frame)
        return self._executor is None or (future is not None and future.done() and not future.cancelled())

    def take(self, frame: int) -> ReferenceFrame:
        """
        Return the reference frame of `frame` of the current stride (waiting for the worker if it is not done).

        A frame taken already, or not yet started, is computed on the worker too, so the adaptation calls run one at a
        time, in the order asked.
        """
        future = self._pending.pop(frame, None)
        if future is not None:
            return future.result()
        if self._executor is None:
            return self.compute(self._clip, frame - self._start)
        return self._executor.submit(self.compute, self._clip, frame - self._start).result()

    def close(self) -> None:
        """Stop the worker thread (frames not yet computed are dropped)."""
        if self._executor is not None:
            self._executor.shutdown(wait=True, cancel_futures=True)


# ----------------------------------------------------------------------------------------- spring lengths

def spring_stage(scene: Scene, model=None) -> SpringLengthComputer:
    """Desired spring lengths of reference poses on `scene`'s model (or `model`): Section VII's skinning."""
    return SpringLengthComputer(scene_model(scene) if model is None else model)


# ----------------------------------------------------------------------------------------------- pushes

def push_forces(model, pushes: tuple, time: float) -> np.ndarray | None:
    """
    External forces `(n_nodes, 3)` N of the pushes active at `time` (None when none is active).

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


# -------------------------------------------------------------------------------------------- simulator

class SimulatorStage:
    """Section V: the soft body, placed at the scene's start pose on the terrain, advanced frame by frame."""

    def __init__(self, model, terrain: HeightField, fidelity: str, pushes: tuple = (),
                 start_xy: tuple = (0.0, 0.0), start_yaw: float = 0.0, options: dict | None = None) -> None:
        """
        Build the simulator for `model` on `terrain`.

        pushes are applied by simulated time. `options` are SoftBodySimulator keywords (fidelity fields such as `dt`,
        `friction`), none by default.
        """
        self.model = model
        self.terrain = terrain
        self.pushes = tuple(pushes)
        self.sim = SoftBodySimulator(model, terrain, fidelity, **(options or {}))
        self.sim.reset(positions=place_on_terrain(model.rest_positions, terrain, xy=start_xy, yaw=start_yaw,
                                                  lift_only=True))
        self.tracker = RootTracker(model)
        self._root, self._root_revision = None, -1
        self.frame = 0

    @property
    def time(self) -> float:
        """Return simulated time at the current frame, s."""
        return self.frame / FRAME_RATE

    def root_pose(self) -> tuple:
        """(root position (3,), orientation xyzw (4,)) of the body now (fitted once per state of the body)."""
        if self._root_revision != self.sim.revision:
            self._root = self.tracker.root_pose(self.sim.positions)
            self._root_revision = self.sim.revision
        return self._root[0].copy(), self._root[1].copy()

    def root_twist(self) -> tuple:
        """(linear (3,) m/s, angular (3,) rad/s) velocity of the body's root region now."""
        return self.tracker.root_twist(self.sim.positions, self.sim.velocities)

    def load_kernels(self) -> None:
        """Load the simulator's compiled step loop without stepping (`SoftBodySimulator.load_kernels`)."""
        self.sim.load_kernels()

    def advance(self, desired_lengths: np.ndarray | None, extra_forces: np.ndarray | None = None) -> None:
        """
        Advance one frame (1/30 s) with desired spring lengths `(n_springs,)` (None = rest lengths).

        the scene's active pushes and optional extra forces `(n_nodes, 3)` N.
        """
        forces = push_forces(self.model, self.pushes, self.time) if self.pushes else None
        if extra_forces is not None:
            forces = extra_forces if forces is None else forces + extra_forces
        self.sim.advance_frame(desired_lengths, forces)
        self.frame += 1


def simulator_stage(scene: Scene, fidelity: str | None = None, model=None,
                    terrain: HeightField | None = None, options: dict | None = None) -> SimulatorStage:
    """
    Return the simulator of `scene`.

    Its model (or `model`) on its terrain (or `terrain`) at its fidelity (unless `fidelity` names a preset), placed at
    its start pose, with its pushes and the SoftBodySimulator `options`.
    """
    return SimulatorStage(scene_model(scene) if model is None else model,
                          scene_terrain(scene) if terrain is None else terrain,
                          scene.fidelity if fidelity is None else fidelity,
                          scene.pushes if scene.needs_pushes else (),
                          (scene.start.x, scene.start.y), np.radians(scene.start.yaw_deg), options)
