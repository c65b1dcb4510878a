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


def _bag_with_strays(directory):
    """
    Return a sound bag of 10 frames whose payloads do not all decode.

    On top of a good message per topic and frame: the mesh Marker's bytes on iguana_state, a cut foot_state, a
    cut push, a motion_clip in a frame that is not the world.
    """
    import numpy as np
    from rclpy.serialization import serialize_message

    from iguana_ros.bag.schema import message_definition
    from iguana_ros.bag.storage import BagWriter
    from iguana_ros.body.skeleton import iguana_skeleton
    from iguana_ros.ros import messages as m
    from iguana_ros.ros.cdr import triangle_list_marker_cdr
    from iguana_ros.ros.conversions import frame_stamp, push_msg
    from iguana_ros.stages import motion_graph
    from iguana_ros.topics import topic

    writer = BagWriter(directory)
    channels = {}
    for key in ('mesh_marker', 'iguana_state', 'foot_state', 'push', 'motion_clip'):
        spec = topic(key)
        channels[key] = writer.add_topic('/' + spec.name, spec.type, message_definition(spec.type))
    verts, tris = np.eye(3), np.array([[0, 1, 2]])
    clip = motion_graph().align('forward', np.zeros(2), 0.0)
    for k in range(10):
        log_ns = 1_000_000_000 + k * 33_000_000
        marker = triangle_list_marker_cdr(verts + 0.01 * k, tris, np.ones((3, 4)), stamp=frame_stamp(k))
        foot = m.foot_state_to_cdr(np.zeros(4), np.ones(4, bool), k)
        writer.write(channels['mesh_marker'], marker, log_ns)
        writer.write(channels['iguana_state'], m.state_to_cdr([0.01 * k, 0, 0.07], [0, 0, 0, 1], np.zeros(3),
                                                              np.zeros(3), k), log_ns + 1)
        writer.write(channels['foot_state'], foot, log_ns + 2)
        if k == 4:
            writer.write(channels['iguana_state'], marker, log_ns + 3)
            writer.write(channels['foot_state'], foot[:30], log_ns + 4)
            push = serialize_message(push_msg([0.0, -40.0, 0.0], 'trunk_left'))
            writer.write(channels['push'], push[:30], log_ns + 5)
            writer.write(channels['push'], push, log_ns + 6)
            writer.write(channels['motion_clip'], m.clip_to_cdr(clip, iguana_skeleton(), 0), log_ns + 7)
            wrong = m.clip_to_cdr(clip, iguana_skeleton(), 3)
            wrong = wrong.replace(b'\x06\x00\x00\x00world\x00', b'\x06\x00\x00\x00wrong\x00', 1)
            writer.write(channels['motion_clip'], wrong, log_ns + 8)
    writer.close()
    return directory


def test_bag_mode_skips_payloads_that_do_not_decode_with_a_note(tmp_path):
    """
    `iguana view BAG` reads with the nodes' decoders: another type's bytes and cut messages are notes, not tracebacks.

    (load_bag is what the command runs before it serves the page.)
    """
    from iguana_ros.view.bag_source import load_bag
    bag = load_bag(_bag_with_strays(tmp_path / 'strays'))
    assert bag.damage == '' and len(bag.view.meshes) == 10
    assert len(bag.view.states.times) == 10 and len(bag.view.pushes) == 1 and len(bag.view.clips) == 1
    notes = '\n'.join(bag.notes)
    for key in ('iguana_state', 'foot_state', 'push', 'motion_clip'):
        assert f'skipped 1 {key} message(s) that did not fit' in notes, notes
    assert "frame_id 'wrong'" in notes


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
