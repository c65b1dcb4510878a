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
Mid-file damage in a bag (chunk CRCs, data-section and summary CRCs, lost index, damaged metadata.yaml).

Detected, reported with what was recovered, every intact chunk recovered, exit status 1 unless --allow-damaged.
"""
import random
import struct

from mcap.reader import make_reader
import pytest

from iguana_ros.bag.schema import message_definition
from iguana_ros.bag.storage import BagReader, BagWriter, summarize

STRING_TYPE = 'std_msgs/msg/String'
T0 = 1_000_000_000
N = 60


def _cdr_string(text: str) -> bytes:
    raw = text.encode() + b'\x00'
    return b'\x00\x01\x00\x00' + len(raw).to_bytes(4, 'little') + raw


def _expected(indices) -> list[tuple[str, bytes]]:
    return [('/a' if i % 2 else '/b', _cdr_string(f'msg {i}')) for i in indices]


@pytest.fixture
def bag(tmp_path):
    """Return a finished directory bag of N messages on /a and /b, one chunk per message."""
    writer = BagWriter(tmp_path / 'b', chunk_age_s=0.0)
    a = writer.add_topic('/a', STRING_TYPE, message_definition(STRING_TYPE))
    b = writer.add_topic('/b', STRING_TYPE, message_definition(STRING_TYPE))
    for i in range(N):
        writer.write(a if i % 2 else b, _cdr_string(f'msg {i}'), T0 + i * 10_000_000)
    writer.close()
    return tmp_path / 'b'


def _mcap(bag):
    return bag / f'{bag.name}.mcap'


def _chunks(bag):
    """Chunk indexes of the undamaged file, read with mcap's own reader."""
    with open(_mcap(bag), 'rb') as f:
        return make_reader(f).get_summary().chunk_indexes


def _overwrite(bag, offset: int, data: bytes) -> None:
    raw = bytearray(_mcap(bag).read_bytes())
    raw[offset:offset + len(data)] = data
    _mcap(bag).write_bytes(bytes(raw))


def _flip(bag, offset: int) -> None:
    raw = bytearray(_mcap(bag).read_bytes())
    raw[offset] ^= 0x10
    _mcap(bag).write_bytes(bytes(raw))


def _recovered(path) -> tuple[list[tuple[str, bytes]], BagReader]:
    reader = BagReader(path)
    return [(m.topic, m.data) for m in reader.messages()], reader


def _assert_refused(cli, argv, *phrases):
    """Exit 1 with one error line naming the damage, and exit 0 with --allow-damaged."""
    rc, out, err = cli(argv)
    assert rc == 1 and len(err.strip().splitlines()) == 1, (rc, out, err)
    assert '--allow-damaged' in err and all(p in err for p in phrases), err
    return out, err


def test_sound_bag_is_verified_by_its_crcs_and_exits_0(bag, cli):
    summary = summarize(bag)
    assert summary.sound and summary.health.data_crc == 'verified' and summary.library.startswith('iguana_ros')
    rc, out, err = cli(['bag', 'info', bag])
    assert rc == 0 and out.startswith('Files:') and 'Library:           iguana_ros' in out and not err
    assert 'Messages:          60' in out


def test_flipped_byte_in_a_chunk_is_reported_and_every_other_chunk_recovered(bag, cli):
    chunk = _chunks(bag)[30]
    _flip(bag, chunk.chunk_start_offset + chunk.chunk_length - 3)  # inside the compressed records
    out, err = _assert_refused(cli, ['bag', 'info', bag], 'damaged')
    first = out.splitlines()[0]
    assert first.startswith('damaged:') and 'recovered 59 of 60 messages' in first, first
    assert 'Messages:          59' in out
    got, reader = _recovered(bag)
    assert got == _expected([i for i in range(N) if i != 30]) and reader.damaged
    rc, out, err = cli(['bag', 'info', bag, '--allow-damaged'])
    assert rc == 0 and out.startswith('damaged:') and not err


def test_64_random_bytes_mid_file_lose_only_the_chunks_they_hit(bag, cli):
    chunks = _chunks(bag)
    start = chunks[20].chunk_start_offset + chunks[20].chunk_length - 40    # the end of chunk 20 and its index
    _overwrite(bag, start, random.Random(12).randbytes(64))
    hit = [i for i, c in enumerate(chunks)
           if c.chunk_start_offset < start + 64 and start < c.chunk_start_offset + c.chunk_length]
    assert hit == [20]
    got, reader = _recovered(bag)
    assert got == _expected([i for i in range(N) if i != 20]) and reader.damaged
    out, _ = _assert_refused(cli, ['bag', 'info', bag], 'damaged', 'recovered 59 of 60 messages')


