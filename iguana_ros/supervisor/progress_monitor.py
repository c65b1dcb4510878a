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
The supervisor's view of a run over DDS, for `iguana run`'s progress.

The node processes' run_events (start-up milestones, the planner's clips), the simulator's iguana_state (how far the run
is, when frames 0 and 1 were published, where the root is) and the planner's accepted_goals (the goal it follows).
Everything comes from messages; nothing is read from a log.

The monitor is a node of its own (`iguana_run_monitor`, its own rclpy context, no signal handlers) that the
supervisor spins in short steps from its own loop (`poll`); a message it cannot read is skipped, never raised.
"""
from __future__ import annotations

import math
import time

import numpy as np

from iguana_ros.constants import FRAME_RATE, MAX_SCHEDULE_AHEAD
from iguana_ros.errors import IguanaError
from iguana_ros.ros.conversions import time_from_msg
from iguana_ros.ros.endpoints import listener, MONITOR_NODE_NAME, release_context, resolve, tool_node
from iguana_ros.ros.messages import state_from_cdr
from iguana_ros.ros.run_events import EVENT_BODY_LOST, EVENT_CLIP
from iguana_ros.ros.run_events import run_event_from_msg
from iguana_ros.ros.wait_loop import ListenerLoop, settle_heap
from iguana_ros.supervisor.progress_display import (active_goal, ProgressDisplay, RateWindow, RunStatus,
                                                    StartupClock)
from iguana_ros.topics import topic_name

MAX_TAKES = 500
"""Most messages one `poll` takes in (a burst after a stall is drained over a few polls)."""


class RunMonitor:
    """Listens to a run (see the module docstring); `display` (optional) shows phases and progress."""

    def __init__(self, nodes: tuple, planned_s: float, display: ProgressDisplay | None = None,
                 namespace: str = '', event_namespaces: list[str] | None = None) -> None:
        """
        Join the graph and subscribe to the run's topics in ROS `namespace`; nothing is shown until `launched()`.

        A world's run has run_events in every one of `event_namespaces` (the simulator's, each character's).
        """
        import rclpy
        from rclpy.signals import SignalHandlerOptions

        self.clock = StartupClock(tuple(nodes))
        self.planned_s, self.display = planned_s, display
        self.rate = RateWindow()
        self.frame, self.root, self.clip = -1, None, ''
        self.goals: list[tuple] = []
        self.heard = 0
        self.body_lost = ''
        self.context = rclpy.Context()
        rclpy.init(context=self.context, signal_handler_options=SignalHandlerOptions.NO)
        self.node = tool_node(MONITOR_NODE_NAME, self.context)
        topics = [('iguana_state', namespace, self._on_state, True),
                  ('accepted_goals', namespace, self._on_goals, False)]
        for events_in in ([namespace] if event_namespaces is None else event_namespaces):
            topics.append(('run_events', events_in, self._on_event, False))
        for key, where, callback, raw in topics:
            _, cls, qos = resolve(key)
            listener(self.node, cls, topic_name(key, where), callback, qos, raw=raw)
        self.loop = ListenerLoop(self.node)
        settle_heap()

    def launched(self) -> None:
        """Note that the supervisor starts the run's processes now."""
        self.clock.launched = time.time()
        self._show()

    def _on_event(self, msg) -> None:
        """Handle a node's run event: a start-up milestone or the planner's new clip."""
        try:
            event = run_event_from_msg(msg)
        except IguanaError:
            return
        self.heard += 1
        self.clock.note(event)
        if event.kind == EVENT_CLIP and event.clip:
            self.clip = event.clip
        elif event.kind == EVENT_BODY_LOST:
            self.body_lost = event.detail

    def _on_state(self, msg, info) -> None:
        """Handle the simulator's state of a frame: its publication time (frames 0 and 1) and the root."""
        try:
            frame, root, _ = state_from_cdr(msg)
        except IguanaError:
            return
        self.heard += 1
        self.clock.note_frame(frame, info['source_timestamp'] / 1e9)
        if frame > self.frame:
            self.frame, self.root = frame, root
            self.rate.add(time.monotonic(), frame / FRAME_RATE)

    def _on_goals(self, msg) -> None:
        """Handle the planner's accepted goals, in order: (x, y, adoption time s)."""
        self.goals = [(p.pose.position.x, p.pose.position.y, time_from_msg(p.header.stamp)) for p in msg.poses]

    def status(self) -> RunStatus:
        """Return simulated time, recent realtime factor, distance to the goal the planner follows, current clip."""
        now = max(self.frame, 0) / FRAME_RATE
        goal = active_goal(self.goals, now, MAX_SCHEDULE_AHEAD)
        distance = math.nan if goal is None or self.root is None else float(np.hypot(*(self.root[:2] - goal)))
        return RunStatus(now, self.planned_s, self.rate.factor(), distance, self.clip)

    def poll(self, timeout: float = 0.0) -> None:
        """Take in what has arrived (waiting up to `timeout` s for the first message) and update the display."""
        taken = self.loop.spin_once(timeout)
        while 0 < taken < MAX_TAKES:           # what came in meanwhile, without waiting (a burst over a few polls)
            more = self.loop.spin_once(0.0)
            taken = taken + more if more else 0
        self._show()

    def _show(self) -> None:
        """Phases as they begin and end; the progress once start-up is over."""
        if self.display is None:
            return
        self.display.phases(self.clock.finished(), self.clock.current())
        if self.clock.over(time.time()):
            self.display.update(self.status())

    def close(self) -> None:
        """Finish the display and leave the graph (once; the clock and status stay readable)."""
        if self.display is not None:
            self.display.close()
        if self.node is None:
            return
        try:
            self.loop.close()
            self.node.destroy_node()
        finally:
            self.node = None
            release_context(self.context)
