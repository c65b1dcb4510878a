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

"""Bag schema text, QoS YAML, crash-safe writer, truncation-tolerant reader and CLI error lines."""
import time

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
import pytest
import yaml

from iguana_ros.bag.schema import field_types, message_definition, SEPARATOR
from iguana_ros.bag.storage import BagReader, BagWriter, parse_qos_profiles, qos_profiles_yaml, summarize
from iguana_ros.errors import InputError

STRING_TYPE = 'std_msgs/msg/String'


def _cdr_string(text: str) -> bytes:
    raw = text.encode() + b'\x00'
    return b'\x00\x01\x00\x00' + len(raw).to_bytes(4, 'little') + raw


def _write_bag(directory, n=30, chunk_age_s=1.0, close=True, sleep=0.0):
    writer = BagWriter(directory, chunk_age_s=chunk_age_s)
    qos = qos_profiles_yaml([{'history': 'keep_last', 'depth': 1, 'reliability': 'reliable',
                              'durability': 'transient_local'}])
    a = writer.add_topic('/a', STRING_TYPE, message_definition(STRING_TYPE), qos, 'RIHS01_ab')
    b = writer.add_topic('/b', STRING_TYPE, message_definition(STRING_TYPE))
    for i in range(n):
        writer.write(a if i % 3 else b, _cdr_string(f'msg {i}'), 1_000_000_000 + i * 10_000_000)
        if sleep:
            time.sleep(sleep)
    if close:
        writer.close()
    return writer


def test_schema_has_dependencies_once_in_rosbag2_layout():
    text = message_definition('visualization_msgs/msg/MarkerArray')
    headers = [line for line in text.splitlines() if line.startswith('MSG: ')]
    assert headers[0] == 'MSG: visualization_msgs/Marker'
    assert len(headers) == len(set(headers))
    assert {'MSG: std_msgs/Header', 'MSG: builtin_interfaces/Time', 'MSG: geometry_msgs/Point',
            'MSG: visualization_msgs/MeshFile'} <= set(headers)
    assert text.count(SEPARATOR + 'MSG: ') == len(headers)


def test_field_types_skip_constants_primitives_and_comments():
    text = 'int32 ADD=0\nstring NAME = "x"\nfloat64[3] a  # geometry_msgs/Point not a type\n' \
           'Point[] pts\nstd_msgs/Header header\nstring<=5 s\n'
    assert field_types(text, 'geometry_msgs') == ['geometry_msgs/Point', 'std_msgs/Header']


def test_unknown_type_names_the_file_searched():
    with pytest.raises(InputError, match='no definition of nopkg/msg/Nope'):
        message_definition('nopkg/msg/Nope')


def test_qos_yaml_round_trip():
    profiles = [{'history': 'unknown', 'depth': 0, 'reliability': 'reliable',
                 'durability': 'transient_local', 'deadline': {'sec': 9223372036, 'nsec': 854775807}}]
    assert parse_qos_profiles(qos_profiles_yaml(profiles)) == profiles
    assert parse_qos_profiles('') == [] and parse_qos_profiles('[: bad') == []


