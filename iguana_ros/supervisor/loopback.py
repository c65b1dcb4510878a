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
The DDS loopback, which asks whether two processes on this ROS_DOMAIN_ID reach each other.

Real DDS between two processes: this process publishes a token on doctor_ping every PING_PERIOD_S, the echo process
(`python -m iguana_ros.supervisor.loopback`, started as a NodeProcess so it dies with its parent) sends it back on
doctor_pong. `iguana run` asks it when it hears none of its nodes; `iguana doctor` reports it (doctor/dds.py).
"""
from __future__ import annotations

from dataclasses import dataclass
import os
import sys
import time
import uuid

from iguana_ros.doctor.checks import Check, DISCOVERY_ENV
from iguana_ros.supervisor.domain_check import current_domain_id, DomainWatch
from iguana_ros.supervisor.process import NodeProcess, stop_all

DOCTOR_NODE_NAME = 'iguana_doctor'
"""ROS node name of the doctor's own participant."""

ECHO_NODE_NAME = 'iguana_doctor_echo'
"""ROS node name of the echo process."""

PING_PERIOD_S = 0.2
"""Wall seconds between two pings while no echo has come back."""

LOOPBACK_TIMEOUT_S = 15.0
"""Wall seconds the loopback may take: the echo process's start (Python, rclpy) plus DDS discovery."""

ECHO_LIFETIME_S = 60.0
"""Wall seconds after which the echo process leaves by itself (its parent stops it long before)."""


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
    echo = NodeProcess([sys.executable, '-m', 'iguana_ros.supervisor.loopback'], 'doctor_echo')
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
    scope = os.environ.get(DISCOVERY_ENV, '').strip().upper()
    if scope == 'OFF':
        return f'{DISCOVERY_ENV}=OFF turns discovery off: export {DISCOVERY_ENV}=LOCALHOST'
    hints = [f'export {DISCOVERY_ENV}=LOCALHOST (processes on this machine only)']
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
    scope = os.environ.get(DISCOVERY_ENV, '') or 'unset'
    return Check(name, False, f'{result.why}: processes cannot reach each other over DDS '
                 f'({DISCOVERY_ENV} {scope})', loopback_fix())


def check_loopback_now(timeout: float = LOOPBACK_TIMEOUT_S) -> Check:
    """Return the loopback check alone (what `iguana run` asks when it hears nothing of its nodes)."""
    watch = DomainWatch((), DOCTOR_NODE_NAME)
    try:
        return check_loopback(loopback(watch, timeout), current_domain_id())
    finally:
        watch.close()


if __name__ == '__main__':
    sys.exit(echo_main())
