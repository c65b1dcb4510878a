"""Child processes for `iguana run` and the node tests: own process group, captured output, clean stop."""
from __future__ import annotations

import os
import signal
import subprocess
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from iguana_ros.errors import IguanaError


def wait_for(predicate: Callable[[], bool], timeout: float = 10.0, period: float = 0.02) -> bool:
    """Poll `predicate()`; False if `timeout` s pass first."""
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            return False
        time.sleep(period)
    return True


class NodeProcess:
    """A command run as a separate process group with stdout/stderr captured to a file.

    `start(ready=...)` waits for a line in its output; `stop()` sends SIGINT, then SIGTERM, then
    SIGKILL, and returns the exit status; `output` holds everything it printed.
    """

    def __init__(self, args: list[str], name: str = 'proc', log_dir: str | Path | None = None,
                 env: dict | None = None, cwd: str | Path | None = None) -> None:
        self.args, self.name = [str(a) for a in args], name
        self.log_dir = Path(log_dir or tempfile.mkdtemp(prefix='iguana_proc_'))
        self.log_dir.mkdir(parents=True, exist_ok=True)
        self.env = dict(os.environ, PYTHONUNBUFFERED='1', **(env or {}))
        self.cwd = cwd
        self.proc: subprocess.Popen | None = None
        self.out_path = self.log_dir / f'{name}.out'
        self._out = None

    def start(self, ready: str | None = None, timeout: float = 20.0) -> 'NodeProcess':
        """Start the process; if `ready` is given, wait until that text appears in its output."""
        self._out = open(self.out_path, 'wb')
        self.proc = subprocess.Popen(self.args, stdout=self._out, stderr=subprocess.STDOUT, cwd=self.cwd,
                                     env=self.env, start_new_session=True)
        if ready is not None and not self.wait_for_output(ready, timeout):
            self.stop()
            raise IguanaError(f'{self.name} did not print {ready!r} within {timeout} s; '
                               f'output:\n{self.tail()}')
        return self

    @property
    def output(self) -> str:
        """Everything the process printed so far (stdout and stderr interleaved)."""
        return self.out_path.read_text(errors='replace') if self.out_path.exists() else ''

    def tail(self, lines: int = 15) -> str:
        """The last `lines` lines of output."""
        return '\n'.join(self.output.splitlines()[-lines:])

    @property
    def running(self) -> bool:
        """Whether the process has been started and has not exited."""
        return self.proc is not None and self.proc.poll() is None

    def wait_for_output(self, text: str, timeout: float = 20.0) -> bool:
        """True once `text` appears in the output; False on timeout or if the process exits first."""
        wait_for(lambda: text in self.output or self.proc.poll() is not None, timeout, period=0.05)
        return text in self.output

    def wait(self, timeout: float = 30.0) -> int:
        """Wait for the process to exit by itself; kill it and raise if it takes longer than `timeout`."""
        try:
            return self.proc.wait(timeout)
        except subprocess.TimeoutExpired:
            self.kill()
            raise IguanaError(f'{self.name} still running after {timeout} s; output:\n{self.tail()}') from None

    def _signal(self, sig: int) -> None:
        """Send `sig` to the process group."""
        try:
            os.killpg(self.proc.pid, sig)
        except ProcessLookupError:
            pass

    def stop(self, timeout: float = 10.0) -> int:
        """SIGINT, then SIGTERM, then SIGKILL (each after `timeout` s); returns the exit status."""
        for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGKILL):
            if self.proc.poll() is not None:
                break
            self._signal(sig)
            try:
                self.proc.wait(timeout)
            except subprocess.TimeoutExpired:
                continue
        self._close()
        return self.proc.wait()

    def kill(self) -> int:
        """SIGKILL the process group at once (a crash); returns the exit status."""
        self._signal(signal.SIGKILL)
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