def test_finished_bag_reads_with_mcap_and_has_metadata(tmp_path):
    _write_bag(tmp_path / 'ok')
    with open(tmp_path / 'ok' / 'ok.mcap', 'rb') as f:
        reader = make_reader(f, validate_crcs=True, decoder_factories=[DecoderFactory()])
        texts = [m.data for _, _, _, m in reader.iter_decoded_messages()]
    assert texts == [f'msg {i}' for i in range(30)]
    meta = yaml.safe_load((tmp_path / 'ok' / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert meta['duration']['nanoseconds'] == 290_000_000
    assert {t['topic_metadata']['name']: t['message_count'] for t in meta['topics_with_message_count']} \
        == {'/a': 20, '/b': 10}
    summary = summarize(tmp_path / 'ok' / 'ok.mcap')
    assert not summary.truncated and summary.message_count == 30
    assert summary.topics[0].type_hash == 'RIHS01_ab'


def test_existing_output_is_refused(tmp_path):
    (tmp_path / 'x').mkdir()
    with pytest.raises(InputError, match='already exists'):
        BagWriter(tmp_path / 'x')


def test_old_chunks_are_flushed_before_close(tmp_path):
    writer = _write_bag(tmp_path / 'live', n=12, chunk_age_s=0.02, close=False, sleep=0.01)
    reader = BagReader(writer.path)  # the recorder is still "running": no summary, no footer yet
    got = [m.data for m in reader.messages()]
    assert reader.truncated and 8 <= len(got) <= 12
    assert got == [_cdr_string(f'msg {i}') for i in range(len(got))]
    writer.close()


def test_every_truncation_point_recovers_a_prefix(tmp_path):
    _write_bag(tmp_path / 'full', n=60, chunk_age_s=0.0)  # one chunk per message
    data = (tmp_path / 'full' / 'full.mcap').read_bytes()
    expected = [_cdr_string(f'msg {i}') for i in range(60)]
    previous = 0
    for cut in range(8, len(data), 97):
        path = tmp_path / f'cut{cut}.mcap'
        path.write_bytes(data[:cut])
        reader = BagReader(path)
        got = [m.data for m in reader.messages()]
        assert reader.truncated and got == expected[:len(got)] and len(got) >= previous
        previous = len(got)
    assert previous >= 55


def test_corrupted_chunk_loses_only_that_chunk(tmp_path):
    _write_bag(tmp_path / 'c', n=60, chunk_age_s=0.0)
    path = tmp_path / 'c' / 'c.mcap'
    with open(path, 'rb') as f:
        chunk = make_reader(f).get_summary().chunk_indexes[30]
    data = bytearray(path.read_bytes())
    data[chunk.chunk_start_offset + chunk.chunk_length - 3] ^= 0xFF  # inside the compressed records
    path.write_bytes(bytes(data))
    reader = BagReader(path)
    got = [m.data for m in reader.messages()]
    assert reader.truncated and reader.damaged and len(got) == 59
    assert f'bytes {chunk.chunk_start_offset}-' in reader.problem and 'chunk' in reader.problem
    assert got == [_cdr_string(f'msg {i}') for i in range(60) if i != 30]


@pytest.mark.parametrize('mask', [0x01, 0x02, 0x80])
def test_a_damaged_message_index_length_loses_no_chunk(tmp_path, mask):
    """
    A flipped bit in the length of the message index after a chunk (found by `iguana bench faults bags`).

    Trusting the length made the scan jump over the next chunk, and its intact messages were lost.
    """
    _write_bag(tmp_path / 'i', n=20, chunk_age_s=0.0)
    path = tmp_path / 'i' / 'i.mcap'
    with open(path, 'rb') as f:
        chunk = make_reader(f).get_summary().chunk_indexes[5]
    data = bytearray(path.read_bytes())
    index_at = chunk.chunk_start_offset + chunk.chunk_length
    assert data[index_at] == 0x07                                     # a MessageIndex record follows the chunk
    for byte in range(1, 5):                                          # the low bytes of its 8-byte length
        damaged = bytearray(data)
        damaged[index_at + byte] ^= mask
        path.write_bytes(bytes(damaged))
        reader = BagReader(path)
        got = [m.data for m in reader.messages()]
        assert reader.damaged, byte
        assert got == [_cdr_string(f'msg {i}') for i in range(20)], (byte, len(got), reader.problem)


def test_info_prints_topics_and_counts(tmp_path, cli):
    _write_bag(tmp_path / 'ok')
    rc, out, _ = cli(['bag', 'info', str(tmp_path / 'ok')])
    assert rc == 0 and 'Messages:          30' in out and 'Duration:          0.290000000s' in out
    assert 'Topic: /a | Type: std_msgs/msg/String | Count: 20 | Serialization Format: cdr' in out


@pytest.mark.parametrize('content, message', [
    (None, 'no bag at'),
    (b'not an mcap file at all', 'is not an MCAP file'),
    (b'', 'is not an MCAP file'),
    (b'\x89MCAP0\r\n\x01\xff\xff', 'is corrupt: no readable MCAP header'),
])
def test_bad_bags_give_one_line_and_exit_1(tmp_path, cli, content, message):
    path = tmp_path / 'bad.mcap'
    if content is not None:
        path.write_bytes(content)
    for action in ('info', 'play'):
        rc, out, err = cli(['bag', action, str(path)])
        assert rc == 1 and message in err and len(err.strip().splitlines()) == 1, err


def test_truncated_bag_info_says_so_in_its_first_line(tmp_path, cli):
    _write_bag(tmp_path / 'ok', n=40, chunk_age_s=0.0)
    data = (tmp_path / 'ok' / 'ok.mcap').read_bytes()
    (tmp_path / 'cut.mcap').write_bytes(data[:len(data) // 2])
    rc, out, err = cli(['bag', 'info', str(tmp_path / 'cut.mcap')])
    first = out.splitlines()[0]
    assert rc == 1 and first.startswith('truncated:') and 'recovered' in first
    assert len(err.strip().splitlines()) == 1 and '--allow-damaged' in err
    n = int(first.split('recovered ')[1].split()[0])
    assert 0 < n < 40 and f'Messages:          {n}' in out
    rc, out, err = cli(['bag', 'info', str(tmp_path / 'cut.mcap'), '--allow-damaged'])
    assert rc == 0 and out.splitlines()[0] == first and not err


def test_play_unknown_topic_lists_what_the_bag_has(tmp_path, cli):
    _write_bag(tmp_path / 'ok')
    rc, _, err = cli(['bag', 'play', str(tmp_path / 'ok'), '--topics', '/nope'])
    assert rc == 1 and "['/nope'] not in bag" in err and "['/a', '/b']" in err


def test_record_refuses_existing_output(tmp_path, cli):
    rc, _, err = cli(['bag', 'record', '/a', '-o', str(tmp_path)])
    assert rc == 1 and 'already exists' in err


@pytest.mark.ros
def test_recorder_reports_unknown_type_and_keeps_the_others(tmp_path, make_node, executor):
    from std_msgs.msg import String

    from iguana_ros.bag.record import Recorder
    node, talker = make_node('recorder_under_test'), make_node('talker')
    executor.add_node(node)
    pub = talker.create_publisher(String, '/good', 10)
    writer = BagWriter(tmp_path / 'rec')
    errors = []
    recorder = Recorder(node, writer, ['/good', '/bad'], log=lambda m: None, error=errors.append)
    recorder._subscribe('/bad', 'nopkg/msg/Nope', [])
    from ros_harness import spin_until
    assert spin_until(executor, lambda: (recorder.poll_discovery() or '/good' in recorder.subscriptions), 10)
    assert spin_until(executor, lambda: pub.get_subscription_count() > 0, 10)
    for i in range(5):
        pub.publish(String(data=f'm{i}'))
    assert spin_until(executor, lambda: recorder.received == 5, 10)
    writer.close()
    assert errors == ['iguana bag record: error: cannot record /bad: unknown message type '
                      "'nopkg/msg/Nope': No module named 'nopkg'; recording the others"]
    assert summarize(tmp_path / 'rec').message_count == 5
