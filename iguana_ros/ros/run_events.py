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
run_events messages.

The vocabulary of what a node process reports about itself (RunEvent, EVENT_*), and its message: the topic table's
diagnostic_msgs/DiagnosticArray: header stamped with the wall clock (system time) of the event, one DiagnosticStatus
whose name is the node, message the event, values detail, clip and frame.
"""
from __future__ import annotations

from dataclasses import dataclass

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from std_msgs.msg import Header

from iguana_ros.errors import InputError
from iguana_ros.ros.conversions import time_from_msg, time_to_msg

EVENT_UP = 'up'
"""Event a node sends once its process has started and its ROS node exists."""

EVENT_LOADED = 'loaded'
"""Event a node sends once it is built (model, motion graph, simulator: what it loads before it can work)."""

EVENT_CLIP = 'clip'
"""Event the planner sends when it starts a clip."""

EVENT_BODY_LOST = 'body_lost'
"""Event the simulator sends when the body left the terrain or fell (detail 'cause: what happened'); the run ends."""

EVENT_PAUSED = 'paused'
"""Event the simulator sends when its sim/pause service holds it (frame: the frame it holds at)."""

EVENT_RESUMED = 'resumed'
"""Event the simulator sends when its sim/resume service lets it advance again."""

EVENT_RESET = 'reset'
"""Event the simulator sends when its sim/reset service put the body back at the scene's start (frame: when)."""


@dataclass(frozen=True)
class RunEvent:
    """
    One message of `run_events`.

    Which node, what happened (EVENT_*), its wall-clock time (s since the epoch), and for a clip its name and start
    frame; `detail` says more (e.g. 'model from cache').
    """

    node: str
    kind: str
    wall_time: float
    detail: str = ''
    clip: str = ''
    frame: int = -1


MAX_TEXT = 200
"""Longest node name, event, detail or clip name accepted from the topic (characters)."""


def run_event_msg(event: RunEvent) -> DiagnosticArray:
    """`DiagnosticArray` of one RunEvent."""
    values = [KeyValue(key='detail', value=event.detail), KeyValue(key='clip', value=event.clip),
              KeyValue(key='frame', value=str(int(event.frame)))]
    status = DiagnosticStatus(level=DiagnosticStatus.OK, name=event.node, message=event.kind, values=values)
    return DiagnosticArray(header=Header(stamp=time_to_msg(event.wall_time)), status=[status])


def run_event_from_msg(msg) -> RunEvent:
    """
    `RunEvent` of a run_events message.

    InputError unless it holds one status with a short name, event and values and an integer frame.
    """
    if len(msg.status) != 1:
        raise InputError(f'run_events holds {len(msg.status)} statuses, expected 1')
    status = msg.status[0]
    values = {kv.key: kv.value for kv in status.values}
    texts = [status.name, status.message, values.get('detail', ''), values.get('clip', '')]
    if any(len(text) > MAX_TEXT for text in texts):
        raise InputError(f'run_events text longer than {MAX_TEXT} characters')
    try:
        frame = int(values.get('frame', '-1'))
    except ValueError:
        raise InputError(f'run_events frame {values.get("frame")!r} is not an integer') from None
    return RunEvent(status.name, status.message, time_from_msg(msg.header.stamp), values.get('detail', ''),
                    values.get('clip', ''), frame)
