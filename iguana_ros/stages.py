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

from collections import deque
from concurrent.futures import Future, ThreadPoolExecutor, wait
import dataclasses
import time
from typing import Callable, Sequence

import numpy as np

from iguana_ros.body.model import build_model
from iguana_ros.body.root_tracking import RootTracker
from iguana_ros.body.skeleton import iguana_skeleton
from iguana_ros.body.spring_lengths import SpringLengthComputer
from iguana_ros.constants import FRAME_RATE, MAX_SCHEDULE_AHEAD
from iguana_ros.errors import InputError
from iguana_ros.geometry import wrap_angle, yaw_of
from iguana_ros.metrics import ProgressWindow, remaining_way
from iguana_ros.motion.clips import ANY_GAIT
from iguana_ros.motion.motion_graph import AlignedClip, IDLE_CLIP, MotionGraph
from iguana_ros.motion.planning import (clip_table, MotionPlanner, MovingObstacles, rest_steps, STAND, STANDING_SPEED,
                                        Target)
from iguana_ros.motion.tracking import LibraryTracking, load_tracking
from iguana_ros.parameters import node_parameters
from iguana_ros.physics.body_watch import BodyLoss, BodyWatch
from iguana_ros.physics.pushes import push_active, region_force, region_masses
from iguana_ros.physics.simulator import SoftBodySimulator
from iguana_ros.scene import PushSpec, Scene
from iguana_ros.scene import terrain_from_spec
from iguana_ros.terrain.adaptation import adapt_pose, AdaptationState, pose_kinematics, residual_heights_of
from iguana_ros.terrain.heightfield import HeightField
from iguana_ros.terrain.placement import place_on_terrain
from iguana_ros.validation import check_push, check_scene_pushes

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
    Return whether a clip of `clip_points` poses started at frame `clip_start` is used up at `frame`.

    Its last pose is the next clip's first: a new clip is chosen there.
    """
    return frame >= clip_start + clip_points - 1


@dataclasses.dataclass(frozen=True)
class PlannerEvent:
    """Something the planner noticed at `frame`: `kind` (one of PLANNER_EVENTS) and a one-line `detail`."""

    frame: int
    kind: str
    detail: str


PLANNER_EVENTS = ('waypoint', 'arrived', 'stuck', 'circling', 'recovered')
"""The planner's event kinds: a route's waypoint passed, the last target reached, no progress (turning or not) and the
recovery strategy taken, progress again."""


@dataclasses.dataclass(frozen=True)
class RecoveryParams:
    """When the planner counts as stuck and what it does then (see `PlannerStage`)."""

    window: int = 8
    """Strides over which the distance to the target must shrink."""
    progress: float = 0.08
    """Least shrinking over `window` strides of the least remaining way to the target (`metrics.remaining_way`)."""
    detour_distance: float = 0.5
    """Distance (m) of a detour waypoint from the body."""
    detour_angle: float = np.radians(70.0)
    """Angle (rad) of a detour waypoint from the bearing to the target, alternating sides."""


@dataclasses.dataclass(frozen=True)
class PlannerStatus:
    """
    Where the planner is.

    `state` ('idle', 'walking', 'recovering', 'arrived'), the current target's index and the number of targets, its
    distance (m) and the heading error (rad, 0 if none is asked), the recovery level.
    """

    state: str
    waypoint: int
    waypoints: int
    distance: float
    heading_error: float
    recovery: int


WAY_ROUND_RADIUS = 0.25
"""Radius (m) within which the way round a standing body counts as passed."""


class PlannerStage:
    """
    Section IV: at each stride end, the next clip toward the goal or along the route, aligned to the body.

    A goal is one target, a route a list of them passed in order (`motion.planning.Target`); the clip is the first of
    the best sequence of the motion-graph search (`MotionPlanner`) from the body's planar pose, whose clip motions are
    corrected online from every stride played. Every frame checks whether the current waypoint is passed or the goal
    reached (a heading goal: at rest, facing it within the tolerance); once there the body comes to rest. Every stride
    end checks progress: if the least remaining way to the target (distance and bearing, `metrics.remaining_way`) has
    not shrunk by `RecoveryParams.progress` over `window` strides, that is 'stuck' (or 'circling' if the body turned a
    full turn meanwhile), reported as an event, and answered by a recovery: first a detour waypoint to one side, then
    the slow walk with its turns on the spot only, then detours to either side in turn; progress again ends it
    ('recovered').
    """

    def __init__(self, graph: MotionGraph, planner: MotionPlanner, goal_radius: float = 0.15,
                 yaw_tolerance: float = np.inf, recovery: RecoveryParams = RecoveryParams()) -> None:
        """Plan over `graph` with the search `planner`; reach goals within `goal_radius` m and `yaw_tolerance` rad."""
        self.graph, self.planner, self.recovery_params = graph, planner, recovery
        self.goal_radius, self.yaw_tolerance = float(goal_radius), float(yaw_tolerance)
        self.targets: tuple = ()
        self.waypoint = 0
        self.arrived = False
        self.settled = False
        self.clip: AlignedClip | None = None
        self.clip_start = 0
        self.frame = -1
        self.history: list[tuple[int, str]] = []
        self.events: list[PlannerEvent] = []
        self.plan_seconds: list[float] = []
        self._scheduled: list[tuple[float, int, tuple]] = []
        self._routes = 0                              # goals and routes scheduled so far: the next one's number
        self.route_number = -1                        # the number of the goal or route adopted last (-1: none)
        self._stride_start: np.ndarray | None = None
        self._early: tuple | None = None
        self._progress = ProgressWindow(recovery.window, recovery.progress)
        self._headings: deque = deque(maxlen=recovery.window + 1)
        self.recovery = 0
        self._stuck_at = np.inf
        self._detour: tuple = ()
        self._rest = rest_steps(planner.table)
        self.obstacles: MovingObstacles | None = None
        """Other bodies the search keeps clear of (the world's other characters, updated each frame)."""

    # ----------------------------------------------------------------------------------------- goals, routes
    def target(self, x: float, y: float, yaw: float | None = None, final: bool = True, radius: float = 0.0,
               yaw_tolerance: float = 0.0) -> Target:
        """Return a Target at (x, y) m, heading `yaw` rad (None: any), within `radius` m and `yaw_tolerance` rad."""
        return Target((float(x), float(y)), None if yaw is None else float(yaw), float(radius or self.goal_radius),
                      float(yaw_tolerance or self.yaw_tolerance), final)

    def set_route(self, targets: tuple) -> None:
        """Follow `targets` (Target, the last final) from the next stride on; () = stop."""
        self.targets, self.waypoint, self.arrived, self.settled = tuple(targets), 0, False, False
        self.recovery, self._detour = 0, ()
        self._restart_progress()

    def set_goal(self, goal_xy: np.ndarray | None, yaw: float | None = None) -> None:
        """Walk to `goal_xy (2,)` (world x, y), facing `yaw` rad if given, from the next stride on; None = stop."""
        self.set_route(() if goal_xy is None else (self.target(goal_xy[0], goal_xy[1], yaw),))

    def route_targets(self, waypoints: list) -> tuple:
        """Targets of a route of (x, y, yaw or None) waypoints: passed in order, the last one reached."""
        last = len(waypoints) - 1
        return tuple(self.target(x, y, yaw if i == last else None, final=i == last)
                     for i, (x, y, yaw) in enumerate(waypoints))

    def schedule_route(self, targets: tuple, at: float = 0.0) -> None:
        """Make `targets` the route once simulated time reaches `at` s (0 = at the next frame)."""
        entry = (float(at), self._routes, tuple(targets))
        self._routes += 1
        self._scheduled = sorted(self._scheduled + [entry], key=lambda e: (e[0], e[1]))

    def schedule_goal(self, goal_xy: np.ndarray, at: float = 0.0, yaw: float | None = None) -> None:
        """Make `goal_xy (2,)` (facing `yaw` rad if given) the goal once simulated time reaches `at` s."""
        self.schedule_route((self.target(goal_xy[0], goal_xy[1], yaw),), at)

    def accept_route(self, targets: tuple, at: float) -> float:
        """
        Schedule a received goal or route stamped `at` s.

        A stamp more than MAX_SCHEDULE_AHEAD past the frame planned last is a wall-clock stamp and adopted now (0).
        Returns the adoption time used, s.
        """
        if at > max(self.frame, 0) / FRAME_RATE + MAX_SCHEDULE_AHEAD:
            at = 0.0
        self.schedule_route(targets, at)
        return at

    def accept_goal(self, goal_xy: np.ndarray, at: float, yaw: float | None = None) -> float:
        """Schedule a received goal `(2,)` (heading `yaw` rad or None) stamped `at` s (see `accept_route`)."""
        return self.accept_route((self.target(goal_xy[0], goal_xy[1], yaw),), at)

    def activate_due_goals(self, time: float) -> None:
        """Apply, in time order, every scheduled goal or route due at simulated `time` s."""
        while self._scheduled and self._scheduled[0][0] <= time + 1e-9:
            _, number, targets = self._scheduled.pop(0)
            self.set_route(targets)
            self.route_number = number

    @property
    def last_route(self) -> int:
        """Return the number of the goal or route scheduled last (-1: none yet)."""
        return self._routes - 1

    def route_state(self, number: int) -> str:
        """Return whether goal or route `number` is 'scheduled', 'active' (adopted last) or 'done' (replaced)."""
        if any(entry[1] == number for entry in self._scheduled):
            return 'scheduled'
        return 'active' if number == self.route_number else 'done'

    def drop_route(self, number: int) -> None:
        """Drop goal or route `number`: off the schedule, or if adopted, stop (to rest from the next stride)."""
        self._scheduled = [entry for entry in self._scheduled if entry[1] != number]
        if number == self.route_number and self.targets:
            self.set_route(())

    @property
    def finished(self) -> bool:
        """Whether the body rests at the last target and no other goal or route is scheduled."""
        return self.settled and not self._scheduled

    @property
    def goal(self) -> np.ndarray | None:
        """Return the final target's position `(2,)`, None without one."""
        return np.array(self.targets[-1].xy) if self.targets else None

    # ------------------------------------------------------------------------------------------------ frames
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
        """
        Every frame: follow the route; at a stride end, align the next clip to the body's root pose.

        The next clip is chosen a frame before the stride end, from the pose then (so a node's search is not on the
        lockstep's critical path, where the simulator waits for the new stride's first frame), and chosen again at the
        stride end only if the goal, route, rest or recovery changed meanwhile.
        """
        self.frame = frame
        self.activate_due_goals(frame / FRAME_RATE)
        pose = np.array([root_position[0], root_position[1], float(yaw_of(root_orientation))])
        end = self.stride_ends_at(frame)
        self._follow(frame, pose, end)
        if not end:
            if self.stride_ends_at(frame + 1):
                self._early = (self._situation(), self.choose(pose))
            return None
        if self.clip is not None and self._stride_start is not None:
            self.planner.observe(self.clip.name, self._stride_start, pose)
        self._check_progress(frame, pose)
        early, self._early = self._early, None
        name = early[1] if early is not None and early[0] == self._situation() else self.choose(pose)
        self.clip = self.graph.align(name, root_position[:2], pose[2], previous=self.clip)
        self.clip_start, self._stride_start = frame, pose
        self.history.append((frame, name))
        return self.clip

    def _situation(self) -> tuple:
        """Return what a clip choice depends on besides the pose: targets, waypoint, rest, recovery and detour."""
        return self.targets, self.waypoint, self.settled, self.recovery, self._detour

    def _follow(self, frame: int, pose: np.ndarray, stride_end: bool) -> None:
        """
        Pass the current waypoint, or note the goal reached.

        Within the radius and heading tolerance: 'arrived'; at a stride end that brings the body to rest there: settled.
        """
        if self.settled or not self.targets:
            return
        if self._detour and self._detour[0].distance(pose[:2]) <= self._detour[0].radius:
            self._detour = ()
        current = self.targets[self.waypoint]
        if not current.final:
            if current.distance(pose[:2]) <= current.radius:
                self.waypoint += 1
                self._detour = ()
                self._restart_progress()
                self.events.append(PlannerEvent(frame, 'waypoint', f'waypoint {self.waypoint} of '
                                                                   f'{len(self.targets)} passed'))
            return
        if not current.reached(pose):
            return
        if not self.arrived:
            self.arrived = True
            self.events.append(PlannerEvent(frame, 'arrived', f'goal ({current.xy[0]:.2f}, {current.xy[1]:.2f}) '
                                                              f'reached'))
        resting = self.clip is None or getattr(self.clip.source, 'exit_gait', ANY_GAIT) in (STAND, ANY_GAIT)
        self.settled = stride_end and resting

    def choose(self, pose: np.ndarray) -> str:
        """Name of the clip to play next from planar `pose (3,)` (x, y, yaw)."""
        current = self.clip.name if self.clip is not None else None
        if self.settled or not self.targets:
            return self._toward_rest(current)
        targets = self._detour + self.targets[self.waypoint:]
        if self.obstacles is not None and not self._detour:
            past = self.obstacles.way_round(pose[:2], np.asarray(targets[0].xy), self.planner.params)
            if past is not None:
                targets = (self.target(past[0], past[1], final=False, radius=WAY_ROUND_RADIUS),) + tuple(targets)
        start = time.perf_counter()
        plan = self.planner.plan(pose, current, list(targets), self._allowed(), self.obstacles)
        self.plan_seconds.append(time.perf_counter() - start)
        return plan.first if plan.clips else self._toward_rest(current)

    def _toward_rest(self, current: str | None) -> str:
        """Return the next clip of the quickest way to rest (the idle clip, or the first clip of a library without)."""
        step = self._rest[self.planner.table.index(current)]
        if step >= 0:
            return self.planner.table.names[step]
        return IDLE_CLIP if IDLE_CLIP in self.graph.clips else self.graph.names[0]

    # ------------------------------------------------------------------------------------ progress, recovery
    def _check_progress(self, frame: int, pose: np.ndarray) -> None:
        """Record the remaining way to the target at this stride end; recover when it stopped shrinking."""
        if self.settled or not self.targets:
            return
        target = self.targets[self.waypoint]          # a detour is a means: progress is toward the target
        goal_yaw = target.yaw if target.wants_heading else None
        remaining = float(remaining_way(pose[:2], pose[2], target.xy, target.radius, goal_yaw)[0])
        self._headings.append(pose[2])
        if not self._progress.add(remaining):
            if self.recovery and min(self._progress.recent) < self._stuck_at - self.recovery_params.progress:
                self.events.append(PlannerEvent(frame, 'recovered', f'progress again at recovery level '
                                                                    f'{self.recovery}'))
                self.recovery, self._detour = 0, ()
            return
        turned = abs(float(np.sum(wrap_angle(np.diff(list(self._headings))))))
        self._recover(frame, pose, target, 'circling' if turned >= 2.0 * np.pi else 'stuck')

    def _restart_progress(self, *seen: float) -> None:
        """Measure progress afresh (a new target), from the remaining ways `seen` (the last stride end's, if any)."""
        self._progress = ProgressWindow(self.recovery_params.window, self.recovery_params.progress)
        for measure in seen:
            self._progress.add(measure)
        self._headings = deque(list(self._headings)[-1:] if seen else [], maxlen=self.recovery_params.window + 1)

    def _recover(self, frame: int, pose: np.ndarray, target: Target, kind: str) -> None:
        """Take the next recovery strategy and report it; progress is then measured afresh."""
        self.recovery += 1
        self._stuck_at = self._progress.least
        self._restart_progress(self._progress.recent[-1])
        if self.recovery == 2:
            strategy = 'slow walk and turns on the spot'
        else:
            side = 1.0 if self.recovery % 2 == 0 else -1.0
            bearing = (np.arctan2(target.xy[1] - pose[1], target.xy[0] - pose[0])
                       + side * self.recovery_params.detour_angle)
            d = self.recovery_params.detour_distance
            self._detour = (self.target(pose[0] + d * np.cos(bearing), pose[1] + d * np.sin(bearing), final=False),)
            strategy = f'detour by ({self._detour[0].xy[0]:.2f}, {self._detour[0].xy[1]:.2f})'
        self.events.append(PlannerEvent(frame, kind, f'no progress toward ({target.xy[0]:.2f}, {target.xy[1]:.2f}) '
                                                     f'in {self.recovery_params.window} strides; {strategy}'))

    def _allowed(self) -> np.ndarray | None:
        """Return the clips the search may use: all, or at recovery level 2 the slow walk's and the ways down to it."""
        if self.recovery != 2:
            return None
        table = self.planner.table
        slow = [table.gaits.names.index(g) for g in (STAND, 'walk', ANY_GAIT) if g in table.gaits.names]
        return np.isin(table.exit_gait, slow) | ~np.isin(table.entry_gait, slow)

    def load_kernels(self) -> None:
        """Load the search's compiled terrain lookups now, not at the first stride end (`MotionPlanner`)."""
        self.planner.load_kernels()

    def status(self) -> PlannerStatus:
        """Return where the planner is (see PlannerStatus), from the last stride end's pose."""
        if not self.targets:
            return PlannerStatus('idle', 0, 0, float('nan'), 0.0, 0)
        pose = self._stride_start if self._stride_start is not None else np.zeros(3)
        target = self.targets[min(self.waypoint, len(self.targets) - 1)]
        state = 'arrived' if self.settled else 'recovering' if self.recovery else 'walking'
        return PlannerStatus(state, self.waypoint, len(self.targets), target.distance(pose[:2]),
                             target.heading_error(pose[2]), self.recovery)


class OtherBodies:
    """
    The other characters' roots by frame, as a planner of a world hears them: its moving obstacles of each frame.

    A world's planners see the others as they are at the start of the frame they plan (`world.World.show_others`); a
    planner node hears each other body's state on its own topic, in any order, so it keeps them by frame until its own
    state of that frame has everyone's (`ready`). A body whose root travelled less than STANDING_SPEED on average over
    the last `window` frames (`PlannerParams.obstacle_velocity_window`) stands (velocity 0: its sway while pivoting on
    the spot is no motion to extrapolate); the others move at their root's velocity.
    """

    def __init__(self, names: Sequence[str], window: int) -> None:
        """Expect the bodies `names`, in the world's order (the obstacles keep it); velocities over `window` frames."""
        self.names = tuple(names)
        self.window = max(1, int(window))
        self.by_frame: dict[int, dict[str, tuple]] = {}

    def add(self, name: str, frame: int, xy: np.ndarray, velocity: np.ndarray) -> None:
        """Keep body `name`'s planar root `(2,)` m and velocity `(2,)` m/s at the start of `frame` (the first heard)."""
        self.by_frame.setdefault(frame, {}).setdefault(name, (np.asarray(xy, float), np.asarray(velocity, float)))

    def ready(self, frame: int) -> bool:
        """Whether every other body's root of `frame` is in."""
        return all(n in self.by_frame.get(frame, {}) for n in self.names)

    def missing(self, frame: int) -> list[str]:
        """Return the bodies whose root of `frame` has not come."""
        return [n for n in self.names if n not in self.by_frame.get(frame, {})]

    def obstacles(self, frame: int, names: Sequence[str] | None = None) -> MovingObstacles:
        """
        Return bodies `names` (default all) at `frame` (once `ready`) as moving obstacles at their root velocities.

        A body that went nowhere over the window stands (velocity 0); frames older than the window are forgotten.
        """
        now, since = self.by_frame.get(frame, {}), max(0, frame - self.window)
        before = self.by_frame.get(since, {})
        for old in [f for f in self.by_frame if f < since]:
            del self.by_frame[old]
        names = self.names if names is None else names
        xy = np.array([now[n][0] for n in names]).reshape(-1, 2)
        velocity = np.array([now[n][1] for n in names]).reshape(-1, 2)
        travel = np.array([np.hypot(*(now[n][0] - before[n][0])) * (FRAME_RATE / (frame - since))
                           if frame > since and n in before else np.inf for n in names])
        velocity[travel < STANDING_SPEED] = 0.0       # going nowhere (pivoting, swaying): it stands
        return MovingObstacles(xy, velocity)


def motion_graph(library: dict | None = None, blend_frames: int | None = None) -> MotionGraph:
    """
    Return the motion graph over `library` (default: the shipped clip library).

    It blends `blend_frames` frames at each transition (default: the planner's declared `blend_frames` parameter).
    """
    if library is None:
        from iguana_ros.motion.clips import load_clip_library
        library = load_clip_library()
    if blend_frames is None:
        blend_frames = node_parameters('planner_node')['blend_frames'].default
    return MotionGraph(library, blend_frames=blend_frames)


def planner_stage(scene: Scene, library: dict | None = None, blend_frames: int | None = None,
                  goal_radius: float = 0.0, yaw_tolerance: float = 0.0, terrain: HeightField | None = None,
                  tracking: dict | None = None) -> PlannerStage:
    """
    Return the planner of `scene`.

    Its motion graph (`motion_graph`), a search over it on the scene's terrain (or `terrain`) with the library's
    tracking figures (a LibraryTracking; default: the shipped ones of the scene's fidelity preset, none for another
    library), and the scene's goal radius and yaw
    tolerance unless `goal_radius` (m) or `yaw_tolerance` (rad) > 0. The scene's goals and route are not scheduled
    here: the library loop schedules them, a node receives them.
    """
    graph = motion_graph(library, blend_frames)
    if tracking is None:
        tracking = load_tracking(fidelity=scene.fidelity) if library is None else LibraryTracking({})
    planner = MotionPlanner(clip_table(graph.clips, tracking.clips, tracking.carry),
                            scene_terrain(scene) if terrain is None else terrain)
    return PlannerStage(graph, planner, goal_radius or scene.goal_radius,
                        yaw_tolerance or np.radians(scene.goal_yaw_tolerance_deg))


# -------------------------------------------------------------------------------------------- goal tasks

GOAL_OUTCOMES = ('succeeded', 'refused', 'canceled', 'replaced', 'no_progress', 'planner_stopped')
"""How a goal with an answer (`GoalTask`) ends; the GoToPose action's result codes are these names in upper case."""

GIVE_UP_RECOVERY = 4
"""Recovery level at which a goal task ends with 'no_progress' (`PlannerStage`: each level is a window of strides
without progress; a level-4 task has tried a detour to either side and the slow walk)."""


@dataclasses.dataclass(frozen=True)
class GoalProgress:
    """How a goal task goes: distance m of the root to the goal, simulated s since it was sent, strides, status."""

    distance: float
    time_elapsed: float
    strides: int
    status: str


@dataclasses.dataclass(frozen=True)
class GoalOutcome:
    """How a goal task ended: `kind` (one of GOAL_OUTCOMES), a one-line `reason`, distance m and simulated s."""

    kind: str
    reason: str
    distance: float = 0.0
    time_elapsed: float = 0.0

    @property
    def reached(self) -> bool:
        """Whether the goal was reached."""
        return self.kind == 'succeeded'


def refused_goal(reason: str) -> GoalOutcome:
    """Return the outcome of a goal refused before it started (its validation's `reason`)."""
    return GoalOutcome('refused', reason)


class GoalTask:
    """
    One goal given to a `PlannerStage` with an answer (the GoToPose action): its progress and how it ends.

    Scheduled like a goal_pose goal (tolerances 0 = the planner's). It ends 'succeeded' once the planner rests at it,
    'replaced' once a newer goal or route is adopted, 'no_progress' (and the planner drops it) at recovery level
    GIVE_UP_RECOVERY, 'canceled' by `cancel` (the planner drops it: the body comes to rest from the next stride).
    """

    def __init__(self, stage: PlannerStage, xy: Sequence, at: float, yaw: float | None = None,
                 radius: float = 0.0, yaw_tolerance: float = 0.0) -> None:
        """Schedule a goal at `xy` (2,) m stamped `at` s, heading `yaw` rad (None: any), on `stage`."""
        self.stage = stage
        self.target = stage.target(xy[0], xy[1], yaw, radius=radius, yaw_tolerance=yaw_tolerance)
        self.at = stage.accept_route((self.target,), at)
        self.number = stage.last_route
        self.start_time = max(stage.frame, 0) / FRAME_RATE
        self.start_strides = len(stage.history)
        self.outcome: GoalOutcome | None = None

    def elapsed(self) -> float:
        """Return simulated seconds since the goal was sent (to the planner's last frame)."""
        return max(self.stage.frame, 0) / FRAME_RATE - self.start_time

    def progress(self, root_xy: Sequence) -> GoalProgress:
        """Return the task's progress with the root at `root_xy` (2,) m."""
        state = self.stage.route_state(self.number)
        if state == 'scheduled':
            status = f'scheduled for t={self.at:.2f} s'
        else:
            planner = self.stage.status()
            status = planner.state if not planner.recovery else f'recovering (level {planner.recovery})'
        return GoalProgress(self.target.distance(root_xy), self.elapsed(), len(self.stage.history) - self.start_strides,
                            status)

    def update(self, root_xy: Sequence) -> GoalOutcome | None:
        """Return how the task ended (decided once, from the planner's state), None while it goes on."""
        if self.outcome is None:
            state = self.stage.route_state(self.number)
            if state == 'done':
                self._end('replaced', 'replaced by a newer goal or route', root_xy)
            elif state == 'active' and self.stage.settled:
                self._end('succeeded', f'goal ({self.target.xy[0]:.2f}, {self.target.xy[1]:.2f}) reached', root_xy)
            elif state == 'active' and self.stage.recovery >= GIVE_UP_RECOVERY:
                self.stage.drop_route(self.number)
                self._end('no_progress', f'no progress after {self.stage.recovery_params.window * GIVE_UP_RECOVERY} '
                                         f'strides of recovery; the planner dropped the goal and rests', root_xy)
        return self.outcome

    def cancel(self, root_xy: Sequence) -> GoalOutcome:
        """Cancel the task unless it has ended: the planner drops the goal and comes to rest; return the outcome."""
        if self.update(root_xy) is None:
            self.stage.drop_route(self.number)
            self._end('canceled', 'cancelled on request; the planner dropped the goal and rests', root_xy)
        return self.outcome

    def _end(self, kind: str, reason: str, root_xy: Sequence) -> None:
        """Note the outcome."""
        self.outcome = GoalOutcome(kind, reason, self.target.distance(root_xy), self.elapsed())


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

    It is for `skeleton` (default the iguana's); the terrain is built only when adaptation runs (or taken from
    `terrain`).
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
    The reference frames of a placed clip's stride, computed in frame order.

    The first is computed by the caller and the rest on one worker thread while the simulator steps (its kernel releases
    the GIL), so the two cores work at once.

    A frame's adapted pose depends only on the clip and the adaptation's warm start from the frame before, never
    on the simulated body, so computing a stride ahead gives the same numbers in the same order as computing each
    frame on demand. A stride's frames are `start … start + len(clip) − 2`: its last pose is the next clip's first.
    """

    def __init__(self, adaptation: AdaptationStage, springs=None, threaded: bool = True) -> None:
        """
        Look ahead with `adaptation` (and `springs`, a SpringLengthComputer) on a worker thread.

        With `threaded` False each frame is computed when asked for instead.
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

def push_forces(model, pushes: Sequence, time: float) -> np.ndarray | None:
    """
    External forces `(n_nodes, 3)` N of the pushes active at `time` (None when none is active).

    Each push's force is spread over its region's nodes in proportion to their mass (total = the force).
    """
    active = [p for p in pushes if push_active(p.at, p.duration, time)]
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

        Pushes are applied by simulated time. `options` are SoftBodySimulator keywords (fidelity fields such as `dt`,
        `friction`), none by default.
        """
        self.model = model
        self.terrain = terrain
        self.region_masses = region_masses(model.node_mass, model.node_tags)
        check_scene_pushes(pushes, self.region_masses)
        self.pushes = tuple(pushes)
        self.live_pushes: list[PushSpec] = []
        self.watch = BodyWatch(terrain)
        self.sim = SoftBodySimulator(model, terrain, fidelity, **(options or {}))
        self.start_positions = place_on_terrain(model.rest_positions, terrain, xy=start_xy, yaw=start_yaw,
                                                lift_only=True)
        self.sim.reset(positions=self.start_positions)
        self.tracker = RootTracker(model)
        self._root, self._root_revision = None, -1
        self.frame = 0
        self.resets = 0

    def close(self) -> None:
        """Stop the simulator's factor thread, if it has one."""
        self.sim.close()

    def reset(self) -> None:
        """
        Put the body back at the scene's start pose, at rest, with no push acting (the simulator's reset service).

        The frame count and simulated time go on, so clocks and bags stay monotonic; the scene's pushes still to
        come are kept. The simulator then behaves as at frame 0: the first lengths ramp from rest.
        """
        self.sim.reset(positions=self.start_positions)
        self.live_pushes = []
        self.pushes = tuple(p for p in self.pushes if p.at >= self.time)
        self.watch = BodyWatch(self.terrain)
        self.resets += 1

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

    def add_push(self, force: np.ndarray, region: str, duration: float, torque: np.ndarray | None = None) -> PushSpec:
        """
        Push `region` with `force (3,)` N for `duration` s from the next frame (a push topic's message).

        InputError (and no push) when `validation.check_push` refuses it (a `torque (3,)` too) beside the pushes
        still acting.
        """
        self.live_pushes = [p for p in self.live_pushes if p.at + p.duration > self.time]
        acting = [p for p in self.live_pushes + list(self.pushes) if push_active(p.at, p.duration, self.time)]
        force = check_push(force, np.zeros(3) if torque is None else torque, region, self.region_masses, self.time,
                           duration, acting)
        push = PushSpec(at=self.time, force=tuple(force.tolist()), duration=float(duration), region=region)
        self.live_pushes.append(push)
        return push

    def advance(self, desired_lengths: np.ndarray | None) -> None:
        """
        Advance one frame (1/30 s) with desired spring lengths `(n_springs,)` (None = rest lengths).

        The scene's and the live pushes acting now are applied. Raises SimulationDiverged; `lost` says once the body
        left the terrain or fell (`physics.body_watch`), and a run ends there.
        """
        self.sim.advance_frame(desired_lengths, self.frame_forces())
        self.end_frame()

    def frame_forces(self) -> np.ndarray | None:
        """Return the pushes acting in this frame as node forces `(n_nodes, 3)` N (None: none)."""
        pushes = (*self.pushes, *self.live_pushes)
        return push_forces(self.model, pushes, self.time) if pushes else None

    def end_frame(self) -> None:
        """Count the frame the simulator has just advanced and watch the body (`advance`; the world's blocks)."""
        self.frame += 1
        root, orientation = self.root_pose()
        self.watch.check(root, orientation, self.time)

    @property
    def lost(self) -> BodyLoss | None:
        """Return the body's loss once it left the terrain or fell; None while it is on the terrain and upright."""
        return self.watch.lost


@dataclasses.dataclass
class SimControl:
    """
    Pause, resume and step of a frame loop (the simulator's services): whether the next frame may be simulated.

    `step_until` is the frame at which a step pauses again (None: no step running).
    """

    paused: bool = False
    step_until: int | None = None

    def may_advance(self, frame: int) -> bool:
        """Return whether frame `frame` may be simulated now."""
        return not self.paused or (self.step_until is not None and frame < self.step_until)

    def pause(self) -> None:
        """Hold at the current frame (a running step stops too)."""
        self.paused, self.step_until = True, None

    def resume(self) -> None:
        """Advance again."""
        self.paused, self.step_until = False, None

    def step(self, frame: int, frames: int) -> int:
        """Advance `frames` frames from frame `frame`, then hold; return the frame the step ends at."""
        if frames < 1:
            raise InputError(f'a step needs at least 1 frame, got {frames}')
        self.paused, self.step_until = True, frame + frames
        return self.step_until

    def step_done(self, frame: int) -> bool:
        """Return whether the running step has reached frame `frame` (it ends there; the loop holds)."""
        if self.step_until is None or frame < self.step_until:
            return False
        self.step_until = None
        return True


def simulator_stage(scene: Scene, fidelity: str | None = None, model=None,
                    terrain: HeightField | None = None, options: dict | None = None) -> SimulatorStage:
    """
    Return the simulator of `scene`.

    Its model (or `model`) on its terrain (or `terrain`) at its fidelity (unless `fidelity` names a preset), placed at
    its start pose, with its pushes and the SoftBodySimulator `options`.
    """
    try:
        return SimulatorStage(scene_model(scene) if model is None else model,
                              scene_terrain(scene) if terrain is None else terrain,
                              scene.fidelity if fidelity is None else fidelity,
                              scene.pushes if scene.needs_pushes else (),
                              (scene.start.x, scene.start.y), np.radians(scene.start.yaw_deg), options)
    except InputError as exc:                      # a push too strong for this body: name the scene
        raise InputError(f'scene {scene.name}: {exc}') from None


def check_pushes_of(scene: Scene, model=None) -> None:
    """Check the scene's pushes against its model's (or `model`'s) masses; InputError naming the scene and push."""
    if not scene.pushes:
        return
    model = scene_model(scene) if model is None else model
    try:
        check_scene_pushes(scene.pushes, region_masses(model.node_mass, model.node_tags))
    except InputError as exc:
        raise InputError(f'scene {scene.name}: {exc}') from None
