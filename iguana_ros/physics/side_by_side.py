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
Independent pieces of work stepped side by side on the process's cores, the same way every time.

The soft body's step kernels release the GIL, so threads run bodies that do not interact in parallel. The work is
split by a fixed rule (`partition`: greedy by cost, no dynamic schedule) and worker 0 is the caller's own thread; each
piece's result is the same whichever thread runs it, so a run is bit for bit the one-thread run.
"""
from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor, wait
import os
from typing import Callable, TypeVar

T = TypeVar('T')

MAX_WORKERS = 4
"""Most threads `default_workers` gives (more bodies than cores gain nothing)."""


def default_workers() -> int:
    """Return the cores this process may run on, at most MAX_WORKERS."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, 'sched_getaffinity') else os.cpu_count() or 1
    return max(1, min(MAX_WORKERS, cores))


def partition(costs: list[float], workers: int) -> list[list[int]]:
    """
    Split tasks of `costs` among `workers`: largest first (ties by index), each to the least loaded worker.

    Returns each worker's task indices in order; worker 0 is the caller's own thread.
    """
    loads, shares = [0.0] * workers, [[] for _ in range(workers)]
    for task in sorted(range(len(costs)), key=lambda t: (-costs[t], t)):
        w = min(range(workers), key=lambda w: (loads[w], w))
        loads[w] += costs[task]
        shares[w].append(task)
    return [sorted(share) for share in shares]


class SideBySide:
    """Runs lists of independent tasks on `workers` threads (`partition`); `close` stops the helpers."""

    def __init__(self, workers: int | None = None) -> None:
        """Use `workers` threads (default `default_workers()`), the caller's one of them."""
        self.workers = default_workers() if workers is None else max(1, int(workers))
        self._pool = ThreadPoolExecutor(self.workers - 1, 'side_by_side') if self.workers > 1 else None

    def run(self, tasks: list[Callable[[], T]], costs: list[float]) -> list[T]:
        """Run every task (costs for the partition); return their results in task order, or raise the first error."""
        shares = partition(costs, min(self.workers, max(1, len(tasks)))) if self._pool is not None else \
            [list(range(len(tasks)))]
        helpers = [self._pool.submit(_run_share, tasks, share) for share in shares[1:] if share]
        try:
            results = _run_share(tasks, shares[0])
        finally:
            wait(helpers)                             # every helper ends before this returns (or raises)
        for done in helpers:
            results.update(done.result())
        return [results[t] for t in range(len(tasks))]

    def close(self) -> None:
        """Stop the helper threads."""
        if self._pool is not None:
            self._pool.shutdown()
            self._pool = None


def _run_share(tasks: list[Callable[[], T]], share: list[int]) -> dict[int, T]:
    """Run the tasks of `share` in order; return their results by index."""
    return {t: tasks[t]() for t in share}
