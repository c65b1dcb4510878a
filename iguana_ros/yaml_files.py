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
Reading a YAML file from a user without letting it cost more than it says: size, nesting, aliases, duplicate keys.

A scene file (or a sweep spec) is at most MAX_SCENE_BYTES; before anything is built from it, the parser's events are
checked: at most MAX_NESTING levels of collections, at most MAX_YAML_NODES nodes with every alias counted at the size
of what it names ('billion laughs'), no key given twice in a mapping, no integer too long for Python to convert.
Errors are one line naming the file and, where there is one, the field.
"""
from __future__ import annotations

import codecs
from dataclasses import dataclass, field
from pathlib import Path
import re
import typing

import yaml

from iguana_ros.errors import InputError

MAX_SCENE_BYTES = 64 * 1024
"""Largest scene file read, bytes (the shipped scenes are under 1 kB); checked before parsing."""
MAX_NESTING = 16
"""Deepest nesting of YAML collections in a scene file (the schema needs 3); checked before composing."""
MAX_YAML_NODES = 100_000
"""Most YAML nodes a scene file may expand to, an alias counted at the size of what it names ('billion laughs')."""


def field_error(error: type[InputError], source: str, path: str, message: str) -> typing.NoReturn:
    """Raise `error` naming file and field (a long field name shortened, so the message stays one line)."""
    if len(path) > 80:
        path = path[:77] + '...'
    raise error(f'{source}: field {path!r}: {message}')


def read_yaml_file(path: Path, what: str = 'scene', error: type[InputError] = InputError):
    """
    Return the parsed YAML of a `what` file (a scene, a sweep spec), its size and structure bounded first.

    At most MAX_SCENE_BYTES, its structure (nesting, alias expansion, duplicate keys) bounded before it is composed;
    `error` (one line naming the file, and the field where there is one) if it is unreadable or too large.
    """
    text = _read_text(path, what, error)
    try:
        _check_structure(text, str(path), error)
        return yaml.load(text, Loader=_LOADER)
    except error:
        raise
    except (yaml.YAMLError, ValueError, OverflowError, TypeError, RecursionError) as exc:
        reason = ' '.join(str(exc).split())
        reason = reason if len(reason) <= 240 else reason[:237] + '...'
        raise error(f'{path}: not a readable YAML {what}: {reason}') from None


_LOADER = getattr(yaml, 'CSafeLoader', yaml.SafeLoader)
"""The YAML loader of scene files (libyaml's when installed: the same safe types, faster)."""


def _read_text(path: Path, what: str, error: type[InputError]) -> str:
    """Return the text of a `what` file of at most MAX_SCENE_BYTES (UTF-8, or UTF-16 with a byte-order mark)."""
    try:
        with path.open('rb') as f:
            data = f.read(MAX_SCENE_BYTES + 1)
    except OSError as exc:
        raise error(f'{path}: cannot read the {what} file: {exc.strerror or exc}') from None
    if len(data) > MAX_SCENE_BYTES:
        raise error(f'{path}: a {what} file may have at most {MAX_SCENE_BYTES} bytes, this one has '
                    f'{max(len(data), path.stat().st_size)}')
    encoding = 'utf-16' if data.startswith((codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE)) else 'utf-8-sig'
    try:
        return data.decode(encoding)
    except UnicodeDecodeError as exc:
        raise error(f'{path}: not a readable YAML {what}: not {encoding.split("-sig")[0].upper()} text '
                    f'(byte 0x{data[exc.start]:02x} at offset {exc.start})') from None


_LONG_INTEGER = re.compile(r'[-+]?[0-9][0-9_]*(:[0-5]?[0-9])*')
"""A plain scalar YAML reads as a decimal (or sexagesimal) integer; Python refuses to convert one of more than 4300
digits, so one longer than 1000 characters is refused before it is constructed."""


@dataclass
class _Collection:
    """An open YAML mapping or sequence while its events are read (see `_check_structure`)."""

    mapping: bool
    anchor: str | None
    size: int = 1
    height: int = 1
    expect_key: bool = True
    index: int = 0
    key: str = ''
    keys: dict = field(default_factory=dict)

    def step(self) -> str:
        """Return the path step to the child being read: '.key' or '[index]'."""
        return f'.{self.key}' if self.mapping else f'[{self.index}]'


def _check_structure(text: str, source: str, error: type[InputError]) -> None:
    """
    Check the structure of the YAML `text` from the parser's events, before anything is composed.

    It allows at most MAX_NESTING levels of collections, at most MAX_YAML_NODES nodes with every alias counted at its
    full size, and no key given twice in a mapping.
    """
    open_: list[_Collection] = [_Collection(mapping=False, anchor=None)]   # the document as a sequence
    anchors: dict[str, tuple[int, int]] = {}            # anchor -> (size, height)

    def where() -> str:
        return ''.join(c.step() for c in open_[1:]).lstrip('.') or '<top level>'

    def begin(event) -> None:
        parent = open_[-1]
        if parent.mapping and parent.expect_key:
            key = str(event.value) if isinstance(event, yaml.ScalarEvent) else '?'
            line = event.start_mark.line + 1
            if key not in ('<<', '?') and key in parent.keys:   # a merge key may repeat; '?' = complex keys
                parent.key = key
                field_error(error, source, where(),
                            f'duplicate key (line {line}; first given on line {parent.keys[key]})')
            parent.keys[key] = line
            parent.key = key

    def finish(size: int, height: int) -> None:
        parent = open_[-1]
        parent.size += size
        parent.height = max(parent.height, height + 1)
        if parent.size > MAX_YAML_NODES:
            field_error(error, source, where(), f'the file expands to more than {MAX_YAML_NODES} YAML nodes '
                                                '(aliases counted at their full size)')
        if parent.mapping:
            parent.expect_key = not parent.expect_key
        else:
            parent.index += 1

    for event in yaml.parse(text, Loader=_LOADER):
        if isinstance(event, (yaml.ScalarEvent, yaml.AliasEvent)):
            begin(event)
            size, height = (1, 0) if isinstance(event, yaml.ScalarEvent) else anchors.get(event.anchor, (1, 0))
            if len(open_) - 1 + height > MAX_NESTING:
                field_error(error, source, where(),
                            f'nested deeper than {MAX_NESTING} levels (through alias *{event.anchor})')
            if isinstance(event, yaml.ScalarEvent):
                if event.anchor:
                    anchors[event.anchor] = (1, 0)
                if event.implicit[0] and len(event.value) > 1000 and _LONG_INTEGER.fullmatch(event.value):
                    field_error(error, source, where(),
                                f'expected a number, got an integer of {len(event.value)} digits')
            finish(size, height)
        elif isinstance(event, (yaml.MappingStartEvent, yaml.SequenceStartEvent)):
            begin(event)
            if len(open_) > MAX_NESTING:
                field_error(error, source, where(), f'nested deeper than {MAX_NESTING} levels')
            open_.append(_Collection(isinstance(event, yaml.MappingStartEvent), event.anchor))
        elif isinstance(event, (yaml.MappingEndEvent, yaml.SequenceEndEvent)):
            done = open_.pop()
            if done.anchor:
                anchors[done.anchor] = (done.size, done.height)
            finish(done.size, done.height)