def test_damaged_chunk_length_resyncs_on_the_index(bag):
    chunk = _chunks(bag)[10]
    _overwrite(bag, chunk.chunk_start_offset + 1, struct.pack('<Q', 1 << 40))   # the record's length field
    got, reader = _recovered(bag)
    assert got == _expected([i for i in range(N) if i != 10]) and reader.damaged


def test_without_an_index_the_scan_finds_the_next_chunk(bag, cli):
    chunks = _chunks(bag)
    raw = bytearray(_mcap(bag).read_bytes()[:chunks[50].chunk_start_offset + 7])   # killed recorder: no summary
    raw[chunks[10].chunk_start_offset + 1:chunks[10].chunk_start_offset + 9] = struct.pack('<Q', 12345)
    raw[chunks[20].chunk_start_offset + 60] ^= 0xFF
    _mcap(bag).write_bytes(bytes(raw))
    (bag / 'metadata.yaml').unlink()
    got, reader = _recovered(bag)
    assert got == _expected([i for i in range(50) if i not in (10, 20)])
    out, err = _assert_refused(cli, ['bag', 'info', bag], 'damaged', 'truncated')
    assert 'recovered 48 messages' in out.splitlines()[0]


def test_every_chunk_repeats_the_channels_so_later_chunks_keep_their_topics(bag):
    chunks = _chunks(bag)
    raw = bytearray(_mcap(bag).read_bytes()[:chunks[-1].chunk_start_offset])       # no summary to name them
    raw[chunks[0].chunk_start_offset + 60] ^= 0xFF                                 # the chunk that had them first
    _mcap(bag).write_bytes(bytes(raw))
    got, _ = _recovered(_mcap(bag))
    assert got == _expected(range(1, N - 1))


def test_truncated_bag_is_reported_and_refused_without_allow_damaged(bag, cli):
    raw = _mcap(bag).read_bytes()
    cut = bag.parent / 'cut.mcap'
    cut.write_bytes(raw[:len(raw) // 2])
    out, _ = _assert_refused(cli, ['bag', 'info', cut], 'truncated')
    assert out.startswith('truncated:')
    rc, out, err = cli(['bag', 'info', cut, '--allow-damaged'])
    assert rc == 0 and out.startswith('truncated:') and not err


@pytest.mark.parametrize('where', ['header', 'message index', 'summary', 'footer', 'magic', 'end magic'])
def test_damage_outside_the_chunks_is_reported_and_loses_nothing(bag, cli, where):
    raw = _mcap(bag).read_bytes()
    chunks = _chunks(bag)
    offset = {'header': 20,                                                       # the library string
              'message index': chunks[5].chunk_start_offset + chunks[5].chunk_length + 15,
              'summary': len(raw) - 200,
              'footer': len(raw) - 12,                                            # the summary CRC
              'magic': 3,
              'end magic': len(raw) - 3}[where]
    _flip(bag, offset)
    got, reader = _recovered(bag)
    assert got == _expected(range(N)) and reader.damaged, reader.health.describe()
    _assert_refused(cli, ['bag', 'info', bag], 'damaged')


def test_play_refuses_a_damaged_bag_before_publishing(bag, cli):
    chunk = _chunks(bag)[30]
    _flip(bag, chunk.chunk_start_offset + chunk.chunk_length - 3)
    _, err = _assert_refused(cli, ['bag', 'play', bag], 'damaged', 'recovered 59 of 60 messages')


_DEEP = b'a: ' + b'[' * 100_000 + b']' * 100_000 + b'\n'


@pytest.mark.parametrize('content, phrase', [
    (bytes(range(256)) * 12, 'not UTF-8'),
    (b'', 'empty'),
    (b'rosbag2_bagfile_information: [unclosed\n', 'not valid YAML'),
    (_DEEP, 'metadata.yaml'),
    (b'- just\n- a list\n', 'rosbag2_bagfile_information'),
    (None, 'no metadata.yaml'),
])
def test_damaged_metadata_yaml_gives_one_line_and_the_mcap_still_reads(bag, cli, content, phrase):
    meta = bag / 'metadata.yaml'
    if content is None:
        meta.unlink()
    else:
        meta.write_bytes(content)
    out, err = _assert_refused(cli, ['bag', 'info', bag], 'metadata.yaml', phrase)
    assert 'Messages:          60' in out and 'Topic: /a | Type: std_msgs/msg/String | Count: 30' in out
    rc, out, err = cli(['bag', 'info', bag, '--allow-damaged'])
    assert rc == 0 and 'Messages:          60' in out
    got, reader = _recovered(bag)
    assert got == _expected(range(N))


def test_metadata_yaml_that_contradicts_the_mcap_is_reported(bag, cli):
    meta = bag / 'metadata.yaml'
    meta.write_text(meta.read_text().replace('message_count: 60', 'message_count: 61'))
    _assert_refused(cli, ['bag', 'info', bag], 'metadata.yaml', 'message_count 61', '60')
