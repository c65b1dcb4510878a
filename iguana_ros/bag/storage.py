"""rosbag2-compatible MCAP storage: a crash-safe writer and a reader that survives truncation (ROS-free).

Layout of a bag: `DIR/DIR.mcap` plus `DIR/metadata.yaml` (rosbag2_bagfile_information, version 9).
MCAP conventions of rosbag2's mcap storage plugin: profile `ros2`, schemas `ros2msg` named
`pkg/msg/Type`, messages `cdr`, channel metadata `offered_qos_profiles` (YAML) and `topic_type_hash`.
"""
from __future__ import annotations

import struct
import time
import zlib
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import yaml
import zstandard
from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.records import Channel, Header, Message, Schema
from mcap.stream_reader import StreamReader
from mcap.writer import CompressionType, Writer

from iguana_ros.errors import InputError

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

_READ_ERRORS = (McapError, EOFError, struct.error, ValueError, zstandard.ZstdError, zlib.error,
                UnicodeDecodeError, KeyError, MemoryError, OverflowError)


def _library() -> str:
    """Library string of the MCAP header, e.g. 'iguana_ros 0.1.0'."""
    try:
        from importlib.metadata import version
        return f'iguana_ros {version("iguana_ros")}'
    except Exception:  # not installed as a distribution (plain source tree)
        return 'iguana_ros'


def qos_profiles_yaml(profiles: list[dict]) -> str:
    """rosbag2's `offered_qos_profiles` YAML text for a list of QoS dicts (v9: policy names as strings)."""
    return yaml.safe_dump(list(profiles), sort_keys=False, default_flow_style=False)


def parse_qos_profiles(text: str) -> list[dict]:
    """QoS dicts from an `offered_qos_profiles` YAML text ('' or unreadable -> [])."""
    try:
        data = yaml.safe_load(text) if text else []
    except yaml.YAMLError:
        return []
    return [p for p in data if isinstance(p, dict)] if isinstance(data, list) else []


@dataclass
class TopicInfo:
    """One recorded topic: name, type, QoS YAML, type hash and message count."""

    name: str
    type: str
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
    """The .mcap file of a bag given as its directory or the file itself; InputError if there is none."""
    p = Path(path)
    if p.is_file():
        return p
    if not p.is_dir():
        raise InputError(f'no bag at {p}: expected a bag directory or an .mcap file')
    meta = p / 'metadata.yaml'
    if meta.is_file():
        try:
            files = yaml.safe_load(meta.read_text())['rosbag2_bagfile_information']['relative_file_paths']
            if files and (p / files[0]).is_file():
                return p / files[0]
        except (yaml.YAMLError, KeyError, TypeError):
            pass
    candidates = sorted(p.glob('*.mcap'))
    if (p / f'{p.name}.mcap').is_file():
        return p / f'{p.name}.mcap'
    if len(candidates) == 1:
        return candidates[0]
    raise InputError(f'bag directory {p} holds {len(candidates)} .mcap files, expected one')


