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
Child processes for `iguana run` and the node tests.

Process groups, parent-death signal, captured output, clean stop; finding a run's processes in /proc.

On Linux every child is started through a few lines of stdlib Python (`_GUARD`) that join or make the process
group, set the parent-death signal (`prctl(PR_SET_PDEATHSIG)`, kept across exec) and then exec the command, so a
child gets `death_signal` (SIGTERM: the recorder finalises its bag, the nodes shut down) whatever ends its
parent, SIGKILL included. This is done in a separate exec step rather than a `preexec_fn`, which is not safe in a
parent with threads (DDS threads in the test process).
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
import os
from pathlib import Path
import signal
import subprocess
import sys
import tempfile
import time

from iguana_ros.errors import IguanaError

_GUARD = """
import ctypes, os, signal, sys
parent, group, death = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
for stop in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
    signal.signal(stop, signal.SIG_DFL)  # an ignored stop signal (nohup, `cmd &`) would be inherited
try:
    if group >= 0:
        os.setpgid(0, group)
except OSError as exc:
    sys.exit(f'cannot join process group {group}: {exc}')
if death > 0 and ctypes.CDLL(None, use_errno=True).prctl(1, death, 0, 0, 0) != 0:
    sys.exit(f'prctl(PR_SET_PDEATHSIG) failed: {os.strerror(ctypes.get_errno())}')
if os.getppid() != parent:
    sys.exit('parent exited before the child started')
os.execvp(sys.argv[4], sys.argv[4:])
"""
"""Child-side start-up: argv = parent pid, process group (0 = new, -1 = keep), death signal (0 = none), command."""

HAS_PARENT_DEATH_SIGNAL = sys.platform.startswith('linux')
"""Whether children can be given a parent-death signal (Linux prctl)."""

RUN_ID_ENV = 'IGUANA_RUN_ID'
"""Environment variable that marks every process of one `iguana run` (inherited by anything they start)."""

NAMESPACE_ENV = 'IGUANA_RUN_NAMESPACE'
"""Environment variable with the ROS namespace of the run a process belongs to ('' the root)."""


def wait_for(predicate: Callable[[], bool], timeout: float = 10.0, period: float = 0.02) -> bool:
    """Poll `predicate()`; False if `timeout` s pass first."""
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            return False
        time.sleep(period)
    return True


def describe_exit(code: int | None) -> str:
    """'status 1', 'status -9 (SIGKILL)' or 'no status (still running)' for a Popen return code."""
    if code is None:
        return 'no status (still running)'
    if code < 0:
        try:
            return f'status {code} ({signal.Signals(-code).name})'
        except ValueError:
            return f'status {code}'
    return f'status {code}'


class NodeProcess:
    """
    A command run as a child process with stdout/stderr captured to a file.

    `group=None` gives the child a process group of its own (signals go to that whole group); `group=0` makes
    it the leader of a new group that later children join with `group=<its pid>` (signals then go to the
    child alone). `death_signal` is sent to the child when its parent dies (Linux). `start(ready=...)` waits
    for a line in its output; `stop()` sends SIGINT, then SIGTERM, then SIGKILL, and returns the exit status;
    `output` holds everything it printed.
    """

    def __init__(self, args: list[str], name: str = 'proc', log_dir: str | Path | None = None,
                 env: dict | None = None, cwd: str | Path | None = None, group: int | None = None,
                 death_signal: int | None = signal.SIGTERM) -> None:
        """Describe the child (nothing is started until `start`)."""
        self.args, self.name = [str(a) for a in args], name
        self.log_dir = Path(log_dir or tempfile.mkdtemp(prefix='iguana_proc_'))
        self.log_dir.mkdir(parents=True, exist_ok=True)
        self.env = {**os.environ, 'PYTHONUNBUFFERED': '1', **(env or {})}
        self.cwd = cwd
        self.group, self.death_signal = group, death_signal
        self.proc: subprocess.Popen | None = None
        self.out_path = self.log_dir / f'{name}.out'
        self._out = None

    def _popen(self) -> subprocess.Popen:
        """Start the child in its process group, with its parent-death signal where the OS has one."""
        common = {'stdin': subprocess.DEVNULL, 'stdout': self._out, 'stderr': subprocess.STDOUT, 'cwd': self.cwd,
                  'env': self.env}
        if not HAS_PARENT_DEATH_SIGNAL:
            return subprocess.Popen(self.args, start_new_session=self.group is None, **common)
        group = 0 if self.group is None else self.group
        guard = [sys.executable, '-S', '-c', _GUARD, str(os.getpid()), str(group), str(int(self.death_signal or 0))]
        return subprocess.Popen(guard + self.args, **common)

    def start(self, ready: str | None = None, timeout: float = 20.0) -> 'NodeProcess':
        """Start the process; if `ready` is given, wait until that text appears in its output."""
        self._out = open(self.out_path, 'wb')
        self.proc = self._popen()
        if ready is not None and not self.wait_for_output(ready, timeout):
            code = self.proc.poll()
            self.stop()
            why = f'exited with {describe_exit(code)}' if code is not None else f'did not within {timeout} s'
            raise IguanaError(f'{self.name} {why} before printing {ready!r}; output:\n{self.tail()}')
        return self

    @property
    def pid(self) -> int | None:
        """Process id of the started child (None before `start`)."""
        return None if self.proc is None else self.proc.pid

    @property
    def output(self) -> str:
        """Everything the process printed so far (stdout and stderr interleaved)."""
        return self.out_path.read_text(errors='replace') if self.out_path.exists() else ''

    def tail(self, lines: int = 15) -> str:
        """Return the last `lines` lines of output."""
        return '\n'.join(self.output.splitlines()[-lines:])

    @property
    def running(self) -> bool:
        """Whether the process has been started and has not exited."""
        return self.proc is not None and self.proc.poll() is None

    def wait_for_output(self, text: str, timeout: float = 20.0) -> bool:
        """Return True once `text` appears in the output; False on timeout or if the process exits first."""
        wait_for(lambda: text in self.output or self.proc.poll() is not None, timeout, period=0.05)
        return text in self.output

    def wait(self, timeout: float = 30.0) -> int:
        """Wait for the process to exit by itself; kill it and raise if it takes longer than `timeout`."""
        try:
            return self.proc.wait(timeout)
        except subprocess.TimeoutExpired:
            self.kill()
            raise IguanaError(f'{self.name} still running after {timeout} s; output:\n{self.tail()}') from None

    def send(self, sig: int) -> None:
        """Send `sig` to the child (to its whole process group if it has one of its own)."""
        if self.proc is None or self.proc.returncode is not None:
            return
        try:
            if self.group is None:
                os.killpg(self.proc.pid, sig)
            else:
                os.kill(self.proc.pid, sig)
        except (ProcessLookupError, PermissionError):
            pass

    def stop(self, timeout: float = 10.0) -> int:
        """SIGINT, then SIGTERM, then SIGKILL (each after `timeout` s); returns the exit status."""
        return stop_all([self], timeout)[0]

    def kill(self) -> int:
        """SIGKILL the process (group) at once (a crash); returns the exit status."""
        self.send(signal.SIGKILL)
        rc = self.proc.wait()
        self._close()
        return rc

    def _close(self) -> None:
        """Close the output file."""
        if self._out is not None and not self._out.closed:
            self._out.close()

    def __enter__(self) -> 'NodeProcess':
        return self

    def __exit__(self, *exc) -> None:
        if self.running:
            self.stop(timeout=3.0)


