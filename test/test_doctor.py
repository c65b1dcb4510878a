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
`iguana doctor` passes on this machine, and fails with a named fix when the RMW is missing, when discovery is off.

or when another participant is on the domain; `iguana run` stops at once with the doctor's line.
"""
from __future__ import annotations

import os
from pathlib import Path
import subprocess
import sys

import pytest

from iguana_ros import doctor
from ros_harness import IGUANA, NodeProcess, REPO

pytestmark = [pytest.mark.ros, pytest.mark.timeout(120)]

CHECKS = ('Python', 'rclpy and RMW', 'DDS loopback on ROS_DOMAIN_ID', 'other participants on ROS_DOMAIN_ID',
          'kernel cache', 'model cache', 'bag folder', 'ffmpeg for MP4')

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
    assert done.stdout.splitlines()[-1].startswith('iguana doctor: ready (8 of 8 checks passed')


def test_a_missing_rmw_is_named_with_its_fix(tmp_path):
    done = iguana('doctor', env={'RMW_IMPLEMENTATION': 'rmw_missing_xyz'})
    assert done.returncode == 1, done.stdout + done.stderr
    lines = done.stdout.splitlines()
    at = lines.index(next(line for line in lines if line.startswith('✗ rclpy and RMW: ')))
    assert 'RMW_IMPLEMENTATION=rmw_missing_xyz cannot be used by this rclpy' in lines[at]
    assert lines[at + 1] == '    fix: unset RMW_IMPLEMENTATION or export RMW_IMPLEMENTATION=rmw_fastrtps_cpp'
    assert 'iguana doctor: 3 of 8 checks failed: rclpy and RMW, DDS loopback, other participants' in lines[-1]
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
    assert doctor.kernel_modules(package) == [package / 'room' / 'fast.py']
    cold = doctor.check_kernel_cache(package)
    assert cold.ok and cold.detail.startswith('cold, writable: room/fast.py compile at first use'), cold
    (package / '__pycache__').mkdir()
    (package / '__pycache__' / STAMP_NAME).write_text(kernel_sources_digest(package))
    (package / 'room' / '__pycache__').mkdir()
    (package / 'room' / '__pycache__' / 'fast.f-4.py311.nbi').write_bytes(b'')
    warm = doctor.check_kernel_cache(package)
    assert warm.ok and warm.detail == 'warm (1 modules compiled and cached), writable', warm


def test_iguana_run_that_hears_none_of_its_nodes_stops_with_the_loopback_line(tmp_path, monkeypatch):
    """
    Discovery off.

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
