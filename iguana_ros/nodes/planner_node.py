"""Planner node (Section IV): goal_pose + iguana_state in, one motion_clip per stride and the clip's stance
flags per frame (reference_stance) out; the goals it accepted on accepted_goals (latched, for their senders)."""
from __future__ import annotations

from nav_msgs.msg import Path

from iguana_ros.constants import FRAME_RATE, WORLD_FRAME
from iguana_ros.motion.motion_graph import MotionGraph, PolicyParams
from iguana_ros.nodes.base import IguanaNode, node_main
from iguana_ros.nodes.messages import clip_to_msg, goal_from_msg, reference_stance_to_msg, state_from_msg
from iguana_ros.pipeline import PlannerStage
from iguana_ros.validation import FRAME_NEW, FRAME_STALE, check_frame, world_bound


MAX_SCHEDULE_AHEAD = 3600.0
"""A goal stamped further ahead of simulated time than this (s) is taken as a wall-clock stamp: adopted now."""


class PlannerNode(IguanaNode):
    """Chooses the next stride clip toward the goal at each stride end, aligned to the simulated root."""

    KIND = 'planner_node'

    def __init__(self, library: dict | None = None, **kwargs) -> None:
        """Build the motion graph over the clip library (or `library`)."""
        super().__init__(**kwargs)
        from iguana_ros.body.skeleton import iguana_skeleton
        if library is None:
            from iguana_ros.motion.clips import load_clip_library
            library = load_clip_library()
        radius = self.param('goal_radius') or self.scene.goal_radius
        graph = MotionGraph(library, blend_frames=self.param('blend_frames'))
        self.stage = PlannerStage(graph, PolicyParams(goal_radius=radius))
        self.skeleton = iguana_skeleton()
        self.half_extent = self.scene.terrain.extent / 2.0
        self.bound = world_bound(self.scene.terrain.extent)
        self.last_frame = -1
        self.goals_received = 0
        self.held_state = None
        self.accepted = Path()
        self.accepted.header.frame_id = WORLD_FRAME
        self.clip_pub = self.publisher('motion_clip')
        self.stance_pub = self.publisher('reference_stance')
        self.subscription('goal_pose', self.guarded('goal_pose', self.on_goal))
        self.subscription('iguana_state', self.guarded('iguana_state', self.on_state))
        self.accepted_pub = self.publisher('accepted_goals')
        self.accepted.header.stamp = self.now_stamp()
        self.accepted_pub.publish(self.accepted)  # latched: senders see the planner and how many goals it has
        self.get_logger().info(f'planner ready: {len(library)} clips, goal radius {radius:.2f} m')

    def on_goal(self, msg) -> None:
        """Schedule a goal (applied at its stamp in simulated time; stamp 0 = at the next stride) and add it to
        accepted_goals."""
        xy, at = goal_from_msg(msg, self.half_extent)
        now = max(self.last_frame, 0) / FRAME_RATE
        if at > now + MAX_SCHEDULE_AHEAD:
            self.get_logger().info(f'goal stamp {at:.0f} s is not simulated time (wall clock?); adopting it now')
            at = 0.0
        self.stage.schedule_goal(xy, at)
        self.goals_received += 1
        self.accepted.poses.append(msg)
        self.accepted.header.stamp = self.now_stamp()
        self.accepted_pub.publish(self.accepted)
        self.get_logger().info(f'goal ({xy[0]:.2f}, {xy[1]:.2f}) scheduled for t={at:.3f} s')
        if self.held_state is not None and self.goals_received >= self.param('wait_for_goals'):
            held, self.held_state = self.held_state, None
            self.on_state(held)

    def on_state(self, msg) -> None:
        """At a stride end, publish the next clip aligned to the body's root; then the frame's stance flags."""
        frame, root, orientation = state_from_msg(msg, self.bound)
        order = check_frame('iguana_state', frame, self.last_frame)
        if order != FRAME_NEW:
            if order == FRAME_STALE:
                self.get_logger().warning(f'ignored stale iguana_state for frame {frame} '
                                          f'(already at {self.last_frame})')
            return
        if self.goals_received < self.param('wait_for_goals'):
            self.held_state = msg  # decided once the scene's goals are in (see wait_for_goals)
            return
        self.last_frame = frame
        clip = self.stage.update(frame, root, orientation)
        if clip is not None:
            self.clip_pub.publish(clip_to_msg(clip, self.skeleton, frame))
            self.get_logger().info(f'frame {frame}: clip {clip.name!r} ({len(clip.root_positions)} frames)')
        self.stance_pub.publish(reference_stance_to_msg(self.stage.reference_contacts(frame), frame))


main = node_main(PlannerNode)

if __name__ == '__main__':
    main()
