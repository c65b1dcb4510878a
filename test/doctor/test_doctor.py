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
`iguana doctor` passes on this machine, and fails with a named fix on a machine that is not ready.

It fails when the RMW is missing, when discovery is off, or when another participant is on the domain; `iguana run`
stops at once with the doctor's line.
"""
from __future__ import annotations

import os
from pathlib import Path
import subprocess
import sys

import pytest

from iguana_ros import jit
from iguana_ros.doctor import checks as doctor
from ros_harness import IGUANA, NodeProcess, REPO

pytestmark = [pytest.mark.ros, pytest.mark.timeout(120)]

CHECKS = ('Python', 'ROS domain id', 'rclpy log directory', 'discovery range', 'rclpy and RMW',
          'DDS loopback on ROS_DOMAIN_ID', 'other participants on ROS_DOMAIN_ID', 'kernel cache', 'model cache',
          'bag folder', 'ffmpeg for MP4')

FOREIGN = """
import time, rclpy
rclpy.init()
node = rclpy.create_node('foreign_participant')
print('ready', flush=True)
end = time.monotonic() + 60
while rclpy.ok() and time.monotonic() < end:
    rclpy.spin_once(node, timeout_sec=0.1)
"""


def iguana(*args, env: dict | None = None, cwd: Path = REPO) -> subprocess.CompletedProcess:
    """Run the iguana CLI with this test's environment plus `env`."""
    return subprocess.run([*IGUANA, *args], cwd=cwd, capture_output=True, text=True, timeout=100,
                          env={**os.environ, **(env or {})})


def marked(out: str, mark: str) -> list[str]:
    """Lines of `out` that start with `mark` ('✓' or '✗')."""
    return [line for line in out.splitlines() if line.startswith(mark)]


def test_doctor_passes_here(tmp_path):
    done = iguana('doctor', '--bags-dir', str(tmp_path / 'bags'))
    assert done.returncode == 0, done.stdout + done.stderr
    passed = marked(done.stdout, '✓')
    for name in CHECKS:
        assert any(line.startswith(f'✓ {name}') for line in passed), (name, done.stdout)
    domain = os.environ['ROS_DOMAIN_ID']
    assert f'✓ DDS loopback on ROS_DOMAIN_ID {domain}: a second process echoed a message' in done.stdout
    assert done.stdout.splitlines()[-1].startswith('iguana doctor: ready (11 of 11 checks passed')


def test_a_missing_rmw_is_named_with_its_fix(tmp_path):
    done = iguana('doctor', env={'RMW_IMPLEMENTATION': 'rmw_missing_xyz'})
    assert done.returncode == 1, done.stdout + done.stderr
    lines = done.stdout.splitlines()
    at = lines.index(next(line for line in lines if line.startswith('✗ rclpy and RMW: ')))
    assert 'RMW_IMPLEMENTATION=rmw_missing_xyz cannot be used by this rclpy' in lines[at]
    assert lines[at + 1] == '    fix: unset RMW_IMPLEMENTATION or export RMW_IMPLEMENTATION=rmw_fastrtps_cpp'
    assert 'iguana doctor: 3 of 11 checks failed: rclpy and RMW, DDS loopback, other participants' in lines[-1]
    assert 'Traceback' not in done.stdout + done.stderr


def test_iguana_run_stops_at_once_with_the_doctors_line(tmp_path):
    done = iguana('run', 'flat_walk', '--record', str(tmp_path / 'bag'), env={'RMW_IMPLEMENTATION': 'rmw_missing_xyz'})
    assert done.returncode == 1 and done.stdout == '', done.stdout + done.stderr
    assert done.stderr.splitlines() == [
        'iguana run: error: ✗ rclpy and RMW: RMW_IMPLEMENTATION=rmw_missing_xyz cannot be used by this rclpy '
        '(import rclpy exits with status 102); the installed RMW is rmw_fastrtps_cpp; fix: unset RMW_IMPLEMENTATION '
        'or export RMW_IMPLEMENTATION=rmw_fastrtps_cpp']
    assert not (tmp_path / 'bag').exists()


def test_discovery_off_fails_the_loopback_with_its_fix():
    done = iguana('doctor', '--timeout', '4', env={'ROS_AUTOMATIC_DISCOVERY_RANGE': 'OFF'})
    assert done.returncode == 1, done.stdout + done.stderr
    failed = marked(done.stdout, '✗')
    assert len(failed) == 1 and 'no echo within 4 s: processes cannot reach each other over DDS' in failed[0], \
        done.stdout
    assert ('    fix: ROS_AUTOMATIC_DISCOVERY_RANGE=OFF turns discovery off: export '
            'ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST') in done.stdout.splitlines()


