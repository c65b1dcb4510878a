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
Scene fault injection: seeded random mutations of the shipped scenes and the checks every one must pass.

Each mutation is the bytes of a scene file damaged one way (wrong types, out-of-range and non-finite numbers,
unknown fields, deep nesting, huge lists and sizes, wrong encodings and binary bytes, duplicate keys, YAML alias
bombs, empty files, truncations, flipped bytes, YAML tags). A trial loads it with `load_scene`: it must either be a
valid Scene within the schema's limits or fail with one SceneError line naming the file (and the field, for a
field's fault), quickly and in bounded memory. A sample is also run through the real `iguana simulate FILE
--duration 0.1` in a subprocess under an address-space limit: an invalid scene exits 1 with one error line, no run
leaves a traceback, and the peak RSS is measured.
"""
from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass, field
import datetime
import json
import math
import os
from pathlib import Path
import random
import re
import signal
import subprocess
import sys
import time
import tracemalloc

import yaml

from iguana_ros.config import config_path
from iguana_ros.scene import (accepts_infinity, load_scene, MAX_DURATION, MAX_EXTENT, MAX_GOALS, MAX_NESTING,
                              MAX_PUSHES, MAX_SCENE_BYTES, MAX_TEXT, MAX_YAML_NODES, Scene, SceneError)

LOAD_SECONDS_LIMIT = 2.0
"""Longest a single `load_scene` of a mutated file may take, s."""
LOAD_PEAK_LIMIT = 64 << 20
"""Largest Python heap peak (tracemalloc) of a single `load_scene` of a mutated file, bytes."""
CLI_MEMORY_LIMIT = 2 << 30
"""Address-space limit (RLIMIT_AS) of each `iguana simulate` subprocess, bytes (a valid short run needs ~1 GB)."""
CLI_RSS_LIMIT = 1 << 30
"""Largest peak RSS an `iguana simulate --duration 0.1` subprocess of a mutated scene may reach, bytes."""
CLI_TIMEOUT = 120.0
"""Wall-clock limit of each `iguana simulate` subprocess, s."""
CLI_DURATION = 0.1
"""Simulated seconds of each `iguana simulate` subprocess."""
FILE_LEVEL = ('not a readable YAML scene', 'empty scene', 'a scene file may have at most', 'cannot read')
"""Phrases of the SceneErrors about a whole file (its bytes, encoding, YAML syntax), which name no field."""

_FIELD = re.compile(r"field '([^']*)'")


@dataclass(frozen=True)
class Mutation:
    """
    One damaged scene file.

    Its bytes, the kind of damage, the shipped scene it came from, the field it damaged ('' = the file as a whole),
    whether it must be rejected, and a note of what was done.
    """

    kind: str
    base: str
    data: bytes
    target: str = ''
    must_reject: bool = False
    note: str = ''
    files: tuple = ()
    """Files written beside the scene: (name, bytes, or an int = a sparse file of that size); `@DIR@` in `data`
    is the folder they are written to."""


@dataclass
class Trial:
    """What loading one mutation gave: 'valid' (a Scene), 'rejected' (a SceneError) or 'crashed' (anything else)."""

    index: int
    kind: str
    base: str
    target: str
    note: str
    must_reject: bool
    outcome: str = ''
    message: str = ''
    named_field: str = ''
    load_s: float = 0.0
    peak_bytes: int = 0
    problems: list = field(default_factory=list)
    file: str = ''


# ------------------------------------------------------------------------------------------------ mutations
def shipped_scenes() -> dict[str, str]:
    """{name: YAML text} of the scenes shipped under msg_configs/scenes/."""
    return {p.stem: p.read_text(encoding='utf-8') for p in sorted(config_path('scenes').glob('*.yaml'))}


def _leaves(node, prefix: str = '') -> list[tuple[str, tuple]]:
    """(field path, key path) of every scalar or list-of-scalars leaf of a parsed scene."""
    out = []
    items = node.items() if isinstance(node, dict) else enumerate(node)
    for key, value in items:
        path = f'{prefix}[{key}]' if isinstance(node, list) else (f'{prefix}.{key}' if prefix else str(key))
        if isinstance(value, dict) or (isinstance(value, list) and value and isinstance(value[0], dict)):
            out += [(p, (key, *keys)) for p, keys in _leaves(value, path)]
        else:
            out.append((path, (key,)))
    return out


def _mappings(node, prefix: str = '') -> list[tuple[str, tuple]]:
    """(field path, key path) of every mapping of a parsed scene, the top level first."""
    out = [(prefix, ())] if isinstance(node, dict) else []
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    for key, value in items:
        path = f'{prefix}[{key}]' if isinstance(node, list) else (f'{prefix}.{key}' if prefix else str(key))
        out += [(p, (key, *keys)) for p, keys in _mappings(value, path)]
    return out


def _get(node, keys: tuple):
    """Return the value at `keys` in nested dicts/lists."""
    for key in keys:
        node = node[key]
    return node


def _set(node, keys: tuple, value) -> None:
    """Set the value at `keys` in nested dicts/lists."""
    _get(node, keys[:-1])[keys[-1]] = value


def _dump(raw) -> bytes:
    """Return a parsed scene as YAML bytes (block style, lists of scalars in flow style)."""
    return yaml.safe_dump(raw, sort_keys=False, default_flow_style=None, width=1 << 20).encode('utf-8')


def _without(raw: dict, key: str) -> str:
    """Return a parsed scene without top-level field `key`, as YAML text ending in a newline."""
    return _dump({k: v for k, v in raw.items() if k != key}).decode('utf-8')


def _copy(raw):
    """Return a deep copy of a parsed scene (plain dicts, lists, scalars)."""
    if isinstance(raw, dict):
        return {k: _copy(v) for k, v in raw.items()}
    if isinstance(raw, list):
        return [_copy(v) for v in raw]
    return raw


def _wrong_type(rng: random.Random, name: str, text: str, raw: dict) -> Mutation:
    """Return a leaf replaced by a value of another type (a string for a number, a list for a string, ...)."""
    path, keys = rng.choice(_leaves(raw))
    old = _get(raw, keys)
    if isinstance(old, bool):
        choices = ['yes please', 1, [True], {'on': True}, None, 'true']
    elif isinstance(old, (int, float)):
        choices = ['fast', [old, old], {'value': old}, True, None, datetime.date(2001, 1, 1), '1.5']
    elif isinstance(old, str):
        choices = [3.5, [old, [old]], {'name': old}, False, 12] + ([None] if path != 'record.topics' else [])
    else:  # a list of scalars (force, topics)
        choices = ['not a list', 7, {'x': 1}, [[1, 2], [3]], [None, None, None]]
    new = _copy(raw)
    _set(new, keys, rng.choice(choices))
    return Mutation('wrong_type', name, _dump(new), path, True, f'{path}: {old!r} -> {_get(new, keys)!r}')


def _numeric_leaves(raw: dict) -> list[tuple[str, tuple]]:
    """Return the numeric leaves (numbers and the items of number lists) of a parsed scene."""
    out = []
    for path, keys in _leaves(raw):
        value = _get(raw, keys)
        if isinstance(value, list):
            out += [(f'{path}[{i}]', (*keys, i)) for i, v in enumerate(value) if isinstance(v, (int, float))]
        elif isinstance(value, (int, float)) and not isinstance(value, bool):
            out.append((path, keys))
    return out


def _out_of_range(rng: random.Random, name: str, text: str, raw: dict) -> Mutation:
    """Return a number replaced by an extreme one: negative, zero, tiny, huge, beyond float range as an integer."""
    path, keys = rng.choice(_numeric_leaves(raw))
    value = rng.choice([-1.0, 0.0, -1e-9, 1e-300, 5e-324, 1e-306, 1e12, -1e12, 1e308, -1e308, 10 ** 30, 10 ** 400,
                        -(10 ** 400), 2 ** 64, MAX_DURATION * 10, MAX_EXTENT * 1.5, 123456789.0])
    new = _copy(raw)
    _set(new, keys, value)
    return Mutation('out_of_range', name, _dump(new), path, False, f'{path} = {str(value)[:12]}')


def _non_finite(rng: random.Random, name: str, text: str, raw: dict) -> Mutation:
    """Return a number replaced by NaN or an infinity."""
    path, keys = rng.choice(_numeric_leaves(raw))
    value = rng.choice([math.nan, math.inf, -math.inf])
    new = _copy(raw)
    _set(new, keys, value)
    allowed = value == math.inf and accepts_infinity(path)       # a yaw tolerance of .inf ignores headings
    return Mutation('non_finite', name, _dump(new), path, not allowed, f'{path} = {value}')


def _unknown_field(rng: random.Random, name: str, text: str, raw: dict) -> Mutation:
    """Return a field that the schema does not know, at the top level or in a nested mapping (often a typo)."""
    path, keys = rng.choice(_mappings(raw))
    mapping = _get(raw, keys)
    known = set(mapping)
    key = ''
    while not key or key in known:
        if known and rng.random() < 0.7:   # a typo of a known key: a letter dropped, doubled or swapped
            word = rng.choice(sorted(known))
            i = rng.randrange(len(word))
            key = rng.choice([word[:i] + word[i + 1:], word[:i] + word[i] + word[i:],
                              word[:i] + word[i + 1:i + 2] + word[i:i + 1] + word[i + 2:], word.upper()])
        else:
            key = rng.choice(['colour', 'speed', 'x_', 'terrain_kind', 'gravity', 'Duration', 'goal'])
    new = _copy(raw)
    _get(new, keys)[key] = rng.choice([1, 'a', [1, 2], {'a': 1}, None])
    target = f'{path}.{key}' if path else key
    return Mutation('unknown_field', name, _dump(new), target, True, f'added {target!r}')


def _nested(depth: int, flow: bool, mapping: bool) -> str:
    """Return a YAML value nested `depth` collections deep (flow or block style)."""
    if flow:
        return ('{a: ' * depth + '1' + '}' * depth) if mapping else ('[' * depth + '1' + ']' * depth)
    if mapping:
        return ''.join('\n' + '  ' * (i + 1) + 'a:' for i in range(depth)) + ' 1'
    return ''.join('\n' + '  ' * (i + 1) + '-' for i in range(depth)) + ' 1'


def _deep_nesting(rng: random.Random, name: str, text: str, raw: dict) -> Mutation:
    """Return a top-level field's value nested far deeper than MAX_NESTING (17 to 50000 levels)."""
    depth = rng.choice([MAX_NESTING + 1, 30, 100, 1000, 5000, 50000])
    flow = rng.random() < 0.6 or depth > 1000
    key = rng.choice(sorted(raw))
    value = _nested(depth, flow, rng.random() < 0.5)
    body = _without(raw, key) + f'{key}: {value}\n'
    return Mutation('deep_nesting', name, body.encode(), key, True, f'{key} nested {depth} deep '
                    f'({"flow" if flow else "block"})')


def _huge(rng: random.Random, name: str, text: str, raw: dict) -> Mutation:
    """Return a list, string, count or terrain grid far beyond its limit (or beyond the file-size limit)."""
    new = _copy(raw)
    choice = rng.choice(['goals', 'pushes', 'description', 'duration', 'grid', 'hills', 'topics', 'bytes'])
    if choice in ('goals', 'pushes'):
        n = rng.choice([(MAX_GOALS if choice == 'goals' else MAX_PUSHES) + 1, 1000, 20000])
        new[choice] = [{'at': float(k % 100)} for k in range(n)]
        target, note = choice, f'{n} {choice}'
    elif choice == 'description':
        n = rng.choice([MAX_TEXT + 1, 50000, MAX_SCENE_BYTES * 4])
        new['description'] = 'x' * n
        target, note = 'description', f'description of {n} characters'
    elif choice == 'duration':
        new['duration'] = rng.choice([MAX_DURATION * 2, 1e7, 1e300])
        target, note = 'duration', f'duration {new["duration"]:g} s'
    elif choice == 'grid':
        new['terrain'] = {'kind': rng.choice(['steps', 'noise']), 'extent': rng.choice([100.0, 500.0, 1000.0]),
                          'spacing': rng.choice([1e-4, 1e-3, 0.01]), 'wavelength': 50.0, 'block_size': 1.0}
        target, note = 'terrain', f'{new["terrain"]["kind"]} grid {new["terrain"]["extent"]:g} m at ' \
                                  f'{new["terrain"]["spacing"]:g} m'
    elif choice == 'hills':
        new['terrain'] = {'kind': 'hills', 'extent': rng.choice([1.0e7, 1000.0, 500.0]),
                          'wavelength': rng.choice([1e-4, 1e-3, 0.01])}
        target, note = 'terrain', f'hills {new["terrain"]["extent"]:g} m, wavelength {new["terrain"]["wavelength"]:g}'
    elif choice == 'topics':
        new['record'] = {'topics': ['all'] * 10 + ['no_such_topic'] * rng.choice([1, 1000])}
        target, note = 'record.topics', 'unknown topics'
    else:
        body = text.encode() + b'#' + b'x' * (MAX_SCENE_BYTES + rng.randrange(1, 1 << 20)) + b'\n'
        return Mutation('huge', name, body, '', True, f'file of {len(body)} bytes')
    return Mutation('huge', name, _dump(new), target, True, note)


def _encoding(rng: random.Random, name: str, text: str, raw: dict) -> Mutation:
    """Return the text in another encoding, with binary bytes, or cut inside a multi-byte character."""
    accented = text.replace('description:', 'description: Iguana verde \u00e1rbol \u2014', 1)
    choice = rng.choice(['utf16_bom', 'utf16_no_bom', 'utf32', 'latin1', 'binary_insert', 'random_bytes',
                         'nul', 'cut_utf8', 'cp1252_quotes'])
    if choice == 'utf16_bom':
        return Mutation('encoding', name, text.encode('utf-16'), '', False, 'UTF-16 with a BOM (valid YAML)')
    if choice == 'utf16_no_bom':
        return Mutation('encoding', name, text.encode('utf-16-le'), '', True, 'UTF-16-LE without a BOM')
    if choice == 'utf32':
        return Mutation('encoding', name, text.encode('utf-32'), '', True, 'UTF-32')
    if choice == 'latin1':
        return Mutation('encoding', name, accented.encode('latin-1', 'replace'), '', True, 'Latin-1 accents')
    if choice == 'cp1252_quotes':
        data = accented.replace('Iguana', '\u201cIguana\u201d').encode('cp1252', 'replace')
        return Mutation('encoding', name, data, '', True, 'cp1252 quotes')
    data = accented.encode('utf-8')
    if choice == 'binary_insert':
        at = rng.randrange(len(data))
        blob = bytes(rng.randrange(256) for _ in range(rng.choice([1, 8, 64, 512])))
        return Mutation('encoding', name, data[:at] + blob + data[at:], '', False, f'{len(blob)} bytes at {at}')
    if choice == 'random_bytes':
        return Mutation('encoding', name, bytes(rng.randrange(256) for _ in range(rng.choice([4, 256, 4096]))),
                        '', True, 'random bytes')
    if choice == 'nul':
        at = rng.randrange(len(data))
        return Mutation('encoding', name, data[:at] + b'\x00' + data[at:], '', True, f'NUL at {at}')
    at = data.index('\u00e1'.encode()) + 1
    return Mutation('encoding', name, data[:at] + b'\n' + data[at:], '', True, 'UTF-8 sequence cut')


def _duplicate_keys(rng: random.Random, name: str, text: str, raw: dict) -> Mutation:
    """Return a key given twice: a top-level line repeated later, or a key repeated inside a flow mapping."""
    lines = text.splitlines()
    flows = [(i, m) for i, line in enumerate(lines) for m in re.finditer(r'\{(\w+): ([^,}]+)', line)
             if m.start() == line.index('{')]        # the line's outer mapping: `_flow_parent` names its field
    if flows and rng.random() < 0.5:
        i, m = rng.choice(flows)
        key = m.group(1)
        lines[i] = lines[i][:m.end()] + f', {key}: {m.group(2)}' + lines[i][m.end():]
        parent = _flow_parent(lines, i)
        return Mutation('duplicate_keys', name, ('\n'.join(lines) + '\n').encode(), f'{parent}.{key}', True,
                        f'{key} twice on line {i + 1}')
    tops = [line for line in lines if re.match(r'^\w+:', line)]
    line = rng.choice(tops)
    key = line.split(':')[0]
    return Mutation('duplicate_keys', name, (text + line + '\n').encode(), key, True, f'{key} repeated')


def _flow_parent(lines: list[str], i: int) -> str:
    """Return the field path of the flow mapping on line `i` of a shipped scene ('terrain' or 'goals[k]')."""
    own = re.match(r'^(\w+):', lines[i])
    if own:
        return own.group(1)
    k = i
    while k > 0 and not re.match(r'^\w+:', lines[k]):
        k -= 1
    items = sum(1 for line in lines[k + 1:i + 1] if line.lstrip().startswith('- '))
    return f'{lines[k].split(":")[0]}[{items - 1}]'


def _alias_bomb(rng: random.Random, name: str, text: str, raw: dict) -> Mutation:
    """Return a 'billion laughs': anchors each aliasing the previous one `width` times, used by a field."""
    width = rng.choice([2, 5, 10])
    levels = rng.choice([5, 9, 20]) if width > 2 else rng.choice([17, 30, 60])
    lines = ['lol0: &lol0 [lol, lol, lol, lol, lol, lol, lol, lol, lol, lol]']
    lines += [f'lol{i}: &lol{i} [' + ', '.join([f'*lol{i - 1}'] * width) + ']' for i in range(1, levels)]
    where = rng.choice(['description', 'record', 'goals', 'extra'])
    use = {'description': f'description: *lol{levels - 1}',
           'record': f'record: {{topics: *lol{levels - 1}}}',
           'goals': f'goals: *lol{levels - 1}', 'extra': ''}[where]
    body = '\n'.join(lines) + '\n' + _without(raw, where) + use + '\n'
    size = 10 * width ** (levels - 1)
    return Mutation('alias_bomb', name, body.encode(), '', True, f'{width}^{levels - 1} x 10 = {size:.3g} nodes '
                    f'({"into " + where if use else "unused"})')


def _anchors(rng: random.Random, name: str, text: str, raw: dict) -> Mutation:
    """Legitimate anchors and merge keys: goals and pushes repeated with <<: (valid within the limits)."""
    n = rng.choice([2, 10, MAX_GOALS, MAX_GOALS + 1])
    body = ['name: anchors', 'terrain: {kind: flat}', 'goals:', '  - &g {x: 1.0, y: 0.5, at: 0.0}']
    body += [f'  - {{<<: *g, at: {k + 1}.0}}' for k in range(n - 1)]
    return Mutation('anchors', name, ('\n'.join(body) + '\nduration: 5.0\n').encode(), 'goals', n > MAX_GOALS,
                    f'{n} goals by merge keys')


def _empty(rng: random.Random, name: str, text: str, raw: dict) -> Mutation:
    """Return an empty file, only whitespace, only comments, an empty document, null, or a BOM alone."""
    data = rng.choice([b'', b'\n', b' \t \n\n', b'\n' * 5000, b'# nothing here\n# at all\n', b'---\n',
                       b'--- \n...\n', b'~\n', b'null\n', b'\xef\xbb\xbf', b'\xef\xbb\xbf\n  \n'])
    return Mutation('empty', name, data, '', True, f'{data[:12]!r}')


def _truncation(rng: random.Random, name: str, text: str, raw: dict) -> Mutation:
    """Return the file cut at a random byte."""
    data = text.encode('utf-8')
    at = rng.randrange(1, len(data))
    return Mutation('truncation', name, data[:at], '', False, f'cut at byte {at} of {len(data)}')


def _byte_flips(rng: random.Random, name: str, text: str, raw: dict) -> Mutation:
    """1 to 8 random bytes of the file replaced by random values."""
    data = bytearray(text.encode('utf-8'))
    n = rng.choice([1, 2, 8])
    for _ in range(n):
        data[rng.randrange(len(data))] = rng.randrange(256)
    return Mutation('byte_flips', name, bytes(data), '', False, f'{n} byte(s) replaced')


def _tags(rng: random.Random, name: str, text: str, raw: dict) -> Mutation:
    """YAML tags: Python objects (never constructed), binary, sets, timestamps, explicit floats, multiple docs."""
    choice = rng.choice(['python', 'python_apply', 'binary', 'set', 'timestamp', 'float', 'docs', 'undefined_alias'])
    key = rng.choice(['duration', 'goal_radius'])
    keep = _without(raw, key)
    value = {'python': "!!python/object:os.system ['echo pwned']",
             'python_apply': "!!python/object/apply:os.system ['touch /tmp/iguana_pwned']",
             'binary': '!!binary aGVsbG8gd29ybGQ=', 'set': '!!set {a, b}', 'timestamp': '2001-12-14t21:59:43.10-05:00',
             'float': "!!float '2.5'", 'docs': '5.0\n---\nname: second', 'undefined_alias': '*nowhere'}[choice]
    return Mutation('tags', name, f'{keep}{key}: {value}\n'.encode(), key, choice != 'float', f'{key}: {choice}')


def _npy(array=None, shape=None, descr: str = '<f8', cut: int = 0) -> bytes:
    """
    Return the bytes of a .npy file of `array`, or a header alone promising `shape` of `descr`.

    `cut` bytes are dropped.
    """
    import io

    import numpy as np

    buffer = io.BytesIO()
    if array is not None:
        np.save(buffer, array, allow_pickle=True)
    else:
        np.lib.format.write_array_header_1_0(buffer, {'descr': descr, 'fortran_order': False, 'shape': shape})
    data = buffer.getvalue()
    return data[:len(data) - cut] if cut else data


def _png(width: int, height: int, valid: bool = True) -> bytes:
    """Return a 16-bit grey PNG (valid) or only a PNG signature and an IHDR chunk claiming `width` x `height`."""
    import zlib

    if not valid:
        ihdr = width.to_bytes(4, 'big') + height.to_bytes(4, 'big') + bytes([16, 0, 0, 0, 0])
        return (b'\x89PNG\r\n\x1a\n' + len(ihdr).to_bytes(4, 'big') + b'IHDR' + ihdr
                + zlib.crc32(b'IHDR' + ihdr).to_bytes(4, 'big'))
    import imageio.v3 as iio
    import numpy as np

    ramp = (np.arange(width * height, dtype=np.uint32).reshape(height, width) * 37 % 65535).astype(np.uint16)
    return iio.imwrite('<bytes>', ramp, extension='.png')


def _heightmap(rng: random.Random, name: str, text: str, raw: dict) -> Mutation:
    """
    Return a heightmap terrain naming a file beside the scene.

    Sound, promising too many values in its header, too big, cut short, NaN-filled, pickled, not an array, missing, of
    another type, or scaled beyond MAX_RELIEF.
    """
    import numpy as np

    from iguana_ros.terrain.heightfield import MAX_GRID_NODES, MAX_HEIGHTMAP_BYTES

    side = math.isqrt(MAX_GRID_NODES) + 1
    cases = {
        'sound_npy': ('h.npy', _npy(0.02 * np.sin(np.arange(600.0)).reshape(30, 20)), False, 1.0),
        'sound_png': ('h.png', _png(40, 30), False, 0.05),
        'header_too_many': ('h.npy', _npy(shape=(side, side)), True, 1.0),
        'header_absurd': ('h.npy', _npy(shape=(10 ** 40, 3)), True, 1.0),
        'png_too_many': ('h.png', _png(side, side, valid=False), True, 1.0),
        'too_big_file': ('h.npy', MAX_HEIGHTMAP_BYTES + 1, True, 1.0),
        'cut_short': ('h.npy', _npy(np.zeros((40, 40)), cut=rng.randrange(1, 12000)), False, 1.0),
        'nan': ('h.npy', _npy(np.full((10, 10), np.nan)), False, 1.0),
        'pickled': ('h.npy', _npy(np.array([[{'a': 1}, None]] * 3, dtype=object)), False, 1.0),
        'one_d': ('h.npy', _npy(np.zeros(50)), True, 1.0),
        'random_bytes': ('h.npy', bytes(rng.randrange(256) for _ in range(300)), True, 1.0),
        'text_file': ('h.txt', b'1 2 3\n4 5 6\n', True, 1.0),
        'missing': ('', b'', True, 1.0),
        'scale_too_big': ('h.npy', _npy(np.zeros((10, 10))), True, 1.0e6),
    }
    case = rng.choice(sorted(cases))
    file_name, content, reject, scale = cases[case]
    new = _copy(raw)
    new['terrain'] = {'kind': 'heightmap', 'file': f'@DIR@/{file_name or "missing.npy"}', 'scale': scale,
                      'spacing': 0.05}
    files = ((file_name, content),) if file_name else ()
    return Mutation('heightmap', name, _dump(new), 'terrain.file', reject, case, files)


MUTATORS = {
    'wrong_type': _wrong_type, 'out_of_range': _out_of_range, 'non_finite': _non_finite,
    'unknown_field': _unknown_field, 'deep_nesting': _deep_nesting, 'huge': _huge, 'encoding': _encoding,
    'duplicate_keys': _duplicate_keys, 'alias_bomb': _alias_bomb, 'anchors': _anchors, 'empty': _empty,
    'truncation': _truncation, 'byte_flips': _byte_flips, 'tags': _tags, 'heightmap': _heightmap,
}
"""Every kind of mutation, by name; trials cycle through them in this order."""


def mutations(n: int, seed: int, scenes: dict[str, str] | None = None) -> list[Mutation]:
    """`n` seeded mutations of `scenes` ({name: text}, default the shipped ones), kinds in turn."""
    scenes = shipped_scenes() if scenes is None else scenes
    parsed = {name: yaml.safe_load(text) for name, text in scenes.items()}
    rng = random.Random(seed)
    kinds = list(MUTATORS)
    out = []
    for i in range(n):
        name = rng.choice(sorted(scenes))
        out.append(MUTATORS[kinds[i % len(kinds)]](rng, name, scenes[name], parsed[name]))
    return out


# ---------------------------------------------------------------------------------------------------- checks
def _within_limits(scene: Scene) -> list[str]:
    """Limits a loaded Scene must respect (the schema's own rules, re-checked from the outside)."""
    from iguana_ros.terrain.heightfield import HILLS_SAMPLES, MAX_GRID_NODES, grid_nodes

    problems = []
    t = scene.terrain
    spacing = t.wavelength / HILLS_SAMPLES if t.kind == 'hills' else t.spacing
    if t.kind in ('hills', 'steps', 'noise') and grid_nodes(t.extent / 2.0, spacing) > MAX_GRID_NODES:
        problems.append(f'accepted a terrain grid of {grid_nodes(t.extent / 2.0, spacing)} nodes')
    if not 0 < scene.duration <= MAX_DURATION:
        problems.append(f'accepted duration {scene.duration}')
    if len(scene.goals) > MAX_GOALS or len(scene.pushes) > MAX_PUSHES:
        problems.append(f'accepted {len(scene.goals)} goals, {len(scene.pushes)} pushes')
    numbers = [scene.duration, scene.goal_radius, t.extent, t.spacing, t.amplitude, t.wavelength, scene.start.x,
               scene.start.y] + [v for g in scene.goals for v in (g.x, g.y, g.at)] \
        + [v for p in scene.pushes for v in (*p.force, p.at, p.duration)]
    if not all(math.isfinite(v) for v in numbers):
        problems.append('accepted a non-finite number')
    return problems


def load_trial(index: int, mutation: Mutation, directory: Path) -> Trial:
    """Write `mutation` to `directory` and load it; the Trial lists every rule it broke (`problems`)."""
    path = directory / f'm{index:04d}_{mutation.base}_{mutation.kind}.yaml'
    beside = directory / f'm{index:04d}_files'
    for file_name, content in mutation.files:
        beside.mkdir(exist_ok=True)
        with (beside / file_name).open('wb') as f:
            if isinstance(content, int):
                f.truncate(content)        # a sparse file of that size
            else:
                f.write(content)
    path.write_bytes(mutation.data.replace(b'@DIR@', str(beside).encode()))
    trial = Trial(index, mutation.kind, mutation.base, mutation.target, mutation.note, mutation.must_reject,
                  file=str(path))
    tracemalloc.start()
    start = time.perf_counter()
    try:
        scene = load_scene(str(path))
        trial.outcome = 'valid'
        trial.problems += _within_limits(scene)
    except SceneError as exc:
        trial.outcome, trial.message = 'rejected', str(exc)
    except BaseException as exc:  # noqa: BLE001 -- the suite records whatever escapes instead of a SceneError
        trial.outcome, trial.message = 'crashed', f'{type(exc).__name__}: {str(exc)[:300]}'
    finally:
        trial.load_s = time.perf_counter() - start
        trial.peak_bytes = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
    trial.problems += _message_problems(trial, str(path))
    if trial.load_s > LOAD_SECONDS_LIMIT:
        trial.problems.append(f'load took {trial.load_s:.2f} s')
    if trial.peak_bytes > LOAD_PEAK_LIMIT:
        trial.problems.append(f'load peaked at {trial.peak_bytes / 2 ** 20:.0f} MB')
    return trial


def _message_problems(trial: Trial, path: str) -> list[str]:
    """
    Return what is wrong with the outcome of a trial.

    A crash, a bad scene accepted, an error that is not one line naming the file (and, for a field's fault, a field).
    """
    if trial.outcome == 'crashed':
        return [f'crashed: {trial.message}']
    if trial.outcome == 'valid':
        return ['accepted a bad scene'] if trial.must_reject else []
    problems = []
    message = trial.message
    if '\n' in message or len(message) > 400:
        problems.append(f'error is not one short line ({len(message)} characters)')
    if not message.startswith(path + ':'):
        problems.append('error does not start with the file')
    found = _FIELD.search(message)
    trial.named_field = found.group(1) if found else ''
    if not found and not any(phrase in message for phrase in FILE_LEVEL):
        problems.append('error names neither a field nor a file-level fault')
    if trial.kind in ('wrong_type', 'non_finite', 'unknown_field', 'duplicate_keys') and not _names(
            trial.named_field, trial.target):
        problems.append(f'error names field {trial.named_field!r}, not the damaged {trial.target!r}')
    return problems


def _names(named: str, target: str) -> bool:
    """Whether an error naming field `named` points at `target` (the same field, a parent or an item of it)."""
    if not named or not target:
        return False
    return named == target or target.startswith((named + '.', named + '[')) or named.startswith(
        (target + '.', target + '['))


# -------------------------------------------------------------------------------------------------- the CLI
def _limit_memory(limit: int) -> None:
    """In the child before exec: cap its address space at `limit` bytes."""
    import resource
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))


def cli_trial(trial: Trial, timeout: float = CLI_TIMEOUT, memory_limit: int = CLI_MEMORY_LIMIT) -> dict:
    """
    Run `iguana simulate FILE --duration 0.1 --json` on a trial's file in a subprocess.

    The subprocess has its own process group and RLIMIT_AS `memory_limit`, and is killed with its group after `timeout`
    s. Returns {exit code, stderr lines, peak RSS, wall s, problems}.
    """
    command = [sys.executable, '-m', 'iguana_ros.cli', 'simulate', trial.file, '--duration', str(CLI_DURATION),
               '--json']
    out_path, err_path = Path(trial.file + '.out'), Path(trial.file + '.err')
    start = time.perf_counter()
    with out_path.open('wb') as out, err_path.open('wb') as err:
        proc = subprocess.Popen(command, stdout=out, stderr=err, stdin=subprocess.DEVNULL, start_new_session=True,
                                preexec_fn=lambda: _limit_memory(memory_limit))
        status, usage, timed_out = _wait_with_rusage(proc, timeout)
    wall = time.perf_counter() - start
    peak = usage.ru_maxrss * 1024
    stdout = out_path.read_bytes().decode('utf-8', 'replace')
    lines = [line for line in err_path.read_bytes().decode('utf-8', 'replace').splitlines() if line.strip()]
    row = {'index': trial.index, 'kind': trial.kind, 'outcome': trial.outcome, 'exit_code': status,
           'stderr': lines[:5], 'peak_rss_mb': round(peak / 2 ** 20, 1), 'wall_s': round(wall, 2), 'problems': []}
    problems = row['problems']
    if timed_out:
        problems.append(f'timed out after {timeout:g} s')
    if any('Traceback' in line for line in lines):
        problems.append('traceback')
    if peak > CLI_RSS_LIMIT:
        problems.append(f'peak RSS {peak / 2 ** 20:.0f} MB')
    if trial.outcome == 'rejected':
        if status != 1 or len(lines) != 1 or stdout.strip():
            problems.append(f'exit {status} with {len(lines)} stderr line(s), {len(stdout)} stdout chars')
        elif not (lines[0].startswith('iguana simulate: error: ') and trial.file in lines[0]):
            problems.append(f'error line does not name the file: {lines[0][:120]}')
    elif status == 0:
        try:
            json.loads(stdout)
        except ValueError:
            problems.append('exit 0 without the JSON metrics')
    elif status != 1 or len(lines) != 1:
        problems.append(f'a valid scene: exit {status} with {len(lines)} stderr line(s)')
    return row


def _wait_with_rusage(proc: subprocess.Popen, timeout: float) -> tuple:
    """
    (exit status, rusage, timed out) of a child started in its own session.

    After `timeout` s its process group is killed. The child is reaped here (wait4), so its peak RSS is its own.
    """
    import threading

    expired = threading.Event()

    def kill() -> None:
        expired.set()
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
    timer = threading.Timer(timeout, kill)
    timer.start()
    try:
        _, status, usage = os.wait4(proc.pid, 0)
    finally:
        timer.cancel()
    proc.returncode = os.waitstatus_to_exitcode(status)
    return proc.returncode, usage, expired.is_set()


# -------------------------------------------------------------------------------------------------- a suite
def run_suite(trials: int = 300, seed: int = 12, cli_sample: int = 12, workers: int = 2,
              directory: Path | None = None, progress=None) -> dict:
    """
    Load `trials` seeded mutations.

    Run `cli_sample` of them (rejected ones from every kind, plus a few valid ones; -1 = every one) through
    `iguana simulate`; the figures and every problem found, as plain data.
    """
    import tempfile

    import importlib

    from iguana_ros.topics import default_topics

    importlib.import_module('iguana_ros.terrain.heightfield')   # imported and read before the trials, so that no
    default_topics()                                             # trial's time or heap peak is an import's
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix='iguana_scene_faults_') as tmp:
        work = Path(directory) if directory is not None else Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        rows = [load_trial(i, m, work) for i, m in enumerate(mutations(trials, seed))]
        load_wall = time.perf_counter() - start
        sample = _cli_sample(rows, cli_sample, random.Random(seed + 1))
        with ThreadPoolExecutor(max(1, workers)) as pool:
            cli_rows = []
            for row in pool.map(cli_trial, sample):
                cli_rows.append(row)
                if progress is not None:
                    progress(row)
    by_kind: dict[str, dict] = {}
    for row in rows:
        counts = by_kind.setdefault(row.kind, {'trials': 0, 'valid': 0, 'rejected': 0, 'crashed': 0, 'problems': 0})
        counts['trials'] += 1
        counts[row.outcome] += 1
        counts['problems'] += bool(row.problems)
    failed = [asdict(r) for r in rows if r.problems]
    cli_failed = [r for r in cli_rows if r['problems']]
    return {
        'seed': seed, 'trials': len(rows), 'survived': len(rows) - len(failed),
        'valid': sum(r.outcome == 'valid' for r in rows), 'rejected': sum(r.outcome == 'rejected' for r in rows),
        'crashed': sum(r.outcome == 'crashed' for r in rows),
        'field_named': sum(bool(r.named_field) for r in rows if r.outcome == 'rejected'),
        'max_load_s': round(max((r.load_s for r in rows), default=0.0), 4),
        'max_load_peak_mb': round(max((r.peak_bytes for r in rows), default=0) / 2 ** 20, 2),
        'load_wall_s': round(load_wall, 2),
        'cli_trials': len(cli_rows), 'cli_survived': len(cli_rows) - len(cli_failed),
        'cli_rejected': sum(r['outcome'] == 'rejected' for r in cli_rows),
        'cli_max_peak_rss_mb': max((r['peak_rss_mb'] for r in cli_rows), default=0.0),
        'cli_max_wall_s': max((r['wall_s'] for r in cli_rows), default=0.0),
        'wall_s': round(time.perf_counter() - start, 2), 'by_kind': by_kind,
        'failures': failed, 'cli_failures': cli_failed,
        'limits': {'load_s': LOAD_SECONDS_LIMIT, 'load_peak_mb': LOAD_PEAK_LIMIT / 2 ** 20,
                   'cli_rss_mb': CLI_RSS_LIMIT / 2 ** 20, 'cli_address_space_mb': CLI_MEMORY_LIMIT / 2 ** 20,
                   'yaml_nodes': MAX_YAML_NODES},
    }


def _cli_sample(rows: list[Trial], n: int, rng: random.Random) -> list[Trial]:
    """`n` trials for the CLI (-1: all): rejected ones spread over the kinds, about one in six valid ones."""
    if n < 0:
        return list(rows)
    valid = [r for r in rows if r.outcome == 'valid']
    rejected = [r for r in rows if r.outcome == 'rejected']
    n_valid = min(len(valid), max(1, n // 6)) if n > 1 else 0
    kinds: dict[str, list[Trial]] = {}
    for r in rejected:
        kinds.setdefault(r.kind, []).append(r)
    picked: list[Trial] = []
    while len(picked) < n - n_valid and any(kinds.values()):
        for kind in sorted(kinds):
            if kinds[kind] and len(picked) < n - n_valid:
                picked.append(kinds[kind].pop(rng.randrange(len(kinds[kind]))))
    return picked + rng.sample(valid, n_valid)
