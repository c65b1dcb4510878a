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
Damage-aware reading of an MCAP file (ROS-free): the records of every intact chunk, and what was wrong.

The scan walks the data section record by record from the start of the file. A chunk is accepted when its
record parses exactly, decompresses to its declared size and matches its CRC; its schemas, channels and
messages are then taken. Anything else at a position -- a chunk failing its CRC, a record running past the
data section, an opcode that does not belong there -- is a damaged region, and reading resumes at the next
chunk: the next offset of the summary's chunk index (each chunk is still verified on its own, so a damaged
index only costs time) or, when there is none, the next bytes that parse as a chunk record.

The summary is read first and trusted only when its CRC matches (or it has none and parses): then its
channels name the messages of chunks whose own channel records were lost, and the chunks, message counts and
message indexes are checked against it. The data-section CRC (DataEnd; BagWriter writes it) covers what no
other CRC covers (header, message indexes). CRCs prove bytes are as written, not that what was written is
consistent, so a file is called sound only after every chunk was read: a schema or channel id defined twice with
different contents (channel 1 first `/iguana_state`, then `/mesh_marker`) is damage, and the messages of such an id
after its second definition are not attributed to either (a reader would decode a Marker as an Odometry).

Decompression is bounded: a chunk declaring more than MAX_CHUNK_MEMORY uncompressed bytes is damage, not an
allocation, and no chunk is decompressed beyond its declared size (a 135 kB zstd chunk declaring 4 GiB took
4.2 GB, an lz4 chunk without a bound 3.4 GB).

