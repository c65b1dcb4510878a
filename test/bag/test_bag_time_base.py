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

"""The recorder's log time on simulated time (SimTimeStamper), the bag's time base, and the player's one /clock."""
import struct

from mcap.writer import Writer
import pytest
import yaml

from iguana_ros.bag.info import bag_info
from iguana_ros.bag.sim_time import clock_ns, HOLD_LIMIT_BYTES, SimTimeStamper
from iguana_ros.bag.storage import BagReader, BagSummary, BagWriter, summarize

MS = 1_000_000
S = 1_000_000_000
WALL = 1_800_000_000 * S
"""A wall-clock receive time (ns since the epoch) the tests count from."""


def clock(sim_ns: int, big_endian: bool = False) -> bytes:
    """Return the serialized rosgraph_msgs/Clock of `sim_ns`."""
    sec, nanosec = divmod(sim_ns, S)
    if big_endian:
        return b'\x00\x00\x00\x00' + struct.pack('>iI', sec, nanosec)
    return b'\x00\x01\x00\x00' + struct.pack('<iI', sec, nanosec)


class Bag:
    """A stand-in writer: the (channel, data, log time, publish time) of each write."""

    def __init__(self):
        self.rows = []
        self.warnings = []

    def write(self, channel, data, log_ns, published_ns):
        self.rows.append((channel, data, log_ns, published_ns))

    def stamper(self):
        return SimTimeStamper(self.write, warn=self.warnings.append)

    def log_times(self, channel):
        return [row[2] for row in self.rows if row[0] == channel]


def test_clock_ns_reads_both_byte_orders_and_refuses_what_is_no_clock():
    assert clock_ns(clock(25 * S + 7)) == 25 * S + 7
    assert clock_ns(clock(3 * S + 5, big_endian=True)) == 3 * S + 5
    for bad in (b'', b'\x00\x01\x00\x00\x01', b'\x07\x01\x00\x00' + bytes(8),
                b'\x00\x01\x00\x00' + struct.pack('<iI', 1, 2 * S)):
        with pytest.raises(ValueError):
            clock_ns(bad)


