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
Planner node (Section IV).

Its inputs are goal_pose, route and iguana_state; its outputs are one motion_clip per stride and the clip's stance flags
per frame (reference_stance), the goals and route waypoints it accepted on accepted_goals (latched, for their senders),
where it is on planner_status (latched: state, waypoint, distance, heading error, recovery) and what it noticed
(waypoints passed, arrival, no progress and the recovery taken) on run_events.

The planner of one character of a world (a scene's `characters`, the node in that character's namespace) also hears
the other characters' iguana_state (sibling namespaces) and plans the strides of a frame once it has every body's state
of that frame, keeping clear of them as moving obstacles (`stages.OtherBodies`, as `world.World` does).

Goals with an answer come through the go_to_pose action (GoToPose): every goal is accepted, then checked like a
goal_pose message; a bad one is aborted at once with code REFUSED and the reason, a good one scheduled like a goal_pose
goal (listed on accepted_goals too) as a `stages.GoalTask`, with feedback at every stride end and a result when the
task ends (reached, replaced by a newer goal or route, no progress, or cancelled: the iguana then comes to rest).
"""
from __future__ import annotations

from typing import Callable, NamedTuple

from nav_msgs.msg import Path
import numpy as np
from rclpy.action import ActionServer, CancelResponse
from rclpy.clock import Clock, ClockType

from iguana_ros.body.skeleton import iguana_skeleton
from iguana_ros.constants import FRAME_RATE, WORLD_FRAME
from iguana_ros.errors import IguanaError
from iguana_ros.geometry import quat_from_yaw
from iguana_ros.nodes.base import FrameGate, IguanaNode, node_main
from iguana_ros.ros.conversions import time_from_msg
from iguana_ros.ros.endpoints import resolve, resolve_action, volatile_readers
from iguana_ros.ros.go_to_pose import feedback_msg, goal_task, result_msg
from iguana_ros.ros.messages import (clip_to_cdr, goal_from_msg, planner_status_msg, reference_stance_to_cdr,
                                     route_from_msg, state_from_cdr, state_twist_from_cdr)
from iguana_ros.ros.run_events import EVENT_CLIP
from iguana_ros.stages import GoalOutcome, GoalTask, OtherBodies, planner_stage, refused_goal
from iguana_ros.validation import world_bound

READERS_PERIOD_S = 0.5
"""Wall seconds between two counts of the goal topics' readers (published on planner_status when they change)."""


class RunningGoal(NamedTuple):
    """A go_to_pose goal under way: its task and its action goal handle."""

    task: GoalTask
    handle: object


class Until:
    """An awaitable for an rclpy coroutine callback: done once `condition()` (checked whenever the executor wakes)."""

    def __init__(self, condition: Callable[[], bool]) -> None:
        """Wait for `condition`."""
        self.condition = condition

    def __await__(self):
        while not self.condition():
            yield


