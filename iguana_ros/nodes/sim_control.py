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
Clients of the simulator's control services (sim/pause, sim/resume, sim/step, sim/reset).

One implementation for `iguana sim`, the viewer's buttons and IguanaCommander: `SimControlClient` on a node of the
caller, `call_sim` for a one-off call from a process of its own.
"""
from __future__ import annotations

from dataclasses import dataclass

import rclpy
from rclpy.signals import SignalHandlerOptions

from iguana_ros.errors import IguanaError
from iguana_ros.nodes.goal_sender import wait_spinning
from iguana_ros.ros.endpoints import release_context, resolve_service

SIM_COMMANDS = ('pause', 'resume', 'step', 'reset')
"""What the simulator's control services do, one service each (`sim_<command>` in topics.yaml)."""


@dataclass(frozen=True)
class SimReply:
    """A control service's answer: whether it did it, its message, and for a step the frame and time reached (s)."""

    success: bool
    message: str
    frame: int | None = None
    time: float | None = None


class SimControlClient:
    """The four control-service clients of one node (names relative to the node's namespace)."""

    def __init__(self, node) -> None:
        """Create the clients on `node`."""
        self.node = node
        self.clients = {}
        for command in SIM_COMMANDS:
            name, cls = resolve_service(f'sim_{command}')
            self.clients[command] = (node.create_client(cls, name), cls)

    def call_async(self, command: str, frames: int = 1):
        """Send `command` (one of SIM_COMMANDS; `frames` for a step); return the rclpy Future of its response."""
        if command not in self.clients:
            raise IguanaError(f'unknown simulation command {command!r}; expected one of {", ".join(SIM_COMMANDS)}')
        client, cls = self.clients[command]
        request = cls.Request()
        if command == 'step':
            request.frames = int(frames)
        return client.call_async(request)

    def ready(self, command: str) -> bool:
        """Return whether the simulator's `command` service is on the graph."""
        return self.clients[command][0].service_is_ready()

    @staticmethod
    def reply(response) -> SimReply:
        """Return the SimReply of a service response."""
        if hasattr(response, 'frame'):
            return SimReply(bool(response.success), response.message, int(response.frame), float(response.time))
        return SimReply(bool(response.success), response.message)

    def call(self, command: str, frames: int = 1, timeout: float = 10.0) -> SimReply:
        """Call `command` and spin the node until it answers; IguanaError if no simulator does within `timeout` s."""
        name = self.node.resolve_service_name(self.clients[command][0].srv_name)
        wait_spinning(lambda: self.ready(command), self.node, timeout, lambda: None,
                      lambda: f'no simulator offers {name} within {timeout:g} s (is `iguana run` running on this '
                              'ROS_DOMAIN_ID?)')
        future = self.call_async(command, frames)
        wait_spinning(future.done, self.node, timeout, lambda: None,
                      lambda: f'the simulator did not answer {name} within {timeout:g} s')
        return self.reply(future.result())


def call_sim(command: str, frames: int = 1, timeout: float = 10.0, namespace: str = '') -> SimReply:
    """Call one control service from a node of its own (`iguana sim`)."""
    context = rclpy.Context()
    rclpy.init(context=context, signal_handler_options=SignalHandlerOptions.NO)
    try:
        node = rclpy.create_node('iguana_sim', namespace=namespace, context=context)
        return SimControlClient(node).call(command, frames, timeout)
    finally:
        release_context(context)
