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
What `iguana run` shows while it runs.

The start-up phases with their durations, and the run's progress — simulated time of the planned duration, realtime
factor, distance to the current goal, current clip — as a live bar on a terminal or as a line every few seconds
otherwise.

The phases are milestones of the whole run, in wall-clock (system) time, from messages only (the node processes'
events on `run_events`, the simulator's `iguana_state`): launching nodes (the supervisor starts the processes ..
every node has announced itself), loading the model (.. every node is built), DDS discovery (.. the simulator,
having found its peers, the goals and the recorder, publishes frame 0), compiling kernels (.. frame 1, whose
computation compiles or loads the kernels in every process).
"""
from __future__ import annotations

from dataclasses import dataclass, field
import math
import sys
import time
from typing import TextIO

from iguana_ros.ros.run_events import EVENT_LOADED, EVENT_UP, RunEvent

PHASES = (('launching', 'launching nodes'), ('loading', 'loading the model'), ('discovery', 'DDS discovery'),
          ('compiling', 'compiling kernels'))
"""Start-up phases in order: (key, what the user reads)."""

RATE_WINDOW_S = 5.0
"""Wall seconds over which the live realtime factor is measured."""

LINE_PERIOD_S = 5.0
"""Wall seconds between two progress lines when the output is not a terminal."""

EVENTS_GRACE_S = 3.0
"""Wall seconds after frame 1 for which progress waits for start-up events still on their way (then shows anyway)."""

PHASE_TAG = '[start-up]'
"""Head of a line naming a start-up phase."""

PROGRESS_TAG = '[progress]'
"""Head of a progress line (and of the bar)."""


@dataclass(frozen=True)
class PhaseTime:
    """A finished start-up phase: its label, wall seconds, and a note (e.g. 'kernel cache warm')."""

    label: str
    seconds: float
    detail: str = ''

    def took(self) -> str:
        """'1.23 s (model from cache)'."""
        return f'{self.seconds:.2f} s' + (f' ({self.detail})' if self.detail else '')

    def text(self) -> str:
        """Return 'loading the model 1.23 s (model from cache)'."""
        return f'{self.label} {self.took()}'


def startup_line(phases: tuple) -> str:
    """'start-up: launching nodes 2.10 s, loading the model 1.02 s, ...' ('' when no phase finished)."""
    return 'start-up: ' + ', '.join(p.text() for p in phases) if phases else ''


@dataclass
class StartupClock:
    """
    Milestones of a run's start-up (wall-clock seconds).

    Launch, each expected node up and loaded, frames 0 and 1 published; the phases between them, finished and current.
    """

    nodes: tuple
    launched: float = math.nan
    up: dict = field(default_factory=dict)
    loaded: dict = field(default_factory=dict)
    frame0: float = math.nan
    frame1: float = math.nan
    details: dict = field(default_factory=dict)

    def note(self, event: RunEvent) -> None:
        """Take in a node's up/loaded event (others are ignored)."""
        if event.node not in self.nodes:
            return
        if event.kind == EVENT_UP:
            self.up.setdefault(event.node, event.wall_time)
        elif event.kind == EVENT_LOADED:
            self.loaded.setdefault(event.node, event.wall_time)
            if event.detail:
                self.details['loading'] = event.detail

    def note_frame(self, frame: int, wall_time: float) -> None:
        """Take in the wall-clock time at which the simulator published frame `frame`'s state."""
        if frame == 0 and math.isnan(self.frame0):
            self.frame0 = wall_time
        elif frame >= 1 and math.isnan(self.frame1):
            self.frame1 = wall_time
            if math.isnan(self.frame0):
                self.frame0 = wall_time

    def _ends(self) -> list[float]:
        """End time of each phase in PHASES order (nan while not reached)."""
        def every(times: dict) -> float:
            return max(times[n] for n in self.nodes) if all(n in times for n in self.nodes) else math.nan
        return [every(self.up), every(self.loaded), self.frame0, self.frame1]

    def finished(self) -> tuple:
        """`PhaseTime` of every phase that has ended, in order (a phase ending before its predecessor counts 0)."""
        done, start = [], self.launched
        for (key, label), end in zip(PHASES, self._ends()):
            if math.isnan(end) or math.isnan(start):
                break
            done.append(PhaseTime(label, max(0.0, end - start), self.details.get(key, '')))
            start = max(start, end)
        return tuple(done)

    def current(self) -> str:
        """Label of the phase under way ('' before the launch and once frame 1 is out)."""
        if math.isnan(self.launched):
            return ''
        done = len(self.finished())
        return PHASES[done][1] if done < len(PHASES) else ''

    def over(self, now: float) -> bool:
        """
        Whether start-up is over at wall time `now`: frame 1 is out and every phase has ended.

        Frame 1 can reach a listener before some node's start-up events do (its publisher discovered later); up to
        EVENTS_GRACE_S after frame 1 start-up still counts as under way, so its phases are told before any progress.
        """
        if math.isnan(self.frame1):
            return False
        return len(self.finished()) == len(PHASES) or now - self.frame1 > EVENTS_GRACE_S


