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
The sweep engine: independent tasks run on a Dask distributed cluster, one row (a JSON-able dict) per task.

A local cluster of worker processes by default (`dask.distributed.LocalCluster`, one single-threaded worker per
core, each with a memory limit), or the workers of a running scheduler (`dask scheduler` / `dask worker ADDRESS`
on other machines). Every worker process first compiles or loads the compiled kernels under the kernel-cache lock
(iguana_lab.sweep.kernels), so workers never compile into the cache at once. A task that raises gives an error row
(its identity, `error`, `error_type`, `wall_s`); a worker that dies (killed, out of memory) gives an error row of
type `KilledWorker` after Dask's retry; neither ends the sweep. Rows come back in task order whatever the number of
workers or the order they finish in.
"""
from __future__ import annotations

from collections.abc import Callable, Iterator
import contextlib
from dataclasses import dataclass
import hashlib
import json
import math
import os
import sys
import time
from typing import Any, NamedTuple

from iguana_ros.errors import IguanaError, InputError

DEFAULT_MEMORY_LIMIT = '3GiB'
"""Memory limit of each local worker process (Dask's nanny restarts a worker above 95 % of it); a fine-mesh
run of 600 s keeps ~0.6 GB of trajectories."""
ENGINE_FAILURES = ('KilledWorker', 'NoWorkerError', 'FutureCancelledError', 'CancelledError', 'CommClosedError')
"""`error_type`s of rows whose task the engine lost (not a result of the task: retried by a resumed sweep)."""
RETRIES_AFTER_WORKER_DEATH = 1
"""Times a task whose worker died is run again on another worker before its row records the death. A local
scheduler gives each worker one task at a time (worker-saturation 1.0), so a dying worker takes no queued
innocent task with it."""
CONNECT_TIMEOUT = '20s'
"""How long to wait for a scheduler given by address."""
NO_WORKERS_TIMEOUT = '5 minutes'
"""How long a local cluster's tasks wait while it has no worker (a nanny that could not restart its worker on an
overloaded machine) before they fail as NoWorkerError rows instead of the sweep waiting for ever."""


class Task(NamedTuple):
    """
    One task: `fn(*args)` on a worker, returning a JSON-able row.

    `key` identifies the inputs (the same inputs always give the same key: resume and Dask keys), `identity` the row
    fields that say what ran (kept in an error row), `label` a short name (shown by the progress bar for the last
    finished task).
    """

    key: str
    fn: Callable[..., Any]
    args: tuple
    identity: dict
    label: str


def _as_rows(results: list) -> list[dict]:
    """Rows of tasks whose results are their rows."""
    return list(results)


class Plan(NamedTuple):
    """
    A sweep ready to run.

    Its `tasks` in order, `rows(results)` turning the results of the first tasks (in task order) into table rows (the
    rows of a longer prefix extend those of a shorter one), and the `timing` columns of those rows (measurements of the
    machine, not of the task: they differ between runs).
    """

    tasks: list
    rows: Callable[[list], list[dict]] = _as_rows
    timing: tuple = ()


@dataclass(frozen=True)
class Cluster:
    """
    Where tasks run.

    Tasks run at the `scheduler` address ('tcp://host:8786'; None = a local cluster of `workers` processes, default one
    per core); `memory_limit` is each local worker's limit (bytes, '3GiB', or 0 = none).
    """

    workers: int | None = None
    scheduler: str | None = None
    memory_limit: str | int = DEFAULT_MEMORY_LIMIT

    def describe(self) -> str:
        """'2 local workers (3GiB each)' or 'scheduler tcp://...'."""
        if self.scheduler:
            return f'scheduler {self.scheduler}'
        n = self.local_workers()
        return f'{n} local worker{"s" * (n != 1)} ({self.memory_limit or "no limit"} each)'

    def local_workers(self) -> int:
        """Worker processes of a local cluster."""
        return self.workers if self.workers is not None else (len(os.sched_getaffinity(0)) or 1)


def task_key(*parts: Any) -> str:
    """Return a stable 16-hex-digit key of JSON-able `parts` (dataclasses as their fields)."""
    text = json.dumps(parts, sort_keys=True, default=_plain, separators=(',', ':'))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _plain(value: Any) -> Any:
    """JSON form of a dataclass or tuple-like value for `task_key`."""
    import dataclasses

    if dataclasses.is_dataclass(value):
        return dataclasses.asdict(value)
    raise TypeError(f'task_key: cannot encode {type(value).__name__}')


def error_row(identity: dict, exc: BaseException, wall: float) -> dict:
    """Return the row of a task that raised `exc`: what ran, `error` (one line), `error_type`, `wall_s`."""
    message = ' '.join(str(exc).split()) or type(exc).__name__
    return {**identity, 'error': message, 'error_type': type(exc).__name__, 'wall_s': wall}


def is_engine_failure(row: dict) -> bool:
    """Whether `row` records a task lost by the engine (a dead worker) rather than the task's own outcome."""
    return row.get('error_type') in ENGINE_FAILURES


def execute(task: Task) -> Any:
    """
    Run `task` on this process (a worker).

    Kernels warmed once, then `fn(*args)`; an exception gives its error row.
    """
    from iguana_lab.sweep.kernels import warm_kernels

    warm_kernels()
    start = time.perf_counter()
    try:
        return task.fn(*task.args)
    except Exception as exc:                      # noqa: BLE001 - the row records the failure
        return error_row(task.identity, exc, time.perf_counter() - start)


