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
Who takes the simulator node's core during a node run, from the scheduler's own record.

``python tools/sched_trace.py [--scene hills] [--seconds 15] [--json]``

`perf record -e sched:sched_switch` traces every core while `iguana run` walks the scene (lockstep, recorded); the
threads of the run's processes are named from `/proc` while it runs. Over the walk (the longest stretch in which the
simulator node's thread is on a core at least half the time) it prints how busy that thread was, the cores' idle
share, how often the thread was preempted (switched out while runnable) and, per thread that took its core first,
how often and how long the simulator then waited to run again. A thread's CPU clock does not show that wait; py-spy
counts it as busy. Needs `perf` (Debian: linux-perf) allowed to trace the scheduler (root, or
kernel.perf_event_paranoid at -1); exits 1 with one line otherwise.
"""
from __future__ import annotations

import argparse
import collections
import json
import os
from pathlib import Path
import re
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import time
import typing

SIMULATOR = 'simulator_node'
SWITCH = re.compile(r'\[(\d+)\]\s+([\d.]+):\s+sched:sched_switch:\s+prev_comm=.*? prev_pid=(\d+) prev_prio=-?\d+ '
                    r'prev_state=(\S+) ==> next_comm=.*? next_pid=(\d+)')
"""One line of `perf script -F cpu,time,event,trace` for a sched_switch."""


class Switch(typing.NamedTuple):
    """One context switch: on `cpu` at `time` (s), thread `prev` (left in `state`) gave the core to `incoming`."""

    cpu: int
    time: float
    prev: int
    state: str
    incoming: int


def parse_switches(text: str) -> list[Switch]:
    """Return the context switches in `perf script` output, in time order."""
    out = [Switch(int(m[1]), float(m[2]), int(m[3]), m[4], int(m[5])) for m in map(SWITCH.search, text.splitlines())
           if m]
    return sorted(out, key=lambda s: s.time)


def run_stretches(switches: list[Switch], tid: int) -> list[tuple[float, float]]:
    """Return the (start, end) times of each stretch `tid` ran on a core."""
    out, start = [], None
    for s in switches:
        if s.incoming == tid:
            start = s.time
        elif s.prev == tid and start is not None:
            out.append((start, s.time))
            start = None
    return out


def busiest_window(stretches: list[tuple[float, float]], bin_s: float = 0.25, share: float = 0.5) -> tuple:
    """Return the longest (start, end) run of `bin_s` bins in which the stretches fill at least `share` of each."""
    if not stretches:
        return (0.0, 0.0)
    origin = stretches[0][0]
    busy = collections.defaultdict(float)
    for start, end in stretches:                     # split each stretch over the bins it spans
        b = int((start - origin) / bin_s)
        while start < end:
            edge = min(end, origin + (b + 1) * bin_s)
            busy[b] += edge - start
            start, b = edge, b + 1
    best, run_start, previous = (0, -1), None, None
    for b in sorted(k for k, v in busy.items() if v >= share * bin_s):
        run_start = b if previous is None or b != previous + 1 else run_start
        previous = b
        if b - run_start > best[1] - best[0]:
            best = (run_start, b)
    return (origin + best[0] * bin_s, origin + (best[1] + 1) * bin_s)


def preemptions(switches: list[Switch], tid: int, window: tuple) -> dict[int, list[float]]:
    """For each thread that took `tid`'s core when `tid` was preempted in `window`: the waits (s) until `tid` ran."""
    waits: dict[int, list[float]] = collections.defaultdict(list)
    since, first = None, None
    for s in switches:
        if s.prev == tid and s.state.startswith('R') and window[0] <= s.time <= window[1]:
            since, first = s.time, s.incoming
        elif s.incoming == tid and since is not None:
            waits[first].append(s.time - since)
            since = None
    return dict(waits)


def core_shares(switches: list[Switch], window: tuple) -> dict[int, float]:
    """Seconds each thread (0: idle) was on a core within `window`, summed over the cores."""
    shares: dict[int, float] = collections.defaultdict(float)
    on: dict[int, tuple[int, float]] = {}
    for s in switches:
        if s.cpu in on:
            tid, start = on[s.cpu]
            shares[tid] += max(0.0, min(s.time, window[1]) - max(start, window[0]))
        on[s.cpu] = (s.incoming, s.time)
    return dict(shares)


def thread_roles(root: int) -> dict[int, str]:
    """Thread id → 'process' or 'process/thread' for the threads of process `root` (`iguana run`) and its children."""
    roles = {}
    for pid in filter(str.isdigit, os.listdir('/proc')):
        try:
            args = Path(f'/proc/{pid}/cmdline').read_text().split('\0')
            process = _process_name(args)
            if process is None or not _descends_from(int(pid), root):
                continue
            for tid in os.listdir(f'/proc/{pid}/task'):
                name = Path(f'/proc/{pid}/task/{tid}/comm').read_text().strip()
                roles[int(tid)] = process if tid == pid else f'{process}/{name}'
        except OSError:
            continue
    return roles