def test_a_busy_domain_is_named_with_its_fix(tmp_path):
    domain = os.environ['ROS_DOMAIN_ID']
    with NodeProcess([sys.executable, '-c', FOREIGN], 'foreign', tmp_path).start(ready='ready', timeout=30):
        done = iguana('doctor')
    assert done.returncode == 1, done.stdout + done.stderr
    failed = marked(done.stdout, '✗')
    assert failed == [f'✗ other participants on ROS_DOMAIN_ID {domain}: 1 node: /foreign_participant; their '
                      "traffic would mix with a run's"], done.stdout
    assert (f'    fix: stop them, or use a domain of your own: export ROS_DOMAIN_ID=<0-101, not {domain}>'
            in done.stdout.splitlines())


def test_check_lines_and_required_checks():
    ok = doctor.Check('thing', True, 'fine')
    bad = doctor.Check('thing', False, 'broken', 'mend it')
    optional = doctor.Check('extra', False, 'absent', 'add it', needed=False)
    assert ok.lines() == ['✓ thing: fine']
    assert bad.lines() == ['✗ thing: broken', '    fix: mend it']
    assert bad.one_line() == '✗ thing: broken; fix: mend it'
    assert optional.lines()[0] == '✗ extra (optional): absent'
    doctor.require([ok, optional])
    with pytest.raises(doctor.CheckFailed, match='^✗ thing: broken; fix: mend it$'):
        doctor.require([ok, bad])
    assert not doctor.check_python((3, 9, 1)).ok and doctor.check_python((3, 10, 0)).ok


def test_bag_folder_check_tries_a_real_file(tmp_path):
    assert doctor.check_bag_folder(tmp_path / 'new' / 'bags').ok
    refused = doctor.check_bag_folder(Path('/proc/iguana_bags'))
    assert not refused.ok and refused.fix.endswith('iguana run --record DIR'), refused


def test_kernel_cache_cold_then_warm(tmp_path):
    from iguana_ros.jit import STAMP_NAME, kernel_sources_digest
    package = tmp_path / 'pkg'
    (package / 'room').mkdir(parents=True)
    (package / 'room' / 'fast.py').write_text('import numba\n\n\n@numba.njit(cache=True)\ndef f(x):\n    return x\n')
    (package / 'plain.py').write_text('"""mentions njit in words only"""\n')
    assert jit.kernel_modules(package) == [package / 'room' / 'fast.py']
    cold = doctor.check_kernel_cache(package, env={})
    assert cold.ok and cold.detail.startswith("cold in the package's __pycache__ folders, writable: room/fast.py "
                                              'compile at first use'), cold
    (package / '__pycache__').mkdir()
    (package / '__pycache__' / STAMP_NAME).write_text(kernel_sources_digest(package))
    (package / 'room' / '__pycache__').mkdir()
    (package / 'room' / '__pycache__' / 'fast.f-4.py311.nbi').write_bytes(b'')
    warm = doctor.check_kernel_cache(package, env={})
    assert warm.ok and warm.detail == "warm (1 modules compiled and cached in the package's __pycache__ folders), " \
        'writable', warm


def test_the_kernel_cache_check_looks_where_numba_caches(tmp_path):
    """With NUMBA_CACHE_DIR set numba writes its cache there, and the doctor looks there (not in __pycache__)."""
    package = tmp_path / 'pkg'
    package.mkdir()
    (package / '__init__.py').write_text('')
    (package / 'fast.py').write_text('import numba\n\n\n@numba.njit(cache=True)\ndef f(x):\n    return x + 1\n')
    numba_dir = tmp_path / 'numba_cache'
    compile_it = ('import sys\nfrom pathlib import Path\nsys.path.insert(0, sys.argv[1])\n'
                  'from iguana_ros.jit import invalidate_stale_kernels\n'
                  'invalidate_stale_kernels(Path(sys.argv[1]) / "pkg")\nimport pkg.fast\npkg.fast.f(1)\n')
    subprocess.run([sys.executable, '-c', compile_it, str(tmp_path)], cwd=REPO, check=True, timeout=120,
                   env={**os.environ, 'NUMBA_CACHE_DIR': str(numba_dir)})
    assert list(numba_dir.rglob('fast.f-*.nbi')) and not list(package.rglob('*.nbi'))   # numba wrote there only
    warm = doctor.check_kernel_cache(package, env={'NUMBA_CACHE_DIR': str(numba_dir)})
    assert warm.ok and warm.detail == f'warm (1 modules compiled and cached in NUMBA_CACHE_DIR ({numba_dir})), ' \
        'writable', warm
    assert jit.kernel_cache(package, env={}).state == 'cold'                   # nothing in __pycache__
    fresh = doctor.check_kernel_cache(package, env={'NUMBA_CACHE_DIR': str(tmp_path / 'fresh')})
    assert fresh.ok and fresh.detail.startswith(f'cold in NUMBA_CACHE_DIR ({tmp_path / "fresh"})'), fresh
    refused = doctor.check_kernel_cache(package, env={'NUMBA_CACHE_DIR': '/etc/hostname/numba'})
    assert not refused.ok and not refused.needed and refused.detail.startswith(
        'NUMBA_CACHE_DIR=/etc/hostname/numba cannot be written (/etc/hostname: Not a directory): numba caches in '
        "the package's __pycache__ folders instead"), refused


