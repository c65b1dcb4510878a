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
`iguana render` of a bag with a damaged metadata.yaml or a damaged chunk: one line, exit 1 unless --allow-damaged.

A sound bag whose payloads do not all decode (another type's bytes on a topic, a cut message) renders the rest with a
note per topic.
"""
import numpy as np

from render_synthetic import write_synthetic_bag


def test_render_with_a_binary_metadata_yaml_gives_one_line(tmp_path, cli):
    bag = write_synthetic_bag(tmp_path / 'synthetic', duration=0.5)
    (bag / 'metadata.yaml').write_bytes(np.random.default_rng(4).bytes(3000))
    png = tmp_path / 'frame.png'
    rc, out, err = cli(['render', bag, '-o', png, '-q'])
    assert rc == 1 and len(err.strip().splitlines()) == 1 and 'metadata.yaml' in err and 'not UTF-8' in err, err
    assert '--allow-damaged' in err
    assert not png.exists()
    rc, out, err = cli(['render', bag, '-o', png, '-q', '--allow-damaged'])
    assert rc == 0 and png.stat().st_size > 0 and 'metadata.yaml' in err


def test_render_of_a_bag_with_a_damaged_chunk_is_refused_without_allow_damaged(tmp_path, cli):
    from mcap.reader import make_reader

    bag = write_synthetic_bag(tmp_path / 'synthetic', duration=1.0, chunk_bytes=4096)
    path = bag / 'synthetic.mcap'
    with open(path, 'rb') as f:
        chunk = make_reader(f).get_summary().chunk_indexes[3]
    raw = bytearray(path.read_bytes())
    raw[chunk.chunk_start_offset + chunk.chunk_length - 3] ^= 0xFF
    path.write_bytes(bytes(raw))
    png = tmp_path / 'frame.png'
    rc, out, err = cli(['render', bag, '-o', png, '-q'])
    assert rc == 1 and len(err.strip().splitlines()) == 1 and 'damaged' in err and '--allow-damaged' in err, err
    assert not png.exists()
    rc, out, err = cli(['render', bag, '-o', png, '-q', '--allow-damaged'])
    assert rc == 0 and png.stat().st_size > 0 and 'damaged' in err


def test_render_skips_payloads_that_do_not_decode_with_a_note(tmp_path, cli):
    from iguana_ros.bag.frames import read_run
    bag = write_synthetic_bag(tmp_path / 'synthetic', duration=1.0, strays=True)
    run = read_run(bag)
    clean = read_run(write_synthetic_bag(tmp_path / 'clean', duration=1.0))
    assert run.damage == '' and len(run.times) == len(clean.times)
    assert np.array_equal(run.track_positions, clean.track_positions)     # the Marker on iguana_state left out
    notes = '\n'.join(run.notes)
    for key in ('iguana_state', 'mesh_marker', 'scene_markers'):
        assert f'skipped 1 {key} message(s) that did not decode' in notes, notes
    png = tmp_path / 'frame.png'
    rc, out, err = cli(['render', bag, '-o', png, '-q'])
    assert rc == 0 and png.stat().st_size > 0, err
    assert 'Traceback' not in err and 'note: skipped 1 iguana_state message(s) that did not decode' in err, err
