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
Fault injection on a recorded bag (ROS-free).

Seeded random truncations and byte corruptions of its MCAP file and damaged metadata.yaml variants, each checked against
an independent reader of the undamaged bag.

The reference is mcap's own reader on the undamaged file: its summary's chunk index gives each chunk's byte
range, and `mcap.stream_reader.breakup_chunk` (CRC-checked) its messages; mcap-ros2-support's decoder
decodes one message of every channel. In a damaged copy a chunk is intact when its bytes are unchanged (after
a truncation: when it ends before the cut). A trial survives when

- `iguana bag info`, `iguana bag play` and `iguana render` each end within the time limit with no traceback,
  exit 1 with exactly one error line (a damaged bag is never reported sound), and `bag info --allow-damaged`
  exits 0 unless the file is not readable as MCAP at all;
- `BagReader` recovers every message of every intact chunk, and nothing that is not in the original.

The commands run in this process (the caller passes the `iguana` entry point, `iguana_ros.cli.main`, which sits
on the floor above), so a trial costs a few scans of the file.
"""
from __future__ import annotations

from collections import Counter
from collections.abc import Callable, Iterator
from contextlib import contextmanager, redirect_stderr, redirect_stdout
from dataclasses import dataclass, field
import hashlib
import io
import os
from pathlib import Path
import random
import shutil
import signal
import struct
import tempfile
import time
import traceback

from iguana_ros.bag.metadata import METADATA_FILE
from iguana_ros.bag.storage import BagReader, resolve_bag_file, summarize
from iguana_ros.errors import IguanaError

CORRUPTION_BYTES = 64
"""Length of a random overwrite (the other corruption kind flips one byte)."""
STRUCTURAL_SHARE = 4
"""Every STRUCTURAL_SHARE-th corruption is aimed at a region outside the chunks (header, message indexes,
summary, footer), which a uniform choice of offset rarely hits."""
TRIAL_TIMEOUT_S = 60.0
"""A trial taking longer than this counts as a hang."""


class TrialTimeout(BaseException):
    """A trial ran past its time limit (BaseException: no `except Exception` in the code under test stops it)."""


@contextmanager
def time_limit(seconds: float) -> Iterator[None]:
    """Raise TrialTimeout in the main thread if the block runs longer than `seconds`."""
    def expire(_signum, _frame):
        raise TrialTimeout(f'no result after {seconds:g} s')
    previous = signal.signal(signal.SIGALRM, expire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def message_key(topic: str, log_time: int, data: bytes) -> tuple[str, int, bytes]:
    """Identity of a message for comparing readers: topic, receive time and a digest of its bytes."""
    return topic, log_time, hashlib.blake2b(data, digest_size=16).digest()


@dataclass
class Reference:
    """The undamaged bag as mcap's own reader sees it: chunk byte ranges with their messages, file regions."""

    mcap_name: str
    size: int
    chunks: list[tuple[int, int, list]]
    """(start offset, end offset, message keys) of every chunk, in file order."""
    regions: dict[str, list[tuple[int, int]]]
    """Byte ranges outside the chunks: 'header', 'message indexes', 'summary', 'footer'."""
    all_messages: Counter = field(default_factory=Counter)
    decoded_channels: int = 0
    data_crc: str = ''
    """The undamaged file's data-section CRC as this project's scan found it: 'verified', or 'absent' (a bag
    written before BagWriter added it: damage to its header record cannot be detected)."""

    def intact(self, changed: Callable[[int, int], bool]) -> Counter:
        """Messages of the chunks for which `changed(start, end)` is False."""
        out: Counter = Counter()
        for start, end, keys in self.chunks:
            if not changed(start, end):
                out.update(keys)
        return out


