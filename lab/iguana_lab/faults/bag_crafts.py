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
Bags crafted to fool a reader: a channel id defined twice, and decompression bombs.

Every file here has valid CRCs (what a CRC check alone calls sound): the damage is in what was written. A channel
id redefined with another topic and type must be reported as damage and never decoded as the first type; a chunk
whose decompressed size is a lie (declared 1 GiB, or declared small and holding more, zstd and lz4) must be refused
within bounded memory. `crafted_suite` runs `iguana bag info`, `bag play --allow-damaged` (to a throwaway domain)
and the viewer's bag reader on each, in child processes whose peak memory (ru_maxrss) is measured.
"""
from __future__ import annotations

from dataclasses import dataclass, field
import io
from pathlib import Path
import subprocess
import sys
import zlib

BOMB_BYTES = 1 << 30
"""What a decompression bomb really decompresses to (1 GiB of zeros: ~32 kB of zstd, ~4 MB of lz4)."""

PEAK_LIMIT_MB = 512
"""Largest peak memory (resident set) of a child reading a crafted bag, MB."""

MAGIC = b'\x89MCAP0\r\n'


@dataclass
class CraftResult:
    """One crafted bag through one reader: exit status, its last line, peak memory, and what was wrong."""

    craft: str
    reader: str
    exit_code: int
    line: str
    peak_mb: float
    problems: list = field(default_factory=list)


def _messages_writer(path: Path, channels: list[tuple[str, str]], duplicate: str | None):
    """Write a finished mcap file: a schema, channel and two messages per (topic, type); `duplicate` redefines one."""
    from mcap.records import Channel
    from mcap.writer import CompressionType, Writer

    from iguana_ros.bag.schema import message_definition

    with open(path, 'wb') as f:
        writer = Writer(f, compression=CompressionType.ZSTD, enable_data_crcs=True)
        writer.start(profile='ros2', library='iguana_ros crafted')
        ids = []
        for topic, type_name in channels:
            schema = writer.register_schema(type_name, 'ros2msg', message_definition(type_name).encode())
            ids.append((writer.register_channel(topic, 'cdr', schema), schema))
        for k, (channel, _) in enumerate(ids):
            for t in range(2):
                writer.add_message(channel, log_time=10 ** 9 * (1 + t) + k, data=_cdr(channels[k][1]),
                                   publish_time=10 ** 9 * (1 + t) + k)
        if duplicate is not None:
            writer.flush()                                   # the first definition's chunk is written
            first, second = ids[0], ids[1]
            topic = channels[1][0] if duplicate == 'conflicting' else channels[0][0]
            schema = second[1] if duplicate == 'conflicting' else first[1]
            again = Channel(id=first[0], topic=topic, message_encoding='cdr', metadata={}, schema_id=schema)
            writer._Writer__chunk_builder.add_channel(again)          # mcap has no public way: that is the point
            if duplicate == 'conflicting':
                writer._Writer__channels[first[0]] = again
            for t in range(2):
                data = _cdr(channels[1][1] if duplicate == 'conflicting' else channels[0][1])
                writer.add_message(first[0], log_time=3 * 10 ** 9 + t, data=data, publish_time=3 * 10 ** 9 + t)
        writer.finish()


def _cdr(type_name: str) -> bytes:
    """Return a default message of `type_name`, serialized."""
    from rclpy.serialization import serialize_message

    from iguana_ros.ros.endpoints import message_class
    return serialize_message(message_class(type_name)())


def _bomb_file(path: Path, compression: str, declared: int) -> None:
    """Write an MCAP file whose one chunk really decompresses to BOMB_BYTES of zeros and declares `declared` bytes."""
    from mcap.data_stream import RecordBuilder
    from mcap.records import Chunk, DataEnd, Footer, Header

    data = _compressed_zeros(compression, BOMB_BYTES)
    builder = RecordBuilder()
    Header(profile='ros2', library='iguana_ros crafted').write(builder)
    Chunk(compression=compression, data=data, message_start_time=0, message_end_time=0, uncompressed_crc=0,
          uncompressed_size=declared).write(builder)
    body = builder.end()
    crc = zlib.crc32(MAGIC + body)
    builder = RecordBuilder()
    DataEnd(data_section_crc=crc).write(builder)
    Footer(summary_start=0, summary_offset_start=0, summary_crc=0).write(builder)
    path.write_bytes(MAGIC + body + builder.end() + MAGIC)


def _compressed_zeros(compression: str, n: int) -> bytes:
    """Return `n` zero bytes compressed as one zstd (with its content size) or lz4 frame, in 16 MiB pieces."""
    piece = bytes(16 << 20)
    out = io.BytesIO()
    if compression == 'zstd':
        import zstandard
        with zstandard.ZstdCompressor(level=1).stream_writer(out, size=n, closefd=False) as writer:
            for _ in range(n // len(piece)):
                writer.write(piece)
        return out.getvalue()
    import lz4.frame
    compressor = lz4.frame.LZ4FrameCompressor()
    out.write(compressor.begin())
    for _ in range(n // len(piece)):
        out.write(compressor.compress(piece))
    out.write(compressor.flush())
    return out.getvalue()


CRAFTS = {
    'channel_redefined': lambda p: _messages_writer(p, [('/iguana_state', 'nav_msgs/msg/Odometry'),
                                                        ('/mesh_marker', 'visualization_msgs/msg/Marker')],
                                                    'conflicting'),
    'channel_repeated': lambda p: _messages_writer(p, [('/iguana_state', 'nav_msgs/msg/Odometry'),
                                                       ('/mesh_marker', 'visualization_msgs/msg/Marker')], 'same'),
    'zstd_bomb_declared': lambda p: _bomb_file(p, 'zstd', BOMB_BYTES),
    'zstd_bomb_understated': lambda p: _bomb_file(p, 'zstd', 1 << 20),
    'lz4_bomb_declared': lambda p: _bomb_file(p, 'lz4', BOMB_BYTES),
    'lz4_bomb_understated': lambda p: _bomb_file(p, 'lz4', 1 << 20),
    'lz4_bomb_overstated': lambda p: _bomb_file(p, 'lz4', BOMB_BYTES + (64 << 20)),
}
"""Crafted bags by name: the two duplicate-channel cases (only `channel_repeated`, an identical record again, is
sound) and decompression bombs whose declared size is the truth, understated, or overstated."""

READERS = {
    'info': ['bag', 'info'],
    'play': ['bag', 'play', '--allow-damaged', '--rate', '100'],
    'view': None,
}
"""How each crafted bag is read: `iguana bag info`, `iguana bag play --allow-damaged`, and the viewer's bag reader."""