def run_tasks(tasks: list[Task], cluster: Cluster = Cluster(),
              on_result: Callable[[int, Any], None] | None = None, progress: bool = False) -> list:
    """
    Return the result of every task, in task order, computed on `cluster`.

    `on_result(index, result)` is called as each task finishes (in finishing order); `progress` shows a bar with
    the ETA on stderr. Raises IguanaError if the cluster cannot be started or reached.
    """
    if not tasks:
        return []
    results: list = [None] * len(tasks)
    with _client(cluster, len(tasks)) as client, _bar(len(tasks), progress) as bar:
        futures = {client.submit(execute, task, key=f'iguana-{k}-{task.key}', pure=False): k
                   for k, task in enumerate(tasks)}
        from distributed import as_completed

        for future in as_completed(futures):
            k = futures[future]
            results[k] = _outcome(future, tasks[k])
            future.release()
            if on_result is not None:
                on_result(k, results[k])
            bar.set_postfix_str(tasks[k].label[:48], refresh=False)
            bar.update(1)
    return results


def _outcome(future, task: Task) -> Any:
    """Return a finished future's result, or the error row of a task the engine lost (its worker died)."""
    try:
        return future.result()
    except Exception as exc:                      # noqa: BLE001 - KilledWorker, a lost connection, ...
        return error_row(task.identity, exc, math.nan)


@contextlib.contextmanager
def _client(cluster: Cluster, n_tasks: int) -> Iterator:
    """Yield a Dask client of a new local cluster (closed on exit, workers stopped) or of `cluster.scheduler`."""
    import dask
    from distributed import Client, LocalCluster

    with dask.config.set({'distributed.scheduler.allowed-failures': RETRIES_AFTER_WORKER_DEATH,
                          'distributed.scheduler.worker-saturation': 1.0,
                          'distributed.scheduler.no-workers-timeout': NO_WORKERS_TIMEOUT}):
        if cluster.scheduler:
            try:
                client = Client(cluster.scheduler, timeout=CONNECT_TIMEOUT)
            except (OSError, TimeoutError) as exc:
                raise IguanaError(f'cannot reach the Dask scheduler at {cluster.scheduler}: '
                                  f'{" ".join(str(exc).split()) or type(exc).__name__}') from None
            with client:
                yield client
            return
        workers = min(cluster.local_workers(), n_tasks)
        if workers < 1:
            raise InputError(f'workers must be at least 1, got {workers}')
        with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, memory_limit=cluster.memory_limit,
                          dashboard_address=None, scheduler_kwargs={'dashboard_address': '127.0.0.1:0'},
                          silence_logs=50) as local, Client(local) as client:   # health page on a free port
            yield client


class _NoBar:
    """Stand-in for a tqdm bar when no progress is shown."""

    def update(self, n: int) -> None:
        """Nothing."""

    def set_postfix_str(self, text: str, refresh: bool = True) -> None:
        """Nothing."""


@contextlib.contextmanager
def _bar(total: int, show: bool) -> Iterator:
    """Yield a tqdm progress bar with ETA on stderr (or nothing)."""
    if not show:
        yield _NoBar()
        return
    from tqdm import tqdm

    with tqdm(total=total, unit='task', file=sys.stderr, dynamic_ncols=True) as bar:
        yield bar


def in_order(callback: Callable[[int, Any], None]) -> Callable[[int, Any], None]:
    """Return an `on_result` that hands results to `callback(index, result)` in task order (buffering early ones)."""
    pending: dict[int, Any] = {}
    state = {'next': 0}

    def deliver(index: int, result: Any) -> None:
        pending[index] = result
        while state['next'] in pending:
            k = state['next']
            callback(k, pending.pop(k))
            state['next'] = k + 1
    return deliver


def row_stream(plan: Plan, show: Callable[[dict], None]) -> Callable[[int, Any], None]:
    """
    Return an `on_result` that calls `show(row)` for each table row of `plan`, in table order.

    Each row is shown as soon as the results it needs (those of every earlier task) are in.
    """
    results: list = []
    shown = {'n': 0}

    def arrived(_index: int, result: Any) -> None:
        results.append(result)
        rows = plan.rows(results)
        for row in rows[shown['n']:]:
            show(row)
        shown['n'] = len(rows)
    return in_order(arrived)


def parallel_map(fn: Callable, arguments: list[tuple], workers: int | None = None,
                 progress: Callable[[Any, int, int], None] | None = None,
                 identity: Callable[[tuple], dict] = lambda args: {}) -> list:
    """
    `fn(*args)` for every tuple of `arguments` on a local cluster of `workers` processes, results in order.

    `progress(result, n_done, n_total)` is called as each finishes; a call that raises (or whose worker dies)
    gives `error_row(identity(args), ...)` as its result.
    """
    tasks = [Task(task_key(k, fn.__module__, fn.__qualname__), fn, tuple(args), identity(tuple(args)), str(k))
             for k, args in enumerate(arguments)]
    return run_local(tasks, workers, progress)


def run_local(tasks: list[Task], workers: int | None = None,
              progress: Callable[[Any, int, int], None] | None = None) -> list:
    """
    Run `run_tasks` on a local cluster of `workers` processes (default one per core); results in task order.

    `progress(result, n_done, n_total)` is called as each task finishes (in finishing order).
    """
    done = {'n': 0}

    def report(_index: int, result: Any) -> None:
        done['n'] += 1
        if progress is not None:
            progress(result, done['n'], len(tasks))
    return run_tasks(tasks, Cluster(workers=workers), on_result=report)
