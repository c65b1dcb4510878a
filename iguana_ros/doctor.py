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
`iguana doctor`'s checks that need no ROS graph.

Python, rclpy and its RMW (probed in a child process), the compiled-kernel cache, the model cache, the bag folder,
ffmpeg. Each gives a `Check`: a pass/fail line and, when it fails, the fix. The DDS checks (a loopback between two
processes, other participants on the domain) are in `iguana_ros.supervisor.doctor_dds`; `iguana run` runs `quick_checks`
before it starts anything.

rclpy is never imported here: with RMW_IMPLEMENTATION naming an RMW that is not installed, `import rclpy` ends
the process (rcl exits with status 102), so it is tried in a child process first.
"""
from __future__ import annotations

from dataclasses import dataclass
import json
import os
from pathlib import Path
import re
import shutil
import subprocess
import sys

from iguana_ros.errors import IguanaError

MIN_PYTHON = (3, 10)
"""Oldest Python the package supports (setup.py python_requires)."""

PROBE_TIMEOUT_S = 30.0
"""Wall seconds the rclpy probe may take (an import on a loaded machine)."""

RMW_ENV = 'RMW_IMPLEMENTATION'
"""Environment variable that picks the ROS middleware."""

_RMW_PROBE = """
import json, sys
try:
    import rclpy
except ImportError as exc:
    print(json.dumps({"import_error": str(exc)}))
    sys.exit(0)
from rclpy.signals import SignalHandlerOptions
from rclpy.utilities import get_rmw_implementation_identifier
context = rclpy.Context()
rclpy.init(context=context, signal_handler_options=SignalHandlerOptions.NO)
print(json.dumps({"rmw": get_rmw_implementation_identifier(), "rclpy": rclpy.__file__}))
rclpy.try_shutdown(context=context)
"""
"""Child-side rclpy probe: one JSON object on stdout (the RMW in use, or why rclpy does not import)."""


@dataclass(frozen=True)
class Check:
    """
    One check's outcome.

    Its name, whether it passed, what was found, the fix if it failed, and whether a run needs it (a failed optional
    check does not make `iguana doctor` fail).
    """

    name: str
    ok: bool
    detail: str
    fix: str = ''
    needed: bool = True

    def lines(self) -> list[str]:
        """'✓ name: detail', or '✗ name: detail' and an indented 'fix: ...' line."""
        mark = '✓' if self.ok else '✗'
        optional = '' if self.ok or self.needed else ' (optional)'
        head = f'{mark} {self.name}{optional}: {self.detail}'
        return [head] if self.ok or not self.fix else [head, f'    fix: {self.fix}']

    def one_line(self) -> str:
        """Return the check and its fix on one line (for an error message)."""
        return '; fix: '.join(part for part in (f'✗ {self.name}: {self.detail}', self.fix) if part)


class CheckFailed(IguanaError):
    """A needed check failed; the message is the check's one line with its fix."""


def check_python(version: tuple = tuple(sys.version_info[:3])) -> Check:
    """Python at least MIN_PYTHON."""
    text = '.'.join(str(v) for v in version)
    if tuple(version[:2]) >= MIN_PYTHON:
        return Check('Python', True, f'{text} at {sys.executable}')
    need = '.'.join(map(str, MIN_PYTHON))
    return Check('Python', False, f'{text} is older than {need}',
                 f'install Python {need} or newer and recreate the venv (make clean && make install)')


def probe_rclpy(env: dict | None = None, timeout: float = PROBE_TIMEOUT_S) -> dict:
    """
    Run the rclpy probe in a child with environment `env`.

    {'rmw': ...} on success, {'import_error': ...} when rclpy is missing, {'status': n, 'stderr': ...} when the child
    failed (e.g. rcl's exit 102).
    """
    try:
        done = subprocess.run([sys.executable, '-c', _RMW_PROBE], capture_output=True, text=True,
                              timeout=timeout, env=env, stdin=subprocess.DEVNULL)
    except subprocess.TimeoutExpired:
        return {'status': None, 'stderr': f'no answer within {timeout:g} s'}
    lines = done.stdout.strip().splitlines()
    if done.returncode == 0 and lines:
        try:
            return json.loads(lines[-1])
        except json.JSONDecodeError:
            pass
    return {'status': done.returncode, 'stderr': done.stderr.strip()}