_PEAK = """
import resource, subprocess, sys
done = subprocess.run(sys.argv[1:], capture_output=True, text=True, timeout=300)
print(done.returncode)
print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)
print(done.stdout + done.stderr)
"""


def read_crafted(path: Path, reader: str, env: dict | None = None) -> tuple[int, str, float, str]:
    """(exit status, last output line, peak memory MB, whole output) of `reader` on the crafted bag at `path`."""
    if reader == 'view':
        argv = [sys.executable, '-c', 'import sys\nfrom iguana_ros.errors import IguanaError\n'
                'from iguana_ros.view.bag_source import load_bag\ntry:\n    load_bag(sys.argv[1], allow_damaged=True)\n'
                'except IguanaError as exc:\n    sys.exit(f"iguana view: error: {exc}")', str(path)]
    else:
        argv = [sys.executable, '-m', 'iguana_ros.cli', *READERS[reader], str(path)]
    done = subprocess.run([sys.executable, '-c', _PEAK, *argv], capture_output=True, text=True, timeout=400, env=env)
    code, peak_kb, output = done.stdout.split('\n', 2)
    lines = [line for line in output.splitlines() if line.strip() and 'Warning' not in line]
    return int(code), (lines[-1] if lines else ''), int(peak_kb) / 1024.0, output


def craft_trial(name: str, reader: str, workdir: Path, env: dict | None = None) -> CraftResult:
    """Craft `name` (once per workdir) and read it with `reader`; judge the outcome."""
    path = workdir / f'{name}.mcap'
    if not path.exists():
        CRAFTS[name](path)
    code, line, peak, output = read_crafted(path, reader, env)
    result = CraftResult(name, reader, code, line, round(peak, 1))
    sound = name == 'channel_repeated'
    if peak > PEAK_LIMIT_MB:
        result.problems.append(f'peak memory {peak:.0f} MB above {PEAK_LIMIT_MB} MB')
    if 'Traceback' in output:
        result.problems.append('a traceback')
    if reader == 'info' and (code == 0) != sound:
        result.problems.append(f'bag info exit {code} on a {"sound" if sound else "damaged"} file: {line}')
    if reader == 'info' and not sound and 'damaged' not in output:
        result.problems.append(f'bag info does not call it damaged: {line}')
    return result


def crafted_suite(workdir: Path, env: dict | None = None, progress=None) -> dict:
    """Every craft through every reader; the figures ({trials, survived, peak_mb, rows})."""
    rows = []
    for name in CRAFTS:
        for reader in READERS:
            rows.append(craft_trial(name, reader, workdir, env))
            if progress is not None:
                progress(rows[-1])
    return {'suite': 'crafted bags', 'trials': len(rows), 'survived': sum(not r.problems for r in rows),
            'peak_mb': max(r.peak_mb for r in rows), 'rows': [r.__dict__ for r in rows]}


def trial_line(row: CraftResult) -> str:
    """One line per trial."""
    verdict = 'ok' if not row.problems else 'FAILED: ' + '; '.join(row.problems)
    return f'{row.craft:22s} {row.reader:5s} exit {row.exit_code} peak {row.peak_mb:6.1f} MB: {verdict} | {row.line}'
