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
A lean wait loop in place of rclpy's executor for nodes that only listen (the bag recorder, the run monitor).

rclpy's executor rebuilds its wait set from every entity of the node on each wake, wraps each callback in a task
and wakes once more after it (its guard condition): most of the recorder's CPU in a profile of a node run.
`ListenerLoop.spin_once` waits on a node's subscriptions alone and takes every message that is in before it waits
again; callbacks are the subscriptions' own, called as the executor calls them (message info where a callback
takes two arguments).
"""
from __future__ import annotations

import gc

from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.subscription import Subscription


def settle_heap() -> None:
    """
    Collect the start-up garbage, then move every survivor out of the collector's generations (`gc.freeze`).

    A process's start (numba, scipy, rclpy, the model) leaves hundreds of thousands of long-lived objects; a full
    collection in the frame loop would walk them all (~35-50 ms in the simulator node). Call once, just before spinning.
    """
    gc.collect()
    gc.freeze()


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