A file that ends inside the data section (a killed recorder) is `truncated`; every complete chunk before the
end is recovered. Truncation and damage both make the file unsound (`Health.sound`).
"""
from __future__ import annotations

import bisect
from collections.abc import Iterator
from dataclasses import dataclass, field
from io import BytesIO
import os
from pathlib import Path
import struct
import zlib

from mcap.data_stream import ReadDataStream
from mcap.exceptions import McapError
from mcap.records import Channel, ChunkIndex, Header, Message, Metadata, Schema, Statistics
import zstandard

from iguana_ros.errors import InputError

MAGIC = b'\x89MCAP0\r\n'
OP_HEADER, OP_FOOTER, OP_SCHEMA, OP_CHANNEL, OP_MESSAGE, OP_CHUNK, OP_MESSAGE_INDEX = 1, 2, 3, 4, 5, 6, 7
OP_CHUNK_INDEX, OP_ATTACHMENT, OP_STATISTICS, OP_METADATA, OP_DATA_END = 8, 9, 0x0B, 0x0C, 0x0F
_SUMMARY_OPS = {OP_FOOTER, OP_CHUNK_INDEX, 0x0A, OP_STATISTICS, 0x0D, 0x0E}
"""Opcodes that belong to the summary section (footer, indexes, statistics, summary offsets)."""
RECORD_HEAD = 9
"""Opcode (1 byte) and record length (8 bytes)."""
FOOTER_TAIL = RECORD_HEAD + 20 + len(MAGIC)
"""Footer record plus the closing magic: the last 37 bytes of a finished file."""
DATA_END_BYTES = RECORD_HEAD + 4
CHUNK_FIXED = 8 + 8 + 8 + 4 + 4 + 8
"""Chunk record body without its compression string and records: times, sizes, CRC and length prefixes."""
COMPRESSIONS = ('', 'zstd', 'lz4')
MAX_CHUNK_BYTES = 1 << 32
MAX_CHUNK_MEMORY = 256 << 20
"""Largest uncompressed chunk read, bytes: BagWriter's chunks hold ~0.8 MB (CHUNK_BYTES), rosbag2's and Foxglove's a
few MB; a chunk declaring more is refused as damage (it would take that much memory at once)."""
"""Largest uncompressed chunk the reader accepts (a damaged size field could claim anything)."""
SEARCH_BLOCK = 1 << 20
"""Bytes read at a time while searching for the next chunk after damage."""
_DATA_END_HEAD = bytes([OP_DATA_END]) + struct.pack('<Q', 4)
_PARSE_ERRORS = (McapError, ValueError, struct.error, EOFError, UnicodeDecodeError, KeyError, OverflowError)
MAX_LISTED = 3
"""Damaged regions named one by one in `Health.describe`; the rest are counted."""


@dataclass(frozen=True)
class Damage:
    """One damaged region of a file: bytes [start, end) and what was wrong there."""

    start: int
    end: int
    what: str

    def __str__(self) -> str:
        """'bytes 120-380: chunk CRC mismatch'."""
        span = f'bytes {self.start}-{self.end}' if self.end > self.start + 1 else f'byte {self.start}'
        return f'{span}: {self.what}'


@dataclass
class Health:
    """What a scan found: damaged regions, truncation, what was recovered and what the summary promised."""

    path: Path
    size: int
    damage: list[Damage] = field(default_factory=list)
    truncated_at: int | None = None
    """Offset at which the file ends inside its data section (no complete summary), or None."""
    chunks: int = 0
    messages: int = 0
    unattributed: int = 0
    """Messages recovered from intact chunks whose channel record was lost with the damage."""
    ambiguous: int = 0
    """Messages on a channel id defined twice with different contents, after the second definition (not attributed)."""
    expected_messages: int | None = None
    expected_chunks: int | None = None
    summary: str = 'missing'
    """'verified', 'missing' or 'damaged'."""
    data_crc: str = 'absent'
    """'verified', 'absent' (written as 0), 'mismatch', or 'unchecked' (no DataEnd)."""

    @property
    def sound(self) -> bool:
        """Neither damaged nor truncated."""
        return not self.damage and self.truncated_at is None

    @property
    def damaged(self) -> bool:
        """Whether any region of the file is damaged; truncation alone is not damage."""
        return bool(self.damage)

    def problems(self) -> list[str]:
        """One phrase per problem: the truncation and each damaged region (the first MAX_LISTED of them)."""
        out = []
        if self.truncated_at is not None:
            where = (f'after its last complete record (byte {self.size})' if self.truncated_at >= self.size
                     else f'at byte {self.truncated_at} of {self.size}, inside a record')
            out.append(f'truncated {where}: no summary (an unfinished recording, or a cut file)')
        out += [str(d) for d in self.damage[:MAX_LISTED]]
        if len(self.damage) > MAX_LISTED:
            out.append(f'{len(self.damage) - MAX_LISTED} more damaged regions')
        if self.unattributed:
            out.append(f'{self.unattributed} messages of intact chunks lost with their channel records')
        if self.ambiguous:
            out.append(f'{self.ambiguous} messages on a redefined channel id not attributed')
        return out

    def recovered(self) -> str:
        """
        Return what was recovered: 'recovered 59 of 60 messages (59 of 60 chunks)'.

        Without a trusted summary it is 'recovered 48 messages in 48 chunks'.
        """
        if self.expected_messages is None:
            return f'recovered {self.messages} messages in {self.chunks} chunks'
        chunks = f' ({self.chunks} of {self.expected_chunks} chunks)' if self.expected_chunks is not None else ''
        return f'recovered {self.messages} of {self.expected_messages} messages{chunks}'

    def describe(self) -> str:
        """One line: 'sound', or the problems and what was recovered."""
        if self.sound:
            return f'sound: {self.recovered()}'
        return '; '.join(self.problems() + [self.recovered()])


class _File:
    """
    Positioned reads of a file.

    There is no shared file position and no memory map: a file shrinking under the reader gives short reads, not a
    crash.
    """

    def __init__(self, path: Path) -> None:
        self.fd = os.open(path, os.O_RDONLY)
        self.size = os.fstat(self.fd).st_size

    def read(self, offset: int, n: int) -> bytes:
        """Up to `n` bytes at `offset` (fewer at the end of the file)."""
        n = max(0, min(n, self.size - offset))
        parts, got = [], 0
        while got < n:
            part = os.pread(self.fd, min(n - got, 1 << 30), offset + got)
            if not part:
                break
            parts.append(part)
            got += len(part)
        return b''.join(parts)

    def crc(self, start: int, stop: int) -> int:
        """CRC-32 of bytes [start, stop)."""
        value, pos = 0, start
        while pos < stop:
            block = self.read(pos, min(SEARCH_BLOCK * 8, stop - pos))
            if not block:
                break
            value = zlib.crc32(block, value)
            pos += len(block)
        return value

    def close(self) -> None:
        """Close the descriptor (again: nothing)."""
        if self.fd >= 0:
            os.close(self.fd)
            self.fd = -1


LEADING_BYTES = 64 * 1024
"""How far `leading_metadata` reads: a writer's Metadata records right after its Header are a few hundred bytes."""


