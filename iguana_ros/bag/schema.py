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
ros2msg schema text of a message type with every dependency appended, as rosbag2 writes it.

The .msg files are looked up under `<prefix>/share/<package>/msg/` for each prefix of
AMENT_PREFIX_PATH, then `sys.prefix` (pip-installed ROS wheels). ROS-free.
"""
from __future__ import annotations

from functools import lru_cache
import os
from pathlib import Path
import re
import sys

from iguana_ros.errors import InputError

SEPARATOR = '=' * 80 + '\n'
PRIMITIVES = frozenset((
    'bool', 'byte', 'char', 'float32', 'float64', 'int8', 'uint8', 'int16', 'uint16', 'int32',
    'uint32', 'int64', 'uint64', 'string', 'wstring'))
_FIELD_TYPE = re.compile(r'^\s*([A-Za-z][A-Za-z0-9_/]*)')


def share_prefixes() -> list[Path]:
    """Install prefixes searched for .msg files: AMENT_PREFIX_PATH entries, then sys.prefix."""
    prefixes = [Path(p) for p in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep) if p]
    return prefixes + [Path(sys.prefix)]


def split_type(type_name: str) -> tuple[str, str]:
    """('pkg', 'Type') of 'pkg/msg/Type' or 'pkg/Type'; InputError for anything else."""
    parts = type_name.split('/')
    if len(parts) == 3 and parts[1] == 'msg':
        return parts[0], parts[2]
    if len(parts) == 2:
        return parts[0], parts[1]
    raise InputError(f'message type {type_name!r} is not of the form package/msg/Type')


@lru_cache(maxsize=256)
def msg_file_text(type_name: str) -> str:
    """Text of the .msg file of `type_name`; InputError naming the folders searched if absent."""
    package, name = split_type(type_name)
    searched = [prefix / 'share' / package / 'msg' / f'{name}.msg' for prefix in share_prefixes()]
    for path in searched:
        if path.is_file():
            return path.read_text()
    raise InputError(f'no definition of {package}/msg/{name}: none of {[str(p) for p in searched]} exists')


def field_types(text: str, package: str) -> list[str]:
    """Non-primitive field types 'pkg/Type' of a .msg text, in order of first use (constants skipped)."""
    found: list[str] = []
    for line in text.splitlines():
        code = line.split('#', 1)[0].strip()
        match = _FIELD_TYPE.match(code)
        if not match or _is_constant(code):
            continue
        base = re.sub(r'\[.*$|<=.*$', '', match.group(1))
        if base in PRIMITIVES:
            continue
        full = base if '/' in base else f'{package}/{base}'
        if full not in found:
            found.append(full)
    return found


def _is_constant(code: str) -> bool:
    """Return True for a constant line 'type NAME=value' (a primitive type with '=' after the name)."""
    parts = code.split(None, 1)
    return len(parts) == 2 and '=' in parts[1] and parts[1].split('=', 1)[0].strip().isidentifier()


def message_definition(type_name: str) -> str:
    r"""Return the ros2msg schema: the .msg text, then each dependency after a '====…\nMSG: pkg/Type\n' line."""
    package, name = split_type(type_name)
    text = msg_file_text(type_name)
    order, queue = [], field_types(text, package)
    while queue:
        dep = queue.pop(0)
        if dep in order:
            continue
        order.append(dep)
        queue.extend(field_types(msg_file_text(dep), split_type(dep)[0]))
    parts = [text.rstrip('\n') + '\n']
    parts += [f'{SEPARATOR}MSG: {dep}\n{msg_file_text(dep).rstrip(chr(10))}\n' for dep in order]
    return ''.join(parts)