def test_iguana_run_that_hears_none_of_its_nodes_stops_with_the_loopback_line(tmp_path, monkeypatch):
    """
    With discovery off, `iguana run` hears none of its nodes and stops with the loopback line.

    No node is ever heard; the run asks the doctor's loopback and stops with its line instead of waiting for a lockstep
    or goal time-out (the silence and loopback limits shortened for the test).
    """
    import yaml

    from iguana_ros.supervisor import run as supervisor
    from iguana_ros.supervisor.run import RunOptions, run_scene

    monkeypatch.setenv('ROS_AUTOMATIC_DISCOVERY_RANGE', 'OFF')
    monkeypatch.setattr(supervisor, 'STARTUP_SILENCE_S', 2.0)
    monkeypatch.setattr(supervisor, 'SILENCE_LOOPBACK_S', 3.0)
    scene = tmp_path / 'walk.yaml'
    scene.write_text(yaml.safe_dump({'name': 'walk', 'terrain': {'kind': 'flat'}, 'model': {'resolution': 'coarse'},
                                     'goals': [{'x': 1.0, 'y': 0.0}], 'duration': 2.0}))
    summary = run_scene(RunOptions(scene=str(scene), record=tmp_path / 'bag', domain_check_s=0.2))
    assert summary.outcome == 'failed' and summary.exit_code == 1, summary.lines()
    assert summary.reason == (
        'no node of the run was heard within 2 s; ✗ DDS loopback on ROS_DOMAIN_ID '
        f'{os.environ["ROS_DOMAIN_ID"]}: no echo within 3 s: processes cannot reach each other over DDS '
        '(ROS_AUTOMATIC_DISCOVERY_RANGE OFF); fix: ROS_AUTOMATIC_DISCOVERY_RANGE=OFF turns discovery off: export '
        'ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST'), summary.reason
    assert summary.phases == ()                                  # not even the launch finished: nothing was heard


# ------------------------------------------------------------------------------- broken environments (issue 30, 7)
DOMAIN_FIX = 'use 0–101 (or 215–232)'


def cli(*args: str, env: dict, prefix: tuple = (), timeout: float = 100) -> subprocess.CompletedProcess:
    """Run the iguana CLI with this test's environment changed by `env` (None deletes a variable), after `prefix`."""
    changed = {**os.environ, **{k: v for k, v in env.items() if v is not None}}
    for name in [k for k, v in env.items() if v is None]:
        changed.pop(name, None)
    return subprocess.run([*prefix, *IGUANA, *args], cwd=REPO, capture_output=True, text=True, timeout=timeout,
                          env=changed)


def read_only_mount(home: Path) -> tuple:
    """Command prefix that runs a command with `home` mounted read-only (a private mount namespace), else a reason."""
    import shutil
    if shutil.which('unshare') is None:
        return 'no unshare(1) here'
    probe = subprocess.run(['unshare', '--mount', 'sh', '-c', 'mount -t tmpfs -o ro tmpfs "$0"', str(home)],
                           capture_output=True, text=True)
    if probe.returncode != 0:
        return f'cannot mount a read-only tmpfs here: {probe.stderr.strip()}'
    return ('unshare', '--mount', 'sh', '-c', 'mount -t tmpfs -o ro tmpfs "$0" && exec "$@"', str(home))


