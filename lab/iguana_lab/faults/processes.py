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
Process fault injection.

Kill `iguana run` or one of its children (SIGKILL, SIGTERM, SIGINT) at a seeded random moment, and check what a user
would: no process of the run is left, the bag is readable, every message recorded before the fault is still in it, and
`iguana run` ended with one clear line (or, killed by SIGKILL, said nothing).

A trial runs the real `iguana run` CLI on a small scene (coarse mesh, flat ground) on the caller's ROS domain.
Just before the fault the growing bag is read (its complete chunks); after the run those messages must still be
there, in order. Leftovers are looked for in /proc: any process with the trial's marker (TRIAL_ENV) in its
environment, which everything started under the trial's `iguana run` inherits.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass, field
import json
import os
from pathlib import Path
import random
import shutil
import signal
import sys
import time

import yaml

from iguana_ros.supervisor.process import NodeProcess, processes_with_env, ProcessInfo, wait_for

TARGETS = ('iguana run', 'recorder', 'planner_node', 'terrain_adaptation_node', 'spring_length_node',
           'simulator_node')
"""What a trial kills: the supervisor or one of its five children."""

SIGNALS = (signal.SIGKILL, signal.SIGTERM, signal.SIGINT)
"""The signals a trial sends."""

TRIAL_SCENE = {'name': 'faults', 'model': {'resolution': 'coarse'}, 'terrain': {'kind': 'flat'},
               'goals': [{'x': 2.0, 'y': 0.0, 'at': 0.0}], 'duration': 20.0}
"""The scene of every trial: quick to start, long enough (20 s simulated, ~8 s wall) to be killed mid-run."""

LATEST_START_UP_FAULT_S = 10.0
"""Latest moment of a random fault during start-up, wall seconds after `iguana run` is launched (start-up takes
~7 s on two idle cores: domain check, recorder, four nodes loading, goals)."""

LATEST_RUNNING_FAULT_S = 5.0
"""Latest moment of a random fault while the run is under way, wall seconds after the bag first holds
iguana_state (the 20 s scene runs ~8 s)."""

ORPHAN_GRACE_S = 30.0
"""Wall seconds the run's processes get to exit after `iguana run` has (they get SIGTERM when it dies)."""

RUN_LIMIT_S = 120.0
"""Wall seconds a trial's `iguana run` may take before the trial calls it hung."""


@dataclass
class Trial:
    """One fault and what came of it. `problems` is empty when the trial survived."""

    index: int
    target: str
    signal: str
    moment_s: float
    phase: str = 'start-up'
    hit: bool = False
    fault_at_s: float = float('nan')
    exit_code: int | None = None
    last_line: str = ''
    orphans: list[str] = field(default_factory=list)
    bag_finalised: bool = False
    bag_messages: int = 0
    before_fault: int = 0
    lost: dict[str, int] = field(default_factory=dict)
    wall_s: float = 0.0
    problems: list[str] = field(default_factory=list)

    @property
    def survived(self) -> bool:
        """No orphan, nothing lost, a readable bag, a clear last line."""
        return not self.problems

    def line(self) -> str:
        """One line: what was killed when, and the verdict."""
        plan = f'{self.phase} +{self.moment_s:.1f} s'
        when = f'at {self.fault_at_s:.1f} s' if self.hit else 'not hit'
        verdict = 'ok' if self.survived else 'FAILED: ' + '; '.join(self.problems)
        return (f'#{self.index:02d} {self.signal:<7} {self.target:<24} {plan:<16} {when:<10} exit {self.exit_code}, '
                f'{self.before_fault} -> {self.bag_messages} messages: {verdict}')


TRIAL_ENV = 'IGUANA_FAULT_TRIAL'
"""Environment variable a trial gives `iguana run`; everything started under it inherits it, so /proc shows
whatever the trial left behind (whether or not `iguana run` marked it as its own)."""


def trial_processes(marker: str) -> list[ProcessInfo]:
    """Live processes whose environment has TRIAL_ENV=`marker`."""
    return processes_with_env(TRIAL_ENV, marker)


def read_growing_bag(bag: Path) -> dict[str, list[int]]:
    """{topic: receive times (ns) in file order} of the complete chunks of a bag that may still be written to."""
    from iguana_ros.bag.storage import BagReader
    from iguana_ros.errors import IguanaError
    try:
        reader = BagReader(bag)
        out: dict[str, list[int]] = {}
        for msg in reader.messages():
            out.setdefault(msg.topic, []).append(msg.log_time)
        return out
    except (IguanaError, OSError):
        return {}


def lost_messages(before: dict[str, list[int]], after: dict[str, list[int]]) -> dict[str, int]:
    """{topic: messages of `before` missing from the start of `after`}; empty if every one is still there."""
    lost = {}
    for topic, times in before.items():
        kept = after.get(topic, [])
        missing = len(times) - sum(1 for a, b in zip(times, kept) if a == b)
        if missing:
            lost[topic] = missing
    return lost