def leading_metadata(path: Path) -> dict[str, dict[str, str]]:
    """
    {name: key-value map} of the Metadata records right after the Header (where BagWriter writes its own).

    Read on their own, without a scan, so a summary taken from a trusted index knows them too; {} when the start of the
    file is not a Header followed by Metadata records.
    """
    out: dict[str, dict[str, str]] = {}
    with open(path, 'rb') as f:
        head = f.read(LEADING_BYTES)
    pos, first = len(MAGIC), True
    while pos + RECORD_HEAD <= len(head):
        op, length = struct.unpack_from('<BQ', head, pos)
        body = head[pos + RECORD_HEAD:pos + RECORD_HEAD + length]
        if len(body) != length or op != (OP_HEADER if first else OP_METADATA):
            break
        if op == OP_METADATA:
            try:
                record = _parse_exact(Metadata, body)
            except _PARSE_ERRORS:
                break
            out[record.name] = dict(record.metadata)
        pos, first = pos + RECORD_HEAD + length, False
    return out


def looks_like_mcap(path: Path) -> bool:
    """Whether the file starts with (most of) the MCAP magic or ends with it; False for anything else."""
    size = path.stat().st_size
    if size < len(MAGIC):
        return False
    with open(path, 'rb') as f:
        head = f.read(len(MAGIC))
        f.seek(size - len(MAGIC))
        tail = f.read(len(MAGIC))
    close = sum(a == b for a, b in zip(head, MAGIC)) >= len(MAGIC) - 2
    return close or (tail == MAGIC and size >= len(MAGIC) + FOOTER_TAIL)


def _chunk_fields(body: bytes | memoryview, at: int = 0, length: int | None = None) -> tuple | None:
    """
    Return the fields of the chunk record body at `at` in `body`, or None if it is not shaped like one.

    The fields are (start_ns, end_ns, uncompressed_size, crc, compression, records_offset, records_length) of a record
    whose length is `length` (default: the rest of `body`).
    """
    length = len(body) - at if length is None else length
    if length < CHUNK_FIXED or len(body) < at + 32:
        return None
    start, end, usize, crc, comp_len = struct.unpack_from('<QQQII', body, at)
    if comp_len > 8 or len(body) < at + 40 + comp_len or start > end or usize > MAX_CHUNK_BYTES:
        return None
    compression = bytes(body[at + 32:at + 32 + comp_len])
    if compression.decode('ascii', 'replace') not in COMPRESSIONS:
        return None
    (records_len,) = struct.unpack_from('<Q', body, at + 32 + comp_len)
    if records_len != length - CHUNK_FIXED - comp_len:
        return None
    return start, end, usize, crc, compression.decode('ascii'), at + 40 + comp_len, records_len


