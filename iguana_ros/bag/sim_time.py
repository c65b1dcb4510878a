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
A bag's time base, and the log times of a recording on simulated time (ROS-free).

`ros2 bag record --use-sim-time` semantics: the recorder's clock is `/clock`, so a message's log time is the simulated
time of the latest `/clock` the recorder had received when the message arrived. "When it arrived" is the middleware's
receive timestamp of each message (wall clock), compared with the receive timestamps of the `/clock` messages, so the
answer does not depend on the order in which the recorder takes its subscriptions' queues: the recorder hands the
messages of one wake to `SimTimeStamper` and stamps them after every `/clock` of that wake is known.

Decisions (docs/PACKAGING.md, "Bags on simulated time"):

- A message received before the first `/clock` (the latched scene markers, the nodes' start-up events) is held in
  memory and written with the first `/clock`'s time, so a recording joined late does not start with an empty stretch
  from time 0. If no `/clock` comes (or the held messages pass HOLD_LIMIT_BYTES) they are written at log time 0, as
  rosbag2 does before its first `/clock`.
- Log times never go backwards on a channel, nor on the recorder's timeline: a `/clock` that jumps back (a reset, a
  looping player) continues the timeline from where it was, advancing with the simulated time after the jump.
- The publish time stays the publisher's wall-clock send time (the DDS source timestamp), as rosbag2 writes it with
  --use-sim-time; `iguana run` takes the run's wall time (realtime factor, CPU per frame) from it.
