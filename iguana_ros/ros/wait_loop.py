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
Lean wait loops in place of rclpy's executor, for the run's own processes.

rclpy's executor rebuilds its wait set from every entity of the node on each wake, wraps each callback in a task
and wakes once more after it (its guard condition): measured ~0.3 ms of Python per message on this VM, most of the
recorder's CPU and a third to a half of each node's. `ListenerLoop.spin_once` waits on a node's subscriptions
alone (the recorder, the run monitor); `NodeLoop` serves everything the iguana nodes have — subscriptions, guard
conditions, timers and services (the parameter services) — in the executor's order per wake (timers,
subscriptions, guard conditions, services). Both take every message that is in before they wait again; callbacks
are the entities' own, called as the executor calls them (message info where a subscription callback takes two
arguments). Waitables (rclpy's QoS event handlers) are not served: the nodes make their endpoints without them.
"""
from __future__ import annotations

from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.subscription import Subscription


class ListenerLoop:
    """Waits on the subscriptions of one rclpy node and runs their callbacks; timers and services are not served."""

    def __init__(self, node) -> None:
        """Serve `node`'s subscriptions (those it has at each `spin_once`)."""
        self.node = node
        self._subscriptions: list = []
        self._wants_info: list[bool] = []
        self._wait_set = None
        self._wake = _rclpy.GuardCondition(node.context.handle)   # never empty (rcl refuses to wait on nothing)

    def close(self) -> None:
        """Release the wait set and the wake-up guard condition (before the node's context shuts down)."""
        for handle in (self._wait_set, self._wake):
            if handle is not None:
                handle.destroy_when_not_in_use()
        self._wait_set = self._wake = None

    def wake(self) -> None:
        """Make a waiting `spin_once` return now (from another thread or a signal handler)."""
        self._wake.trigger_guard_condition()

    def _refresh(self) -> None:
        """Rebuild the wait set when the node's subscriptions changed (the recorder subscribes as topics appear)."""
        subscriptions = list(self.node.subscriptions)
        if subscriptions == self._subscriptions and self._wait_set is not None:
            return
        self._subscriptions = subscriptions
        self._wants_info = [s._callback_type is Subscription.CallbackType.WithMessageInfo   # rclpy's own reading
                            for s in subscriptions]
        self._wait_set = _rclpy.WaitSet(len(subscriptions), 1, 0, 0, 0, 0, self.node.context.handle)

    def spin_once(self, timeout_s: float) -> int:
        """Wait up to `timeout_s` for messages, then take and handle every one that is in; return how many."""
        self._refresh()
        wait_set = self._wait_set
        wait_set.clear_entities()
        for sub in self._subscriptions:
            wait_set.add_subscription(sub.handle)
        wait_set.add_guard_condition(self._wake)
        wait_set.wait(int(max(timeout_s, 0.0) * 1e9))
        ready = set(wait_set.get_ready_entities('subscription'))
        handled = 0
        for sub, info in zip(self._subscriptions, self._wants_info):
            if sub.handle.pointer in ready:
                handled += self._drain(sub, info)
        return handled

    @staticmethod
    def _drain(sub, wants_info: bool) -> int:
        """Take every message queued on `sub` and run its callback on each; return how many."""
        taken = 0
        while True:
            got = sub.handle.take_message(sub.msg_type, sub.raw)
            if got is None:
                return taken
            taken += 1
            if wants_info:
                sub.callback(*got)
            else:
                sub.callback(got[0])


class NodeLoop:
    """Single-threaded loop over the subscriptions, guard conditions, timers and services of some rclpy nodes."""

    def __init__(self, nodes: list, context) -> None:
        """Serve `nodes` (sharing `context`) until `context` shuts down."""
        self.nodes, self.context = list(nodes), context
        self._entities: tuple = ()
        self._wait_set = None

    def _refresh(self) -> tuple:
        """Return (subscriptions, guards, timers, services) now; a new wait set when their numbers changed."""
        entities = tuple([e for node in self.nodes for e in getattr(node, kind)]
                         for kind in ('subscriptions', 'guards', 'timers', 'services'))
        if self._wait_set is None or tuple(map(len, entities)) != tuple(map(len, self._entities)):
            subs, guards, timers, services = entities
            self._wait_set = _rclpy.WaitSet(len(subs), len(guards), len(timers), 0, len(services), 0,
                                            self.context.handle)
        self._entities = entities
        return entities

    def spin(self, poll_s: float = 0.25) -> None:
        """Serve until the context shuts down (checked at least every `poll_s` s)."""
        while self.context.ok():
            self.spin_once(poll_s)

    def spin_once(self, timeout_s: float) -> None:
        """Wait up to `timeout_s` for work, then do all of it that is ready."""
        subs, guards, timers, services = self._refresh()
        ws = self._wait_set
        ws.clear_entities()
        for sub in subs:
            ws.add_subscription(sub.handle)
        for gc in guards:
            ws.add_guard_condition(gc.handle)
        for tmr in timers:
            ws.add_timer(tmr.handle)
        for srv in services:
            ws.add_service(srv.handle)
        ws.wait(int(max(timeout_s, 0.0) * 1e9))
        ready_timers = set(ws.get_ready_entities('timer'))
        ready_subs = set(ws.get_ready_entities('subscription'))
        ready_guards = set(ws.get_ready_entities('guard_condition'))
        ready_services = set(ws.get_ready_entities('service'))
        for tmr in timers:
            if tmr.handle.pointer in ready_timers and tmr.handle.is_timer_ready():
                tmr.handle.call_timer()
                tmr.callback()
        for sub in subs:
            if sub.handle.pointer in ready_subs:
                ListenerLoop._drain(sub, sub._callback_type is Subscription.CallbackType.WithMessageInfo)
        for gc in guards:
            if gc.handle.pointer in ready_guards and gc.callback is not None:
                gc.callback()
        for srv in services:
            if srv.handle.pointer in ready_services:
                _serve(srv)

    def close(self) -> None:
        """Release the wait set."""
        if self._wait_set is not None:
            self._wait_set.destroy_when_not_in_use()
            self._wait_set = None


def _serve(srv) -> None:
    """Answer every request queued on service `srv` (as rclpy's executor does)."""
    while True:
        request, header = srv.handle.service_take_request(srv.srv_type.Request)
        if header is None:
            return
        srv.send_response(srv.callback(request, srv.srv_type.Response()), header)