def _descends_from(pid: int, root: int) -> bool:
    """Whether process `pid` is `root` or one of its descendants (by /proc's parent ids)."""
    while pid > 1:
        if pid == root:
            return True
        stat = Path(f'/proc/{pid}/stat').read_text()
        pid = int(stat[stat.rindex(')') + 2:].split()[1])
    return False


def _process_name(args: list[str]) -> str | None:
    """Role of a process from its command line: a node's module, the recorder, `iguana run`; None for others."""
    if '-m' in args and args.index('-m') + 1 < len(args):
        module = args[args.index('-m') + 1]
        if module.startswith('iguana_ros.nodes.'):
            return module.rsplit('.', 1)[-1]
        if module == 'iguana_ros.cli':
            return 'recorder' if 'bag' in args else 'iguana run'
    return 'iguana run' if any(a.endswith('/iguana') for a in args[:2]) and 'run' in args else None


def trace_run(scene: str, seconds: float, workdir: Path) -> tuple[str, dict[int, str], str]:
    """Run the scene under `perf record`; return (`perf script` text, thread roles, the run's output)."""
    data = workdir / 'sched.data'
    perf = subprocess.Popen(['perf', 'record', '-q', '-e', 'sched:sched_switch', '-a', '-o', str(data)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    time.sleep(1.0)
    if perf.poll() is not None:
        raise RuntimeError(f'perf record could not start: {perf.stderr.read().strip().splitlines()[-1:]}')
    env = {**os.environ, 'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST'}
    run = subprocess.Popen([sys.executable, '-m', 'iguana_ros.cli', 'run', scene, '--duration', str(seconds),
                            '--record', str(workdir / 'bag'), '--progress-every', '0'], env=env,
                           stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    roles: dict[int, str] = {}
    try:
        while run.poll() is None:
            roles.update(thread_roles(run.pid))
            time.sleep(0.1)
    finally:
        perf.send_signal(signal.SIGINT)
        perf.wait(timeout=60)
    output = run.communicate()[0]
    if run.returncode != 0:
        raise RuntimeError(f'iguana run failed: {output.strip().splitlines()[-1:]}')
    text = subprocess.run(['perf', 'script', '-i', str(data), '-F', 'cpu,time,event,trace'], capture_output=True,
                          text=True, check=True).stdout
    return text, roles, output


def analyse(switches: list[Switch], roles: dict[int, str]) -> dict:
    """Return the walk's window, the simulator's busy share, the idle share and its preemptions by first thread."""
    sim = next((tid for tid, role in roles.items() if role == SIMULATOR), None)
    if sim is None:
        raise RuntimeError('no simulator_node thread was seen')
    window = busiest_window(run_stretches(switches, sim))
    span = max(window[1] - window[0], 1e-9)
    shares = core_shares(switches, window)
    waits = preemptions(switches, sim, window)
    by_name: dict[str, list[float]] = collections.defaultdict(list)   # threads of one name (a pool) summed
    for tid, w in waits.items():
        by_name['idle' if tid == 0 else roles.get(tid, f'other thread {tid}')].extend(w)
    by_thread = {name: {'count': len(w), 'wait_total_s': sum(w), 'wait_median_us': 1e6 * statistics.median(w)}
                 for name, w in sorted(by_name.items(), key=lambda kv: -sum(kv[1]))}
    return {'window_s': span, 'simulator_busy_share': shares.get(sim, 0.0) / span,
            'idle_share_of_one_core': shares.get(0, 0.0) / span,
            'preemptions': sum(len(w) for w in waits.values()),
            'preempted_wait_s': sum(sum(w) for w in waits.values()), 'preempted_by': by_thread}


def main(argv: list | None = None) -> int:
    """Trace one run and print the figures (exit 1 with one line if perf or the run fails)."""
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument('--scene', default='hills')
    parser.add_argument('--seconds', type=float, default=15.0, help='simulated seconds (default 15)')
    parser.add_argument('--json', action='store_true')
    args = parser.parse_args(argv)
    if shutil.which('perf') is None:
        print('sched_trace: perf is not installed (Debian: linux-perf)', file=sys.stderr)
        return 1
    with tempfile.TemporaryDirectory(prefix='iguana_sched_') as tmp:
        try:
            text, roles, _ = trace_run(args.scene, args.seconds, Path(tmp))
            result = analyse(parse_switches(text), roles)
        except (RuntimeError, subprocess.SubprocessError, OSError) as exc:
            print(f'sched_trace: {exc}', file=sys.stderr)
            return 1
    if args.json:
        print(json.dumps(result, indent=1))
        return 0
    print(f"walk: {result['window_s']:.2f} s; simulator thread on a core {100 * result['simulator_busy_share']:.0f} % "
          f"of it; cores idle {100 * result['idle_share_of_one_core']:.0f} % of one core")
    print(f"preempted {result['preemptions']} times, waiting {1e3 * result['preempted_wait_s']:.0f} ms in all; "
          'by the thread that took its core first:')
    for thread, row in list(result['preempted_by'].items())[:12]:
        print(f"  {thread:40s} {row['count']:6d} times, {1e3 * row['wait_total_s']:7.1f} ms "
              f"(median {row['wait_median_us']:.0f} us)")
    return 0


if __name__ == '__main__':
    sys.exit(main())
