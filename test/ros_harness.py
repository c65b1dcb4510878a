"""Node-level test helpers: spin until a condition, real node processes, dumps of serialized messages."""
from __future__ import annotations

import base64
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
HELPERS = Path(__file__).resolve().parent / 'helpers'
IGUANA = [sys.executable, '-c', 'import sys; from iguana_ros.cli import main; sys.exit(main())']
"""Command line of the `iguana` CLI run with the test interpreter."""


def spin_until(executor_or_node, predicate: Callable[[], bool], timeout: float = 10.0) -> bool:
    """Spin (executor or node) until `predicate()` is true; False if `timeout` s pass first."""
    executor, own = executor_or_node, False
    if not hasattr(executor, 'spin_once'):
        from rclpy.executors import SingleThreadedExecutor
        executor, own = SingleThreadedExecutor(context=executor_or_node.context), True
        executor.add_node(executor_or_node)
    try:
        deadline = time.monotonic() + timeout
        while not predicate():
            if time.monotonic() > deadline:
                return False
            executor.spin_once(timeout_sec=0.02)
        return True
    finally:
        if own:
            executor.remove_node(executor_or_node)
            executor.shutdown()


def wait_for(predicate: Callable[[], bool], timeout: float = 10.0, period: float = 0.02) -> bool:
    """Poll `predicate()` without spinning; False if `timeout` s pass first."""
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            return False
        time.sleep(period)
    return True


class NodeProcess:
    """A command run as a separate process group with stdout/stderr captured to files.

    `start(ready=...)` waits for a line in its output; `stop()` sends SIGINT, then SIGTERM, then
    SIGKILL, and returns the exit status; `output` holds everything it printed.
    """

    def __init__(self, args: list[str], name: str = 'proc', log_dir: str | Path | None = None,
                 env: dict | None = None) -> None:
        self.args, self.name = [str(a) for a in args], name
        self.log_dir = Path(log_dir or tempfile.mkdtemp(prefix='iguana_proc_'))
        self.env = dict(os.environ, PYTHONUNBUFFERED='1', **(env or {}))
        self.proc: subprocess.Popen | None = None
        self.out_path = self.log_dir / f'{name}.out'

    def start(self, ready: str | None = None, timeout: float = 20.0) -> 'NodeProcess':
        """Start the process; if `ready` is given, wait until that text appears in its output."""
        self._out = open(self.out_path, 'wb')
        self.proc = subprocess.Popen(self.args, stdout=self._out, stderr=subprocess.STDOUT,
                                     cwd=REPO, env=self.env, start_new_session=True)
        if ready is not None and not self.wait_for_output(ready, timeout):
            self.stop()
            raise AssertionError(f'{self.name} did not print {ready!r} within {timeout} s; '
                                 f'output:\n{self.output}')
        return self

    @property
    def output(self) -> str:
        """Everything the process printed so far (stdout and stderr interleaved)."""
        return self.out_path.read_text(errors='replace') if self.out_path.exists() else ''

    def wait_for_output(self, text: str, timeout: float = 20.0) -> bool:
        """True once `text` appears in the output; False on timeout or if the process exits first."""
        def seen_or_dead() -> bool:
            return text in self.output or self.proc.poll() is not None
        wait_for(seen_or_dead, timeout, period=0.05)
        return text in self.output

    def wait(self, timeout: float = 30.0) -> int:
        """Wait for the process to exit by itself; kill it and raise if it takes longer than `timeout`."""
        try:
            return self.proc.wait(timeout)
        except subprocess.TimeoutExpired:
            self.kill()
            raise AssertionError(f'{self.name} still running after {timeout} s; output:\n{self.output}')

    def _signal(self, sig: int) -> None:
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
        self._out.close()
        return self.proc.wait()

    def kill(self) -> int:
        """SIGKILL the process group at once (a crash); returns the exit status."""
        self._signal(signal.SIGKILL)
        rc = self.proc.wait()
        self._out.close()
        return rc

    def __enter__(self) -> 'NodeProcess':
        return self

    def __exit__(self, *exc) -> None:
        if self.proc is not None and self.proc.poll() is None:
            self.stop(timeout=3.0)


def helper(script: str, *args) -> list[str]:
    """Command line running test/helpers/<script> with the test interpreter."""
    return [sys.executable, str(HELPERS / script), *map(str, args)]


def write_dump(path: str | Path, records: list[tuple[str, bytes]], extra: dict | None = None) -> None:
    """Save (topic, serialized bytes) records (and extra info) as JSON for a test to compare."""
    Path(path).write_text(json.dumps({
        'messages': [[topic, base64.b64encode(data).decode()] for topic, data in records],
        'extra': extra or {}}))


def read_dump(path: str | Path) -> tuple[dict[str, list[bytes]], dict]:
    """({topic: [bytes, …] in order}, extra) of a dump written by `write_dump`."""
    data = json.loads(Path(path).read_text())
    by_topic: dict[str, list[bytes]] = {}
    for topic, b64 in data['messages']:
        by_topic.setdefault(topic, []).append(base64.b64decode(b64))
    return by_topic, data['extra']
