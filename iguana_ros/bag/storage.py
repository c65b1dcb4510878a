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
rosbag2-compatible MCAP storage: a crash-safe writer and a reader that survives damage (ROS-free).

Layout of a bag: `DIR/DIR.mcap` plus `DIR/metadata.yaml` (rosbag2_bagfile_information, version 9).
MCAP conventions of rosbag2's mcap storage plugin: profile `ros2`, schemas `ros2msg` named
`pkg/msg/Type`, messages `cdr`, channel metadata `offered_qos_profiles` (YAML) and `topic_type_hash`.
The writer adds a data-section CRC and repeats the schema and channel records at the start of every chunk,
so each chunk can be read (and its topics named) on its own. Reading goes through `iguana_ros.bag.scan`:
every intact chunk is recovered, and what was damaged or missing is reported, never passed off as sound.

The bag's time base (`iguana_ros.bag.sim_time`: 'simulated', log times from /clock, or 'wall', receive times) is
a Metadata record named `iguana_ros` written right after the Header (so a killed recorder's bag keeps it) and
metadata.yaml's `custom_data`; a bag without it (older bags, other recorders) is taken as 'wall'.
"""
from __future__ import annotations

from collections.abc import Iterator
import copy
from dataclasses import dataclass, field
import os
from pathlib import Path
import time

from mcap.data_stream import RecordBuilder
from mcap.records import Channel, Header, Message, Schema
from mcap.writer import CompressionType, Writer
import yaml

from iguana_ros.bag.metadata import check_metadata, load_metadata, relative_files
from iguana_ros.bag.scan import Health, leading_metadata, looks_like_mcap, Scan
from iguana_ros.bag.sim_time import (CLOCK_TOPIC, CUSTOM_DATA_KEYS, METADATA_NAME, TIME_BASE_WALL,
                                     TIME_BASES)
from iguana_ros.errors import IguanaError, InputError

PROFILE = 'ros2'
SCHEMA_ENCODING = 'ros2msg'
MESSAGE_ENCODING = 'cdr'
METADATA_VERSION = 9
ROS_DISTRO = 'jazzy'
CHUNK_BYTES = 768 * 1024
"""Uncompressed size at which a chunk is closed (rosbag2's mcap default is 768 KiB)."""
CHUNK_AGE_S = 1.0
"""A chunk is closed at least this often, so a killed recorder loses at most ~this much data."""
INFINITE_DURATION = {'sec': 9223372036, 'nsec': 854775807}
"""RMW_DURATION_INFINITE as rosbag2 writes it."""
_NO_SIZE_LIMIT = 1 << 62
"""Chunk size given to mcap's Writer: BagWriter closes chunks itself (so each new one gets its preamble)."""

SPACE_RESERVE_BYTES = 1 << 20
"""Disk space a BagWriter holds (a hidden file in the bag directory, released when it finishes or the disk is full),
so that the summary and metadata.yaml still fit after a full disk: other processes writing to the same disk took
the room of the cut-off chunk before the summary was written in 1 of 4 runs. 1 MiB holds the summary of ~2 h."""

RESERVE_NAME = '.space_reserve'
"""Name of that file."""

DISK_FULL_EXIT = 28
"""Exit status of `iguana bag record` when writing failed (28 = ENOSPC, a full disk): `iguana run` names it."""


class BagWriteError(IguanaError):
    """Writing the bag failed (a full disk); the bag was finalised from what reached the disk. One line."""


@dataclass
class _Written:
    """What was on disk after the last chunk the OS took: file size, chunk indexes, statistics, CRC, counts, times."""

    offset: int
    chunks: int
    statistics: object
    data_crc: int
    counts: dict
    first_ns: int | None
    last_ns: int


class DamagedBag(InputError):
    """A bag that is damaged or truncated, refused because --allow-damaged was not given."""


def _library() -> str:
    """Library string of the MCAP header, e.g. 'iguana_ros 0.1.0'."""
    from iguana_ros import package_version
    return f'iguana_ros {package_version()}'


def qos_profiles_yaml(profiles: list[dict]) -> str:
    """rosbag2's `offered_qos_profiles` YAML text for a list of QoS dicts (v9: policy names as strings)."""
    return yaml.safe_dump(list(profiles), sort_keys=False, default_flow_style=False)


def parse_qos_profiles(text: str) -> list[dict]:
    """`QoS` dicts from an `offered_qos_profiles` YAML text ('' or unreadable -> [])."""
    try:
        data = yaml.safe_load(text) if text else []
    except yaml.YAMLError:
        return []
    return [p for p in data if isinstance(p, dict)] if isinstance(data, list) else []


@dataclass
class TopicInfo:
    """One recorded topic: name, type, QoS YAML, type hash and message count."""

    name: str
    type: str  # noqa: A003 - rosbag2 metadata.yaml's topic_metadata.type
    offered_qos_profiles: str = ''
    type_hash: str = ''
    message_count: int = 0


@dataclass
class BagMessage:
    """One message as stored: topic, serialized CDR bytes, receive and publish time in ns, channel id."""

    topic: str
    data: bytes
    log_time: int
    publish_time: int
    channel_id: int = 0


def resolve_bag_file(path: str | Path) -> Path:
    """
    Return the .mcap file of a bag given as its directory or the file itself; InputError if there is none.

    For a directory: `DIR/DIR.mcap`, else the file its metadata.yaml names (when readable), else its one .mcap.
    """
    p = Path(path)
    if p.is_file():
        return p
    if not p.is_dir():
        raise InputError(f'no bag at {p}: expected a bag directory or an .mcap file')
    if (p / f'{p.name}.mcap').is_file():
        return p / f'{p.name}.mcap'
    info, _ = load_metadata(p)
    listed = [p / name for name in relative_files(info) if (p / name).is_file()]
    if listed:
        return listed[0]
    candidates = sorted(p.glob('*.mcap'))
    if len(candidates) == 1:
        return candidates[0]
    raise InputError(f'bag directory {p} holds {len(candidates)} .mcap files, expected one')


class BagWriter:
    """
    Writes `DIR/DIR.mcap` with zstd chunks bounded in size and age; `close()` adds summary + metadata.

    Every chunk after the first starts with the schema and channel records registered so far (a preamble), and
    DataEnd carries the CRC of the data section: a reader can name the messages of any intact chunk even when
    the chunk that first held a channel is lost, and can tell damage outside the chunks.
    """

    def __init__(self, directory: str | Path, chunk_bytes: int = CHUNK_BYTES,
                 chunk_age_s: float = CHUNK_AGE_S, time_base: str = TIME_BASE_WALL,
                 clock_topic: str = CLOCK_TOPIC) -> None:
        if time_base not in TIME_BASES:
            raise ValueError(f'time_base must be one of {TIME_BASES}, got {time_base!r}')
        self.time_base, self.clock_topic = time_base, clock_topic
        self.directory = Path(directory)
        if self.directory.exists():
            raise InputError(f'output {self.directory} already exists; choose a new bag directory')
        self.directory.mkdir(parents=True)
        self.path = self.directory / f'{self.directory.name}.mcap'
        self._reserve = self.directory / RESERVE_NAME
        try:
            with open(self._reserve, 'wb') as reserve:
                os.posix_fallocate(reserve.fileno(), 0, SPACE_RESERVE_BYTES)
        except OSError as exc:
            self._reserve.unlink(missing_ok=True)
            raise BagWriteError(f'{exc.strerror or exc} in {self.directory}: no room to start a bag') from None
        self._file = open(self.path, 'wb')
        self._writer = Writer(self._file, chunk_size=_NO_SIZE_LIMIT, compression=CompressionType.ZSTD,
                              enable_data_crcs=True)
        if not (hasattr(self._writer, '_Writer__finalize_chunk') and hasattr(self._writer, '_Writer__chunk_builder')):
            raise RuntimeError('this mcap version has no chunk finaliser; age-bounded chunks need mcap>=1.1')
        self._writer.start(profile=PROFILE, library=_library())
        self._writer.add_metadata(METADATA_NAME, self.time_base_record())
        self._file.flush()
        self.failed: OSError | None = None
        self.chunk_bytes = chunk_bytes
        self.chunk_age_s = chunk_age_s
        self._preamble: list[Schema | Channel] = []
        self._chunk_opened: float | None = None
        self._schemas: dict[str, int] = {}
        self._channels: dict[int, TopicInfo] = {}
        self._first_ns: int | None = None
        self._last_ns = 0
        self.closed = False
        self._written = self._snapshot()

    def time_base_record(self) -> dict[str, str]:
        """Return the map of the `iguana_ros` Metadata record: time_base and clock_topic."""
        return {'time_base': self.time_base, 'clock_topic': self.clock_topic}

    def add_topic(self, name: str, type_name: str, schema_text: str,
                  offered_qos_profiles: str = '', type_hash: str = '') -> int:
        """Register a topic (its schema once per type); returns the channel id for `write`."""
        if type_name not in self._schemas:
            data = schema_text.encode()
            schema_id = self._writer.register_schema(name=type_name, encoding=SCHEMA_ENCODING, data=data)
            self._schemas[type_name] = schema_id
            self._preamble.append(Schema(id=schema_id, name=type_name, encoding=SCHEMA_ENCODING, data=data))
        metadata = {'offered_qos_profiles': offered_qos_profiles}
        if type_hash:
            metadata['topic_type_hash'] = type_hash
        channel_id = self._writer.register_channel(
            topic=name, message_encoding=MESSAGE_ENCODING, schema_id=self._schemas[type_name],
            metadata=metadata)
        self._preamble.append(Channel(id=channel_id, topic=name, message_encoding=MESSAGE_ENCODING,
                                      schema_id=self._schemas[type_name], metadata=metadata))
        self._channels[channel_id] = TopicInfo(name, type_name, offered_qos_profiles, type_hash)
        return channel_id

    def write(self, channel_id: int, data: bytes, log_time: int, publish_time: int | None = None) -> None:
        """
        Append one serialized message; BagWriteError when the disk is full.

        Times are ns: `log_time` in the bag's time base (since the epoch on wall time), `publish_time` the publisher's
        send time (wall clock; `log_time` when None).
        """
        try:
            self._write(channel_id, data, log_time, publish_time)
        except OSError as exc:
            self._fail(exc)

    def _write(self, channel_id: int, data: bytes, log_time: int, publish_time: int | None) -> None:
        """Append one message (see `write`)."""
        info = self._channels[channel_id]
        seq = info.message_count
        self._writer.add_message(channel_id=channel_id, log_time=log_time, data=data,
                                 publish_time=log_time if publish_time is None else publish_time,
                                 sequence=seq & 0xFFFFFFFF)
        info.message_count += 1
        self._first_ns = log_time if self._first_ns is None else min(self._first_ns, log_time)
        self._last_ns = max(self._last_ns, log_time)
        if self._chunk_opened is None:
            self._chunk_opened = time.monotonic()
        if self._writer._Writer__chunk_builder.count > self.chunk_bytes:
            self.close_chunk()
        else:
            self.close_chunk_if_old()

    def close_chunk_if_old(self) -> None:
        """Close and flush the open chunk if it is older than `chunk_age_s` (call it from a timer too)."""
        if self._chunk_opened is not None and time.monotonic() - self._chunk_opened >= self.chunk_age_s:
            try:
                self.close_chunk()
            except OSError as exc:
                self._fail(exc)

    def close_chunk(self) -> None:
        """
        Write the open chunk (if any) and flush it to the OS, so it survives a killed process.

        The next chunk starts with the preamble of schema and channel records.
        """
        builder = self._writer._Writer__chunk_builder     # mcap keeps the chunk machinery private
        written = builder.num_messages > 0
        self._writer._Writer__finalize_chunk()
        if written:
            for record in self._preamble:
                (builder.add_schema if isinstance(record, Schema) else builder.add_channel)(record)
        self._file.flush()
        self._chunk_opened = None
        self._written = self._snapshot()

    @property
    def topics(self) -> list[TopicInfo]:
        """Return registered topics with their message counts so far."""
        return list(self._channels.values())

    def close(self) -> None:
        """Finish the MCAP file (last chunk, summary, footer) and write metadata.yaml; BagWriteError on a full disk."""
        if self.closed:
            return
        self._reserve.unlink(missing_ok=True)
        try:
            self._writer.finish()
            self._file.close()
        except OSError as exc:
            self._fail(exc)
        self.closed = True
        try:
            self._write_metadata()
        except OSError as exc:
            self.failed = exc
            raise BagWriteError(f'{exc.strerror or exc} writing {self.directory / "metadata.yaml"}; the bag '
                                f'{self.path} is finalised, without metadata.yaml') from None

    def _write_metadata(self) -> None:
        """Write metadata.yaml (rosbag2's) beside the MCAP file."""
        (self.directory / 'metadata.yaml').write_text(yaml.safe_dump(
            self.metadata(), sort_keys=False, default_flow_style=False))

    def _snapshot(self) -> _Written:
        """Return what is on disk now (after each flushed chunk): where a failed write is cut back to."""
        w = self._writer
        return _Written(self._file.tell(), len(w._Writer__chunk_indices), copy.deepcopy(w._Writer__statistics),
                        w._Writer__data_section_crc, {c: t.message_count for c, t in self._channels.items()},
                        self._first_ns, self._last_ns)

    def _fail(self, exc: OSError) -> None:
        """
        Finalise the bag from what reached the disk and raise BagWriteError saying so (once; then it is closed).

        The file is cut back to its last whole chunk (freeing the bytes of the one that did not fit), the writer's
        summary of the chunks before is written after it, and metadata.yaml; what cannot be written is named.
        """
        if self.failed is not None:
            raise BagWriteError(self._failure_line(self.failed, True, True)) from None
        self.failed, self.closed = exc, True
        self._reserve.unlink(missing_ok=True)          # the room for the summary and metadata.yaml
        try:
            self._file.close()                          # flushes what it can, then closes the file regardless
        except OSError:
            pass
        os.truncate(self.path, self._written.offset)
        ended = self._finish_written()
        for info_id, n in self._written.counts.items():
            self._channels[info_id].message_count = n
        self._first_ns, self._last_ns = self._written.first_ns, self._written.last_ns
        try:
            self._write_metadata()
            metadata = True
        except OSError:
            metadata = False
        raise BagWriteError(self._failure_line(exc, ended, metadata)) from None

    def _finish_written(self) -> bool:
        """Write the summary and footer of the chunks on disk after them; False (file cut back) if even that fails."""
        w, done = self._writer, self._written
        try:
            with open(self.path, 'r+b') as stream:
                stream.seek(done.offset)
                w._Writer__stream = stream               # mcap keeps its state private: the chunks on disk, no more
                w._Writer__record_builder = RecordBuilder()
                w._Writer__chunk_builder.reset()
                del w._Writer__chunk_indices[done.chunks:]
                w._Writer__statistics = copy.deepcopy(done.statistics)
                w._Writer__data_section_crc = done.data_crc
                w.finish()
            return True
        except OSError:
            os.truncate(self.path, done.offset)
            return False

    def _failure_line(self, exc: OSError, ended: bool, metadata: bool) -> str:
        """One line: what failed, where, and what the bag keeps."""
        kept = sum(self._written.counts.values())
        how = ('finalised' if ended and metadata else
               'its summary written, metadata.yaml not' if ended else
               'without a summary (bag info --allow-damaged reads it)' + ('' if metadata else ' or metadata.yaml'))
        return (f'{exc.strerror or exc} writing {self.path}; the bag keeps the {kept} messages of its complete chunks, '
                f'{how}')

    def metadata(self) -> dict:
        """
        metadata.yaml contents in rosbag2's `rosbag2_bagfile_information` format (version 9).

        From version 9 on, rosbag2 stores offered_qos_profiles here as a YAML list (in the MCAP
        channel metadata it stays a YAML string).
        """
        start = self._first_ns or 0
        duration = self._last_ns - start if self._first_ns is not None else 0
        count = sum(t.message_count for t in self._channels.values())
        return {'rosbag2_bagfile_information': {
            'version': METADATA_VERSION, 'storage_identifier': 'mcap',
            'duration': {'nanoseconds': duration},
            'starting_time': {'nanoseconds_since_epoch': start},
            'message_count': count,
            'topics_with_message_count': [
                {'topic_metadata': {'name': t.name, 'type': t.type, 'serialization_format': 'cdr',
                                    'offered_qos_profiles': parse_qos_profiles(t.offered_qos_profiles),
                                    'type_description_hash': t.type_hash},
                 'message_count': t.message_count} for t in self._channels.values()],
            'compression_format': '', 'compression_mode': '',
            'relative_file_paths': [self.path.name],
            'files': [{'path': self.path.name, 'starting_time': {'nanoseconds_since_epoch': start},
                       'duration': {'nanoseconds': duration}, 'message_count': count}],
            'custom_data': {CUSTOM_DATA_KEYS[k]: v for k, v in self.time_base_record().items()},
            'ros_distro': ROS_DISTRO}}


@dataclass
class BagSummary:
    """
    What `bag info` prints: file, header, topics with recovered counts, time range, and what is wrong.

    `health` is the MCAP scan's (iguana_ros.bag.scan.Health); `metadata_problems` name what is wrong with the
    directory's metadata.yaml. `truncated` (the MCAP is not sound) and `problem` (why) summarise the scan.
    """

    path: Path
    size: int
    profile: str
    library: str
    topics: list[TopicInfo]
    message_count: int
    start_ns: int
    end_ns: int
    truncated: bool = False
    problem: str = ''
    schemas: dict[str, str] = field(default_factory=dict)
    health: Health | None = None
    metadata_problems: list[str] = field(default_factory=list)
    bag: Path | None = None
    """The bag as given (its directory, or the file)."""
    time_base: str = TIME_BASE_WALL
    """'simulated' (log times from `clock_topic`) or 'wall' (receive times; also a bag that does not say)."""
    clock_topic: str = CLOCK_TOPIC

    @property
    def sound(self) -> bool:
        """Nothing damaged, truncated or contradicting in the MCAP and the metadata.yaml."""
        return (self.health is None or self.health.sound) and not self.metadata_problems

    def report_line(self) -> str:
        """'sound: …', or 'damaged: BAG: what; …; recovered N of M messages' ('truncated: …' if only cut off)."""
        health = self.health or Health(self.path, self.size)
        if self.sound:
            return f'sound: {self.bag or self.path}: {health.recovered()}'
        status = 'damaged' if health.damaged or self.metadata_problems else 'truncated'
        return f'{status}: {self.bag or self.path}: ' + '; '.join(
            health.problems() + self.metadata_problems + [health.recovered()])


def accept(summary: BagSummary, allow_damaged: bool) -> str:
    """'' for a sound bag; the damage report line for an unsound one with `allow_damaged`; else DamagedBag."""
    if summary.sound:
        return ''
    line = summary.report_line()
    if not allow_damaged:
        raise DamagedBag(f'{line}; --allow-damaged accepts what was recovered')
    return line


def _topic_from_channel(channel: Channel, schemas: dict[int, Schema]) -> TopicInfo:
    """`TopicInfo` of an MCAP channel record."""
    schema = schemas.get(channel.schema_id)
    return TopicInfo(channel.topic, schema.name if schema else '',
                     channel.metadata.get('offered_qos_profiles', ''),
                     channel.metadata.get('topic_type_hash', ''))


class BagReader:
    """
    Streams the messages of every intact chunk of a bag in file order (see iguana_ros.bag.scan).

    After iterating, `health` says what was damaged or cut off, `truncated` whether the stream is incomplete
    (the file is truncated or damaged) and `problem` why. InputError at once for a missing or non-MCAP file.
    """

    def __init__(self, path: str | Path) -> None:
        self.path = resolve_bag_file(path)
        self.header: Header | None = None
        self.schemas: dict[int, Schema] = {}
        self.channels: dict[int, Channel] = {}
        self.health: Health | None = None
        if not looks_like_mcap(self.path):
            with open(self.path, 'rb') as f:
                head = f.read(8)
            raise InputError(f'{self.path} is not an MCAP file (bad magic bytes {head!r})')

    @property
    def truncated(self) -> bool:
        """Whether the last pass found the file truncated or damaged (some messages may be missing)."""
        return self.health is not None and not self.health.sound

    @property
    def damaged(self) -> bool:
        """Whether the last pass found damage (not only a cut-off end)."""
        return self.health is not None and self.health.damaged

    @property
    def problem(self) -> str:
        """Return what the last pass found wrong, in one line ('' if the file is sound)."""
        return self.health.describe() if self.truncated else ''

    def topic(self, channel_id: int) -> TopicInfo:
        """`TopicInfo` of a channel seen so far."""
        return _topic_from_channel(self.channels[channel_id], self.schemas)

    def messages(self) -> Iterator[BagMessage]:
        """Every message of every intact chunk, in file order, CRCs checked."""
        scan = Scan(self.path)
        self.schemas, self.channels = scan.schemas, scan.channels
        for record in scan.records():
            if isinstance(record, Message):
                yield BagMessage(self.channels[record.channel_id].topic, record.data, record.log_time,
                                 record.publish_time, record.channel_id)
        self.header, self.health = scan.header, scan.health


def summarize(path: str | Path, verify: bool = True) -> BagSummary:
    """
    `BagSummary` of the bag at `path` (directory or .mcap), its metadata.yaml checked for a directory.

    With `verify` the file is checked in full by reading every chunk (CRCs prove bytes as written, not a
    consistent file: a channel id defined twice is found only there; ~0.2 s for 25 MB). Without it a trusted
    summary is taken as it is (the chunks are checked when they are read). InputError for a missing or non-MCAP
    file, or one with nothing readable.
    """
    mcap = resolve_bag_file(path)
    scan = Scan(mcap)
    trusted = scan.health.summary == 'verified'
    if not verify and trusted:
        scan.close()
        scan.counts = dict(scan.statistics.channel_message_counts) if scan.statistics else {}
        scan.health.messages = sum(scan.counts.values())
        stats = scan.statistics
        scan.start_ns, scan.end_ns = (stats.message_start_time, stats.message_end_time) if stats else (0, 0)
    else:
        for _ in scan.records():
            pass
    health = scan.health
    if scan.header is None and health.messages == 0 and not scan.channels:
        raise InputError(f'{mcap} is corrupt: no readable MCAP header ({health.describe()})')
    topics = []
    for cid, channel in scan.channels.items():
        topic = _topic_from_channel(channel, scan.schemas)
        topic.message_count = scan.counts.get(cid, 0)
        topics.append(topic)
    header = scan.header
    summary = BagSummary(mcap, health.size, header.profile if header else '', header.library if header else '',
                         topics, health.messages, scan.start_ns or 0, scan.end_ns, truncated=not health.sound,
                         problem='' if health.sound else health.describe(),
                         schemas={s.name: s.data.decode(errors='replace') for s in scan.schemas.values()},
                         health=health, bag=Path(path))
    if Path(path).is_dir():
        summary.metadata_problems = _metadata_problems(Path(path), mcap, scan)
    summary.time_base, summary.clock_topic = time_base_of(path, mcap)
    return summary


def time_base_of(path: str | Path, mcap: Path | None = None) -> tuple[str, str]:
    """
    (time base, clock topic) of a bag: its `iguana_ros` Metadata record, else metadata.yaml's custom_data, else wall.

    Bags recorded before the time base was written (and by other recorders) have neither: they are on wall time.
    """
    mcap = mcap or resolve_bag_file(path)
    record = leading_metadata(mcap).get(METADATA_NAME, {})
    if record.get('time_base') not in TIME_BASES and Path(path).is_dir():
        info, _ = load_metadata(path)
        custom = info.get('custom_data') if isinstance(info, dict) else None
        if isinstance(custom, dict):
            record = {k: custom.get(key) for k, key in CUSTOM_DATA_KEYS.items()}
    time_base = record.get('time_base')
    if time_base not in TIME_BASES:
        return TIME_BASE_WALL, CLOCK_TOPIC
    clock = record.get('clock_topic')
    return time_base, clock if isinstance(clock, str) and clock else CLOCK_TOPIC


def _metadata_problems(directory: Path, mcap: Path, scan: Scan) -> list[str]:
    """Return what is wrong with DIR/metadata.yaml, against the MCAP's counts where they are known in full."""
    info, problem = load_metadata(directory)
    if info is None:
        unfinished = scan.health.truncated_at is not None and not (directory / 'metadata.yaml').exists()
        return [] if unfinished else [problem]     # a killed recorder writes no metadata.yaml: not more damage
    counts = None
    if scan.health.sound:
        counts = scan.counts
    elif scan.statistics is not None and scan.health.summary == 'verified':
        counts = dict(scan.statistics.channel_message_counts)
    topic_counts = None
    if counts is not None:
        topic_counts = {}
        for cid, n in counts.items():
            if cid in scan.channels:
                name = scan.channels[cid].topic
                topic_counts[name] = topic_counts.get(name, 0) + n
    total = sum(counts.values()) if counts is not None else None
    return check_metadata(info, mcap.name, topic_counts, total)
