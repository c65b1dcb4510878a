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
What a run reports, from data only.

How far it got (the last iguana_state stamp in its bag), the wall time of its simulation loop (the recorder's receive
times of the first and last iguana_state), the supervisor's own wall time, whether the bag was finalised, and the
outcome (completed, failed, the body lost: left_terrain or fell, stopped by a signal).
"""
from __future__ import annotations

from dataclasses import dataclass, field
import math
from pathlib import Path

from iguana_ros.physics.body_watch import BODY_LOST_EXIT_CODES
from iguana_ros.supervisor.cpu import cpu_line
from iguana_ros.supervisor.progress_display import startup_line
from iguana_ros.supervisor.run_gait import RunGait
from iguana_ros.topics import topic_name

STATE_KEY, EVENTS_KEY = 'iguana_state', 'run_events'
"""Recorded topics whose stamps say how far the simulation got, and whose simulator events say when it was paused
and resumed."""


@dataclass
class BagProgress:
    """
    One pass over a run's bag.

    Messages per topic, wall-clock send times (ns, the messages' publish times: a run's log times are simulated) of the
    first and last iguana_state, whether the file was finalised (summary section and metadata.yaml written) and what
    ended it early.
    """

    exists: bool = False
    finalised: bool = False
    counts: dict[str, int] = field(default_factory=dict)
    state_first_ns: int = 0
    state_last_ns: int = 0
    problem: str = ''
    pauses: list = field(default_factory=list)
    """The simulator's pause and resume events in order: (EVENT_PAUSED or EVENT_RESUMED, wall time s)."""

    @property
    def messages(self) -> int:
        """Messages recovered from the bag."""
        return sum(self.counts.values())

    @property
    def loop_wall_s(self) -> float:
        """Wall seconds from the first to the last iguana_state the simulator sent (0 if fewer than 2)."""
        return max(0.0, (self.state_last_ns - self.state_first_ns) / 1e9)

    @property
    def paused_s(self) -> float:
        """Wall seconds the simulation loop was paused (sim/pause to sim/resume, or to the last iguana_state)."""
        return paused_seconds(self.pauses, self.state_first_ns / 1e9, self.state_last_ns / 1e9)

    def note(self) -> str:
        """'finalised, 1234 messages on 12 topics' or what is wrong with the bag."""
        if not self.exists:
            return 'no bag: the run stopped before the recorder started'
        held = f'{self.messages} messages on {len(self.counts)} topics'
        if self.finalised:
            return f'finalised, {held}'
        return f'not finalised ({self.problem or "no summary section"}): {held} recovered from its complete chunks'


def bag_progress(bag: Path, namespace: str = '', state_topic: str | None = None) -> BagProgress:
    """
    `BagProgress` of the bag of a run in `namespace` (a missing or unreadable bag gives exists=False / a problem).

    `state_topic` is the iguana_state that says how far the run got (a world's: its first character's).
    """
    from iguana_ros.bag.storage import BagReader
    from iguana_ros.errors import IguanaError

    progress = BagProgress()
    try:
        reader = BagReader(bag)
    except IguanaError as exc:
        progress.problem = str(exc)
        return progress
    progress.exists = True
    state_topic, events_topic = state_topic or topic_name(STATE_KEY, namespace), topic_name(EVENTS_KEY, namespace)
    for msg in reader.messages():
        progress.counts[msg.topic] = progress.counts.get(msg.topic, 0) + 1
        if msg.topic == state_topic:
            progress.state_first_ns = progress.state_first_ns or msg.publish_time
            progress.state_last_ns = msg.publish_time
        elif msg.topic == events_topic:
            progress.pauses.extend(_pause_events(bytes(msg.data)))
    progress.problem = reader.problem
    progress.finalised = not reader.truncated and (Path(bag) / 'metadata.yaml').is_file()
    return progress


def body_contact_figures(bag: Path) -> tuple[int, float]:
    """Return (frames with contact, deepest node m) of a world's bag from its body_contacts (damaged ones skipped)."""
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.serialization import deserialize_message

    from iguana_ros.bag.trajectory import read_topics
    from iguana_ros.ros.body_contacts import body_contacts_from_msg
    from iguana_ros.errors import IguanaError
    frames, deepest = set(), 0.0
    try:
        recorded = read_topics(bag, ['body_contacts'], '').messages['body_contacts']
    except IguanaError:                 # an unreadable bag: its note says so; the summary still prints
        return 0, 0.0
    for data in recorded:
        try:
            pairs = body_contacts_from_msg(deserialize_message(data, DiagnosticArray))
        except Exception:  # noqa: BLE001 -- a damaged message (any decoder error): the figures stand without it
            continue
        frames.update(p.frame for p in pairs)
        deepest = max([deepest, *(p.max_depth for p in pairs)])
    return len(frames), deepest


def _pause_events(data: bytes) -> list:
    """Return [(kind, wall time s)] of a recorded run_events message if it is the simulator's pause or resume."""
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.serialization import deserialize_message

    from iguana_ros.ros.run_events import EVENT_PAUSED, EVENT_RESUMED, run_event_from_msg
    try:
        event = run_event_from_msg(deserialize_message(data, DiagnosticArray))
    except Exception:  # noqa: BLE001 -- a damaged message (any decoder error): the figures stand without it
        return []
    return [(event.kind, event.wall_time)] if event.kind in (EVENT_PAUSED, EVENT_RESUMED) else []


