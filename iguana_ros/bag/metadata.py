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
A bag directory's `metadata.yaml` (rosbag2_bagfile_information), read without trusting it (ROS-free).

Whatever the file holds -- binary bytes, broken or deeply nested YAML, the wrong structure, counts that
contradict the MCAP -- the result is one phrase saying what is wrong, never an exception: the MCAP is read
on its own, and the phrase joins the bag's damage report.
"""
from __future__ import annotations

from pathlib import Path
import re

import yaml

METADATA_FILE = 'metadata.yaml'
MAX_METADATA_BYTES = 16 * 1024 * 1024
"""Larger than any bag's description (the sample run's is 8 KiB); a bigger file is not read."""
MAX_PROBLEMS = 3
"""Disagreements with the MCAP named one by one; the rest are counted."""
MAX_FLOW_DEPTH = 32
MAX_INDENT = 128
"""Bracket nesting and indentation beyond which a file is not parsed (a bag description nests 6 levels; the YAML
parser recurses per level, so a deeper file would exhaust the stack)."""
_BRACKETS = re.compile(r'[\[\]{}]')
_SAFE_LOADER = getattr(yaml, 'CSafeLoader', yaml.SafeLoader)
"""libyaml's parser when PyYAML has it (30x faster), else the pure-Python one."""


def load_metadata(directory: str | Path) -> tuple[dict | None, str]:
    """Return (the rosbag2_bagfile_information mapping, '') of DIR/metadata.yaml, or (None, what is wrong with it)."""
    path = Path(directory) / METADATA_FILE
    if not path.is_file():
        return None, f'no {METADATA_FILE} (written when the recorder finishes; `ros2 bag reindex` rebuilds it)'
    size = path.stat().st_size
    if size == 0:
        return None, f'{METADATA_FILE} is empty'
    if size > MAX_METADATA_BYTES:
        return None, f'{METADATA_FILE} is {size} bytes, more than a bag description ({MAX_METADATA_BYTES})'
    raw = path.read_bytes()
    try:
        text = raw.decode('utf-8')
    except UnicodeDecodeError as exc:
        return None, f'{METADATA_FILE} is not UTF-8 text (byte 0x{raw[exc.start]:02x} at offset {exc.start})'
    if '\x00' in text:
        return None, f'{METADATA_FILE} is not UTF-8 text (NUL byte at offset {text.index(chr(0))})'
    if _too_deep(text):
        return None, f'{METADATA_FILE} is nested too deeply to be a bag description'
    try:
        data = yaml.load(text, Loader=_SAFE_LOADER)  # noqa: S506 -- a safe loader
    except yaml.YAMLError as exc:
        return None, f'{METADATA_FILE} is not valid YAML ({_yaml_reason(exc)})'
    except RecursionError:
        return None, f'{METADATA_FILE} is nested too deeply to be a bag description'
    info = data.get('rosbag2_bagfile_information') if isinstance(data, dict) else None
    if not isinstance(info, dict):
        return None, f'{METADATA_FILE} has no rosbag2_bagfile_information mapping'
    return info, ''


def _too_deep(text: str) -> bool:
    """
    Return whether brackets nest deeper than MAX_FLOW_DEPTH or a line is indented more than MAX_INDENT.

    Quoted text counts too: a bag description has no such strings.
    """
    depth = 0
    for bracket in _BRACKETS.findall(text):
        depth += 1 if bracket in '[{' else -1
        if depth > MAX_FLOW_DEPTH:
            return True
    return any(len(line) - len(line.lstrip(' ')) > MAX_INDENT for line in text.splitlines())


def _yaml_reason(exc: yaml.YAMLError) -> str:
    """One line of a PyYAML error: the problem and its line."""
    problem = getattr(exc, 'problem', None) or str(exc).splitlines()[0]
    mark = getattr(exc, 'problem_mark', None)
    return f'{problem} at line {mark.line + 1}' if mark is not None else problem


def relative_files(info: dict | None) -> list[str]:
    """Return the plain file names listed in relative_file_paths ([] when absent or malformed)."""
    files = info.get('relative_file_paths') if isinstance(info, dict) else None
    if not isinstance(files, list):
        return []
    return [f for f in files if isinstance(f, str) and f and '/' not in f and f not in ('.', '..')]


def _count(value) -> int | None:
    """Return an integer count (not bool), else None."""
    return value if isinstance(value, int) and not isinstance(value, bool) else None


def check_metadata(info: dict, mcap_name: str, topic_counts: dict[str, int] | None,
                   message_count: int | None) -> list[str]:
    """
    Return what in a loaded metadata mapping is malformed or contradicts the MCAP file `mcap_name`.

    The MCAP's full per-topic and total message counts are given when known (None for a damaged MCAP without a trusted
    summary: then the counts are not compared).
    """
    problems = []
    if info.get('storage_identifier') != 'mcap':
        problems.append(f'storage_identifier is {info.get("storage_identifier")!r}, expected \'mcap\'')
    if mcap_name not in relative_files(info):
        problems.append(f'relative_file_paths does not list {mcap_name}')
    total = _count(info.get('message_count'))
    if total is None:
        problems.append('message_count is missing or not an integer')
    elif message_count is not None and total != message_count:
        problems.append(f'message_count {total} disagrees with the MCAP ({message_count})')
    topics = info.get('topics_with_message_count')
    listed: dict[str, int | None] = {}
    if not isinstance(topics, list):
        problems.append('topics_with_message_count is missing or not a list')
    else:
        for entry in topics:
            meta = entry.get('topic_metadata') if isinstance(entry, dict) else None
            name = meta.get('name') if isinstance(meta, dict) else None
            if not isinstance(name, str):
                problems.append('a topics_with_message_count entry has no topic name')
                break
            listed[name] = _count(entry.get('message_count'))
    if topic_counts is not None and isinstance(topics, list):
        for name in sorted(set(listed) | set(topic_counts)):
            if listed.get(name, 0) != topic_counts.get(name, 0):
                problems.append(f'topic {name}: message_count {listed.get(name)} disagrees with the MCAP '
                                f'({topic_counts.get(name, 0)})')
    if len(problems) > MAX_PROBLEMS:
        problems = problems[:MAX_PROBLEMS] + [f'{len(problems) - MAX_PROBLEMS} more disagreements']
    return [f'{METADATA_FILE}: {p}' for p in problems]