def stop_all(children: list[NodeProcess], timeout: float = 10.0) -> list[int]:
    """
    Stop several children at once.

    SIGINT to all, then SIGTERM, then SIGKILL to those still running after `timeout` s each; returns their exit
    statuses.
    """
    started = [c for c in children if c.proc is not None]
    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGKILL):
        running = [c for c in started if c.proc.poll() is None]
        if not running:
            break
        for child in running:
            child.send(sig)
        deadline = time.monotonic() + timeout
        for child in running:
            try:
                child.proc.wait(max(0.0, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                continue
    for child in started:
        child.proc.wait()
        child._close()
    return [c.proc.returncode if c.proc is not None else 0 for c in children]


@dataclass(frozen=True)
class ProcessInfo:
    """A live process found in /proc: pid, command line, and the values of a few environment variables."""

    pid: int
    command: str
    run_id: str
    domain_id: str
    namespace: str = ''

    def label(self) -> str:
        """'1234 (planner_node)', '1235 (bag record)' or the start of the command line."""
        words = self.command.split()
        module = words[words.index('-m') + 1] if '-m' in words[:-1] else ''
        if module == 'iguana_ros.cli':
            name = ' '.join(words[words.index('-m') + 2:][:2])
        elif module.startswith('iguana_ros.'):
            name = module.rsplit('.', 1)[-1]
        else:
            name = ' '.join(words[:3])[:60]
        return f'{self.pid} ({name})'


def _environ(pid: int) -> dict[str, str] | None:
    """Environment of process `pid` (None if it is gone or not ours to read)."""
    try:
        raw = Path(f'/proc/{pid}/environ').read_bytes()
    except OSError:
        return None
    env = {}
    for item in raw.split(b'\0'):
        key, sep, value = item.partition(b'=')
        if sep:
            env[key.decode(errors='replace')] = value.decode(errors='replace')
    return env


def stat_fields(pid: int) -> list[str] | None:
    """Fields of `/proc/<pid>/stat` after the command name (state first, see proc(5)); None if it is gone or unread."""
    try:
        fields = Path(f'/proc/{pid}/stat').read_text().rpartition(')')[2].split()
    except OSError:
        return None
    return fields or None


def _alive(pid: int) -> bool:
    """Return True unless process `pid` is gone or a zombie."""
    fields = stat_fields(pid)
    return fields is not None and fields[0] != 'Z'


def processes_with_env(key: str, value: str | None = None) -> list[ProcessInfo]:
    """
    Live processes (not zombies, not this one) with environment variable `key` (equal to `value` if given), by pid.

    Empty where there is no /proc or for processes not ours to read.
    """
    found = []
    proc = Path('/proc')
    if not proc.is_dir():
        return found
    for entry in proc.iterdir():
        if not entry.name.isdigit() or int(entry.name) == os.getpid():
            continue
        env = _environ(int(entry.name))
        if env is None or key not in env or (value is not None and env[key] != value):
            continue
        if not _alive(int(entry.name)):
            continue
        try:
            command = (entry / 'cmdline').read_bytes().replace(b'\0', b' ').decode(errors='replace').strip()
        except OSError:
            continue
        found.append(ProcessInfo(int(entry.name), command, env.get(RUN_ID_ENV, ''),
                                 env.get('ROS_DOMAIN_ID', '').strip() or '0', env.get(NAMESPACE_ENV, '')))
    return sorted(found, key=lambda p: p.pid)


def run_processes(run_id: str | None = None) -> list[ProcessInfo]:
    """Live processes marked with RUN_ID_ENV: of run `run_id`, or of any run."""
    return processes_with_env(RUN_ID_ENV, run_id)
