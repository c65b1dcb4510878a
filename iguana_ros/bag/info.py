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
`iguana bag info`: duration, topics, types and counts of a bag, laid out like `ros2 bag info` (ROS-free).

One line more than rosbag2's: `Time base`, simulated (log times from /clock) or wall (receive times).
"""
from __future__ import annotations

from datetime import datetime
from pathlib import Path

from iguana_ros.bag.sim_time import time_base_description, TIME_BASE_SIMULATED
from iguana_ros.bag.storage import BagSummary, summarize


def _size(n_bytes: int) -> str:
    """Human-readable size, e.g. '1.2 MiB'."""
    size = float(n_bytes)
    for unit in ('B', 'KiB', 'MiB', 'GiB'):
        if size < 1024 or unit == 'GiB':
            return f'{size:.0f} {unit}' if unit == 'B' else f'{size:.1f} {unit}'
        size /= 1024
    return f'{n_bytes} B'


def _time(ns: int) -> str:
    """Local date and time with ms, plus epoch seconds, as ros2 bag info prints them."""
    stamp = datetime.fromtimestamp(ns / 1e9)
    epoch = f'{ns // 1_000_000_000}.{ns % 1_000_000_000:09d}'
    return f'{stamp:%b %d %Y %H:%M:%S}.{stamp.microsecond // 1000:03d} ({epoch})'


def _sim_time(ns: int) -> str:
    """Seconds of simulated time, e.g. '2.000000000 s (simulated)'."""
    return f'{ns // 1_000_000_000}.{ns % 1_000_000_000:09d} s (simulated)'


def format_summary(summary: BagSummary) -> str:
    """Multi-line text of a BagSummary."""
    duration = max(summary.end_ns - summary.start_ns, 0) * 1e-9
    stamp = _sim_time if summary.time_base == TIME_BASE_SIMULATED else _time
    lines = [f'Files:             {summary.path.name}',
             f'Bag size:          {_size(summary.size)}',
             'Storage id:        mcap',
             f'Library:           {summary.library}',
             f'Duration:          {duration:.9f}s',
             f'Time base:         {time_base_description(summary.time_base, summary.clock_topic)}']
    if summary.message_count:
        lines += [f'Start:             {stamp(summary.start_ns)}',
                  f'End:               {stamp(summary.end_ns)}']
    lines.append(f'Messages:          {summary.message_count}')
    rows = [f'Topic: {t.name} | Type: {t.type} | Count: {t.message_count} | '
            f'Serialization Format: cdr' for t in summary.topics] or ['(none)']
    lines.append(f'Topic information: {rows[0]}')
    lines += [' ' * 19 + row for row in rows[1:]]
    return '\n'.join(lines)


def bag_info(path: str | Path) -> tuple[str, BagSummary]:
    """
    (printable text, summary) of the bag at `path` (directory or .mcap), every chunk checked.

    A damaged or truncated bag's text starts with its report line (`BagSummary.report_line`). InputError if unreadable.
    """
    summary = summarize(path)
    text = format_summary(summary)
    if not summary.sound:
        text = summary.report_line() + '\n' + text
    return text, summary