def _decompress(compression: str, data: bytes, size: int) -> bytes:
    """
    Return the chunk's records; ValueError when they do not decompress to exactly `size` bytes.

    Never more than `size` bytes (at most MAX_CHUNK_MEMORY) are produced.
    """
    if size > MAX_CHUNK_MEMORY:
        raise ValueError(f'declares {size} bytes uncompressed, above the {MAX_CHUNK_MEMORY >> 20} MiB a chunk may '
                         'hold here')
    if compression == '':
        out = data
    elif compression == 'zstd':
        declared = zstandard.frame_content_size(data)
        if declared not in (-1, size):
            raise ValueError(f'zstd frame declares {declared} bytes, the chunk {size}')
        out = zstandard.ZstdDecompressor().decompress(data, max_output_size=size, allow_extra_data=False)
    else:
        try:
            import lz4.frame
        except ImportError:
            raise ValueError('lz4-compressed chunk and the lz4 package is not installed') from None
        decompressor = lz4.frame.LZ4FrameDecompressor()
        out = decompressor.decompress(data, max_length=size)
        if not decompressor.eof:
            raise ValueError(f'lz4 frame does not end within the {size} bytes the chunk declares')
    if len(out) != size:
        raise ValueError(f'decompressed to {len(out)} bytes, the chunk declares {size}')
    return out


def _stream(data: bytes) -> ReadDataStream:
    return ReadDataStream(BytesIO(data))


def _parse_exact(cls, body: bytes):
    """Record `cls` parsed from its whole body; ValueError if it is shorter or longer than the record."""
    stream = _stream(body)
    record = cls.read(stream)
    if stream.count != len(body):
        raise ValueError(f'{cls.__name__} record has {len(body) - stream.count} stray bytes')
    return record


def _message(body: bytes) -> Message:
    """Message record from its body."""
    if len(body) < 22:
        raise ValueError('Message record shorter than its fixed fields')
    channel_id, sequence, log_time, publish_time = struct.unpack_from('<HIQQ', body, 0)
    return Message(channel_id=channel_id, sequence=sequence, log_time=log_time, publish_time=publish_time,
                   data=body[22:])


def _chunk_records(records: bytes) -> list[tuple[int, object]]:
    """
    (offset in the records, Schema | Channel | Message) of a chunk's decompressed records.

    ValueError if they do not parse exactly.
    """
    out, pos = [], 0
    while pos < len(records):
        if len(records) - pos < RECORD_HEAD:
            raise ValueError('chunk records end inside a record header')
        op, length = struct.unpack_from('<BQ', records, pos)
        body = records[pos + RECORD_HEAD:pos + RECORD_HEAD + length]
        if len(body) != length:
            raise ValueError('a record runs past the end of its chunk')
        if op == OP_MESSAGE:
            out.append((pos, _message(body)))
        elif op == OP_SCHEMA:
            out.append((pos, _parse_exact(Schema, body)))
        elif op == OP_CHANNEL:
            out.append((pos, _parse_exact(Channel, body)))
        else:
            raise ValueError(f'opcode 0x{op:02x} inside a chunk')
        pos += RECORD_HEAD + length
    return out