def active_goal(goals: list, now: float, adopt_now_after: float) -> tuple | None:
    """
    Return the goal `(x, y)` the planner follows at simulated `now` s.

    The last of `goals` [(x, y, at)] (in the order accepted) whose time has come; a time more than `adopt_now_after` s
    ahead counts as now (a wall-clock stamp).
    """
    due = [(x, y) for x, y, at in goals if at <= now + 1e-9 or at > now + adopt_now_after]
    return due[-1] if due else None


@dataclass
class RateWindow:
    """Realtime factor over the last `window_s` wall seconds from (wall, simulated) samples."""

    window_s: float = RATE_WINDOW_S
    samples: list = field(default_factory=list)

    def add(self, wall: float, simulated: float) -> None:
        """Record that `simulated` s were reached at wall time `wall`."""
        self.samples.append((wall, simulated))
        while len(self.samples) > 2 and self.samples[1][0] < wall - self.window_s:
            self.samples.pop(0)

    def factor(self) -> float:
        """Return simulated seconds per wall second over the window (nan with fewer than two samples)."""
        if len(self.samples) < 2 or self.samples[-1][0] <= self.samples[0][0]:
            return math.nan
        (w0, s0), (w1, s1) = self.samples[0], self.samples[-1]
        return (s1 - s0) / (w1 - w0)


@dataclass(frozen=True)
class RunStatus:
    """
    What the progress line shows.

    Simulated and planned seconds, realtime factor, m to the goal (nan: no goal), the current clip ('' before the
    first).
    """

    simulated: float
    planned: float
    realtime_factor: float = math.nan
    goal_distance: float = math.nan
    clip: str = ''

    def fields(self) -> list[str]:
        """['realtime factor 1.31', '2.10 m to the goal', "clip 'walk_3'"], without what is unknown."""
        parts = []
        if not math.isnan(self.realtime_factor):
            parts.append(f'realtime factor {self.realtime_factor:.2f}')
        if not math.isnan(self.goal_distance):
            parts.append(f'{self.goal_distance:.2f} m to the goal')
        if self.clip:
            parts.append(f'clip {self.clip!r}')
        return parts

    def line(self) -> str:
        """'3.40 of 25.00 s simulated (14 %), realtime factor 1.31, 2.10 m to the goal, clip 'walk_3''."""
        share = f' ({100 * self.simulated / self.planned:.0f} %)' if self.planned > 0 else ''
        return ', '.join([f'{self.simulated:.2f} of {self.planned:.2f} s simulated{share}', *self.fields()])


class ProgressDisplay:
    """
    Writes phases and progress to `stream`.

    A tqdm bar on a terminal, else a line every `period_s` s (and every phase as it begins and ends, on both).
    """

    def __init__(self, stream: TextIO | None = None, period_s: float = LINE_PERIOD_S,
                 bar: bool | None = None) -> None:
        """
        `bar` None = a bar when `stream` is a terminal.

        Lines are headed PHASE_TAG or PROGRESS_TAG (not the command's name, which heads only its one error line).
        """
        self.stream, self.period_s = stream or sys.stdout, period_s
        self.use_bar = self.stream.isatty() if bar is None else bar
        self._bar = None
        self._next_line = 0.0
        self._phase = ''
        self._shown = 0
        self._last_line = ''

    def write(self, text: str) -> None:
        """One line above the bar (or plain)."""
        if self._bar is not None:
            self._bar.write(text, file=self.stream)
        else:
            print(text, file=self.stream, flush=True)

    def phases(self, finished: tuple, current: str) -> None:
        """Announce each newly finished phase and the one now under way."""
        for phase in finished[self._shown:]:
            self.write(f'{PHASE_TAG} {phase.label}: {phase.took()}')
        self._shown = len(finished)
        if current and current != self._phase:
            self.write(f'{PHASE_TAG} {current} ...')
        self._phase = current

    def update(self, status: RunStatus) -> None:
        """Show the run's progress (the bar at once, a line at most every period_s)."""
        if self.use_bar:
            self._update_bar(status)
            return
        now, line = time.monotonic(), f'{PROGRESS_TAG} {status.line()}'
        if now >= self._next_line and line != self._last_line:   # nothing new (e.g. the run is ending): no line
            self._next_line, self._last_line = now + self.period_s, line
            self.write(line)

    def _update_bar(self, status: RunStatus) -> None:
        """Create or move the tqdm bar (total: the planned simulated seconds)."""
        if self._bar is None:
            from tqdm import tqdm
            self._bar = tqdm(total=round(status.planned, 2), file=self.stream, unit='s', dynamic_ncols=True,
                             desc=f'{PROGRESS_TAG} simulated', leave=True,
                             bar_format='{desc} {n:.2f}/{total:.2f} s |{bar}| {postfix} [{elapsed}<{remaining}]')
        self._bar.n = min(round(status.simulated, 2), self._bar.total)
        self._bar.set_postfix_str(', '.join(status.fields()), refresh=False)
        self._bar.refresh()

    def close(self) -> None:
        """Finish the bar (the summary follows below it)."""
        if self._bar is not None:
            self._bar.close()
            self._bar = None
