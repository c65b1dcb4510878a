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

Python, the ROS environment (ROS_DOMAIN_ID, rclpy's log directory, the discovery range, static peers), rclpy and its
RMW (probed in a child process), the compiled-kernel cache, the model cache, the bag folder, ffmpeg. Each gives a
`Check`: a pass/fail line and, when it fails, the fix. The DDS checks (a loopback between two processes, other
participants on the domain) are in `doctor/dds.py`; `iguana run` runs `quick_checks` before it starts
anything, and every command that uses ROS runs `require_ros` (the same environment checks and rclpy probe) before its
first `rclpy.init`.

rclpy is never imported here: with RMW_IMPLEMENTATION naming an RMW that is not installed, `import rclpy` ends
the process (rcl exits with status 102), so it is tried in a child process first. A ROS_DOMAIN_ID beyond what DDS
maps to UDP ports ends the process too (Fast DDS exits when the first node is created), and a domain id that is not
a number or a log directory that cannot be created make `rclpy.init` fail: the environment checks name those causes
before anything is tried.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
import json
import os
from pathlib import Path
import re
import shutil
import subprocess
import sys

from iguana_ros.errors import IguanaError
from iguana_ros.jit import kernel_cache, nearest_existing, write_error

MIN_PYTHON = (3, 10)
"""Oldest Python the package supports (setup.py python_requires)."""

PROBE_TIMEOUT_S = 30.0
"""Wall seconds the rclpy probe may take (an import on a loaded machine)."""

RMW_ENV = 'RMW_IMPLEMENTATION'
"""Environment variable that picks the ROS middleware."""

DOMAIN_ENV = 'ROS_DOMAIN_ID'
"""Environment variable that picks the ROS domain."""

DOMAIN_ID_MAX = 232
"""Largest ROS_DOMAIN_ID that DDS's default port mapping (7400 + 250 x domain + offsets) keeps below port 65536:
Fast DDS exits the process when a node is created on a higher one."""

EPHEMERAL_DOMAINS = range(102, 215)
"""Domains whose ports overlap Linux's default ephemeral port range (32768-60999): they work, but may collide with
ports other programs were given (the ROS 2 documentation's advice: 0-101, or 215-232)."""

DOMAIN_ADVICE = 'use 0–101 (or 215–232)'
DOMAIN_FIX = 'export ROS_DOMAIN_ID=<a number in 0–101>, or unset it for domain 0'

LOG_FIX = ('point ROS_LOG_DIR at a writable folder, e.g. export ROS_LOG_DIR=/tmp/ros_log (rclpy writes its log files '
           'to $ROS_LOG_DIR, else $ROS_HOME/log, else ~/.ros/log)')

DISCOVERY_ENV = 'ROS_AUTOMATIC_DISCOVERY_RANGE'
DISCOVERY_RANGES = ('LOCALHOST', 'SUBNET', 'OFF', 'SYSTEM_DEFAULT')
"""The values rcl knows (case matters: anything else is warned about and read as LOCALHOST)."""

STATIC_PEERS_ENV = 'ROS_STATIC_PEERS'

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


def _shown(raw: str) -> str:
    """Return `raw` as typed, quoted when it is empty or has surrounding blanks."""
    return raw if raw and raw.strip() == raw else repr(raw)


def check_domain_id(env: Mapping[str, str] | None = None) -> Check:
    """ROS_DOMAIN_ID unset, or a plain decimal number that DDS can map to ports (0–232)."""
    env = os.environ if env is None else env
    raw = env.get(DOMAIN_ENV)
    if raw is None or raw == '':
        state = 'unset' if raw is None else 'empty, which rcl reads as unset'
        return Check('ROS domain id', True, f'0 ({DOMAIN_ENV} {state})')
    text, name = raw.strip(), f'{DOMAIN_ENV}={_shown(raw)}'
    if not re.fullmatch(r'[+-]?[0-9]+', text):
        return Check('ROS domain id', False, f'{name} is not an integer: {DOMAIN_ADVICE}', DOMAIN_FIX)
    value = int(text)
    if not 0 <= value <= DOMAIN_ID_MAX:
        return Check('ROS domain id', False, f'{name} is out of range: {DOMAIN_ADVICE}; DDS maps only domains '
                     f'0–{DOMAIN_ID_MAX} to UDP ports', DOMAIN_FIX)
    if not re.fullmatch(r'0|[1-9][0-9]*', text):
        return Check('ROS domain id', False, f'{name} is not written as a plain decimal number (rcl reads a leading '
                     f'0 as octal, not as {value}): {DOMAIN_ADVICE}', DOMAIN_FIX)
    if value in EPHEMERAL_DOMAINS:
        return Check('ROS domain id', True, f'{value}; domains 102–214 may collide with the ephemeral UDP ports of '
                     'other programs (0–101 and 215–232 do not)')
    return Check('ROS domain id', True, str(value))


def _expand_user(path: str, env: Mapping[str, str]) -> Path | None:
    """Return `path` with a leading ~ replaced by HOME, as rcutils expands it (None: ~ without a HOME)."""
    if not path.startswith('~'):
        return Path(path)
    home = env.get('HOME')
    return Path(home + path[1:]) if home else None


def ros_log_dir(env: Mapping[str, str] | None = None) -> tuple[Path | None, str]:
    """
    Return (the folder rclpy's logging writes to, what chose it).

    ROS_LOG_DIR, else $ROS_HOME/log, else ~/.ros/log (rcl_logging's order; a leading ~ is HOME); None when no folder
    can be named (HOME unset).
    """
    env = os.environ if env is None else env
    if env.get('ROS_LOG_DIR'):
        return _expand_user(env['ROS_LOG_DIR'], env), 'ROS_LOG_DIR'
    if env.get('ROS_HOME'):
        home = _expand_user(env['ROS_HOME'], env)
        return (home / 'log' if home else None), '$ROS_HOME/log'
    home = env.get('HOME')
    return (Path(home) / '.ros' / 'log' if home else None), '~/.ros/log; ROS_LOG_DIR and ROS_HOME unset'


def check_log_dir(env: Mapping[str, str] | None = None) -> Check:
    """Whether rclpy's log directory can be created and written (rclpy.init fails otherwise)."""
    folder, source = ros_log_dir(env)
    if folder is None:
        return Check('rclpy log directory', False, f'none can be named ({source}): HOME is unset or empty, so '
                     'rclpy.init fails', LOG_FIX)
    why = write_error(folder)
    if why:
        return Check('rclpy log directory', False, f'{folder} cannot be created or written ({why}), so rclpy.init '
                     f'fails ({source})', LOG_FIX)
    return Check('rclpy log directory', True, f'{folder} ({source}), writable')


def check_discovery_range(env: Mapping[str, str] | None = None) -> Check:
    """ROS_AUTOMATIC_DISCOVERY_RANGE unset or one of the values rcl knows."""
    env = os.environ if env is None else env
    raw = env.get(DISCOVERY_ENV, '')
    if not raw:
        return Check('discovery range', True, f"{DISCOVERY_ENV} unset: rcl's default (SUBNET)")
    if raw in DISCOVERY_RANGES:
        note = ': discovery is off, only ROS_STATIC_PEERS are reached' if raw == 'OFF' else ''
        return Check('discovery range', True, f'{DISCOVERY_ENV}={raw}{note}')
    return Check('discovery range', False, f'{DISCOVERY_ENV}={_shown(raw)} is not one of '
                 f'{", ".join(DISCOVERY_RANGES)} (rcl warns and reads it as LOCALHOST)',
                 f'export {DISCOVERY_ENV}=LOCALHOST (this machine only) or SUBNET')


def check_static_peers(env: Mapping[str, str] | None = None) -> Check | None:
    """Every host in ROS_STATIC_PEERS resolves (rmw cannot create a node otherwise); None when it is unset."""
    import socket
    env = os.environ if env is None else env
    peers = [p.strip() for p in env.get(STATIC_PEERS_ENV, '').split(';') if p.strip()]
    if not peers:
        return None
    for peer in peers:
        try:
            socket.getaddrinfo(peer, None)
        except (socket.gaierror, UnicodeError) as exc:
            why = exc.strerror if isinstance(exc, socket.gaierror) else str(exc)
            return Check('static peers', False, f'{STATIC_PEERS_ENV} names {peer!r}, which does not resolve ({why}), '
                         'so no node can be created', f'list addresses or host names separated by ";", or unset '
                         f'{STATIC_PEERS_ENV}')
    return Check('static peers', True, f'{STATIC_PEERS_ENV}: {", ".join(peers)}')


def environment_checks(env: Mapping[str, str] | None = None) -> list[Check]:
    """Return the checks of the ROS environment that need no process (a few milliseconds): domain, logs, discovery."""
    peers = check_static_peers(env)
    return [check_domain_id(env), check_log_dir(env), check_discovery_range(env)] + ([peers] if peers else [])


def probe_environment(env: Mapping[str, str], log_dir: str) -> tuple[dict, list[str]]:
    """
    Return (a copy of `env` without what the environment checks refuse, what was changed).

    An invalid ROS_DOMAIN_ID or ROS_STATIC_PEERS is dropped and an unusable log directory replaced by `log_dir`, so
    the rclpy probe judges rclpy and its RMW rather than those (which have checks of their own).
    """
    probe, changed = dict(env), []
    if not check_domain_id(env).ok:
        probe.pop(DOMAIN_ENV, None)
        changed.append(f'{DOMAIN_ENV} unset')
    if not check_log_dir(env).ok:
        probe['ROS_LOG_DIR'] = log_dir
        changed.append('a temporary ROS_LOG_DIR')
    peers = check_static_peers(env)
    if peers is not None and not peers.ok:
        probe.pop(STATIC_PEERS_ENV, None)
        changed.append(f'{STATIC_PEERS_ENV} unset')
    return probe, changed


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


def check_rmw(env: Mapping[str, str] | None = None) -> Check:
    """Rclpy imports and initialises with the RMW of `env` (default: this process's environment)."""
    import tempfile
    env = dict(os.environ if env is None else env)
    with tempfile.TemporaryDirectory(prefix='iguana_doctor_log_') as log_dir:
        probe, changed = probe_environment(env, log_dir)
        found = probe_rclpy(probe)
        wanted = env.get(RMW_ENV, '').strip()
        default = None
        if 'rmw' not in found and 'import_error' not in found and wanted:
            default = probe_rclpy({k: v for k, v in probe.items() if k != RMW_ENV})
    tried = f' (tried with {" and ".join(changed)}: see the lines above)' if changed else ''
    if 'rmw' in found:
        chosen = f'{RMW_ENV}={wanted}' if wanted else f'the default ({RMW_ENV} unset)'
        return Check('rclpy and RMW', True, f'rclpy initialises with {found["rmw"]}, {chosen}{tried}')
    if 'import_error' in found:
        return Check('rclpy and RMW', False, f'rclpy does not import ({found["import_error"]})',
                     "install the ROS 2 Jazzy wheels (make install, or pip install -e '.[ros]'), or source "
                     '/opt/ros/jazzy/setup.bash before creating the venv')
    return _rmw_failed(found, wanted, default, tried)


def _rmw_failed(found: dict, wanted: str, default: dict | None, tried: str) -> Check:
    """
    Return the failed rclpy check for a probe answer `found` of the RMW `wanted` ('' = the default).

    `default` is the probe's answer without RMW_IMPLEMENTATION (None when not asked): only an RMW that fails where the
    default works is called not installed.
    """
    status = found.get('status')
    how = f'exits with status {status}' if status is not None else found.get('stderr', 'fails')
    said = _last_line(found.get('stderr', ''))
    if not wanted:
        return Check('rclpy and RMW', False, f'import rclpy {how}{tried}', 'reinstall the ROS 2 wheels (make clean && '
                     'make install); the child said: ' + said)
    if default is not None and 'rmw' in default:
        return Check('rclpy and RMW', False, f'{RMW_ENV}={wanted} cannot be used by this rclpy (import rclpy {how})'
                     f'; the installed RMW is {default["rmw"]}',
                     f'unset {RMW_ENV} or export {RMW_ENV}={default["rmw"]}')
    return Check('rclpy and RMW', False, f'rclpy does not initialise, with {RMW_ENV}={wanted} or without it (import '
                 f'rclpy {how}){tried}', 'reinstall the ROS 2 wheels (make clean && make install); the child said: '
                 + said)


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
    return not write_error(folder), nearest_existing(folder)


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


def check_kernel_cache(package_dir: Path | None = None, env: Mapping[str, str] | None = None) -> Check:
    """
    Check whether the compiled kernels are cached where numba looks for them (NUMBA_CACHE_DIR honoured).

    Warm: a run starts at once; cold: the first run compiles them. The check also says whether they can be cached at
    all.
    """
    cache = kernel_cache(package_dir, env)
    if cache.unwritable:
        folders = ', '.join(str(m.parent / '__pycache__') for m in cache.unwritable[:3])
        return Check('kernel cache', False, f'numba can write no cache folder ({folders}, NUMBA_CACHE_DIR, '
                     '~/.cache/numba): every run compiles its kernels again (about a minute)',
                     'install the package where you can write (pip install -e .), or export NUMBA_CACHE_DIR=<a '
                     'writable folder>', needed=False)
    if cache.refused:
        return Check('kernel cache', False, f'{cache.refused}: numba caches in {cache.where} instead ({cache.state} '
                     'there)', 'export NUMBA_CACHE_DIR=<a writable folder>, or unset it', needed=False)
    if not cache.cold:
        return Check('kernel cache', True, f'warm ({len(cache.modules)} modules compiled and cached in '
                     f'{cache.where}), writable')
    listed = ', '.join(cache.cold[:3]) + (f' and {len(cache.cold) - 3} more' if len(cache.cold) > 3 else '')
    return Check('kernel cache', True, f'{cache.state} in {cache.where}, writable: {listed} compile at first use '
                 '(about a minute on 2 cores), cached afterwards; `iguana warm` (make install runs it) compiles them '
                 'ahead')


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

    Python, the ROS environment, rclpy and RMW, the bag folder.
    """
    return [check_python(), *environment_checks(), check_rmw(), check_bag_folder(bag_folder)]


def require(checks: list[Check]) -> None:
    """`CheckFailed` with the first failed needed check's line."""
    for check in checks:
        if check.needed and not check.ok:
            raise CheckFailed(check.one_line())


def require_ros(env: Mapping[str, str] | None = None) -> None:
    """
    `CheckFailed` unless the ROS environment passes its checks and rclpy initialises (a child probe, ~0.2 s).

    What every command that uses ROS calls before its first `rclpy.init`.
    """
    require(environment_checks(env))
    require([check_rmw(env)])
