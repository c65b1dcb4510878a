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
CPU time of a run's processes while it steps, per simulated frame (Linux `/proc`; elsewhere nothing is reported).

A lockstep node run on a few cores is bound by the CPU all its processes need per frame, not by any one of them, so
`iguana run`'s summary and `iguana bench pipeline` report each process's CPU per frame (user and system time of all
its threads). The supervisor samples the CPU against the wall clock as the run goes; the window is chosen afterwards
from the bag: the recorder's receive times of the first and last iguana_state.
"""
from __future__ import annotations

import os
import time

from iguana_ros.supervisor.process import stat_fields


def process_cpu_s(pid: int) -> float | None:
    """Return user + system CPU seconds of process `pid` (all threads) so far; None if it is gone or has no /proc."""
    fields = stat_fields(pid)
    try:
        return (int(fields[11]) + int(fields[12])) / os.sysconf('SC_CLK_TCK')   # utime, stime in clock ticks
    except (TypeError, IndexError, ValueError, OSError):
        return None


class CpuWindow:
    """Each process's CPU seconds sampled against the wall clock (`time.time()`, s), by process name."""

    def __init__(self) -> None:
        """Start with no samples."""
        self.samples: dict[str, list[tuple[float, float]]] = {}

    def sample(self, pids: dict[str, int], now: float | None = None) -> None:
        """Note the CPU of every process in `pids` (name -> pid) at wall time `now` (default: the clock now)."""
        now = time.time() if now is None else now
        for name, pid in pids.items():
            cpu = process_cpu_s(pid)
            if cpu is not None:
                self.samples.setdefault(name, []).append((now, cpu))

    def ms_per_frame(self, start: float, end: float, frames: int) -> dict[str, float]:
        """
        Return CPU ms per frame of each process over the wall window [`start`, `end`] s that held `frames` frames.

        A process's CPU rate between its first and last sample inside the window, times the window's seconds per
        frame. A window too short to hold two of a process's samples (a run of a few frames) takes the rate between
        the samples just outside it; a process not sampled on both sides of it is left out.
        """
        out = {}
        if frames <= 0 or end <= start:
            return out
        for name, samples in self.samples.items():
            inside = [(t, cpu) for t, cpu in samples if start <= t <= end]
            if len(inside) < 2 or inside[-1][0] <= inside[0][0]:
                before = [sample for sample in samples if sample[0] <= start]
                after = [sample for sample in samples if sample[0] >= end]
                inside = [before[-1], after[0]] if before and after else []
            if len(inside) >= 2 and inside[-1][0] > inside[0][0]:
                rate = (inside[-1][1] - inside[0][1]) / (inside[-1][0] - inside[0][0])
                out[name] = 1e3 * rate * (end - start) / frames
        return out


def cpu_line(ms_per_frame: dict[str, float]) -> str:
    """'CPU per frame while stepping: 25.1 ms (simulator_node 13.4, …)', busiest first ('' when nothing was sampled)."""
    if not ms_per_frame:
        return ''
    parts = ', '.join(f'{name} {ms:.1f}' for name, ms in sorted(ms_per_frame.items(), key=lambda kv: -kv[1]))
    return f'CPU per frame while stepping: {sum(ms_per_frame.values()):.1f} ms ({parts})'