def paused_seconds(pauses: list, start: float, end: float) -> float:
    """
    Return the wall seconds within [`start`, `end`] s spent paused, from pause and resume events [(kind, time s)].

    A pause lasts until the next resume, or until `end`; a repeated pause or resume changes nothing.
    """
    total, since = 0.0, None
    for kind, at in sorted(pauses, key=lambda event: event[1]):
        at = min(max(at, start), end)
        if kind == 'paused' and since is None:
            since = at
        elif kind == 'resumed' and since is not None:
            total, since = total + at - since, None
    return total + (end - since if since is not None else 0.0)


@dataclass
class CharacterSummary:
    """How one character of a run did: how far it got (s), its goal or route end, its gait figures."""

    simulated_s: float
    reached_goal: bool
    time_to_goal: float
    final_goal_distance: float
    gait: RunGait | None = None

    def goal_line(self) -> str:
        """'goal reached at t=3.20 s', 'goal not reached' or 'goal not reached (final distance 0.42 m)'."""
        if self.reached_goal:
            return f'goal reached at t={self.time_to_goal:.2f} s'
        if math.isnan(self.final_goal_distance):
            return 'goal not reached'
        return f'goal not reached (final distance {self.final_goal_distance:.2f} m)'


@dataclass
class RunSummary:
    """
    What a run reports.

    `exit_code`: 0 completed, 1 failed, 128 + n stopped by signal n. `simulated_s` is the last recorded iguana_state
    stamp, `wall_s` the wall time from the first to the last of them (their send times); `message` holds the last
    lines of the node that failed.
    """

    scene: str
    bag: Path
    logs: Path
    simulated_s: float
    wall_s: float
    reached_goal: bool
    time_to_goal: float
    final_goal_distance: float
    exit_code: int
    message: str = ''
    gait: RunGait | None = None
    planned_s: float = float('nan')
    outcome: str = ''
    reason: str = ''
    total_wall_s: float = 0.0
    bag_note: str = ''
    failed_node: str = ''
    phases: tuple = ()
    """Start-up phases that finished (supervisor/progress_display.py PhaseTime), from the node processes' run_events."""
    cpu_ms_per_frame: dict = field(default_factory=dict)
    """CPU ms per simulated frame of each process of the run while it stepped (`supervisor/cpu.py`; {} off Linux)."""
    paused_s: float = 0.0
    """Wall seconds of `wall_s` during which the simulation was paused (sim/pause, `iguana run --paused`)."""
    characters: dict[str, CharacterSummary] = field(default_factory=dict)
    """A world's characters by name (the run's goal figures are then every one's: reached when all reached)."""
    body_contact_frames: int = 0
    """A world's frames with body-body contact (the bag's body_contacts messages)."""
    body_contact_max_depth: float = 0.0
    """The deepest node of one body inside another over the run, m."""

    @property
    def realtime_factor(self) -> float:
        """Return simulated seconds per wall second of the simulation loop while it was not paused."""
        running = self.wall_s - self.paused_s
        return self.simulated_s / running if running > 0 else 0.0

    def progress(self) -> str:
        """'3.40 of 60.00 s simulated' (or '3.40 s simulated' when the planned duration is unknown)."""
        if math.isnan(self.planned_s):
            return f'{self.simulated_s:.2f} s simulated'
        return f'{self.simulated_s:.2f} of {self.planned_s:.2f} s simulated'

    def outcome_text(self) -> str:
        """'run completed', 'run failed: <reason>', 'run ended: the iguana fell …' or 'run stopped by SIGTERM'."""
        if self.outcome in ('', 'completed'):
            return f'run completed: {self.progress()}'
        got = self.progress() if self.simulated_s > 0 else 'no frame simulated'
        if self.outcome == 'stopped':
            return f'run {self.reason} after {got}'
        if self.outcome in BODY_LOST_EXIT_CODES:
            return f'run ended after {got}: {self.reason}'
        return f'run failed after {got}' + (f': {self.reason}' if self.reason else '')

    def headline(self) -> str:
        """One line for the error stream: the outcome and where the bag is."""
        return f'{self.outcome_text()}; bag {self.bag_note or "?"} at {self.bag}'

    def lines(self) -> list[str]:
        """Human-readable summary lines."""
        goal = CharacterSummary(self.simulated_s, self.reached_goal, self.time_to_goal,
                                self.final_goal_distance).goal_line()
        if self.characters:
            arrived = sum(c.reached_goal for c in self.characters.values())
            goal = f'{arrived} of {len(self.characters)} characters reached their goals'
        gait = self.gait.lines() if self.gait is not None else []
        for name, one in self.characters.items():
            gait += [f'{name}: {one.goal_line()}', *('  ' + line for line in (one.gait.lines() if one.gait else []))]
        if self.characters:
            gait.append(f'body contact: {self.body_contact_frames} frames, deepest node '
                        f'{self.body_contact_max_depth * 1000:.1f} mm inside another body')
        total = f', {self.total_wall_s:.1f} s with start-up' if self.total_wall_s > 0 else ''
        detail = [f'last lines of {self.failed_node}:', *('  ' + line for line in self.message.splitlines())] \
            if self.message and self.failed_node else []
        bag = f'bag: {self.bag}' + (f' ({self.bag_note})' if self.bag_note else '')
        return [f'scene {self.scene}: {goal}', self.outcome_text(),
                f'simulated {self.simulated_s:.2f} s in {self.wall_s:.2f} s wall '
                + (f'({self.paused_s:.1f} s of it paused; ' if self.paused_s > 0 else '(')
                + f'realtime factor {self.realtime_factor:.2f}{total})',
                *([startup_line(self.phases)] if self.phases else []),
                *([cpu_line(self.cpu_ms_per_frame)] if self.cpu_ms_per_frame else []),
                *gait, *detail, bag, f'logs: {self.logs}']