def _target_pid(run: NodeProcess, target: str, marker: str) -> int | None:
    """Pid of the trial's target if it is alive now (a child is found in /proc by its command line)."""
    if target == 'iguana run':
        return run.pid if run.running else None
    word = 'record' if target == 'recorder' else f'iguana_ros.nodes.{target}'
    for proc in trial_processes(marker):
        if proc.pid != run.pid and word in proc.command.split():
            return proc.pid
    return None


def _kill_leftovers(procs: list[ProcessInfo]) -> None:
    """SIGKILL leftover processes (after they were reported), so one trial does not spoil the next."""
    for proc in procs:
        try:
            os.kill(proc.pid, signal.SIGKILL)
        except (ProcessLookupError, PermissionError):
            pass


def trial_folder(workdir: Path, index: int, scene: dict) -> tuple[Path, Path, Path]:
    """Return (a fresh folder for trial `index` under `workdir`, the `scene` written there, the bag's path)."""
    folder = workdir / f'trial_{index:02d}'
    shutil.rmtree(folder, ignore_errors=True)
    folder.mkdir(parents=True)
    path = folder / f'{scene.get("name", "scene")}.yaml'
    path.write_text(yaml.safe_dump(scene))
    return folder, path, folder / 'bag'


def run_trial(index: int, target: str, sig: int, moment_s: float, workdir: Path, domain_id: str | None = None,
              under_way: bool = False, before_fault: Callable[[Path], None] | None = None) -> Trial:
    """
    Launch `iguana run` on the trial scene, send `sig` to `target` and check the aftermath.

    The signal goes `moment_s` wall seconds after launch or, with `under_way`, once the bag holds the iguana_state of a
    simulated frame, not only the initial one. A target that is not alive at that moment is killed as soon as it is.
    `before_fault(trial folder)` is called just before the fault.
    """
    domain_id = domain_id or os.environ.get('ROS_DOMAIN_ID', '0')
    trial = Trial(index, target, signal.Signals(sig).name, moment_s, 'under way' if under_way else 'start-up')
    folder, scene, bag = trial_folder(workdir, index, TRIAL_SCENE)
    command = [sys.executable, '-m', 'iguana_ros.cli', 'run', str(scene), '--record', str(bag)]
    marker = f'{os.getpid()}-{index}-{time.time_ns()}'
    run = NodeProcess(command, 'iguana_run', folder, env={'ROS_DOMAIN_ID': domain_id, TRIAL_ENV: marker})
    launched = time.monotonic()
    run.start()
    before: dict[str, list[int]] = {}
    try:
        if under_way:
            wait_for(lambda: not run.running or len(read_growing_bag(bag).get('/iguana_state', ())) >= 2,
                     RUN_LIMIT_S, 0.2)
        wait_for(lambda: not run.running, moment_s, 0.05)
        pid = _target_pid(run, target, marker)
        deadline = time.monotonic() + 30.0
        while pid is None and run.running and time.monotonic() < deadline:
            time.sleep(0.05)
            pid = _target_pid(run, target, marker)
        if pid is not None:
            if before_fault is not None:
                before_fault(folder)
            before = read_growing_bag(bag)
            os.kill(pid, sig)
            trial.hit, trial.fault_at_s = True, time.monotonic() - launched
        if not wait_for(lambda: not run.running, RUN_LIMIT_S, 0.1):
            trial.problems.append(f'iguana run still running {RUN_LIMIT_S:g} s after the fault')
            run.kill()
    finally:
        if run.running:
            run.kill()
        run.stop()
    trial.exit_code = run.proc.returncode
    trial.wall_s = time.monotonic() - launched
    _check_output(trial, run)
    wait_for(lambda: not trial_processes(marker), ORPHAN_GRACE_S, 0.1)
    left = trial_processes(marker)
    if left:
        trial.orphans = [p.label() for p in left]
        trial.problems.append(f'{len(left)} processes left behind: {", ".join(trial.orphans)}')
        _kill_leftovers(left)
    _check_bag(trial, bag, before)
    return trial


def _check_output(trial: Trial, run: NodeProcess) -> None:
    """One clear line from `iguana run` (none when it was SIGKILLed itself), never a traceback."""
    text = run.output
    if any(line.startswith('Traceback') for line in text.splitlines()):  # a node's quoted last lines are indented
        trial.problems.append('a traceback in the output of iguana run')
    lines = [line for line in text.splitlines() if line.startswith('iguana run:')]
    trial.last_line = lines[-1] if lines else ''
    killed_itself = trial.hit and trial.target == 'iguana run' and trial.signal == 'SIGKILL'
    before_set_up = trial.hit and trial.target == 'iguana run' and trial.exit_code == -signal.Signals[trial.signal] \
        and not (run.log_dir / 'bag_logs').exists()  # died of the signal before it had started anything
    if killed_itself or before_set_up:
        return
    if trial.exit_code == 0:
        if trial.hit and not _completed(text):
            trial.problems.append('exit status 0 after a fault that stopped the run')
        return
    if len(lines) != 1:
        trial.problems.append(f'{len(lines)} "iguana run:" lines, expected one')


