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
`iguana doctor`'s DDS checks.

A publish/subscribe loopback with a second process on this ROS_DOMAIN_ID, and the other participants already on that
domain (the rclpy graph after a discovery wait; other runs' processes from /proc, as `iguana run`'s own domain check
finds them).

The loopback is real DDS between two processes: this process publishes a token on doctor_ping every
PING_PERIOD_S, the echo process (`python -m iguana_ros.supervisor.doctor_dds`, started as a NodeProcess so it dies
with its parent) sends it back on doctor_pong.
"""
from __future__ import annotations

from dataclasses import dataclass
import os
import sys
import time
import uuid

from iguana_ros.doctor import Check
from iguana_ros.supervisor.domain_check import current_domain_id, DomainReport, DomainWatch, other_runs
from iguana_ros.supervisor.process import NodeProcess, stop_all

DOCTOR_NODE_NAME = 'iguana_doctor'
"""ROS node name of the doctor's own participant."""

ECHO_NODE_NAME = 'iguana_doctor_echo'
"""ROS node name of the echo process."""

PING_PERIOD_S = 0.2
"""Wall seconds between two pings while no echo has come back."""

LOOPBACK_TIMEOUT_S = 15.0
"""Wall seconds the loopback may take: the echo process's start (Python, rclpy) plus DDS discovery."""

DISCOVERY_WAIT_S = 3.0
"""Wall seconds on the graph before other participants are listed (Fast DDS re-announces every 3 s)."""

ECHO_LIFETIME_S = 60.0
"""Wall seconds after which the echo process leaves by itself (its parent stops it long before)."""

DISCOVERY_RANGE_ENV = 'ROS_AUTOMATIC_DISCOVERY_RANGE'
"""Environment variable that limits DDS discovery (LOCALHOST, SUBNET, OFF, SYSTEM_DEFAULT)."""


@dataclass(frozen=True)
class LoopbackResult:
    """How the loopback went: whether the token came back, after how many wall seconds, and why not."""

    ok: bool
    seconds: float
    why: str = ''


def echo_main(lifetime_s: float = ECHO_LIFETIME_S) -> int:
    """Return the echo process: send every doctor_ping back on doctor_pong until SIGINT/SIGTERM or `lifetime_s`."""
    import rclpy
    from rclpy.executors import ExternalShutdownException

    from iguana_ros.ros.endpoints import resolve

    rclpy.init()
    node = rclpy.create_node(ECHO_NODE_NAME)
    name, cls, qos = resolve('doctor_pong')
    pong = node.create_publisher(cls, name, qos)
    name, cls, qos = resolve('doctor_ping')
    node.create_subscription(cls, name, pong.publish, qos)
    deadline = time.monotonic() + lifetime_s
    try:
        while rclpy.ok() and time.monotonic() < deadline:
            rclpy.spin_once(node, timeout_sec=0.1)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


def loopback(watch: DomainWatch, timeout: float = LOOPBACK_TIMEOUT_S) -> LoopbackResult:
    """Start the echo process and ping it from `watch`'s node until the token comes back or `timeout` s pass."""
    from rclpy.executors import SingleThreadedExecutor

    from iguana_ros.ros.endpoints import resolve

    token = f'{os.getpid()}-{uuid.uuid4().hex}'
    echoed: list[str] = []
    name, cls, qos = resolve('doctor_ping')
    ping = watch.node.create_publisher(cls, name, qos)
    name, cls, qos = resolve('doctor_pong')
    watch.node.create_subscription(cls, name, lambda msg: echoed.append(msg.data), qos)
    executor = SingleThreadedExecutor(context=watch.context)
    executor.add_node(watch.node)
    echo = NodeProcess([sys.executable, '-m', 'iguana_ros.supervisor.doctor_dds'], 'doctor_echo')
    start = time.monotonic()
    try:
        echo.start()
        next_ping = start
        while token not in echoed:
            now = time.monotonic()
            if now - start > timeout:
                return LoopbackResult(False, now - start, f'no echo within {timeout:g} s')
            if not echo.running:
                return LoopbackResult(False, now - start, f'the echo process exited ({echo.tail(3) or "no output"})')
            if now >= next_ping:
                ping.publish(cls(data=token))
                next_ping = now + PING_PERIOD_S
            executor.spin_once(timeout_sec=0.02)
        return LoopbackResult(True, time.monotonic() - start)
    finally:
        stop_all([echo], 3.0)
        executor.remove_node(watch.node)
        executor.shutdown()


def loopback_fix() -> str:
    """Return what to change when two processes on this machine cannot reach each other over DDS."""
    scope = os.environ.get(DISCOVERY_RANGE_ENV, '').strip().upper()
    if scope == 'OFF':
        return f'{DISCOVERY_RANGE_ENV}=OFF turns discovery off: export {DISCOVERY_RANGE_ENV}=LOCALHOST'
    hints = [f'export {DISCOVERY_RANGE_ENV}=LOCALHOST (processes on this machine only)']
    for name in ('FASTRTPS_DEFAULT_PROFILES_FILE', 'FASTDDS_DEFAULT_PROFILES_FILE', 'ROS_STATIC_PEERS'):
        if os.environ.get(name):
            hints.append(f'check or unset {name}={os.environ[name]}')
    hints.append('let UDP through on the loopback interface (ports 7400-7500 for domains 0-1) and keep /dev/shm '
                 'writable')
    return '; '.join(hints)


def check_loopback(result: LoopbackResult, domain: str) -> Check:
    """Return the loopback's Check line."""
    name = f'DDS loopback on ROS_DOMAIN_ID {domain}'
    if result.ok:
        return Check(name, True, f'a second process echoed a message in {result.seconds:.2f} s '
                     '(start-up and discovery included)')
    scope = os.environ.get(DISCOVERY_RANGE_ENV, '') or 'unset'
    return Check(name, False, f'{result.why}: processes cannot reach each other over DDS '
                 f'({DISCOVERY_RANGE_ENV} {scope})', loopback_fix())


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


def check_loopback_now(timeout: float = LOOPBACK_TIMEOUT_S) -> Check:
    """Return the loopback check alone (what `iguana run` asks when it hears nothing of its nodes)."""
    watch = DomainWatch((), DOCTOR_NODE_NAME)
    try:
        return check_loopback(loopback(watch, timeout), current_domain_id())
    finally:
        watch.close()


if __name__ == '__main__':
    sys.exit(echo_main())