class BagWriter:
    """Writes `DIR/DIR.mcap` with zstd chunks bounded in size and age; `close()` adds summary + metadata."""

    def __init__(self, directory: str | Path, chunk_bytes: int = CHUNK_BYTES,
                 chunk_age_s: float = CHUNK_AGE_S) -> None:
        self.directory = Path(directory)
        if self.directory.exists():
            raise InputError(f'output {self.directory} already exists; choose a new bag directory')
        self.directory.mkdir(parents=True)
        self.path = self.directory / f'{self.directory.name}.mcap'
        self._file = open(self.path, 'wb')
        self._writer = Writer(self._file, chunk_size=chunk_bytes, compression=CompressionType.ZSTD)
        if not hasattr(self._writer, '_Writer__finalize_chunk'):
            raise RuntimeError('this mcap version has no chunk finaliser; age-bounded chunks need mcap>=1.1')
        self._writer.start(profile=PROFILE, library=_library())
        self._file.flush()
        self.chunk_age_s = chunk_age_s
        self._chunk_opened: float | None = None
        self._schemas: dict[str, int] = {}
        self._channels: dict[int, TopicInfo] = {}
        self._first_ns: int | None = None
        self._last_ns = 0
        self.closed = False

    def add_topic(self, name: str, type_name: str, schema_text: str,
                  offered_qos_profiles: str = '', type_hash: str = '') -> int:
        """Register a topic (its schema once per type); returns the channel id for `write`."""
        if type_name not in self._schemas:
            self._schemas[type_name] = self._writer.register_schema(
                name=type_name, encoding=SCHEMA_ENCODING, data=schema_text.encode())
        metadata = {'offered_qos_profiles': offered_qos_profiles}
        if type_hash:
            metadata['topic_type_hash'] = type_hash
        channel_id = self._writer.register_channel(
            topic=name, message_encoding=MESSAGE_ENCODING, schema_id=self._schemas[type_name],
            metadata=metadata)
        self._channels[channel_id] = TopicInfo(name, type_name, offered_qos_profiles, type_hash)
        return channel_id

    def write(self, channel_id: int, data: bytes, log_time: int, publish_time: int | None = None) -> None:
        """Append one serialized message (times in ns since the epoch)."""
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
        self.close_chunk_if_old()

    def close_chunk_if_old(self) -> None:
        """Close and flush the open chunk if it is older than `chunk_age_s` (call it from a timer too)."""
        if self._chunk_opened is not None and time.monotonic() - self._chunk_opened >= self.chunk_age_s:
            self.close_chunk()

    def close_chunk(self) -> None:
        """Write the open chunk (if any) and flush it to the OS, so it survives a killed process."""
        self._writer._Writer__finalize_chunk()  # mcap keeps this private; see class docstring
        self._file.flush()
        self._chunk_opened = None

    @property
    def topics(self) -> list[TopicInfo]:
        """Registered topics with their message counts so far."""
        return list(self._channels.values())

    def close(self) -> None:
        """Finish the MCAP file (last chunk, summary, footer) and write metadata.yaml."""
        if self.closed:
            return
        self._writer.finish()
        self._file.close()
        self.closed = True
        (self.directory / 'metadata.yaml').write_text(yaml.safe_dump(
            self.metadata(), sort_keys=False, default_flow_style=False))

    def metadata(self) -> dict:
        """metadata.yaml contents in rosbag2's `rosbag2_bagfile_information` format (version 9).

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
            'custom_data': None, 'ros_distro': ROS_DISTRO}}


@dataclass
class BagSummary:
    """What `bag info` prints: file, header, topics with counts, time range, and damage if any."""

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


def _topic_from_channel(channel: Channel, schemas: dict[int, Schema]) -> TopicInfo:
    """TopicInfo of an MCAP channel record."""
    schema = schemas.get(channel.schema_id)
    return TopicInfo(channel.topic, schema.name if schema else '',
                     channel.metadata.get('offered_qos_profiles', ''),
                     channel.metadata.get('topic_type_hash', ''))


class BagReader:
    """Streams the messages of a bag in file order; a truncated or damaged tail ends the stream cleanly.

    After iterating, `truncated` and `problem` say whether (and where) the file stopped early.
    """

    def __init__(self, path: str | Path) -> None:
        self.path = resolve_bag_file(path)
        self.header: Header | None = None
        self.schemas: dict[int, Schema] = {}
        self.channels: dict[int, Channel] = {}
        self.truncated = False
        self.problem = ''
        self._check_magic()

    def _check_magic(self) -> None:
        """InputError in one line if the file does not start like an MCAP file."""
        with open(self.path, 'rb') as f:
            head = f.read(8)
        if head != b'\x89MCAP0\r\n':
            raise InputError(f'{self.path} is not an MCAP file (bad magic bytes {head[:8]!r})')

    def topic(self, channel_id: int) -> TopicInfo:
        """TopicInfo of a channel seen so far."""
        return _topic_from_channel(self.channels[channel_id], self.schemas)

    def messages(self) -> Iterator[BagMessage]:
        """Every message of every complete chunk, in file order, CRCs checked."""
        with open(self.path, 'rb') as f:
            records = StreamReader(f, validate_crcs=True, record_size_limit=1 << 31).records
            try:
                for record in records:
                    if isinstance(record, Message):
                        channel = self.channels.get(record.channel_id)
                        if channel is not None:
                            yield BagMessage(channel.topic, record.data, record.log_time,
                                             record.publish_time, record.channel_id)
                    elif isinstance(record, Schema):
                        self.schemas[record.id] = record
                    elif isinstance(record, Channel):
                        self.channels[record.id] = record
                    elif isinstance(record, Header):
                        self.header = record
            except _READ_ERRORS as exc:
                self.truncated = True
                self.problem = f'{type(exc).__name__}: {exc}' if str(exc) else type(exc).__name__
        if self.header is None and not self.truncated:
            self.truncated, self.problem = True, 'no MCAP header record'


def summarize(path: str | Path) -> BagSummary:
    """BagSummary from the file's summary section, or by streaming every complete chunk if it has none."""
    reader = BagReader(path)
    summary = _summary_from_index(reader.path)
    if summary is not None:
        return summary
    counts: dict[int, int] = {}
    first, last = None, 0
    for msg in reader.messages():
        counts[msg.channel_id] = counts.get(msg.channel_id, 0) + 1
        first = msg.log_time if first is None else min(first, msg.log_time)
        last = max(last, msg.log_time)
    if reader.header is None:
        raise InputError(f'{reader.path} is corrupt: no readable MCAP header ({reader.problem})')
    topics = [reader.topic(cid) for cid in reader.channels]
    for cid, topic in zip(reader.channels, topics):
        topic.message_count = counts.get(cid, 0)
    header = reader.header
    return BagSummary(reader.path, reader.path.stat().st_size, header.profile, header.library,
                      topics, sum(counts.values()), first or 0,
                      last, truncated=True,
                      problem=reader.problem or 'no summary section (recorder did not finish)',
                      schemas={s.name: s.data.decode(errors='replace') for s in reader.schemas.values()})


def _summary_from_index(path: Path) -> BagSummary | None:
    """BagSummary read from the footer's summary section; None if the file has no usable summary."""
    try:
        with open(path, 'rb') as f:
            reader = make_reader(f)
            header = reader.get_header()
            summary = reader.get_summary()
    except _READ_ERRORS:
        return None
    if summary is None or summary.statistics is None:
        return None
    stats = summary.statistics
    topics = []
    for cid, channel in summary.channels.items():
        topic = _topic_from_channel(channel, summary.schemas)
        topic.message_count = stats.channel_message_counts.get(cid, 0)
        topics.append(topic)
    return BagSummary(path, path.stat().st_size, header.profile, header.library, topics,
                      stats.message_count, stats.message_start_time, stats.message_end_time,
                      schemas={s.name: s.data.decode(errors='replace') for s in summary.schemas.values()})