def check_rmw(env: dict | None = None) -> Check:
    """Rclpy imports and initialises with the RMW of `env` (default: this process's environment)."""
    env = dict(os.environ if env is None else env)
    found = probe_rclpy(env)
    wanted = env.get(RMW_ENV, '').strip()
    if 'rmw' in found:
        chosen = f'{RMW_ENV}={wanted}' if wanted else f'the default ({RMW_ENV} unset)'
        return Check('rclpy and RMW', True, f'rclpy initialises with {found["rmw"]}, {chosen}')
    if 'import_error' in found:
        return Check('rclpy and RMW', False, f'rclpy does not import ({found["import_error"]})',
                     "install the ROS 2 Jazzy wheels (make install, or pip install -e '.[ros]'), or source "
                     '/opt/ros/jazzy/setup.bash before creating the venv')
    status = found.get('status')
    how = f'exits with status {status}' if status is not None else found.get('stderr', 'fails')
    if not wanted:
        return Check('rclpy and RMW', False, f'import rclpy {how}', 'reinstall the ROS 2 wheels (make clean && '
                     'make install); the child said: ' + _last_line(found.get('stderr', '')))
    default = probe_rclpy({k: v for k, v in env.items() if k != RMW_ENV}).get('rmw')
    fix = (f'unset {RMW_ENV} or export {RMW_ENV}={default}' if default else
           f'install {wanted} (e.g. pip install ros-jazzy-{wanted.replace("_", "-")}) or unset {RMW_ENV}')
    return Check('rclpy and RMW', False,
                 f'{RMW_ENV}={wanted} cannot be used by this rclpy (import rclpy {how})'
                 + (f'; the installed RMW is {default}' if default else ''), fix)


def _last_line(text: str) -> str:
    """Last non-empty line of `text` ('' if none)."""
    lines = [line for line in text.splitlines() if line.strip()]
    return lines[-1].strip() if lines else ''


def _writable_dir(folder: Path) -> tuple[bool, Path]:
    """
    Return (whether a file can be created in `folder`, else in its nearest existing parent; that folder).

    The parent is tried when `folder` does not exist yet, and the test is for real: permission bits say nothing
    to root or on a read-only mount.
    """
    import tempfile
    probe = Path(folder).absolute()
    while not probe.exists() and probe != probe.parent:
        probe = probe.parent
    try:
        with tempfile.TemporaryFile(dir=probe):
            return True, probe
    except OSError:
        return False, probe


def check_bag_folder(folder: Path = Path('bags')) -> Check:
    """Bags can be written under `folder` (created if missing); names the free space."""
    ok, existing = _writable_dir(folder)
    if not ok:
        return Check('bag folder', False, f'{folder} cannot be written ({existing} is not writable)',
                     'run from a folder you can write to, or choose one: iguana run --record DIR')
    free = shutil.disk_usage(existing).free / 1e9
    where = folder if existing == Path(folder).absolute() else f'{folder} (will be created in {existing})'
    if free < 0.5:
        return Check('bag folder', False, f'{where}: only {free:.2f} GB free; a 25 s run records ~30 MB',
                     'free some disk space or record elsewhere: iguana run --record DIR')
    return Check('bag folder', True, f'{where} writable, {free:.1f} GB free')


KERNEL_DECORATOR = re.compile(rb'^\s*@(\w+\.)?njit\b', re.MULTILINE)
"""A line that decorates a compiled kernel."""


def kernel_modules(package_dir: Path | None = None) -> list[Path]:
    """Package modules that define compiled kernels, sorted."""
    from iguana_ros.jit import PACKAGE_DIR
    root = Path(package_dir or PACKAGE_DIR)
    return sorted(p for p in root.rglob('*.py') if KERNEL_DECORATOR.search(p.read_bytes()))


@dataclass(frozen=True)
class KernelCache:
    """
    State of the compiled-kernel cache.

    The package's kernel modules, those without cached kernels for their current source (relative paths), those whose
    cache folder cannot be written.
    """

    modules: tuple
    cold: tuple
    unwritable: tuple

    @property
    def state(self) -> str:
        """'warm', 'cold' or 'partly warm (7 of 10)'."""
        if not self.cold:
            return 'warm'
        if len(self.cold) == len(self.modules):
            return 'cold'
        return f'partly warm ({len(self.modules) - len(self.cold)} of {len(self.modules)})'