def test_a_message_takes_the_latest_clock_received_before_it_whatever_order_they_are_taken_in():
    bag = Bag()
    stamper = bag.stamper()
    # One wake: the recorder took the state of frames 0 and 1 before the /clock of both frames.
    stamper.add(1, b'state0', WALL + 1 * MS, WALL + 0 * MS)
    stamper.add(1, b'state1', WALL + 12 * MS, WALL + 11 * MS)
    stamper.clock(WALL + 0 * MS, clock(0))
    stamper.clock(WALL + 11 * MS, clock(S // 30))
    stamper.flush()
    assert bag.log_times(1) == [0, S // 30]
    # The publish time stays the publisher's wall-clock send time (rosbag2's send_timestamp).
    assert [row[3] for row in bag.rows] == [WALL, WALL + 11 * MS]
    stamper.add(2, b'late', WALL + 30 * MS, WALL + 29 * MS)        # after the last /clock: that one
    stamper.flush()
    assert bag.log_times(2) == [S // 30]


def test_messages_before_the_first_clock_are_held_and_take_its_time():
    bag = Bag()
    stamper = bag.stamper()
    stamper.add(1, b'latched scene', WALL, WALL)
    stamper.flush()
    assert bag.rows == [] and not stamper.started           # held: no /clock yet
    stamper.clock(WALL + 5 * S, clock(100 * S))            # a recording joined late: the first /clock says 100 s
    stamper.add(2, b'state', WALL + 5 * S + MS, WALL + 5 * S)
    stamper.flush()
    assert bag.log_times(1) == [100 * S] and bag.log_times(2) == [100 * S]


def test_without_any_clock_messages_are_written_at_zero_on_close_with_a_warning():
    bag = Bag()
    stamper = bag.stamper()
    stamper.add(1, b'a', WALL, WALL)
    stamper.add(1, b'b', WALL + S, WALL + S)
    stamper.close()
    assert bag.log_times(1) == [0, 0]
    assert len(bag.warnings) == 1 and 'no /clock was received' in bag.warnings[0]


def test_held_messages_beyond_the_limit_go_to_zero_then_the_clock_takes_over():
    bag = Bag()
    stamper = bag.stamper()
    big = bytes(HOLD_LIMIT_BYTES // 2 + 1)
    stamper.add(1, big, WALL, WALL)
    assert bag.rows == []
    stamper.add(1, big, WALL + 1, WALL + 1)                 # past the limit: both written at 0
    stamper.add(1, b'more', WALL + 2, WALL + 2)             # still no /clock: at once, at 0
    assert bag.log_times(1) == [0, 0, 0] and 'recording them at log time 0' in bag.warnings[0]
    stamper.clock(WALL + 3, clock(7 * S))
    stamper.add(1, b'stamped', WALL + 4, WALL + 4)
    stamper.flush()
    assert bag.log_times(1)[-1] == 7 * S


def test_a_clock_jumping_back_continues_the_timeline_and_no_channel_goes_back():
    bag = Bag()
    stamper = bag.stamper()
    for k, sim in enumerate((0, S, 2 * S, 0, S)):          # a reset to 0 after 2 s
        stamper.clock(WALL + k * S, clock(sim))
        stamper.add(1, b'm', WALL + k * S + 1, WALL + k * S)
    stamper.flush()
    assert bag.log_times(1) == [0, S, 2 * S, 2 * S, 3 * S] and stamper.backward_jumps == 1
    # a message received (by the middleware's stamp) before one already written on its channel keeps that time
    stamper.add(1, b'old', WALL, WALL)
    stamper.flush()
    assert bag.log_times(1)[-1] == 3 * S


def test_log_times_are_the_clock_times_for_a_run_of_frames():
    bag = Bag()
    stamper = bag.stamper()
    for frame in range(90):                                 # 3 s at 30 Hz, ~3x realtime, one wake per 2 frames
        t = WALL + frame * 11 * MS
        stamper.clock(t, clock(frame * S // 30))
        stamper.add(0, b'clock', t, t)
        stamper.add(1, b'state', t + MS // 10, t)
        if frame % 2:
            stamper.flush()
    stamper.close()
    expected = [frame * S // 30 for frame in range(90)]
    assert bag.log_times(0) == expected and bag.log_times(1) == expected


# -- the bag's time base -------------------------------------------------------------------------------------------

def _write(directory, time_base, close=True):
    writer = BagWriter(directory, time_base=time_base)
    channel = writer.add_topic('/clock', 'rosgraph_msgs/msg/Clock', 'builtin_interfaces/Time clock\n')
    for frame in range(31):
        writer.write(channel, clock(frame * S // 30), frame * S // 30, WALL + frame * 11 * MS)
    if close:
        writer.close()
    else:
        writer.close_chunk()
    return writer


def test_writer_records_the_time_base_in_the_mcap_and_metadata_yaml(tmp_path):
    _write(tmp_path / 'sim', 'simulated')
    summary = summarize(tmp_path / 'sim')
    assert summary.sound and summary.time_base == 'simulated' and summary.clock_topic == '/clock'
    assert (summary.end_ns - summary.start_ns) == S
    meta = yaml.safe_load((tmp_path / 'sim' / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert meta['custom_data'] == {'iguana_ros.time_base': 'simulated', 'iguana_ros.clock_topic': '/clock'}
    from mcap.reader import make_reader
    with open(tmp_path / 'sim' / 'sim.mcap', 'rb') as f:
        reader = make_reader(f, validate_crcs=True)
        records = {m.name: m.metadata for m in reader.iter_metadata()}
        assert len(list(reader.iter_messages())) == 31
    assert records == {'iguana_ros': {'time_base': 'simulated', 'clock_topic': '/clock'}}
    text, _ = bag_info(tmp_path / 'sim')
    assert 'Time base:         simulated (/clock)' in text
    assert 'Start:             0.000000000 s (simulated)' in text and 'End:               1.000000000 s' in text
    messages = list(BagReader(tmp_path / 'sim').messages())
    assert [m.publish_time for m in messages][:2] == [WALL, WALL + 11 * MS]


def test_a_killed_recorders_bag_keeps_its_time_base(tmp_path):
    _write(tmp_path / 'killed', 'simulated', close=False)     # no summary, no metadata.yaml
    summary = summarize(tmp_path / 'killed')
    assert not summary.sound and summary.time_base == 'simulated'


def test_wall_bags_old_bags_and_custom_data_alone(tmp_path):
    _write(tmp_path / 'wall', 'wall')
    assert summarize(tmp_path / 'wall').time_base == 'wall'
    assert 'Time base:         wall (receive time)' in bag_info(tmp_path / 'wall')[0]
    # A bag of the old format (or another recorder): no Metadata record, no custom_data -> wall.
    old = tmp_path / 'old'
    old.mkdir()
    with open(old / 'old.mcap', 'wb') as f:
        writer = Writer(f)
        writer.start(profile='ros2', library='iguana_ros 0.0.9')
        schema = writer.register_schema('std_msgs/msg/String', 'ros2msg', b'string data\n')
        channel = writer.register_channel('/a', 'cdr', schema, {'offered_qos_profiles': ''})
        writer.add_message(channel, log_time=WALL, data=b'\x00\x01\x00\x00\x01\x00\x00\x00\x00', publish_time=WALL)
        writer.finish()
    summary = summarize(old / 'old.mcap')
    assert summary.time_base == 'wall'
    text = bag_info(old / 'old.mcap')[0]
    assert 'Time base:         wall (receive time)' in text and 'Start:             ' in text and '1970' not in text
    # metadata.yaml's custom_data alone (the Metadata record lost, e.g. a bag rewritten by another tool) is enough.
    sim = tmp_path / 'sim'
    _write(sim, 'simulated')
    with open(sim / 'sim.mcap', 'rb') as f:
        data = f.read()
    data = data.replace(b'time_base', b'xxxx_base')
    (sim / 'sim.mcap').write_bytes(data)
    from iguana_ros.bag.storage import time_base_of
    assert time_base_of(sim) == ('simulated', '/clock')
    assert time_base_of(sim / 'sim.mcap') == ('wall', '/clock')


def test_writer_refuses_an_unknown_time_base(tmp_path):
    with pytest.raises(ValueError, match='time_base'):
        BagWriter(tmp_path / 'x', time_base='gps')


# -- the player's one /clock ---------------------------------------------------------------------------------------

def _summary(*topics):
    from iguana_ros.bag.storage import TopicInfo
    from pathlib import Path
    return BagSummary(Path('b.mcap'), 0, 'ros2', '', [TopicInfo(t, 'x/msg/Y') for t in topics], 0, 0, 0,
                      time_base='simulated')


def test_clock_source_plays_the_recorded_clock_or_its_own_never_both():
    from iguana_ros.bag.play import clock_source
    with_clock = _summary('/iguana_state', '/clock')
    selected, own = clock_source(with_clock, list(with_clock.topics), clock=True)
    assert [t.name for t in selected] == ['/iguana_state', '/clock'] and not own
    only_state = [with_clock.topics[0]]
    selected, own = clock_source(with_clock, only_state, clock=True)   # --topics left /clock out: added back
    assert [t.name for t in selected] == ['/iguana_state', '/clock'] and not own
    selected, own = clock_source(with_clock, only_state, clock=False)
    assert [t.name for t in selected] == ['/iguana_state'] and not own
    without = _summary('/iguana_state')
    selected, own = clock_source(without, list(without.topics), clock=True)
    assert [t.name for t in selected] == ['/iguana_state'] and own
