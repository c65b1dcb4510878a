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
Environment fault injection: a table of broken environments and what the doctor and `iguana goal` must say.

Each row sets (or unsets) environment variables the way a user's shell gets them wrong: domain ids that are no number,
too large, negative or octal, an RMW that is not installed, an rclpy log directory or a cache folder that cannot be
written, discovery settings rcl does not know, static peers that do not resolve. A trial runs the real `iguana doctor`
and `iguana goal 1 0` with that environment in subprocesses: the doctor must print a ✗ line for the row's check with
the row's phrase (and exit 1 when that check is needed for a run), `iguana goal` must exit non-zero with exactly one
line on stderr saying the row's phrase (its own cause, or, for a fault that goal does not depend on, that no planner
answered), and neither may print a traceback.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass, field
import json
import os
from pathlib import Path
import subprocess
import sys
import tempfile
import time

DOCTOR_TIMEOUT_S = 3.0
"""The doctor's DDS loopback limit in a trial (`--timeout`): only the rows whose environment passes reach it."""

GOAL_TIMEOUT_S = 2.0
"""How long a trial's `iguana goal` waits for a planner (there is none)."""

RUN_LIMIT_S = 120.0
"""Wall seconds a trial's command may take before the trial calls it hung."""

NO_PLANNER = 'no planner answers the go_to_pose action within'
"""What `iguana goal` says when nothing listens: the line of the rows whose fault goal does not depend on."""

LOG_UNSET = (('ROS_LOG_DIR', None), ('ROS_HOME', None))
"""Variables a log directory row unsets so that HOME decides."""


@dataclass(frozen=True)
class EnvFault:
    """
    One broken environment.

    Its name; the variables it sets (value None: unset); the doctor check that must fail ('✗ check') and the phrase on
    that line; whether that check is needed for a run (doctor exit 1); the phrase of `iguana goal`'s one line ('' = the
    doctor's phrase).
    """

    name: str
    env: tuple
    check: str
    says: str
    needed: bool = True
    goal_says: str = ''


FAULTS = (
    EnvFault('domain-huge', (('ROS_DOMAIN_ID', '999'),), 'ROS domain id',
             'ROS_DOMAIN_ID=999 is out of range: use 0–101 (or 215–232)'),
    EnvFault('domain-first-beyond', (('ROS_DOMAIN_ID', '233'),), 'ROS domain id', 'ROS_DOMAIN_ID=233 is out of range'),
    EnvFault('domain-uint32-max', (('ROS_DOMAIN_ID', '4294967295'),), 'ROS domain id',
             'ROS_DOMAIN_ID=4294967295 is out of range'),
    EnvFault('domain-overflow', (('ROS_DOMAIN_ID', '99999999999999999999'),), 'ROS domain id',
             'ROS_DOMAIN_ID=99999999999999999999 is out of range'),
    EnvFault('domain-negative', (('ROS_DOMAIN_ID', '-1'),), 'ROS domain id', 'ROS_DOMAIN_ID=-1 is out of range'),
    EnvFault('domain-word', (('ROS_DOMAIN_ID', 'abc'),), 'ROS domain id',
             'ROS_DOMAIN_ID=abc is not an integer: use 0–101 (or 215–232)'),
    EnvFault('domain-blank', (('ROS_DOMAIN_ID', '  '),), 'ROS domain id', "ROS_DOMAIN_ID='  ' is not an integer"),
    EnvFault('domain-trailing-junk', (('ROS_DOMAIN_ID', '5x'),), 'ROS domain id', 'ROS_DOMAIN_ID=5x is not an integer'),
    EnvFault('domain-octal', (('ROS_DOMAIN_ID', '010'),), 'ROS domain id',
             'ROS_DOMAIN_ID=010 is not written as a plain decimal number'),
    EnvFault('rmw-missing', (('RMW_IMPLEMENTATION', 'rmw_missing_xyz'),), 'rclpy and RMW',
             'RMW_IMPLEMENTATION=rmw_missing_xyz cannot be used by this rclpy'),
    EnvFault('log-dir-unwritable', (('ROS_LOG_DIR', '/proc/iguana_ros_log'),), 'rclpy log directory',
             '/proc/iguana_ros_log cannot be created or written'),
    EnvFault('ros-home-through-a-file', (('ROS_LOG_DIR', None), ('ROS_HOME', '/etc/hostname/ros')),
             'rclpy log directory', '/etc/hostname/ros/log cannot be created or written'),
    EnvFault('home-through-a-file', (*LOG_UNSET, ('HOME', '/etc/hostname/home')), 'rclpy log directory',
             '/etc/hostname/home/.ros/log cannot be created or written'),
    EnvFault('home-unset', (*LOG_UNSET, ('HOME', None)), 'rclpy log directory', 'HOME is unset or empty'),
    EnvFault('discovery-junk', (('ROS_AUTOMATIC_DISCOVERY_RANGE', 'junk'),), 'discovery range',
             'ROS_AUTOMATIC_DISCOVERY_RANGE=junk is not one of LOCALHOST, SUBNET, OFF, SYSTEM_DEFAULT'),
    EnvFault('discovery-lowercase', (('ROS_AUTOMATIC_DISCOVERY_RANGE', 'localhost'),), 'discovery range',
             'ROS_AUTOMATIC_DISCOVERY_RANGE=localhost is not one of'),
    EnvFault('static-peers-unresolvable', (('ROS_STATIC_PEERS', 'no-such-host.invalid'),), 'static peers',
             "ROS_STATIC_PEERS names 'no-such-host.invalid', which does not resolve"),
    EnvFault('model-cache-unwritable', (('IGUANA_CACHE_DIR', '/proc/iguana_ros_cache'),), 'model cache',
             '/proc/iguana_ros_cache is not writable', needed=False, goal_says=NO_PLANNER),
    EnvFault('kernel-cache-unwritable', (('NUMBA_CACHE_DIR', '/proc/iguana_ros_numba'),), 'kernel cache',
             'NUMBA_CACHE_DIR=/proc/iguana_ros_numba cannot be written', needed=False, goal_says=NO_PLANNER),
    EnvFault('discovery-off', (('ROS_AUTOMATIC_DISCOVERY_RANGE', 'OFF'),), 'DDS loopback on ROS_DOMAIN_ID',
             'fix: ROS_AUTOMATIC_DISCOVERY_RANGE=OFF turns discovery off', goal_says=NO_PLANNER),
)
"""The broken environments, each with what must be said about it."""