def kernel_cache(package_dir: Path | None = None) -> KernelCache:
    """`KernelCache` of the package (cold unless the cache's source stamp matches the sources, see jit.py)."""
    from iguana_ros.jit import PACKAGE_DIR, STAMP_NAME, kernel_sources_digest
    root = Path(package_dir or PACKAGE_DIR)
    modules = kernel_modules(root)
    stamp = root / '__pycache__' / STAMP_NAME
    fresh = stamp.is_file() and stamp.read_text(encoding='ascii', errors='replace').strip() == \
        kernel_sources_digest(root)
    cached = [m for m in modules if any((m.parent / '__pycache__').glob(f'{m.stem}.*.nbi'))] if fresh else []
    return KernelCache(tuple(modules), tuple(str(m.relative_to(root)) for m in modules if m not in cached),
                       tuple(m for m in modules if not _writable_dir(m.parent / '__pycache__')[0]))


def check_kernel_cache(package_dir: Path | None = None) -> Check:
    """
    Whether the compiled kernels are cached.

    (warm: a run starts at once; cold: the first run compiles them) and whether the cache folders can be written.
    """
    cache = kernel_cache(package_dir)
    if cache.unwritable:
        folders = ', '.join(str(m.parent / '__pycache__') for m in cache.unwritable[:3])
        return Check('kernel cache', False, f'cannot write {folders}: every run compiles its kernels again '
                     '(about a minute)', 'install the package where you can write (pip install -e .), or set '
                     'NUMBA_CACHE_DIR to a writable folder', needed=False)
    if not cache.cold:
        return Check('kernel cache', True, f'warm ({len(cache.modules)} modules compiled and cached), writable')
    listed = ', '.join(cache.cold[:3]) + (f' and {len(cache.cold) - 3} more' if len(cache.cold) > 3 else '')
    return Check('kernel cache', True, f'{cache.state}, writable: {listed} compile at first use (about a minute on '
                 '2 cores), cached afterwards; `iguana warm` (make install runs it) compiles them ahead')


def check_model_cache(resolution: str = 'medium') -> Check:
    """Whether the body model of `resolution` is built and cached, and the cache folder writable."""
    from iguana_ros.body.model import cache_dir, cache_path
    folder = cache_dir()
    ok, existing = _writable_dir(folder)
    if not ok:
        return Check('model cache', False, f'{folder} is not writable ({existing}): every run rebuilds the model',
                     'export IGUANA_CACHE_DIR=<a writable folder>', needed=False)
    if cache_path(resolution).is_file():
        return Check('model cache', True, f'{resolution} model cached in {folder}, writable')
    return Check('model cache', True, f'{folder} writable; the {resolution} model is built at first use '
                 '(~10-30 s) and cached')


def check_ffmpeg() -> Check:
    """Return an ffmpeg that `iguana render -o run.mp4` can use (imageio-ffmpeg's bundled binary or one on PATH)."""
    try:
        import imageio_ffmpeg
        exe = imageio_ffmpeg.get_ffmpeg_exe()
    except Exception as exc:  # noqa: BLE001 -- a missing package or binary are both "no ffmpeg"
        exe, why = shutil.which('ffmpeg'), f'{type(exc).__name__}: {exc}'
        if exe is None:
            return Check('ffmpeg for MP4', False, f'no ffmpeg ({why}); GIF and PNG still work',
                         'pip install imageio-ffmpeg (make install does), or apt-get install ffmpeg', needed=False)
    try:
        done = subprocess.run([exe, '-version'], capture_output=True, text=True, timeout=20)
    except (OSError, subprocess.TimeoutExpired) as exc:
        return Check('ffmpeg for MP4', False, f'{exe} does not run ({exc})',
                     'reinstall imageio-ffmpeg, or apt-get install ffmpeg', needed=False)
    words = done.stdout.split()
    version = words[2] if len(words) > 2 and words[:2] == ['ffmpeg', 'version'] else '?'
    return Check('ffmpeg for MP4', done.returncode == 0, f'ffmpeg {version} at {exe}',
                 'reinstall imageio-ffmpeg, or apt-get install ffmpeg', needed=False)


def quick_checks(bag_folder: Path = Path('bags')) -> list[Check]:
    """
    Return the checks `iguana run` makes before it starts anything (about 0.3 s).

    Python, rclpy and RMW, the bag folder.
    """
    return [check_python(), check_rmw(), check_bag_folder(bag_folder)]


def require(checks: list[Check]) -> None:
    """`CheckFailed` with the first failed needed check's line."""
    for check in checks:
        if check.needed and not check.ok:
            raise CheckFailed(check.one_line())
