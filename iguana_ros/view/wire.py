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
What a viewer page may send: the checks of every websocket message from a browser before viser sees it.

viser decodes a page's message (msgpack, a map naming its `type`) inside the connection's reader: a message that
does not decode, names no known type or lacks a field ended the connection with a 15-line traceback on the viewer's
terminal, and one that decodes but does not fit (a word where a GUI number goes, a click ray of two numbers) raised
in viser's own tasks or in the page's callbacks. `check_message` accepts only the three messages the page acts on,
with every field as a browser sends it, and says in one phrase what is wrong with anything else.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
import math

CAMERA = 'ViewerCameraMessage'
POINTER = 'ScenePointerMessage'
GUI_UPDATE = 'GuiUpdateMessage'

READ_ONLY_TYPES = frozenset({CAMERA})
"""What a page without the token may send: its own camera (viser needs it to count the page as connected)."""

KEY_MODIFIERS = frozenset({'cmd/ctrl', 'alt', 'shift', 'cmd/ctrl+alt', 'cmd/ctrl+shift', 'alt+shift',
                           'cmd/ctrl+alt+shift'})
"""viser's `KeyModifier` values (a click's held keys)."""

MAX_TEXT = 200
"""Longest string a page may send as a GUI value (a dropdown option)."""


class BadMessage(ValueError):
    """A page's message that is not passed on; the text says what is wrong with it."""


@dataclass(frozen=True)
class InputRule:
    """
    What a page may send as the value of one GUI input.

    Its label (for the log line), kind ('button', 'checkbox', 'number' or 'choice'), range of a number and choices.
    """

    label: str
    kind: str
    low: float = -math.inf
    high: float = math.inf
    choices: tuple = ()

    def check(self, value: object) -> None:
        """`BadMessage` unless `value` is one this input's page element sends."""
        if self.kind == 'button' and value is not True:
            raise BadMessage(f'the button {self.label!r} sends true, not {value!r:.60}')
        if self.kind == 'checkbox' and not isinstance(value, bool):
            raise BadMessage(f'the checkbox {self.label!r} takes true or false, not {value!r:.60}')
        if self.kind == 'number' and not (_is_number(value) and self.low <= value <= self.high):
            raise BadMessage(f'{self.label!r} takes a number in [{self.low:g}, {self.high:g}], not {value!r:.60}')
        if self.kind == 'choice' and value not in self.choices:
            raise BadMessage(f'{self.label!r} takes one of {", ".join(map(str, self.choices))}, not {value!r:.60}')


def _is_number(value: object) -> bool:
    """Return True for a finite int or float (not a bool)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _numbers(fields: Mapping, name: str, count: int, optional: bool = False) -> None:
    """`BadMessage` unless field `name` is `count` finite numbers (or None when `optional`)."""
    value = fields.get(name)
    if value is None and optional and name in fields:
        return
    if not (isinstance(value, (list, tuple)) and len(value) == count and all(map(_is_number, value))):
        raise BadMessage(f'{name} must be {count} finite numbers, not {value!r:.60}')


def _fields(fields: Mapping, names: set[str]) -> None:
    """`BadMessage` unless the message has exactly the fields `names` (besides its type)."""
    missing, extra = sorted(names - set(fields)), sorted(set(fields) - names)
    if missing or extra:
        parts = [f'lacks {", ".join(missing)}'] if missing else []
        parts += [f'has unknown {", ".join(extra)}'] if extra else []
        raise BadMessage(' and '.join(parts))


def _check_camera(fields: Mapping, _inputs: Mapping) -> None:
    """Check a page's camera: pose, look-at and up direction, field of view, clip planes, image size."""
    _fields(fields, {'wxyz', 'position', 'fov', 'near', 'far', 'image_height', 'image_width', 'look_at',
                     'up_direction'})
    _numbers(fields, 'wxyz', 4)
    for name in ('position', 'look_at', 'up_direction'):
        _numbers(fields, name, 3)
    for name in ('fov', 'near', 'far', 'image_height', 'image_width'):
        if not (_is_number(fields[name]) and fields[name] >= 0):
            raise BadMessage(f'{name} must be a finite number >= 0, not {fields[name]!r:.60}')