@dataclass
class Trial:
    """What the doctor and `iguana goal` said in one broken environment; `problems` is empty when it survived."""

    name: str
    check: str
    needed: bool
    doctor_status: int | None = None
    doctor_line: str = ''
    goal_status: int | None = None
    goal_line: str = ''
    wall_s: float = 0.0
    problems: list = field(default_factory=list)

    @property
    def survived(self) -> bool:
        """Return True if the doctor named the cause and goal stopped with one clear line."""
        return not self.problems

    def line(self) -> str:
        """One line: the row, and what was said or went wrong."""
        head = f'{"ok  " if self.survived else "FAIL"} {self.name:26s}'
        if self.problems:
            return f'{head} {"; ".join(self.problems)}'
        return f'{head} doctor {self.doctor_status}: {self.doctor_line[:90]} | goal {self.goal_status}'


def fault_environment(fault: EnvFault, base: dict) -> dict:
    """Return `base` changed by the row's variables (None unsets one)."""
    env = dict(base)
    for name, value in fault.env:
        if value is None:
            env.pop(name, None)
        else:
            env[name] = value
    return env


def _command(args: list[str], env: dict, cwd: Path) -> subprocess.CompletedProcess | str:
    """Run `python -m iguana_ros.cli ARGS`; the finished process, or why it did not finish."""
    try:
        return subprocess.run([sys.executable, '-m', 'iguana_ros.cli', *args], env=env, cwd=cwd, capture_output=True,
                              text=True, timeout=RUN_LIMIT_S, stdin=subprocess.DEVNULL)
    except subprocess.TimeoutExpired:
        return f'no exit within {RUN_LIMIT_S:g} s'


def check_doctor(trial: Trial, fault: EnvFault, done: subprocess.CompletedProcess | str) -> None:
    """Record the doctor's line for the row's check and what is wrong with what it said."""
    if isinstance(done, str):
        trial.problems.append(f'doctor: {done}')
        return
    trial.doctor_status = done.returncode
    lines = done.stdout.splitlines()
    at = next((k for k, line in enumerate(lines) if line.startswith(f'✗ {fault.check}')), None)
    if at is not None:   # the ✗ line and the fix under it
        fix = lines[at + 1].strip() if at + 1 < len(lines) and lines[at + 1].startswith('    fix: ') else ''
        trial.doctor_line = ' / '.join(part for part in (lines[at], fix) if part)
    if fault.says not in trial.doctor_line:
        trial.problems.append(f'the doctor has no ✗ {fault.check} line saying {fault.says!r}: '
                              f'{trial.doctor_line or (lines[-1] if lines else done.stderr.strip()[-200:])!r}')
    elif lines[at].startswith(f'✗ {fault.check} (optional)') == fault.needed:
        trial.problems.append(f'the doctor marks {fault.check} {"optional" if fault.needed else "needed"}')
    needed_failed = any(line.startswith('✗ ') and not line.split(': ', 1)[0].endswith(' (optional)')
                        for line in lines)
    if done.returncode != (1 if needed_failed else 0):
        trial.problems.append(f'the doctor exits {done.returncode} with{"" if needed_failed else "out"} a needed ✗')
    if 'Traceback' in done.stdout + done.stderr:
        trial.problems.append('the doctor printed a traceback')