class PlannerNode(IguanaNode):
    """Chooses the next stride clip toward the goal or along the route at each stride end, aligned to the root."""

    KIND = 'planner_node'

    def __init__(self, library: dict | None = None, **kwargs) -> None:
        """Build the scene's planner (`stages.planner_stage`) over the clip library (or `library`)."""
        super().__init__(**kwargs)
        self.stage = planner_stage(self.scene, library, self.param('blend_frames'), self.param('goal_radius'),
                                   self.param('yaw_tolerance'))
        self.stage.load_kernels()                    # before the first state arrives, not at its stride end
        self.skeleton = iguana_skeleton()
        self.half_extent = self.scene.terrain.extent / 2.0
        self.bound = world_bound(self.scene.terrain.extent)
        self.state_gate = FrameGate(self, 'iguana_state')   # the clip is latched: a repeated state needs no reply
        self.goals_received = 0
        self.events_sent = 0
        self.held_state = None
        self.accepted = Path()
        self.accepted.header.frame_id = WORLD_FRAME
        self.clip_pub = self.publisher('motion_clip')
        self.stance_pub = self.publisher('reference_stance')
        self.status_pub = self.publisher('planner_status')
        self.subscription('goal_pose', self.guarded('goal_pose', self.on_goal))
        self.subscription('route', self.guarded('route', self.on_route))
        self.subscription('iguana_state', self.guarded('iguana_state', self.on_state), raw=True)
        self.others = self._hear_others()
        self.waiting_state = None
        self.accepted_pub = self.publisher('accepted_goals')
        self.accepted.header.stamp = self.now_stamp()
        self.accepted_pub.publish(self.accepted)  # latched: senders see the planner and how many goals it has
        self.root = (np.array([self.scene.start.x, self.scene.start.y, 0.0]), quat_from_yaw(0.0))
        self.running: dict[bytes, RunningGoal] = {}
        name, cls = resolve_action('go_to_pose')
        self.action_server = ActionServer(self, cls, name, self.execute_goal, cancel_callback=self.cancel_goal)
        self.readers: dict[str, int] = {}
        self.status_frame = 0
        self.count_readers()
        self.readers_timer = self.create_timer(READERS_PERIOD_S, self.count_readers,
                                               clock=Clock(clock_type=ClockType.STEADY_TIME))
        self.get_logger().info(f'planner ready: {len(self.stage.graph.clips)} clips, '
                               f'goal radius {self.stage.goal_radius:.2f} m')

    def _hear_others(self) -> OtherBodies | None:
        """
        Subscribe to the other characters' iguana_state in a world whose character keeps clear of them (else None).

        The others' topics are siblings of this node's namespace (`/iguana_a` hears `/iguana_b/iguana_state`).
        """
        world, mine = self.world_scene, self.characters[0][0]
        if len(world.characters) < 2 or not next(c for c in world.characters if c.name == mine).avoid_others:
            return None                             # alone in its world (or walking as if alone): no one to hear
        namespace = self.get_namespace().rstrip('/')
        parent = namespace.rsplit('/', 1)[0] if namespace.rsplit('/', 1)[-1] == mine else namespace
        window = round(self.stage.planner.params.obstacle_velocity_window * FRAME_RATE)
        others = OtherBodies([c.name for c in world.characters if c.name != mine], window)
        for name in others.names:
            self.subscription('iguana_state', self.guarded(f'{name}/iguana_state', self._other_state(name)), raw=True,
                              prefix=f'{parent}/{name}/')
        return others

    def _other_state(self, name: str) -> Callable:
        """Return the callback of character `name`'s iguana_state: keep its root; go on with a state waiting for it."""
        def on_other(msg) -> None:
            frame, root, _, twist = state_twist_from_cdr(msg, self.bound)
            self.others.add(name, frame, root[:2], twist[:2])
            if self.waiting_state is not None and self.others.ready(self.waiting_state[0]):
                held, self.waiting_state = self.waiting_state[1], None
                self.on_state(held)
        return on_other

    def on_goal(self, msg) -> None:
        """
        Schedule a goal and add it to accepted_goals.

        The goal is applied at its stamp in simulated time; stamp 0 = at the next stride.
        """
        goal = goal_from_msg(msg, self.half_extent)
        at = self.stage.accept_goal(goal.xy, goal.at, goal.yaw)
        heading = 'any heading' if goal.yaw is None else f'heading {goal.yaw:.2f} rad'
        self._accepted([msg], goal.at, at, f'goal ({goal.xy[0]:.2f}, {goal.xy[1]:.2f}), {heading}')

    def on_route(self, msg) -> None:
        """Schedule a route (its waypoints passed in order from its stamp on); add its waypoints to accepted_goals."""
        route = route_from_msg(msg, self.half_extent)
        at = self.stage.accept_route(self.stage.route_targets(list(route.waypoints)), route.at)
        poses = [self._stamped(pose, msg.header) for pose in msg.poses]
        self._accepted(poses, route.at, at, f'route of {len(route.waypoints)} waypoints')

    def cancel_goal(self, _handle) -> CancelResponse:
        """Accept a cancel request: the goal's execution ends it ('canceled') and the planner comes to rest."""
        return CancelResponse.ACCEPT

    async def execute_goal(self, handle):
        """Run a go_to_pose goal: refuse it with the reason, or schedule it and answer when its task ends."""
        try:
            task = goal_task(handle.request, self.stage, self.half_extent)
        except IguanaError as exc:
            self.health.reject(f'go_to_pose: {exc}')
            return self.finish_goal(handle, refused_goal(str(exc)))
        heading = 'any heading' if task.target.yaw is None else f'heading {task.target.yaw:.2f} rad'
        self._accepted([handle.request.pose], time_from_msg(handle.request.pose.header.stamp), task.at,
                       f'go_to_pose goal ({task.target.xy[0]:.2f}, {task.target.xy[1]:.2f}), {heading}')
        key = bytes(handle.goal_id.uuid)
        self.running[key] = RunningGoal(task, handle)
        handle.publish_feedback(feedback_msg(task.progress(self.root[0][:2]), *self.root))  # says: scheduled
        try:
            await Until(lambda: task.outcome is not None or handle.is_cancel_requested)
        finally:
            del self.running[key]
        return self.finish_goal(handle, task.outcome or task.cancel(self.root[0][:2]))

    def finish_goal(self, handle, outcome: GoalOutcome):
        """Set a go_to_pose goal's final state from its outcome, log it, and return its result message."""
        if outcome.kind == 'succeeded':
            handle.succeed()
        elif outcome.kind == 'canceled' and handle.is_cancel_requested:
            handle.canceled()
        else:
            handle.abort()
        if outcome.kind in ('succeeded', 'canceled'):      # one call site per severity (rclpy's rule)
            self.get_logger().info(f'go_to_pose goal {outcome.kind}: {outcome.reason}')
        else:
            self.get_logger().warning(f'go_to_pose goal {outcome.kind}: {outcome.reason}')
        return result_msg(outcome)

    def update_tasks(self, stride_end: bool) -> None:
        """Decide the running go_to_pose goals' outcomes; at a stride end, publish the feedback of the rest."""
        for task, handle in list(self.running.values()):
            if task.update(self.root[0][:2]) is None and stride_end:
                handle.publish_feedback(feedback_msg(task.progress(self.root[0][:2]), *self.root))

    @staticmethod
    def _stamped(pose, header):
        """Return a route waypoint as its sender compares it with accepted_goals (with the route's header)."""
        pose.header = header
        return pose

    def _accepted(self, poses: list, stamp: float, at: float, what: str) -> None:
        """List accepted goal poses on accepted_goals, log the adoption time; release a held state once all are in."""
        if at != stamp:
            self.get_logger().info(f'goal stamp {stamp:.0f} s is not simulated time (wall clock?); adopting it now')
        self.goals_received += 1
        self.accepted.poses.extend(poses)
        self.accepted.header.stamp = self.now_stamp()
        self.accepted_pub.publish(self.accepted)
        self.get_logger().info(f'{what} scheduled for t={at:.3f} s')
        if self.held_state is not None and self.goals_received >= self.param('wait_for_goals'):
            held, self.held_state = self.held_state, None
            self.on_state(held)

    def on_state(self, msg) -> None:
        """At a stride end, publish the next clip aligned to the body's root; then the frame's stance flags."""
        frame, root, orientation = state_from_cdr(msg, self.bound)
        if not self.state_gate.admit(frame):
            return
        if self.goals_received < self.param('wait_for_goals'):
            self.held_state = msg  # decided once the scene's goals are in (see wait_for_goals)
            self.get_logger().info(f'holding iguana_state of frame {frame} until {self.param("wait_for_goals")} '
                                   f'goals have arrived ({self.goals_received} so far)')
            return
        if self.others is not None:
            if not self.others.ready(frame):
                self.waiting_state = (frame, msg)    # planned once every other body's state of the frame is in
                return
            self.stage.obstacles = self.others.obstacles(frame)
        self.state_gate.handled(frame)
        clip = self.stage.update(frame, root, orientation)
        self.root = (root, orientation)
        self.update_tasks(clip is not None)
        if clip is not None:
            self.clip_pub.publish(clip_to_cdr(clip, self.skeleton, frame))   # serialized from numpy: 21 x 34 bones
            self.get_logger().info(f'frame {frame}: clip {clip.name!r} ({len(clip.root_positions)} frames)')
            self.report(EVENT_CLIP, clip=clip.name, frame=frame)
        self.stance_pub.publish(reference_stance_to_cdr(self.stage.reference_contacts(frame), frame))
        if clip is not None or len(self.stage.events) > self.events_sent:
            self.report_events()
            self.publish_status(frame)

    def report_events(self) -> None:
        """Send the stage's new events (waypoint, arrived, stuck, circling, recovered) on run_events and the log."""
        for event in self.stage.events[self.events_sent:]:
            self.report(event.kind, detail=event.detail, frame=event.frame)
            line = f'frame {event.frame}: {event.kind}: {event.detail}'
            if event.kind in ('stuck', 'circling'):     # one call site per severity: rclpy refuses a second
                self.get_logger().warning(line)
            else:
                self.get_logger().info(line)
        self.events_sent = len(self.stage.events)

    def publish_status(self, frame: int) -> None:
        """Publish where the planner is on planner_status (latched), stamped with the frame's simulated time."""
        self.status_frame = frame
        self.status_pub.publish(planner_status_msg(self.stage.status(), self.goals_received, frame,
                                                   frame / FRAME_RATE, self.readers))

    def count_readers(self) -> None:
        """Count the volatile readers of goal_pose and route; publish the status again when they changed."""
        counts = {key: volatile_readers(self, resolve(key)[0]) for key in ('goal_pose', 'route')}
        if counts != self.readers:
            self.readers = counts
            self.publish_status(self.status_frame)


main = node_main(PlannerNode)

if __name__ == '__main__':
    main()