class Scan:
    """
    One damage-aware pass over an MCAP file.

    Iterate `records()`, then read `health`, `header`, `schemas`, `channels`, `counts` (recovered messages per channel
    id), `statistics` (of a trusted summary).
    """

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        if not looks_like_mcap(self.path):
            with open(self.path, 'rb') as f:
                head = f.read(len(MAGIC))
            raise InputError(f'{self.path} is not an MCAP file (bad magic bytes {head!r})')
        self.health = Health(self.path, self.path.stat().st_size)
        self.header: Header | None = None
        self.schemas: dict[int, Schema] = {}
        self.channels: dict[int, Channel] = {}
        self.counts: dict[int, int] = {}
        self.start_ns: int | None = None
        self.end_ns = 0
        self.statistics: Statistics | None = None
        self.chunk_index: dict[int, ChunkIndex] = {}
        """Chunk index entries of a trusted summary, by chunk offset."""
        self._hints: list[int] = []
        """Chunk offsets named by any readable chunk index (trusted or not): where to look after damage."""
        self._footer: tuple[int, int, int] | None = None
        self._summary_ok = False
        self._limit = self.health.size
        self._data_end: int | None = None
        self._data_end_crc = 0
        self._last_chunk: dict[int, tuple[int, int]] = {}
        self._redefined: set[tuple[type, int]] = set()
        """(Schema or Channel, id) defined twice with different contents: their messages are not attributed."""
        self._span = (0, 0)
        """Bytes of the record (or chunk) being taken, for the damage a redefinition is."""
        self._file = _File(self.path)
        try:
            self._read_ends()
        except BaseException:
            self._file.close()
            raise

    # -- the ends of the file: magic, footer, summary ----------------------------------------------------------

    def _damage(self, start: int, end: int, what: str) -> None:
        self.health.damage.append(Damage(start, max(end, start), what))

    def _read_ends(self) -> None:
        """Check both magics, read the footer and the summary (trusted only if its CRC matches)."""
        f, size = self._file, self.health.size
        head = f.read(0, len(MAGIC))
        if head != MAGIC:
            self._damage(0, len(MAGIC), 'bad magic bytes at the start')
        if size < len(MAGIC) + FOOTER_TAIL:
            return
        tail = f.read(size - FOOTER_TAIL, FOOTER_TAIL)
        op, length = struct.unpack_from('<BQ', tail, 0)
        end_magic = tail[-len(MAGIC):] == MAGIC
        if op != OP_FOOTER or length != 20:
            if end_magic:
                self._damage(size - FOOTER_TAIL, size - len(MAGIC), 'footer record unreadable')
            return                       # no footer: an unfinished file, or damage found by the scan
        if not end_magic:
            self._damage(size - len(MAGIC), size, 'bad magic bytes at the end')
        self._footer = struct.unpack_from('<QQI', tail, RECORD_HEAD)
        summary_start, _, summary_crc = self._footer
        footer_pos = size - FOOTER_TAIL
        if summary_start == 0:
            return
        if not len(MAGIC) < summary_start <= footer_pos:
            self._damage(footer_pos, footer_pos + RECORD_HEAD + 20,
                         f'footer points its summary to byte {summary_start}, outside the file')
            self.health.summary = 'damaged'
            return
        summary = f.read(summary_start, footer_pos - summary_start)
        crc_ok = summary_crc == 0 or zlib.crc32(tail[:RECORD_HEAD + 16], zlib.crc32(summary)) == summary_crc
        parsed = self._parse_summary(summary, summary_start)
        if crc_ok and parsed:
            self._summary_ok = True
            self.health.summary = 'verified'
            self._limit = summary_start
            self.health.expected_chunks = len(self.chunk_index)
            if self.statistics is not None:
                self.health.expected_messages = self.statistics.message_count
        else:
            self.health.summary = 'damaged'
            self.schemas, self.channels, self.chunk_index, self.statistics = {}, {}, {}, None
            self._damage(summary_start, footer_pos,
                         'summary section fails its CRC' if not crc_ok else 'summary section does not parse')

    def _parse_summary(self, data: bytes, base: int) -> bool:
        """
        Read the summary's schemas, channels, chunk indexes and statistics.

        False if a record is unreadable (the chunk offsets read so far are kept as hints).
        """
        pos = 0
        try:
            while pos < len(data):
                op, length = struct.unpack_from('<BQ', data, pos)
                body = data[pos + RECORD_HEAD:pos + RECORD_HEAD + length]
                if len(body) != length:
                    return False
                if op in (OP_SCHEMA, OP_CHANNEL):
                    self._span = (base + pos, base + pos + RECORD_HEAD + length)
                    self._register(_parse_exact(Schema if op == OP_SCHEMA else Channel, body))
                elif op == OP_CHUNK_INDEX:
                    index = _parse_exact(ChunkIndex, body)
                    self.chunk_index[index.chunk_start_offset] = index
                    if len(MAGIC) <= index.chunk_start_offset < base:
                        bisect.insort(self._hints, index.chunk_start_offset)
                elif op == OP_STATISTICS:
                    self.statistics = _parse_exact(Statistics, body)
                pos += RECORD_HEAD + length
        except (*_PARSE_ERRORS, MemoryError):
            return False
        return True

    # -- the data section ---------------------------------------------------------------------------------------

    def records(self) -> Iterator[Schema | Channel | Message]:
        """
        Schemas, channels and messages of every intact chunk (and top-level record) in file order.

        Messages only once their channel is known. `health` is complete when the iterator is exhausted.
        """
        try:
            yield from self._scan()
        finally:
            self._file.close()

    def close(self) -> None:
        """Release the file without scanning the data section (a trusted summary taken as it is)."""
        self._file.close()

    def _scan(self) -> Iterator:
        f, limit = self._file, self._limit
        pos = len(MAGIC)
        while pos < limit:
            head = f.read(pos, RECORD_HEAD)
            if len(head) < RECORD_HEAD:
                pos = self._lost(pos, 'record header cut off', past_end=True)
                continue
            op, length = struct.unpack_from('<BQ', head)
            end = pos + RECORD_HEAD + length
            if pos == len(MAGIC) and op != OP_HEADER:
                self._damage(pos, pos, 'no Header record at the start of the file')
            if end > limit:
                pos = self._lost(pos, f'record of {length} bytes runs past the data section', past_end=True)
                continue
            if op != OP_CHUNK and self._runs_into_chunk(pos, end):
                pos = self._lost(pos, f'record of {length} bytes runs into the next indexed chunk')
                continue
            if op == OP_DATA_END:
                if length != 4:
                    pos = self._lost(pos, 'DataEnd record of the wrong length')
                    continue
                self._data_end = pos
                (self._data_end_crc,) = struct.unpack('<I', f.read(pos + RECORD_HEAD, 4))
                break
            problem = ''
            if op == OP_CHUNK:
                problem = yield from self._chunk(pos, length)
            elif op == OP_MESSAGE_INDEX:
                self._check_message_index(pos, f.read(pos + RECORD_HEAD, length))
            elif op in (OP_SCHEMA, OP_CHANNEL, OP_MESSAGE) or (op == OP_HEADER and pos == len(MAGIC)):
                try:
                    record = self._top_level(op, f.read(pos + RECORD_HEAD, length), pos)
                except _PARSE_ERRORS:
                    record, problem = None, f'unreadable record (opcode 0x{op:02x})'
                if record is not None:
                    yield record
            elif op not in (OP_ATTACHMENT, OP_METADATA):
                problem = ('summary record in the data section' if op in _SUMMARY_OPS
                           else f'unexpected opcode 0x{op:02x}')
            pos = self._lost(pos, problem) if problem else end
        self._finish(pos)

    def _runs_into_chunk(self, pos: int, end: int) -> bool:
        """
        Tell whether a record at `pos` ending at `end` covers the start of a chunk the summary indexes.

        Its length is then damaged: only a chunk starts there, and trusting the length would skip an intact chunk.
        """
        k = bisect.bisect_right(self._hints, pos)
        return k < len(self._hints) and self._hints[k] < end

    def _lost(self, pos: int, what: str, past_end: bool = False) -> int:
        """
        Record the damaged region from `pos` to where reading resumes, and return that offset.

        In a file without footer, a last record cut off with nothing readable after it is a truncation instead.
        """
        resume = self._resync(pos)
        if past_end and resume >= self._limit and self._footer is None:
            self.health.truncated_at = pos
        else:
            self._damage(pos, resume, what)
        return resume

    def _resync(self, pos: int) -> int:
        """
        Offset of the next chunk (or DataEnd) after a damaged record at `pos`.

        With a trusted summary: the next indexed chunk, else DataEnd. Otherwise the next bytes shaped like a chunk or
        the next offset of an untrusted index, whichever comes first; the end of the data section if none.
        """
        k = bisect.bisect_right(self._hints, pos)
        hint = self._hints[k] if k < len(self._hints) and self._hints[k] < self._limit else None
        if self._summary_ok:
            data_end = self._limit - DATA_END_BYTES
            return hint if hint is not None else data_end if data_end > pos else self._limit
        found = self._search(pos + 1, self._limit if hint is None else hint)
        if found is not None:
            return found
        return self._limit if hint is None else hint

    def _search(self, start: int, stop: int) -> int | None:
        """First offset in [start, stop) holding a record shaped like a chunk or a DataEnd, or None."""
        pos = start
        while pos < stop:
            n = min(SEARCH_BLOCK, stop - pos)
            block = self._file.read(pos, n + RECORD_HEAD + CHUNK_FIXED + 8)
            for k in _candidates(block, n):
                if block[k] == OP_DATA_END:
                    if block[k:k + RECORD_HEAD] == _DATA_END_HEAD:
                        return pos + k
                    continue
                if block[k + 6:k + RECORD_HEAD] != b'\x00\x00\x00':      # a chunk is shorter than 1 TiB
                    continue
                (length,) = struct.unpack_from('<Q', block, k + 1)
                if pos + k + RECORD_HEAD + length <= self._limit and \
                        _chunk_fields(block, k + RECORD_HEAD, length) is not None:
                    return pos + k
            pos += n
        return None

    def _chunk(self, pos: int, length: int):
        """
        Verify the chunk record at `pos` and yield its records.

        Returns '' or, for a damaged chunk, what is wrong with it (then nothing was yielded).
        """
        body = self._file.read(pos + RECORD_HEAD, length)
        fields = _chunk_fields(body)
        if fields is None:
            return 'chunk record with inconsistent fields'
        _, _, usize, crc, compression, at, n = fields
        try:
            records = _decompress(compression, body[at:at + n], usize)
            if crc != 0 and zlib.crc32(records) != crc:
                return 'chunk fails its CRC'
            parsed = _chunk_records(records)
        except (*_PARSE_ERRORS, zstandard.ZstdError, MemoryError, RuntimeError) as exc:
            return f'chunk unreadable ({exc or type(exc).__name__})'
        self.health.chunks += 1
        self._last_chunk = {}
        self._span = (pos, pos + RECORD_HEAD + length)
        times = []
        for offset, record in parsed:
            if isinstance(record, Message):
                self._last_chunk[offset] = (record.channel_id, record.log_time)
                times.append(record.log_time)
            taken = self._take(record)
            if taken is not None:
                yield taken
        self._check_chunk(pos, length, fields, times)
        return ''

    def _check_chunk(self, pos: int, length: int, fields: tuple, times: list[int]) -> None:
        """Damage (no loss) where an intact chunk's own header or its index entry disagrees with its messages."""
        start, end, usize, _, compression, _, n = fields
        if times and (min(times), max(times)) != (start, end):
            self._damage(pos, pos + RECORD_HEAD + length, 'chunk header times disagree with its messages')
        if not self._summary_ok:
            return
        entry = self.chunk_index.get(pos)
        if entry is None:
            self._damage(pos, pos + RECORD_HEAD + length, 'chunk missing from the summary index')
        elif (entry.chunk_length, entry.compression, entry.uncompressed_size, entry.compressed_size,
              entry.message_start_time, entry.message_end_time) != (RECORD_HEAD + length, compression, usize, n,
                                                                    start, end):
            self._damage(pos, pos + RECORD_HEAD + length, 'chunk disagrees with its summary index entry')

    def _check_message_index(self, pos: int, body: bytes) -> None:
        """Damage (no loss) when a message index record does not list exactly its chunk's messages."""
        try:
            channel_id, n_bytes = struct.unpack_from('<HI', body, 0)
            if n_bytes != len(body) - 6 or n_bytes % 16:
                raise ValueError
            entries = struct.iter_unpack('<QQ', body[6:])
            ok = all(self._last_chunk.get(offset) == (channel_id, log_time) for log_time, offset in entries)
            ok = ok and n_bytes // 16 == sum(1 for c, _ in self._last_chunk.values() if c == channel_id)
        except (ValueError, struct.error):
            ok = False
        if not ok:
            self._damage(pos, pos + RECORD_HEAD + len(body), 'message index does not match its chunk')

    def _top_level(self, op: int, body: bytes, pos: int = 0):
        """Return a Schema, Channel or Message record outside a chunk (unchunked files), or the Header."""
        if op == OP_HEADER:
            self.header = _parse_exact(Header, body)
            return None
        self._span = (pos, pos + RECORD_HEAD + len(body))
        if op == OP_MESSAGE:
            return self._take(_message(body))
        return self._take(_parse_exact(Schema if op == OP_SCHEMA else Channel, body))

    def _take(self, record):
        """
        Register a schema/channel (the first record of an id wins; another definition is damage: `_register`).

        Count a message. Returns the record to yield, or None (a message whose channel is unknown).
        """
        if isinstance(record, Message):
            if record.channel_id not in self.channels:
                self.health.unattributed += 1
                return None
            if self._ambiguous(record.channel_id):
                self.health.ambiguous += 1
                return None
            self.counts[record.channel_id] = self.counts.get(record.channel_id, 0) + 1
            self.health.messages += 1
            self.start_ns = record.log_time if self.start_ns is None else min(self.start_ns, record.log_time)
            self.end_ns = max(self.end_ns, record.log_time)
            return record
        self._register(record)
        return record

    def _register(self, record: Schema | Channel) -> None:
        """Keep the first definition of an id; one with other contents is damage and makes the id ambiguous."""
        table = self.schemas if isinstance(record, Schema) else self.channels
        known = table.setdefault(record.id, record)
        if known != record and (type(record), record.id) not in self._redefined:
            self._redefined.add((type(record), record.id))
            if isinstance(record, Channel):
                what = f'channel {record.id} defined twice: {known.topic} and {record.topic}'
            else:
                what = f'schema {record.id} defined twice: {known.name} and {record.name}'
            self._damage(*self._span, what)

    def _ambiguous(self, channel_id: int) -> bool:
        """Whether a channel id, or the schema its channel names, was defined twice with different contents."""
        schema = self.channels[channel_id].schema_id
        return (Channel, channel_id) in self._redefined or (Schema, schema) in self._redefined

    def _finish(self, pos: int) -> None:
        """After the data section: a missing DataEnd or summary, the data-section CRC, counts against the summary."""
        health = self.health
        if self._data_end is None:
            health.data_crc = 'unchecked'
            if self._footer is not None:
                self._damage(pos, health.size, 'no DataEnd record after the data section')
            elif health.truncated_at is None:
                health.truncated_at = pos        # ends after a complete record: an unfinished recording
            return
        if self._footer is None:
            self._damage(self._data_end + DATA_END_BYTES, health.size,
                         'summary or footer missing or unreadable after a complete data section')
        if self._data_end_crc == 0:
            health.data_crc = 'absent'
        elif any(len(MAGIC) <= d.start < self._data_end for d in health.damage):
            health.data_crc = 'mismatch'         # explained by the damage found in the data section
        elif self._file.crc(0, self._data_end) != self._data_end_crc:
            health.data_crc = 'mismatch'
            self._damage(0, self._data_end, 'data section fails its CRC (damage outside the chunks: header '
                                            'or message indexes)')
        else:
            health.data_crc = 'verified'
        stats = self.statistics
        if self._summary_ok and not health.damage and stats is not None and (
                stats.message_count != health.messages
                or {c: k for c, k in stats.channel_message_counts.items() if k} != self.counts):
            self._damage(self._footer[0], health.size, f'summary counts {stats.message_count} messages, the '
                                                       f'chunks hold {health.messages}')


def _candidates(block: bytes, n: int) -> Iterator[int]:
    """Offsets k < n of `block`, in order, holding a chunk or a DataEnd opcode with a record header's room after."""
    nxt = {op: block.find(bytes([op]), 0, n) for op in (OP_CHUNK, OP_DATA_END)}
    while True:
        live = [k for k in nxt.values() if k >= 0]
        if not live:
            return
        k = min(live)
        op = block[k]
        nxt[op] = block.find(bytes([op]), k + 1, n)
        if len(block) - k >= (RECORD_HEAD if op == OP_DATA_END else RECORD_HEAD + CHUNK_FIXED):
            yield k
