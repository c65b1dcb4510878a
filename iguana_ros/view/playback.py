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

"""The bag timeline's clock (ROS-free): play, pause, scrub and speed over a recording's simulated time."""
from __future__ import annotations

from dataclasses import dataclass

SPEEDS = (0.25, 0.5, 1.0, 2.0, 4.0)
"""Playback speeds offered on the timeline (simulated seconds per wall second)."""


@dataclass
class Playback:
    """
    Simulated time `time` s within [`start`, `end`], advancing at `speed` while `playing`.

    At the end it stops (or, with `loop`, starts again).
    """

    start: float
    end: float
    time: float = 0.0
    speed: float = 1.0
    playing: bool = True
    loop: bool = False

    def __post_init__(self) -> None:
        """Begin at the start."""
        self.end = max(self.end, self.start)
        self.time = self.clamp(self.start if self.time < self.start else self.time)

    def clamp(self, time: float) -> float:
        """`time` limited to the recording."""
        return min(max(float(time), self.start), self.end)

    def advance(self, wall_dt: float) -> float:
        """Move on by `wall_dt` wall seconds (when playing); returns the new time."""
        if not self.playing or wall_dt <= 0.0:
            return self.time
        t = self.time + wall_dt * self.speed
        if t >= self.end:
            if self.loop and self.end > self.start:
                t = self.start + (t - self.start) % (self.end - self.start)
            else:
                t, self.playing = self.end, False
        self.time = t
        return t

    def seek(self, time: float) -> float:
        """Jump to `time` s (scrubbing); returns the time taken."""
        self.time = self.clamp(time)
        return self.time

    def toggle(self) -> bool:
        """Play or pause; playing at the end starts from the beginning. Returns whether it now plays."""
        if not self.playing and self.time >= self.end:
            self.time = self.start
        self.playing = not self.playing
        return self.playing
