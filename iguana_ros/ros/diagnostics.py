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
Each node's health on `/diagnostics` (diagnostic_msgs/DiagnosticArray, 1 Hz), as rqt_robot_monitor and Foxglove read it.

A node counts its work in a `NodeHealth` (input frames handled, stale inputs dropped, inputs rejected with the last
reason, and for the simulator its simulated time); once a wall-clock second the node turns the counts since the last
report into one DiagnosticStatus: OK, or WARN when inputs were rejected or dropped as stale in that second, with the
rates and the realtime factor as values.
"""
from __future__ import annotations

from dataclasses import dataclass
import math

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from std_msgs.msg import Header

from iguana_ros.ros.conversions import time_to_msg

HARDWARE_ID = 'iguana_ros'
"""The `hardware_id` of every status: the simulated iguana."""

REPORT_PERIOD_S = 1.0
"""Wall seconds between two reports of a node."""


@dataclass
class NodeHealth:
    """
    A node's counters since its start.

    Input frames handled, stale inputs dropped, inputs rejected (and the last reason), simulated seconds (the
    simulator; NaN for the others) and whether the simulation is paused (the simulator's sim/pause).
    """

    frames: int = 0
    late: int = 0
    rejected: int = 0
    last_rejected: str = ''
    sim_time: float = math.nan
    paused: bool = False

    def reject(self, why: str) -> None:
        """Count a rejected input and keep its reason."""
        self.rejected += 1
        self.last_rejected = why[:200]


@dataclass(frozen=True)
class HealthSample:
    """The counters of a NodeHealth at one wall-clock time (s), to take the next report's differences from."""

    wall: float
    frames: int = 0
    late: int = 0
    rejected: int = 0
    sim_time: float = math.nan

    @classmethod
    def of(cls, health: NodeHealth, wall: float) -> HealthSample:
        """Return the sample of `health` at wall-clock time `wall`."""
        return cls(wall, health.frames, health.late, health.rejected, health.sim_time)


def health_status(node: str, health: NodeHealth, since: HealthSample, now: HealthSample) -> DiagnosticStatus:
    """Return the DiagnosticStatus of `node` for the counts between samples `since` and `now`."""
    seconds = max(now.wall - since.wall, 1e-9)
    rejected, late = now.rejected - since.rejected, now.late - since.late
    values = {'frames_per_s': f'{(now.frames - since.frames) / seconds:.2f}', 'frames': str(now.frames),
              'late_inputs': str(now.late), 'rejected_inputs': str(now.rejected)}
    if math.isfinite(now.sim_time):
        rtf = (now.sim_time - since.sim_time) / seconds if math.isfinite(since.sim_time) else 0.0
        values.update(simulated_s=f'{now.sim_time:.3f}', realtime_factor=f'{rtf:.2f}')
    if health.last_rejected:
        values['last_rejected'] = health.last_rejected
    problems = [f'{rejected} input{"s" * (rejected != 1)} rejected'] if rejected else []
    problems += [f'{late} stale input{"s" * (late != 1)} dropped'] if late else []
    level = DiagnosticStatus.WARN if problems else DiagnosticStatus.OK
    state = 'paused' if health.paused else 'running'
    return DiagnosticStatus(level=level, name=node, hardware_id=HARDWARE_ID,
                            message='; '.join(problems) + ' in the last report' if problems else state,
                            values=[KeyValue(key=k, value=v) for k, v in values.items()])


def diagnostics_msg(statuses: list[DiagnosticStatus], wall_time: float) -> DiagnosticArray:
    """Return the DiagnosticArray of `statuses`, stamped with the wall clock (s since the epoch)."""
    return DiagnosticArray(header=Header(stamp=time_to_msg(wall_time)), status=list(statuses))