def reference(bag: str | Path) -> Reference:
    """
    Return reference of the undamaged bag, read with mcap's reader and decoded with mcap-ros2-support.

    IguanaError if the bag is not a finished, sound MCAP file (the faults must be the only damage).
    """
    from mcap.data_stream import ReadDataStream
    from mcap.exceptions import McapError
    from mcap.reader import make_reader
    from mcap.records import Chunk, Message
    from mcap.stream_reader import breakup_chunk
    from mcap_ros2.decoder import DecoderFactory

    path = resolve_bag_file(bag)
    size = path.stat().st_size
    with open(path, 'rb') as f:
        try:
            reader = make_reader(f, validate_crcs=True)
            summary = reader.get_summary()
        except (McapError, ValueError, EOFError) as exc:
            raise IguanaError(f'{path}: mcap cannot read the undamaged bag ({exc})') from exc
        if summary is None or not summary.chunk_indexes:
            raise IguanaError(f'{path}: the bag has no summary with a chunk index; record a finished bag')
        chunks, decoders, decoded = [], {}, set()
        factory = DecoderFactory()
        for index in sorted(summary.chunk_indexes, key=lambda c: c.chunk_start_offset):
            f.seek(index.chunk_start_offset)
            opcode, _length = struct.unpack('<BQ', f.read(9))
            records = breakup_chunk(Chunk.read(ReadDataStream(f)), validate_crc=True)
            keys = []
            for record in records:
                if not isinstance(record, Message):
                    continue
                channel = summary.channels[record.channel_id]
                keys.append(message_key(channel.topic, record.log_time, record.data))
                if record.channel_id not in decoded:
                    schema = summary.schemas[channel.schema_id]
                    decoder = decoders.setdefault(channel.schema_id, factory.decoder_for('cdr', schema))
                    decoder(record.data)
                    decoded.add(record.channel_id)
            chunks.append((index.chunk_start_offset, index.chunk_start_offset + index.chunk_length, keys))
        f.seek(-8 - 20, os.SEEK_END)
        summary_start = struct.unpack('<Q', f.read(8))[0]
    regions = {'header': [(0, chunks[0][0])],
               'message indexes': [(a[1], b[0]) for a, b in zip(chunks, chunks[1:]) if b[0] > a[1]]
               + [(chunks[-1][1], summary_start)],
               'summary': [(summary_start, size - 37)],
               'footer': [(size - 37, size)]}
    ref = Reference(path.name, size, chunks, {k: [r for r in v if r[1] > r[0]] for k, v in regions.items()})
    for _, _, keys in chunks:
        ref.all_messages.update(keys)
    ref.decoded_channels = len(decoded)
    ref.data_crc = summarize(path).health.data_crc
    return ref


@dataclass(frozen=True)
class Fault:
    """
    One fault.

    Cut the MCAP at `offset` ('truncate'), write `data` at `offset` ('bytes'), XOR the byte at `offset` with the mask
    `data` ('flip'), or replace metadata.yaml by `data` ('metadata'; `data` None: delete it). `label` names the variant
    or the region aimed at.
    """

    kind: str
    offset: int = 0
    data: bytes | None = b''
    label: str = ''

    def apply(self, mcap: Path) -> None:
        """Damage the copied bag whose MCAP file is `mcap`."""
        if self.kind == 'truncate':
            os.truncate(mcap, self.offset)
        elif self.kind in ('bytes', 'flip'):
            with open(mcap, 'r+b') as f:
                f.seek(self.offset)
                data = self.data
                if self.kind == 'flip':              # XOR with a non-zero mask: the byte always changes
                    data = bytes([f.read(1)[0] ^ self.data[0]])
                    f.seek(self.offset)
                f.write(data)
        elif self.data is None:
            (mcap.parent / METADATA_FILE).unlink(missing_ok=True)
        else:
            (mcap.parent / METADATA_FILE).write_bytes(self.data)

    def changed(self, start: int, end: int) -> bool:
        """Whether bytes [start, end) of the MCAP differ from the original after this fault."""
        if self.kind == 'truncate':
            return end > self.offset
        if self.kind in ('bytes', 'flip'):
            return self.offset < end and start < self.offset + len(self.data)
        return False

    def describe(self) -> str:
        """'flip at byte 1234 (summary)' and the like."""
        if self.kind == 'metadata':
            return f'metadata.yaml: {self.label}'
        where = f' ({self.label})' if self.label else ''
        return {'truncate': f'truncate at byte {self.offset}',
                'bytes': f'{len(self.data or b"")} random bytes at byte {self.offset}{where}',
                'flip': f'byte flipped at {self.offset}{where}'}[self.kind]


def corruption_faults(ref: Reference, truncations: int, corruptions: int, seed: int) -> list[Fault]:
    """
    Return seeded random faults of the MCAP.

    There are `truncations` cuts anywhere in the file and `corruptions` alternating 64-byte overwrites and flipped bytes
    (every STRUCTURAL_SHARE-th aimed at a region outside the chunks).
    """
    rng = random.Random(seed)
    faults = [Fault('truncate', rng.randrange(ref.size)) for _ in range(truncations)]
    regions = [(name, r) for name, ranges in ref.regions.items() for r in ranges]
    for k in range(corruptions):
        label = ''
        if k % STRUCTURAL_SHARE == STRUCTURAL_SHARE - 1 and regions:
            names = sorted({name for name, _ in regions})
            label = rng.choice(names)
            start, end = rng.choice([r for name, r in regions if name == label])
            offset = rng.randrange(start, end)
        else:
            offset = rng.randrange(ref.size)
        if k % 2 == 0:
            n = min(CORRUPTION_BYTES, ref.size - offset)
            data = bytes(rng.randrange(256) for _ in range(n))
            faults.append(Fault('bytes', offset, data, label))
        else:
            faults.append(Fault('flip', offset, bytes([rng.randrange(1, 256)]), label))
    return faults


