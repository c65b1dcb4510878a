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

"""Node parameter declarations of msg_configs/parameters.yaml as plain data (ROS-free)."""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import yaml

from iguana_ros.config import config_path
from iguana_ros.errors import InputError

TYPES = {'string': str, 'double': float, 'integer': int, 'bool': bool}


@dataclass(frozen=True)
class ParamSpec:
    """
    One declared parameter.

    Name, type name, default, description, numeric range or string choices; `dynamic` parameters may be set while the
    node runs (the others are read-only).
    """

    name: str
    type: str  # noqa: A003 - the `type` key of msg_configs/parameters.yaml
    default: object
    description: str = ''
    range: tuple | None = None  # noqa: A003 - the `range` key of msg_configs/parameters.yaml
    choices: tuple | None = None
    dynamic: bool = False

    def check(self, value) -> object:
        """`value` if it fits the type, range and choices; else InputError naming the parameter."""
        expected = TYPES[self.type]
        ok_type = isinstance(value, expected) and not (expected is not bool and isinstance(value, bool))
        if expected is float and isinstance(value, int) and not isinstance(value, bool):
            value, ok_type = float(value), True
        if not ok_type:
            raise InputError(f'parameter {self.name}: expected {self.type}, got {value!r}')
        if self.range is not None and not self.range[0] <= value <= self.range[1]:
            raise InputError(f'parameter {self.name}: {value!r} outside [{self.range[0]}, {self.range[1]}]')
        if self.choices is not None and value not in self.choices:
            raise InputError(f'parameter {self.name}: {value!r} is not one of {", ".join(self.choices)}')
        return value


def _spec(name: str, raw: dict, source: Path) -> ParamSpec:
    """Validate one declaration."""
    if not isinstance(raw, dict) or raw.get('type') not in TYPES or 'default' not in raw:
        raise InputError(f'{source}: parameter {name!r} needs a type ({", ".join(TYPES)}) and a default')
    spec = ParamSpec(name=name, type=raw['type'], default=raw['default'],
                     description=str(raw.get('description', '')),
                     range=tuple(raw['range']) if 'range' in raw else None,
                     choices=tuple(str(c) for c in raw['choices']) if 'choices' in raw else None,
                     dynamic=bool(raw.get('dynamic', False)))
    spec.check(spec.default)
    return spec


def load_parameters(path: Path | None = None) -> dict[str, dict[str, ParamSpec]]:
    """{node name or 'common': {parameter: ParamSpec}} from msg_configs/parameters.yaml (or `path`)."""
    source = Path(path) if path is not None else config_path('parameters.yaml')
    try:
        raw = yaml.safe_load(source.read_text())
    except (OSError, yaml.YAMLError) as exc:
        raise InputError(f'{source}: cannot read parameter declarations: {exc}') from exc
    return {node: {name: _spec(name, decl, source) for name, decl in (params or {}).items()}
            for node, params in raw.items()}


@lru_cache(maxsize=1)
def _default_parameters() -> dict:
    """Return the package's declarations, read once per process."""
    return load_parameters()


def node_parameters(node: str) -> dict[str, ParamSpec]:
    """Return declarations of `node` (common ones included)."""
    table = _default_parameters()
    if node not in table:
        raise KeyError(f'no parameter declarations for node {node!r}; known: {sorted(table)}')
    return {**table.get('common', {}), **table[node]}