def _check_pointer(fields: Mapping, _inputs: Mapping) -> None:
    """Check a click in the scene: its kind, the camera ray, where on the screen, the keys held."""
    _fields(fields, {'event_type', 'ray_origin', 'ray_direction', 'screen_pos', 'modifier'})
    if fields['event_type'] not in ('click', 'rect-select'):
        raise BadMessage(f'event_type must be click or rect-select, not {fields["event_type"]!r:.60}')
    _numbers(fields, 'ray_origin', 3, optional=True)
    _numbers(fields, 'ray_direction', 3, optional=True)
    screen = fields['screen_pos']
    if not (isinstance(screen, (list, tuple)) and 1 <= len(screen) <= 2 and all(
            isinstance(p, (list, tuple)) and len(p) == 2 and all(map(_is_number, p)) for p in screen)):
        raise BadMessage(f'screen_pos must be one or two pairs of finite numbers, not {screen!r:.60}')
    if fields['modifier'] is not None and fields['modifier'] not in KEY_MODIFIERS:
        raise BadMessage(f'modifier must be none or one of {", ".join(sorted(KEY_MODIFIERS))}, not '
                         f'{fields["modifier"]!r:.60}')


def _check_gui_update(fields: Mapping, inputs: Mapping) -> None:
    """Check a new value of one of the page's GUI inputs (`inputs`: uuid -> InputRule)."""
    _fields(fields, {'uuid', 'updates'})
    rule = inputs.get(fields['uuid']) if isinstance(fields['uuid'], str) else None
    if rule is None:
        raise BadMessage(f'uuid {fields["uuid"]!r:.60} is no input of this page')
    updates = fields['updates']
    if not (isinstance(updates, dict) and set(updates) == {'value'}):
        raise BadMessage(f'updates must be {{"value": ...}}, not {updates!r:.60}')
    rule.check(updates['value'])


CHECKS = {CAMERA: _check_camera, POINTER: _check_pointer, GUI_UPDATE: _check_gui_update}
"""The messages a page may send, each with its check."""


def check_message(raw: bytes | str, inputs: Mapping[str, InputRule]) -> str:
    """
    Return the type of a page's websocket message `raw` if it is one the page acts on, well formed; else `BadMessage`.

    `inputs` are the page's GUI inputs by uuid. The message must then also decode as viser's own message of that type.
    """
    import msgspec

    if not isinstance(raw, bytes):
        raise BadMessage('a text frame (viser pages send binary msgpack)')
    try:
        fields = msgspec.msgpack.decode(raw)
    except (msgspec.DecodeError, ValueError, TypeError) as exc:
        raise BadMessage(f'not msgpack ({exc})') from None
    if not isinstance(fields, dict) or not isinstance(fields.get('type'), str):
        raise BadMessage(f'not a map with a type: {fields!r:.60}')
    kind = fields.pop('type')
    if kind not in CHECKS:
        raise BadMessage(f'type {kind!r:.60} is not one this page takes ({", ".join(sorted(CHECKS))})')
    CHECKS[kind](fields, inputs)
    _decodes_in_viser(raw, kind)
    return kind


def _decodes_in_viser(raw: bytes, kind: str) -> None:
    """`BadMessage` unless viser's own decoder makes a message of type `kind` of `raw`."""
    from viser import _messages

    try:
        decoded = _messages.Message.deserialize(raw)
    except Exception as exc:  # noqa: BLE001 -- whatever viser's decoder raises, the message is not passed on
        raise BadMessage(f'viser cannot decode it ({type(exc).__name__}: {exc})') from None
    if type(decoded).__name__ != kind:
        raise BadMessage(f'viser decodes it as {type(decoded).__name__}, not {kind}')