def metadata_faults(text: str, seed: int) -> list[Fault]:
    """
    Damaged variants of a bag's metadata.yaml `text`.

    Binary, empty, cut, invalid or deeply nested YAML, wrong structure, wrong counts or file name, another encoding, a
    NUL byte, an alias bomb, too large, absent.
    """
    rng = random.Random(seed)
    raw = text.encode()
    count_line = next((line for line in text.splitlines() if line.startswith('  message_count:')), None)
    bomb = 'a: &a ["x","x","x","x","x","x","x","x","x"]\n' + ''.join(
        f'{c}: &{c} [{",".join(["*" + p] * 9)}]\n' for p, c in zip('abcdefgh', 'bcdefghi'))
    variants = [
        ('binary', bytes(rng.randrange(256) for _ in range(4096))),
        ('empty', b''),
        ('cut in half', raw[:len(raw) // 2]),
        ('invalid YAML', b'rosbag2_bagfile_information: {version: [9\n'),
        ('deeply nested', b'x: ' + b'[' * 50_000 + b']' * 50_000 + b'\n'),
        ('a list', b'- rosbag2_bagfile_information\n'),
        ('UTF-16', text.encode('utf-16')),
        ('NUL byte', raw[:100] + b'\x00' + raw[101:]),
        ('alias bomb', bomb.encode()),
        ('too large', b'#' * (16 * 1024 * 1024 + 1)),
        ('absent', None),
        ('wrong file name', raw.replace(b'.mcap', b'_other.mcap')),
    ]
    if count_line is not None:
        n = int(count_line.split(':')[1])
        variants.append(('wrong message_count', text.replace(count_line, f'  message_count: {n + 1}').encode()))
    return [Fault('metadata', 0, data, label) for label, data in variants]


@dataclass
class _Run:
    """One command run in-process: exit status (None if it raised), output, and the traceback if any."""

    rc: int | None
    out: str
    err: str
    crash: str = ''


Iguana = Callable[[list[str]], 'int | None']
"""The `iguana` command's entry point (`iguana_ros.cli.main`): argv -> exit status."""


def _cli(main: Iguana, argv: list[str]) -> _Run:
    """Run `iguana ARGV` in this process, capturing its output; an escaping exception is a crash."""
    out, err = io.StringIO(), io.StringIO()
    try:
        with redirect_stdout(out), redirect_stderr(err):
            rc = main(argv)
    except TrialTimeout:
        raise
    except BaseException:                  # noqa: BLE001 -- any escaping exception is what the suite looks for
        return _Run(None, out.getvalue(), err.getvalue(), traceback.format_exc(limit=-3))
    return _Run(rc, out.getvalue(), err.getvalue())


def _refusal_problems(name: str, run: _Run) -> list[str]:
    """Why a command's run on a damaged bag is not 'exit 1 with one error line', if it is not."""
    if run.crash:
        return [f'{name}: traceback {run.crash.strip().splitlines()[-1]}']
    lines = run.err.strip().splitlines()
    problems = []
    if run.rc == 0:
        problems.append(f'{name}: exit 0 on a damaged bag')
    elif run.rc != 1:
        problems.append(f'{name}: exit {run.rc}')
    if run.rc != 0 and len(lines) != 1:
        problems.append(f'{name}: {len(lines)} error lines')
    if 'Traceback' in run.err:
        problems.append(f'{name}: traceback text on stderr')
    return problems


def run_trial(bag: Path, fault: Fault, ref: Reference, workdir: Path, timeout_s: float = TRIAL_TIMEOUT_S, *,
              iguana: Iguana) -> dict:
    """Copy the bag into `workdir`, apply `fault`, run the commands (through `iguana`) and the reader; one row."""
    trial = workdir / bag.name
    shutil.rmtree(trial, ignore_errors=True)
    trial.mkdir(parents=True)
    shutil.copyfile(bag / ref.mcap_name, trial / ref.mcap_name)
    if (bag / METADATA_FILE).is_file():
        shutil.copyfile(bag / METADATA_FILE, trial / METADATA_FILE)
    mcap = trial / ref.mcap_name
    fault.apply(mcap)
    intact = ref.intact(fault.changed)
    row = {'fault': fault.describe(), 'kind': fault.kind, 'problems': [], 'intact': sum(intact.values()),
           'recovered_intact': 0, 'salvaged': 0, 'wrong': 0, 'exit_0': False, 'crash': False, 'hang': False}
    started = time.perf_counter()
    try:
        with time_limit(timeout_s):
            runs = {'bag info': _cli(iguana, ['bag', 'info', str(trial)]),
                    'bag play': _cli(iguana, ['bag', 'play', str(trial), '--rate', '1000',
                                              '--wait-for-subscribers', '0']),
                    'render': _cli(iguana, ['render', str(trial), '-o', str(workdir / 'frame.png'), '-q'])}
            allowed = _cli(iguana, ['bag', 'info', str(trial), '--allow-damaged'])
            recovered: Counter = Counter()
            try:
                reader = BagReader(trial)
                recovered.update(message_key(m.topic, m.log_time, m.data) for m in reader.messages())
            except IguanaError:
                pass
    except TrialTimeout as exc:
        row.update(hang=True, problems=[f'hang: {exc}'], wall_s=time.perf_counter() - started)
        return row
    finally:
        (workdir / 'frame.png').unlink(missing_ok=True)
    for name, run in runs.items():
        row['problems'] += _refusal_problems(name, run)
    row['exit_0'] = any(run.rc == 0 for run in runs.values())
    if allowed.crash:
        row['problems'].append(f'bag info --allow-damaged: traceback {allowed.crash.strip().splitlines()[-1]}')
    elif allowed.rc != 0 and '--allow-damaged' in allowed.err:
        row['problems'].append('bag info --allow-damaged still refuses')
    row['crash'] = any(run.crash for run in (*runs.values(), allowed))
    missing = intact - recovered
    wrong = recovered - ref.all_messages
    row['recovered_intact'] = sum((intact & recovered).values())
    row['salvaged'] = sum((recovered - intact).values()) - sum(wrong.values())
    row['wrong'] = sum(wrong.values())
    if missing:
        row['problems'].append(f'{sum(missing.values())} messages of intact chunks not recovered')
    if wrong:
        row['problems'].append(f'{sum(wrong.values())} recovered messages not in the original')
    row['first_line'] = (runs['bag info'].out.splitlines() or runs['bag info'].err.splitlines() or [''])[0]
    row['wall_s'] = time.perf_counter() - started
    return row


def run_suite(bag: str | Path, truncations: int = 100, corruptions: int = 100, seed: int = 0,
              timeout_s: float = TRIAL_TIMEOUT_S, metadata: bool = True,
              progress: Callable[[dict, int, int], None] | None = None, *, iguana: Iguana) -> dict:
    """
    Every fault on the bag directory `bag`, one after the other, its commands run through `iguana` (the CLI's main).

    The figures and the failed trials.
    """
    bag = Path(bag)
    if not bag.is_dir():
        raise IguanaError(f'{bag}: the fault suite needs a bag directory (its .mcap and metadata.yaml)')
    ref = reference(bag)
    faults = corruption_faults(ref, truncations, corruptions, seed)
    meta = bag / METADATA_FILE
    if metadata and meta.is_file():
        faults += metadata_faults(meta.read_text(errors='replace'), seed)
    started = time.perf_counter()
    rows = []
    with tempfile.TemporaryDirectory(prefix='iguana_faults_') as tmp:
        for k, fault in enumerate(faults):
            rows.append(run_trial(bag, fault, ref, Path(tmp), timeout_s, iguana=iguana))
            if progress is not None:
                progress(rows[-1], k + 1, len(faults))
    return summarize_trials(bag, ref, rows, seed, time.perf_counter() - started)


def summarize_trials(bag: Path, ref: Reference, rows: list[dict], seed: int, wall_s: float) -> dict:
    """
    Figures of a suite run.

    Trials and survivors per kind, exits 0 on damage, tracebacks, hangs, messages of intact chunks recovered and lost,
    wrong messages, and the failed trials.
    """
    kinds = Counter(r['kind'] for r in rows)
    survived = Counter(r['kind'] for r in rows if not r['problems'])
    return {
        'bag': str(bag), 'bytes': ref.size, 'chunks': len(ref.chunks), 'messages': sum(ref.all_messages.values()),
        'decoded_channels': ref.decoded_channels, 'data_crc': ref.data_crc, 'seed': seed,
        'trials': dict(kinds), 'survived': dict(survived),
        'trials_total': len(rows), 'survived_total': sum(survived.values()),
        'exit_0_on_damage': sum(r['exit_0'] for r in rows),
        'tracebacks': sum(r['crash'] for r in rows), 'hangs': sum(r['hang'] for r in rows),
        'intact_messages': sum(r['intact'] for r in rows),
        'recovered_intact_messages': sum(r['recovered_intact'] for r in rows),
        'lost_intact_messages': sum(r['intact'] - r['recovered_intact'] for r in rows if not r['hang']),
        'salvaged_messages': sum(r['salvaged'] for r in rows), 'wrong_messages': sum(r['wrong'] for r in rows),
        'wall_s': wall_s, 'max_trial_s': max((r['wall_s'] for r in rows), default=0.0),
        'failures': [{'fault': r['fault'], 'problems': r['problems']} for r in rows if r['problems']],
    }