def _completed(text: str) -> bool:
    """Whether iguana run's summary says the run completed."""
    return any(line.startswith('run completed') for line in text.splitlines())


def _check_bag(trial: Trial, bag: Path, before: dict[str, list[int]]) -> None:
    """Check the bag readable, finalised unless its recorder was SIGKILLed, every message read before the fault kept."""
    from iguana_ros.bag.storage import BagReader
    from iguana_ros.errors import IguanaError

    trial.before_fault = sum(len(v) for v in before.values())
    if not bag.exists():
        if trial.before_fault:
            trial.problems.append('the bag is gone')
        return
    try:
        reader = BagReader(bag)
        after: dict[str, list[int]] = {}
        for msg in reader.messages():
            after.setdefault(msg.topic, []).append(msg.log_time)
    except (IguanaError, OSError) as exc:
        trial.problems.append(f'bag unreadable: {exc}')
        return
    trial.bag_messages = sum(len(v) for v in after.values())
    trial.bag_finalised = not reader.truncated and (bag / 'metadata.yaml').is_file()
    recorder_killed = trial.hit and trial.target == 'recorder' and trial.signal == 'SIGKILL'
    if not trial.bag_finalised and not recorder_killed:
        trial.problems.append(f'bag not finalised ({reader.problem or "no metadata.yaml"})')
    trial.lost = lost_messages(before, after)
    if trial.lost:
        trial.problems.append('messages recorded before the fault are gone: ' + ', '.join(
            f'{topic} {n}' for topic, n in sorted(trial.lost.items())))


def plan_trials(n: int, seed: int) -> list[tuple[str, int, float, bool]]:
    """
    `n` seeded (target, signal, moment, under way) plans.

    Every target x signal in turn, each once during start-up (moment uniform in [0.2 s, LATEST_START_UP_FAULT_S] after
    launch) and once under way (uniform in [0, LATEST_RUNNING_FAULT_S] after the first iguana_state is recorded).
    """
    rng = random.Random(seed)
    plans = [(t, s, w) for t in TARGETS for s in SIGNALS for w in (False, True)]
    rng.shuffle(plans)
    return [(target, sig, round(rng.uniform(0.0, LATEST_RUNNING_FAULT_S) if under_way
                                else rng.uniform(0.2, LATEST_START_UP_FAULT_S), 2), under_way)
            for target, sig, under_way in (plans[i % len(plans)] for i in range(n))]


def fault_suite(trials: int = 20, seed: int = 12, workdir: Path | None = None, domain_id: str | None = None,
                progress=None) -> dict:
    """
    Run `trials` seeded process-fault trials.

    Return the figures ({trials, survived, hit, lost, orphans, wall_s, rows}). `progress(trial)` is called after each
    one.
    """
    import tempfile
    own = workdir is None
    workdir = Path(workdir or tempfile.mkdtemp(prefix='iguana_faults_'))
    started = time.monotonic()
    rows = []
    try:
        for index, (target, sig, moment, under_way) in enumerate(plan_trials(trials, seed)):
            trial = run_trial(index, target, sig, moment, workdir, domain_id, under_way)
            rows.append(trial)
            if progress is not None:
                progress(trial)
    finally:
        if own:
            shutil.rmtree(workdir, ignore_errors=True)
    return {'suite': 'processes', 'trials': len(rows), 'seed': seed, 'survived': sum(t.survived for t in rows),
            'hit': sum(t.hit for t in rows), 'under_way': sum(t.phase == 'under way' for t in rows),
            'messages_before_faults': sum(t.before_fault for t in rows),
            'lost_messages': sum(sum(t.lost.values()) for t in rows),
            'orphans': sum(len(t.orphans) for t in rows), 'wall_s': round(time.monotonic() - started, 1),
            'rows': [asdict(t) for t in rows]}


def suite_line(result: dict) -> str:
    """Return the figures of a fault_suite result in one line."""
    return (f"processes: {result['survived']}/{result['trials']} trials survived ({result['hit']} faults landed, "
            f"{result['under_way']} while the run was under way), {result['orphans']} processes left behind, "
            f"{result['lost_messages']} of {result['messages_before_faults']} messages recorded before the faults "
            f"lost, {result['wall_s']:.0f} s wall")


def to_json(result: dict) -> str:
    """Return the result as indented JSON."""
    return json.dumps(result, indent=1)
