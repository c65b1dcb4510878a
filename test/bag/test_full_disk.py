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
A full disk while recording (issue 30, item 5).

The probe's recorder died with two chained tracebacks, `iguana run` said `recorder exited with status 1` and never
"no space left on device", and no metadata.yaml was written. Now one line names it, and the bag is finalised from what
reached the disk: cut back to its last whole chunk, its summary and metadata.yaml written after it.
"""
from __future__ import annotations

import os
from pathlib import Path
import subprocess
import uuid

import numpy as np
import pytest
import yaml

from iguana_ros.bag.storage import BagWriteError, BagWriter, summarize


@pytest.fixture
def small_disk(tmp_path, request):
    """Yield a tmpfs of 3 MB (or the test's `disk_size` marker; root mounts it, skipped where it may not)."""
    marker = request.node.get_closest_marker('disk_size')
    where = tmp_path / f'disk_{uuid.uuid4().hex[:6]}'
    where.mkdir()
    size = marker.args[0] if marker else '3m'
    done = subprocess.run(['mount', '-t', 'tmpfs', '-o', f'size={size}', 'tmpfs', str(where)], capture_output=True,
                          text=True)
    if done.returncode != 0:
        pytest.skip(f'cannot mount a small tmpfs here: {done.stderr.strip()}')
    try:
        yield where
    finally:
        subprocess.run(['umount', '-l', str(where)], check=False)


def _fill(writer: BagWriter, channel: int) -> int:
    """Write incompressible messages until the disk is full; return how many were handed to the writer."""
    rng = np.random.default_rng(0)
    for k in range(10 ** 6):
        writer.write(channel, rng.bytes(20_000), log_time=10 ** 9 + k * 10 ** 7)
    raise AssertionError('the disk never filled')


def test_a_full_disk_is_one_line_and_the_bag_is_finalised_from_what_was_written(small_disk):
    writer = BagWriter(small_disk / 'bag', chunk_bytes=200_000)
    channel = writer.add_topic('/mesh_marker', 'visualization_msgs/msg/Marker', 'schema', '')
    with pytest.raises(BagWriteError) as info:
        _fill(writer, channel)
    line = str(info.value)
    assert '\n' not in line and 'No space left on device' in line and 'finalised' in line, line
    writer.close()                                     # after the failure: nothing more, no second error
    summary = summarize(small_disk / 'bag')
    assert summary.health.sound, summary.problem                  # a whole MCAP: summary, footer, CRCs
    kept = int(line.split('keeps the ')[1].split()[0])
    assert summary.message_count == kept > 0
    assert summary.metadata_problems == []                        # metadata.yaml written and agreeing
    meta = yaml.safe_load((small_disk / 'bag' / 'metadata.yaml').read_text())
    assert meta['rosbag2_bagfile_information']['message_count'] == kept


@pytest.mark.ros
@pytest.mark.long
@pytest.mark.timeout(300)
@pytest.mark.disk_size('600m')                 # above the doctor's 0.5 GB: it fills while the run goes on
def test_a_run_recording_onto_a_full_disk_says_so_in_its_line(small_disk, tmp_path):
    """The run starts with room; a filler takes all but 1 MB once the bag has its first chunks."""
    import shutil
    from ros_harness import IGUANA, NodeProcess, wait_for
    scene = tmp_path / 'long.yaml'
    scene.write_text(yaml.safe_dump({'model': {'resolution': 'coarse'}, 'terrain': {'kind': 'flat'},
                                     'goals': [{'x': 1.0, 'y': 0.0}], 'duration': 60.0}))
    bag = small_disk / 'bag'
    run = NodeProcess([*IGUANA, 'run', str(scene), '--record', str(bag)], 'run', tmp_path,
                      env={'PYTHONUNBUFFERED': '1'}).start()
    with run:
        mcap = bag / 'bag.mcap'
        assert wait_for(lambda: mcap.exists() and mcap.stat().st_size > 200_000, 120), run.output
        with open(small_disk / 'filler', 'wb') as filler:
            os.posix_fallocate(filler.fileno(), 0, shutil.disk_usage(small_disk).free - (1 << 20))
        code = run.wait(240)
    last = [line for line in run.output.splitlines() if line.startswith('iguana run:')]
    assert code == 1 and len(last) == 1, run.output[-3000:]
    assert 'no space left on device' in last[0], last
    assert 'Traceback' not in run.output
    recorder = (bag.parent / 'bag_logs' / 'recorder.out').read_text()
    summary = summarize(bag)
    assert summary.health.sound and summary.message_count > 0, (summary.problem, recorder[-2000:])
    assert (bag / 'metadata.yaml').is_file() and os.path.getsize(Path(bag) / 'metadata.yaml') > 0
