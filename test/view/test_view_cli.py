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
`iguana view` / `iguana run --view` on bad input.

No bag, a bag without mesh frames, a port in use, a bad port; each is one line on stderr (no traceback) and exit status
1, and nothing is started.
"""
from __future__ import annotations

import socket
import subprocess

import pytest

from ros_harness import IGUANA, REPO

pytestmark = pytest.mark.timeout(120)


def _iguana(*args) -> subprocess.CompletedProcess:
    """Run the iguana CLI with `args` (60 s at most)."""
    return subprocess.run([*IGUANA, *map(str, args)], cwd=REPO, capture_output=True, text=True, timeout=60)


def _one_error_line(result: subprocess.CompletedProcess, command: str, *words: str) -> str:
    """Return the single stderr line of a failed command, checked to name every one of `words`."""
    assert result.returncode == 1, (result.stdout, result.stderr)
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f'{command}: error: '), result.stderr
    for word in words:
        assert word in lines[0], lines[0]
    return lines[0]


def _bag_without_mesh(directory):
    """Return a bag holding iguana_state messages only."""
    from rclpy.serialization import serialize_message

    from iguana_ros.bag.schema import message_definition
    from iguana_ros.bag.storage import BagWriter
    from iguana_ros.ros.conversions import odometry_msg
    from iguana_ros.topics import topic

    spec = topic('iguana_state')
    writer = BagWriter(directory)
    channel = writer.add_topic('/' + spec.name, spec.type, message_definition(spec.type))
    for k in range(5):
        msg = odometry_msg([0.1 * k, 0, 0.07], [0, 0, 0, 1], [0, 0, 0], [0, 0, 0], stamp=k / 30)
        writer.write(channel, serialize_message(msg), 1_000_000_000 + k * 33_000_000)
    writer.close()
    return directory


def test_a_missing_bag_is_one_line(tmp_path):
    _one_error_line(_iguana('view', tmp_path / 'nothing_here'), 'iguana view', 'no bag at', 'nothing_here')


def test_a_bag_without_mesh_frames_is_one_line(tmp_path):
    bag = _bag_without_mesh(tmp_path / 'no_mesh')
    _one_error_line(_iguana('view', bag), 'iguana view', 'no mesh_marker topic', 'recorded: /iguana_state',
                    'nothing to show')


@pytest.fixture
def busy_port():
    """Yield a port on 127.0.0.1 that another socket listens on."""
    with socket.socket() as sock:
        sock.bind(('127.0.0.1', 0))
        sock.listen()
        yield sock.getsockname()[1]


def test_a_port_in_use_is_one_line_live_and_with_a_run(busy_port, tmp_path):
    _one_error_line(_iguana('view', '--port', busy_port), 'iguana view', f'port {busy_port}', 'in use', '--port')
    bag = tmp_path / 'run_bag'
    result = _iguana('run', 'flat_walk', '--view', '--view-port', busy_port, '--record', bag)
    _one_error_line(result, 'iguana run', f'port {busy_port}', 'in use')
    assert not bag.exists() and not result.stdout       # refused before anything started


def test_a_port_out_of_range_is_one_line():
    _one_error_line(_iguana('view', '--port', 70000), 'iguana view', 'port 70000', 'out of range')


@pytest.mark.parametrize('rate', ['0', '61', 'nan'])
def test_a_redraw_rate_out_of_range_is_one_line(rate):
    _one_error_line(_iguana('view', '--rate', rate), 'iguana view', f'--rate is {float(rate):g}', '(0, 60]')


def test_a_run_with_a_bad_view_rate_is_refused_before_it_starts(tmp_path):
    result = _iguana('run', 'flat_walk', '--view', '--view-port', '0', '--view-rate', '-2', '--record', tmp_path / 'b')
    _one_error_line(result, 'iguana run', '--view-rate is -2', 'redraws per second')
    assert not (tmp_path / 'b').exists() and not result.stdout          # refused before anything started
