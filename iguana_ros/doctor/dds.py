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
`iguana doctor`'s DDS checks: the loopback between two processes, and the other participants already on the domain.

The other participants: the rclpy graph after a discovery wait, and other runs' processes from /proc, as `iguana
run`'s own domain check finds them. The loopback itself is the supervisor's (supervisor/loopback.py).
"""
from __future__ import annotations

import time

from iguana_ros.doctor.checks import Check
from iguana_ros.supervisor.domain_check import current_domain_id, DomainReport, DomainWatch, other_runs
from iguana_ros.supervisor.loopback import (check_loopback, DOCTOR_NODE_NAME, ECHO_NODE_NAME, loopback,
                                            LOOPBACK_TIMEOUT_S)

DISCOVERY_WAIT_S = 3.0
"""Wall seconds on the graph before other participants are listed (Fast DDS re-announces every 3 s)."""


def check_participants(others: list[str], domain: str, run_nodes: list[str], processes: list) -> Check:
    """Return the 'other participants' Check line: foreign nodes on the graph and other runs' processes."""
    name = f'other participants on ROS_DOMAIN_ID {domain}'
    if not others and not processes:
        return Check(name, True, f'none after {DISCOVERY_WAIT_S:g} s of discovery')
    parts = []
    if processes:
        parts.append(DomainReport(domain, processes=processes).findings())
    if others:
        named = ', '.join(others[:8]) + (f' and {len(others) - 8} more' if len(others) > 8 else '')
        parts.append(f'{len(others)} node{"s" * (len(others) != 1)}: {named}')
    clash = " (named like a run's own: iguana run would refuse this domain)" if run_nodes else ''
    pids = ' '.join(str(p.pid) for p in processes)
    stop = f'stop them (kill {pids})' if pids else 'stop them'
    return Check(name, False, '; '.join(parts) + clash + "; their traffic would mix with a run's",
                 f'{stop}, or use a domain of your own: export ROS_DOMAIN_ID=<0-101, not {domain}>')


def dds_checks(run_node_names: tuple[str, ...], timeout: float = LOOPBACK_TIMEOUT_S,
               discovery_s: float = DISCOVERY_WAIT_S) -> list[Check]:
    """
    Return the checks [loopback, other participants] on this process's ROS_DOMAIN_ID.

    `run_node_names` are the names a run's nodes have (found on the graph, they make `iguana run` refuse the domain).
    """
    domain = current_domain_id()
    watch = DomainWatch(run_node_names, DOCTOR_NODE_NAME)
    joined = time.monotonic()
    try:
        result = loopback(watch, timeout)
        time.sleep(max(0.0, discovery_s - (time.monotonic() - joined)))
        others = watch.other_nodes(own=(ECHO_NODE_NAME,))
    finally:
        watch.close()
    run_nodes = [n for n in others if n.rsplit('/', 1)[-1] in run_node_names]
    return [check_loopback(result, domain), check_participants(others, domain, run_nodes, other_runs(domain))]
