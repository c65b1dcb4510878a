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
Strangers on the graph at start-up: subscribers and publishers on every topic of the table, of other nodes.

What `ros2 topic echo`, Foxglove, RViz2 or a plotter does to a run: subscribe to its topics, and create publishers
of the inputs (goal_pose, route, push) it may never use. A trial starts one stray process at a drawn moment before or
during the start of `iguana run` on a small scene, holding endpoints of one of STRAY_MODES under a drawn QoS variant
(the table's, best effort, transient local, a deep history). With strays of the 'readers' and 'inputs' modes the run
must complete as it would alone: exit status 0, `run completed`, every frame in the bag, the scene goal recorded once,
no lockstep time-out, within RUN_LIMIT_S (the probe's stranger on goal_pose made 2 of 6 runs wait 60 s and 1 fail).
Publishers of the run's outputs ('outputs': another run, a bag played into the domain) would mix foreign messages
into the run: it refuses the busy domain in one line (`supervisor/domain_check.py`) unless it was already done.
"""
from __future__ import annotations

import argparse
from dataclasses import asdict, dataclass, field
import os
from pathlib import Path
import random
import signal
import sys
import time

from iguana_lab.faults.processes import trial_folder
from iguana_ros.constants import FRAME_RATE
from iguana_ros.supervisor.process import NodeProcess, wait_for

STRAY_MODES = ('readers', 'inputs', 'outputs')
"""What a stray holds: a subscriber on every topic; those and a publisher of every input topic (no node of the
package publishes it); a publisher of every output topic (one the package's nodes publish)."""

QOS_VARIANTS = ('table', 'best_effort', 'transient_local', 'deep')
"""How a stray's endpoints ask: the table's QoS, best effort, transient local, or the table's with depth 100."""

TRIAL_SCENE = {'name': 'strays', 'model': {'resolution': 'coarse'}, 'terrain': {'kind': 'flat'},
               'goals': [{'x': 1.0, 'y': 0.0, 'at': 0.0}], 'duration': 2.0}
"""The scene of every trial: a 2 s walk on the coarse body."""

LATEST_STRAY_S = 6.0
"""Latest moment the strays appear, wall seconds after `iguana run` is launched (start-up takes ~5-7 s)."""

RUN_LIMIT_S = 90.0
"""A trial's `iguana run` must end within this many wall seconds (alone it takes ~10-15 s on two busy cores)."""

READY_LINE = 'strays ready'
"""What the stray process prints once its endpoints exist."""


@dataclass
class StrayTrial:
    """One trial: its index, QoS variant, when the strays appeared (s after launch, negative: before) and the result."""

    index: int
    mode: str
    qos: str
    moment_s: float
    exit_code: int | None = None
    wall_s: float = 0.0
    frames: int = 0
    goals_recorded: int = 0
    last_line: str = ''
    problems: list = field(default_factory=list)

    @property
    def survived(self) -> bool:
        """Return whether the run was as it is alone."""
        return not self.problems


def stray_main(argv: list[str] | None = None) -> int:
    """Hold the endpoints of `--mode` (STRAY_MODES) under `--qos` (QOS_VARIANTS) until SIGINT/SIGTERM."""
    parser = argparse.ArgumentParser(prog='strays')
    parser.add_argument('--mode', choices=STRAY_MODES, default='readers')
    parser.add_argument('--qos', choices=QOS_VARIANTS, default='table')
    args = parser.parse_args(argv)
    import rclpy
    from rclpy.qos import DurabilityPolicy, ReliabilityPolicy
    from rclpy.signals import SignalHandlerOptions

    from iguana_ros.ros.endpoints import resolve
    from iguana_ros.topics import load_topics

    stop = [False]
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda _s, _f: stop.__setitem__(0, True))
    rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
    node = rclpy.create_node(f'stray_{os.getpid()}')
    for key, spec in load_topics().items():
        name, cls, qos = resolve(key)
        if args.qos == 'best_effort':
            qos.reliability = ReliabilityPolicy.BEST_EFFORT
        elif args.qos == 'transient_local':
            qos.durability = DurabilityPolicy.TRANSIENT_LOCAL
        elif args.qos == 'deep':
            qos.depth = 100
        output = bool(spec.publisher_nodes)
        if args.mode != 'outputs':
            node.create_subscription(cls, name, lambda _m: None, qos)
        if (args.mode == 'inputs' and not output) or (args.mode == 'outputs' and output):
            node.create_publisher(cls, name, qos)
    print(READY_LINE, flush=True)
    while not stop[0] and rclpy.ok():
        rclpy.spin_once(node, timeout_sec=0.1)
    node.destroy_node()
    rclpy.try_shutdown()
    return 0


def run_trial(index: int, mode: str, qos: str, moment_s: float, workdir: Path) -> StrayTrial:
    """Launch `iguana run` on the trial scene, start the strays `moment_s` s after (before, if negative), check it."""
    trial = StrayTrial(index, mode, qos, moment_s)
    folder, scene, bag = trial_folder(workdir, index, TRIAL_SCENE)
    strays = NodeProcess([sys.executable, '-m', 'iguana_lab.faults.strays', '--mode', mode, '--qos', qos], 'strays',
                         folder)
    run = NodeProcess([sys.executable, '-m', 'iguana_ros.cli', 'run', str(scene), '--record', str(bag)], 'iguana_run',
                      folder)
    try:
        if moment_s < 0:
            strays.start(ready=READY_LINE, timeout=60)
        launched = time.monotonic()
        run.start()
        if moment_s >= 0:
            wait_for(lambda: not run.running, moment_s, 0.05)
            strays.start()
        if not wait_for(lambda: not run.running, RUN_LIMIT_S, 0.1):
            trial.problems.append(f'iguana run still running after {RUN_LIMIT_S:g} s')
            run.kill()
        trial.wall_s = round(time.monotonic() - launched, 1)
    finally:
        for proc in (run, strays):
            if proc.proc is not None and proc.running:
                proc.stop()
    trial.exit_code = run.proc.returncode
    _check(trial, run.output, bag)
    return trial


def _check(trial: StrayTrial, output: str, bag: Path) -> None:
    """
    Check the run against what it does alone.

    Exit status 0, run completed, every frame and the scene goal once in the bag, no lockstep time-out; or, for
    'outputs' strays, possibly refused in one line naming the busy domain (with a finalised bag, or no bag when
    refused before anything started).
    """
    from iguana_ros.bag.storage import BagReader
    lines = [line for line in output.splitlines() if line.startswith('iguana run:')]
    trial.last_line = lines[-1] if lines else ''
    if trial.mode == 'outputs' and trial.exit_code == 1:
        # refused once running (the bag finalised), or, when the strays were up before the run's domain check
        # finished (a slow start under load), before anything started: then there is no bag at all
        finalised = 'bag finalised' in (lines[0] if lines else '') or not bag.exists()
        if len(lines) != 1 or 'is in use' not in lines[0] or not finalised:
            trial.problems.append(f'refused, but not in one line naming the busy domain: {lines}')
        return
    if trial.exit_code != 0:
        trial.problems.append(f'exit status {trial.exit_code}: {trial.last_line}')
    if not any(line.startswith('run completed') for line in output.splitlines()):
        trial.problems.append('no "run completed" line')
    if 'lockstep: no spring_rest_lengths' in output or 'timed out' in output:
        trial.problems.append('a lockstep time-out')
    try:
        topics = [m.topic for m in BagReader(bag).messages()]
    except Exception as exc:  # noqa: BLE001 -- an unreadable bag is this trial's finding, whatever raised
        trial.problems.append(f'bag unreadable: {exc}')
        return
    trial.frames, trial.goals_recorded = topics.count('/iguana_state'), topics.count('/goal_pose')
    expected = int(round(TRIAL_SCENE['duration'] * FRAME_RATE)) + 1
    if trial.frames != expected:
        trial.problems.append(f'{trial.frames} iguana_state messages in the bag, expected {expected}')
    if trial.goals_recorded != 1:
        trial.problems.append(f'{trial.goals_recorded} goal_pose messages in the bag, expected the scene goal once')


def plan_trials(n: int, seed: int) -> list[tuple[str, str, float]]:
    """
    Return `n` seeded (mode, QoS variant, moment) plans.

    Every mode x variant in turn, 'readers' and 'inputs' twice as often as 'outputs'; the moment in
    [-1, LATEST_STRAY_S].
    """
    rng = random.Random(seed)
    plans = [(m, q) for m in ('readers', 'inputs', 'readers', 'inputs', 'outputs') for q in QOS_VARIANTS]
    return [(*plans[i % len(plans)], round(rng.uniform(-1.0, LATEST_STRAY_S), 2)) for i in range(n)]


def stray_suite(trials: int, seed: int, workdir: Path, progress=None) -> dict:
    """Run `trials` seeded trials; the figures ({trials, survived, wall_s, rows}). `progress(trial)` after each."""
    started = time.monotonic()
    rows = []
    for index, (mode, qos, moment) in enumerate(plan_trials(trials, seed)):
        rows.append(run_trial(index, mode, qos, moment, workdir))
        if progress is not None:
            progress(rows[-1])
    return {'suite': 'strays', 'trials': len(rows), 'seed': seed, 'survived': sum(t.survived for t in rows),
            'refused': sum(t.exit_code == 1 and t.survived for t in rows),
            'wall_s': round(time.monotonic() - started, 1),
            'max_run_wall_s': max((t.wall_s for t in rows), default=0),
            'rows': [asdict(t) for t in rows]}


def trial_line(trial: StrayTrial) -> str:
    """One line per trial."""
    verdict = 'ok' if trial.survived else 'FAILED: ' + '; '.join(trial.problems)
    return (f'strays {trial.index:3d} {trial.mode:7s} qos {trial.qos:15s} at {trial.moment_s:5.2f} s: '
            f'{trial.wall_s:5.1f} s, '
            f'{trial.frames} frames, {trial.goals_recorded} goal: {verdict}')


if __name__ == '__main__':
    sys.exit(stray_main())