@pytest.fixture(params=['read-only mount', 'a path through a file'])
def unwritable_home(request, tmp_path) -> tuple[dict, tuple]:
    """(environment, command prefix) where HOME cannot hold ~/.ros/log and neither ROS_LOG_DIR nor ROS_HOME is set."""
    env = {'ROS_LOG_DIR': None, 'ROS_HOME': None, 'IGUANA_CACHE_DIR': str(tmp_path / 'models')}
    if request.param == 'a path through a file':
        return {**env, 'HOME': '/etc/hostname/x'}, ()
    home = tmp_path / 'home'
    home.mkdir()
    prefix = read_only_mount(home)
    if isinstance(prefix, str):
        pytest.skip(prefix)
    return {**env, 'HOME': str(home)}, prefix


BROKEN = {
    '999': ({'ROS_DOMAIN_ID': '999'}, f'✗ ROS domain id: ROS_DOMAIN_ID=999 is out of range: {DOMAIN_FIX}'),
    'abc': ({'ROS_DOMAIN_ID': 'abc'}, f'✗ ROS domain id: ROS_DOMAIN_ID=abc is not an integer: {DOMAIN_FIX}'),
}
"""A broken ROS_DOMAIN_ID: its environment and the start of the line that names it."""


def one_error_line(done: subprocess.CompletedProcess, command: str) -> str:
    """Return the one line on stderr of a command that failed before it started anything (nothing on stdout)."""
    assert done.returncode == 1, done.stdout + done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f'{command}: error: '), done.stderr
    assert done.stdout == '', done.stdout
    return lines[0][len(f'{command}: error: '):]


def command_args(command: str, tmp_path: Path) -> tuple:
    """Return the arguments of `iguana goal` (3 s time-out) or `iguana run flat_walk` (bag under `tmp_path`)."""
    if command == 'goal':
        return ('goal', '1', '0', '--timeout', '3')
    return ('run', 'flat_walk', '--record', str(tmp_path / 'bag'))


@pytest.mark.parametrize('domain', sorted(BROKEN))
def test_a_bad_domain_id_is_named_by_the_doctor(domain):
    env, named = BROKEN[domain]
    done = cli('doctor', '--timeout', '5', env=env)
    assert done.returncode == 1, done.stdout + done.stderr
    lines = done.stdout.splitlines()
    assert any(line.startswith(named) for line in lines), done.stdout
    assert '✓ rclpy and RMW: rclpy initialises with rmw_fastrtps_cpp' in done.stdout, done.stdout
    assert '✗ DDS loopback: not tried: fix ROS domain id first' in lines, done.stdout
    assert 'install rmw' not in done.stdout and 'Calculated port number' not in done.stdout + done.stderr
    assert 'Traceback' not in done.stdout + done.stderr


@pytest.mark.parametrize('domain', sorted(BROKEN))
@pytest.mark.parametrize('command', ['goal', 'run'])
def test_a_bad_domain_id_stops_goal_and_run_with_one_line(domain, command, tmp_path):
    env, named = BROKEN[domain]
    line = one_error_line(cli(*command_args(command, tmp_path), env=env), f'iguana {command}')
    assert line.startswith(named) and 'fix: export ROS_DOMAIN_ID=' in line, line
    assert not (tmp_path / 'bag').exists()


def test_an_unwritable_log_directory_is_named_by_the_doctor(unwritable_home):
    env, prefix = unwritable_home
    done = cli('doctor', '--timeout', '5', env=env, prefix=prefix)
    assert done.returncode == 1, done.stdout + done.stderr
    lines = done.stdout.splitlines()
    named = [line for line in lines if line.startswith('✗ rclpy log directory: ')]
    assert named and f'{env["HOME"]}/.ros/log cannot be created' in named[0], done.stdout
    fix = lines[lines.index(named[0]) + 1]
    assert 'export ROS_LOG_DIR=/tmp/ros_log' in fix and 'ROS_HOME' in fix, fix
    assert '✓ rclpy and RMW: rclpy initialises with rmw_fastrtps_cpp' in done.stdout, done.stdout
    assert 'install rmw' not in done.stdout and 'Traceback' not in done.stdout + done.stderr


@pytest.mark.parametrize('command', ['goal', 'run'])
def test_an_unwritable_log_directory_stops_goal_and_run_with_one_line(unwritable_home, command, tmp_path):
    env, prefix = unwritable_home
    line = one_error_line(cli(*command_args(command, tmp_path), env=env, prefix=prefix), f'iguana {command}')
    assert line.startswith('✗ rclpy log directory: ') and 'export ROS_LOG_DIR=/tmp/ros_log' in line, line
    assert 'install rmw' not in line
    assert not (tmp_path / 'bag').exists()