def check_goal(trial: Trial, fault: EnvFault, done: subprocess.CompletedProcess | str) -> None:
    """Record `iguana goal`'s line and what is wrong with it: it must fail with one line saying the row's phrase."""
    if isinstance(done, str):
        trial.problems.append(f'goal: {done}')
        return
    trial.goal_status = done.returncode
    lines = done.stderr.strip().splitlines()
    trial.goal_line = lines[-1] if lines else ''
    wanted = fault.goal_says or fault.says
    if done.returncode == 0:
        trial.problems.append('iguana goal exited 0')
    if len(lines) != 1 or not lines[0].startswith('iguana goal: error: ') or wanted not in lines[0]:
        trial.problems.append(f'iguana goal did not say {wanted!r} in one line: {done.stderr.strip()[-300:]!r}')
    if done.stdout.strip():
        trial.problems.append(f'iguana goal printed on stdout: {done.stdout.strip()[-200:]!r}')


def run_trial(fault: EnvFault, workdir: Path, base: dict | None = None) -> Trial:
    """Run the doctor and `iguana goal 1 0` in the row's environment (`base`: this process's) and check both."""
    env = fault_environment(fault, dict(os.environ if base is None else base))
    trial = Trial(fault.name, fault.check, fault.needed)
    started = time.monotonic()
    folder = workdir / fault.name
    folder.mkdir(parents=True, exist_ok=True)
    check_doctor(trial, fault, _command(['doctor', '--timeout', f'{DOCTOR_TIMEOUT_S:g}', '--bags-dir',
                                         str(folder / 'bags')], env, folder))
    check_goal(trial, fault, _command(['goal', '1', '0', '--timeout', f'{GOAL_TIMEOUT_S:g}'], env, folder))
    trial.wall_s = round(time.monotonic() - started, 2)
    return trial


def select(names: list[str] | None) -> tuple[EnvFault, ...]:
    """Return the rows named `names` (all for None); ValueError naming an unknown one."""
    if not names:
        return FAULTS
    known = {f.name: f for f in FAULTS}
    unknown = [n for n in names if n not in known]
    if unknown:
        raise ValueError(f'no environment fault {", ".join(unknown)}; known: {", ".join(known)}')
    return tuple(known[n] for n in names)


def environment_suite(names: list[str] | None = None, domain_id: str | None = None,
                      progress: Callable[[Trial], None] | None = None) -> dict:
    """Run the rows `names` (all by default) on `domain_id` (default: this process's); return the figures and rows."""
    base = dict(os.environ)
    if domain_id is not None:
        base['ROS_DOMAIN_ID'] = domain_id
    started, rows = time.monotonic(), []
    with tempfile.TemporaryDirectory(prefix='iguana_env_faults_') as workdir:
        for fault in select(names):
            rows.append(run_trial(fault, Path(workdir), base))
            if progress is not None:
                progress(rows[-1])
    return {'suite': 'environments', 'trials': len(rows), 'survived': sum(t.survived for t in rows),
            'named_by_doctor': sum(bool(t.doctor_line) for t in rows),
            'needed': sum(t.needed for t in rows),
            'goal_named_the_cause': sum(t.survived and NO_PLANNER not in t.goal_line for t in rows),
            'goal_found_no_planner': sum(t.survived and NO_PLANNER in t.goal_line for t in rows),
            'by_check': _by_check(rows), 'wall_s': round(time.monotonic() - started, 1),
            'rows': [asdict(t) for t in rows]}


def _by_check(rows: list[Trial]) -> dict[str, dict[str, int]]:
    """{check: {trials, survived}} of the rows."""
    out: dict[str, dict[str, int]] = {}
    for trial in rows:
        counts = out.setdefault(trial.check, {'trials': 0, 'survived': 0})
        counts['trials'] += 1
        counts['survived'] += trial.survived
    return out


def suite_lines(result: dict) -> list[str]:
    """Return the figures of an environment_suite result: the totals, then one line per check."""
    lines = [f"environments: {result['survived']}/{result['trials']} broken environments survived; the doctor named "
             f"{result['named_by_doctor']} causes ({result['needed']} needed for a run: exit 1, "
             f"{result['trials'] - result['needed']} optional); iguana goal stopped with one line naming the cause "
             f"{result['goal_named_the_cause']} times and said no planner answered {result['goal_found_no_planner']} "
             f"times (faults it does not depend on); {result['wall_s']:.0f} s wall"]
    lines += [f"  {check:32s} {c['survived']}/{c['trials']}" for check, c in result['by_check'].items()]
    return lines


def to_json(result: dict) -> str:
    """Return the result as indented JSON."""
    return json.dumps(result, indent=1)