"""
from __future__ import annotations

import bisect
from collections.abc import Callable
from dataclasses import dataclass
import struct

TIME_BASE_SIMULATED = 'simulated'
TIME_BASE_WALL = 'wall'
TIME_BASES = (TIME_BASE_SIMULATED, TIME_BASE_WALL)
CLOCK_TOPIC = '/clock'

METADATA_NAME = 'iguana_ros'
"""Name of the MCAP Metadata record (written first in the data section, so a killed recorder's bag keeps it) that
holds `time_base` and `clock_topic`; rosbag2's metadata.yaml has no field for them, so its `custom_data` repeats
them under CUSTOM_DATA_KEYS."""
CUSTOM_DATA_KEYS = {'time_base': 'iguana_ros.time_base', 'clock_topic': 'iguana_ros.clock_topic'}
"""Keys of metadata.yaml's custom_data (rosbag2 v9: a string map) for the time base and its clock topic."""

HOLD_LIMIT_BYTES = 64 << 20
"""Bytes of messages held while no /clock has come; beyond it they are written at log time 0."""
TIMELINE_LENGTH = 4096
"""/clock receipts kept for the look-up (the messages of one wake, ~20 ms, need a few)."""


def time_base_description(time_base: str, clock_topic: str = CLOCK_TOPIC) -> str:
    """Return 'simulated (/clock)' or 'wall (receive time)': what `iguana bag info` prints."""
    return f'simulated ({clock_topic})' if time_base == TIME_BASE_SIMULATED else 'wall (receive time)'


def clock_ns(data: bytes) -> int:
    """Nanoseconds of a serialized rosgraph_msgs/Clock (CDR, either byte order); ValueError if it is not one."""
    if len(data) < 12 or data[0] != 0 or data[1] not in (0, 1):
        raise ValueError('not a CDR rosgraph_msgs/Clock')
    sec, nanosec = struct.unpack_from('<iI' if data[1] == 1 else '>iI', data, 4)
    if sec < 0 or nanosec >= 1_000_000_000:
        raise ValueError(f'/clock out of range ({sec} s, {nanosec} ns)')
    return sec * 1_000_000_000 + nanosec


@dataclass
class Pending:
    """One received message waiting for its log time: channel, bytes, receive and source times (wall, ns)."""

    channel: int
    data: bytes
    received_ns: int
    published_ns: int


Write = Callable[[int, bytes, int, int], None]
"""Writes one message: (channel, data, log time, publish time)."""


class SimTimeStamper:
    """
    Gives each received message the simulated log time of the latest /clock received before it (module docstring).

    Feed every /clock with `clock` and every message to record with `add` (the /clock message itself too, after its
    `clock`); `flush` writes what can be stamped (call it after each wake), `close` writes the rest.
    """

    def __init__(self, write: Write, warn: Callable[[str], None] = print) -> None:
        self._write, self._warn = write, warn
        self._received: list[int] = []     # wall receive time of each /clock kept, non-decreasing
        self._times: list[int] = []        # its time on the timeline (simulated + offset), non-decreasing
        self._last_sim: int | None = None
        self._offset = 0
        self._pending: list[Pending] = []
        self._held_bytes = 0
        self._at_zero = False              # no /clock yet and too much held: written at log time 0 at once
        self._last_log: dict[int, int] = {}
        self.clocks = 0
        self.backward_jumps = 0

    @property
    def started(self) -> bool:
        """Whether a /clock has been received."""
        return self._last_sim is not None

    def clock(self, received_ns: int, data: bytes) -> int:
        """Take a serialized /clock received at wall time `received_ns`; returns its time on the timeline."""
        sim = clock_ns(data)
        if self._last_sim is not None and sim < self._last_sim:
            self._offset += self._last_sim - sim
            self.backward_jumps += 1
        self._last_sim = sim
        self._at_zero = False
        value = sim + self._offset
        if self._times and value < self._times[-1]:
            value = self._times[-1]
        if self._received:                   # both lists stay sorted (receive stamps of one reader do not go back)
            received_ns = max(received_ns, self._received[-1])
        self._received.append(received_ns)
        self._times.append(value)
        if len(self._received) > TIMELINE_LENGTH:
            del self._received[:-TIMELINE_LENGTH // 2], self._times[:-TIMELINE_LENGTH // 2]
        self.clocks += 1
        return value

    def log_time(self, received_ns: int) -> int:
        """Time on the timeline of the latest /clock received at or before `received_ns` (the first one if none)."""
        k = bisect.bisect_right(self._received, received_ns)
        return self._times[max(k - 1, 0)]

    def add(self, channel: int, data: bytes, received_ns: int, published_ns: int) -> None:
        """Queue one message received at wall time `received_ns` (sent at `published_ns`) for `flush`."""
        if self._at_zero:
            self._emit(channel, data, 0, published_ns)
            return
        self._pending.append(Pending(channel, data, received_ns, published_ns))
        if not self.started:
            self._held_bytes += len(data)
            if self._held_bytes > HOLD_LIMIT_BYTES:
                self._warn(f'iguana bag record: warning: no {CLOCK_TOPIC} within {len(self._pending)} messages '
                           f'({self._held_bytes >> 20} MiB); recording them at log time 0 until one comes')
                self._write_all_at_zero()
                self._at_zero = True

    def flush(self) -> None:
        """Write every queued message once a /clock is known (else they stay held)."""
        if not self.started or not self._pending:
            return
        pending, self._pending, self._held_bytes = self._pending, [], 0
        for msg in pending:
            self._emit(msg.channel, msg.data, self.log_time(msg.received_ns), msg.published_ns)

    def close(self) -> None:
        """Write what is still queued: stamped if a /clock came, else at log time 0 (with a warning)."""
        if self.started:
            self.flush()
        elif self._pending:
            self._warn(f'iguana bag record: warning: no {CLOCK_TOPIC} was received; the {len(self._pending)} '
                       f'messages are recorded at log time 0')
            self._write_all_at_zero()

    def _write_all_at_zero(self) -> None:
        pending, self._pending, self._held_bytes = self._pending, [], 0
        for msg in pending:
            self._emit(msg.channel, msg.data, 0, msg.published_ns)

    def _emit(self, channel: int, data: bytes, log_ns: int, published_ns: int) -> None:
        """Write with the log time raised to the channel's last one (never backwards on a channel)."""
        log_ns = max(log_ns, self._last_log.get(channel, 0))
        self._last_log[channel] = log_ns
        self._write(channel, data, log_ns, published_ns)
