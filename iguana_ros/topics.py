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

"""The topic, service and action tables of msg_configs/topics.yaml (ROS-free): the one source of their names."""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
import re

import yaml

from iguana_ros.config import config_path
from iguana_ros.executables import NODE_EXECUTABLES

RELIABILITY = ('reliable', 'best_effort')
DURABILITY = ('volatile', 'transient_local')
HISTORY = ('keep_last', 'keep_all')


@dataclass(frozen=True)
class QosSpec:
    """QoS of one topic in plain words (reliability, durability, history, depth)."""

    reliability: str = 'reliable'
    durability: str = 'volatile'
    history: str = 'keep_last'
    depth: int = 10


@dataclass(frozen=True)
class TopicSpec:
    """One row of the topic table: key, ROS name, message type, QoS, rate and who talks on it."""

    key: str
    name: str
    type: str  # noqa: A003 - the `type` key of msg_configs/topics.yaml
    qos: QosSpec
    rate_hz: float | None = None
    publishers: tuple = field(default_factory=tuple)
    subscribers: tuple = field(default_factory=tuple)
    description: str = ''

    @property
    def subscriber_nodes(self) -> tuple:
        """Return the package's nodes among the subscribers ('simulator_node (goal marker)' names simulator_node)."""
        return tuple(entry.split()[0] for entry in self.subscribers if entry.split()[0] in NODE_EXECUTABLES)

    @property
    def publisher_nodes(self) -> tuple:
        """Return the package's nodes among the publishers."""
        return tuple(entry.split()[0] for entry in self.publishers if entry.split()[0] in NODE_EXECUTABLES)


@dataclass(frozen=True)
class InterfaceSpec:
    """One row of the service or action table: key, ROS name, service or action type, its server and clients."""

    key: str
    name: str
    type: str  # noqa: A003 - the `type` key of msg_configs/topics.yaml
    server: str
    clients: tuple = field(default_factory=tuple)
    description: str = ''


class TopicConfigError(ValueError):
    """msg_configs/topics.yaml is malformed; the message names the file and the field."""


def _parse_qos(key: str, raw: dict, source: Path) -> QosSpec:
    """Validate and build the QoS of topic `key`."""
    if not isinstance(raw, dict):
        raise TopicConfigError(f'{source}: topics.{key}.qos must be a mapping')
    qos = QosSpec(**{k: raw[k] for k in raw if k in QosSpec.__dataclass_fields__})
    unknown = set(raw) - set(QosSpec.__dataclass_fields__)
    if unknown:
        raise TopicConfigError(f'{source}: topics.{key}.qos has unknown fields {sorted(unknown)}')
    for fname, allowed in (('reliability', RELIABILITY), ('durability', DURABILITY),
                           ('history', HISTORY)):
        if getattr(qos, fname) not in allowed:
            raise TopicConfigError(
                f'{source}: topics.{key}.qos.{fname} is {getattr(qos, fname)!r}, expected one of {allowed}')
    if not isinstance(qos.depth, int) or qos.depth < 1:
        raise TopicConfigError(f'{source}: topics.{key}.qos.depth must be a positive integer')
    return qos


def _parse_topic(key: str, raw: dict, source: Path) -> TopicSpec:
    """Validate and build one topic row."""
    for required in ('name', 'type', 'qos'):
        if required not in raw:
            raise TopicConfigError(f'{source}: topics.{key} lacks the field {required!r}')
    if raw['type'].count('/') != 2 or '/msg/' not in raw['type']:
        raise TopicConfigError(
            f'{source}: topics.{key}.type is {raw["type"]!r}, expected package/msg/Type')
    return TopicSpec(
        key=key, name=raw['name'], type=raw['type'], qos=_parse_qos(key, raw['qos'], source),
        rate_hz=raw.get('rate_hz'), publishers=tuple(raw.get('publishers') or ()),
        subscribers=tuple(raw.get('subscribers') or ()), description=raw.get('description', ''))


def _parse_interface(section: str, kind: str, key: str, raw: dict, source: Path) -> InterfaceSpec:
    """Validate and build one row of the `services` (kind 'srv') or `actions` (kind 'action') table."""
    if not isinstance(raw, dict):
        raise TopicConfigError(f'{source}: {section}.{key} must be a mapping')
    for required in ('name', 'type', 'server'):
        if required not in raw:
            raise TopicConfigError(f'{source}: {section}.{key} lacks the field {required!r}')
    if raw['type'].count('/') != 2 or f'/{kind}/' not in raw['type']:
        raise TopicConfigError(f'{source}: {section}.{key}.type is {raw["type"]!r}, expected package/{kind}/Type')
    unknown = set(raw) - set(InterfaceSpec.__dataclass_fields__)
    if unknown:
        raise TopicConfigError(f'{source}: {section}.{key} has unknown fields {sorted(unknown)}')
    return InterfaceSpec(key=key, name=raw['name'], type=raw['type'], server=raw['server'],
                         clients=tuple(raw.get('clients') or ()), description=raw.get('description', ''))


def _read_table(source: Path) -> dict:
    """Return the parsed YAML mapping of the table file `source`, which has a `topics:` mapping."""
    try:
        data = yaml.safe_load(source.read_text())
    except (OSError, yaml.YAMLError) as exc:
        raise TopicConfigError(f'{source}: cannot read topic table: {exc}') from exc
    if not isinstance(data, dict) or not isinstance(data.get('topics'), dict):
        raise TopicConfigError(f'{source}: expected a top-level mapping "topics:"')
    for section in ('services', 'actions'):
        if not isinstance(data.get(section) or {}, dict):
            raise TopicConfigError(f'{source}: "{section}:" must be a mapping')
    return data


def load_topics(path: Path | None = None) -> dict[str, TopicSpec]:
    """Read the topic table (default msg_configs/topics.yaml) into {key: TopicSpec}."""
    source = Path(path) if path is not None else config_path('topics.yaml')
    return {key: _parse_topic(key, raw, source) for key, raw in _read_table(source)['topics'].items()}


def load_interfaces(section: str, path: Path | None = None) -> dict[str, InterfaceSpec]:
    """Read the `services` or `actions` table (default msg_configs/topics.yaml) into {key: InterfaceSpec}."""
    kinds = {'services': 'srv', 'actions': 'action'}
    if section not in kinds:
        raise ValueError(f'unknown table {section!r}; expected one of {sorted(kinds)}')
    source = Path(path) if path is not None else config_path('topics.yaml')
    rows = _read_table(source).get(section) or {}
    return {key: _parse_interface(section, kinds[section], key, raw, source) for key, raw in rows.items()}


@lru_cache(maxsize=1)
def default_topics() -> dict[str, TopicSpec]:
    """Return the package's topic table, read once per process."""
    return load_topics()


@lru_cache(maxsize=2)
def default_interfaces(section: str) -> dict[str, InterfaceSpec]:
    """Return the package's `services` or `actions` table, read once per process."""
    return load_interfaces(section)


def service(key: str) -> InterfaceSpec:
    """Return the InterfaceSpec of service `key` (e.g. 'sim_pause'); KeyError lists the known keys."""
    return _row(default_interfaces('services'), 'service', key)


def action(key: str) -> InterfaceSpec:
    """Return the InterfaceSpec of action `key` (e.g. 'go_to_pose'); KeyError lists the known keys."""
    return _row(default_interfaces('actions'), 'action', key)


def _row(table: dict, kind: str, key: str):
    """Return `table[key]`, or KeyError naming the kind and the known keys."""
    if key not in table:
        raise KeyError(f'unknown {kind} key {key!r}; known: {sorted(table)}')
    return table[key]


def topic(key: str) -> TopicSpec:
    """Return the TopicSpec for `key` (e.g. 'goal_pose'); KeyError lists the known keys."""
    table = default_topics()
    if key not in table:
        raise KeyError(f'unknown topic key {key!r}; known: {sorted(table)}')
    return table[key]


RUN_CLOCK = '/clock'
"""The absolute topic that is a run's own all the same: a run in a namespace publishes and follows `<ns>/clock`
(`iguana run --namespace` remaps it for every node), so two runs on one domain keep two clocks."""

_NAME_TOKEN = re.compile(r'[A-Za-z_][A-Za-z0-9_]*')


def check_namespace(text: str) -> str:
    """Return ROS namespace `text` as '/a/b' ('' for the root); InputError naming the rule it breaks."""
    from iguana_ros.errors import InputError
    tokens = text.strip().strip('/').split('/') if text.strip().strip('/') else []
    for token in tokens:
        if not _NAME_TOKEN.fullmatch(token):
            raise InputError(f'namespace {text!r}: each part must be letters, digits and underscores, not starting '
                             'with a digit (e.g. iguana1 or zoo/iguana1)')
    return '/' + '/'.join(tokens) if tokens else ''


def topic_name(key: str, namespace: str = '') -> str:
    """Return the absolute name of topic `key` for a run in `namespace` ('' root; see RUN_CLOCK)."""
    name = topic(key).name
    if name.startswith('/') and name != RUN_CLOCK:
        return name
    return f'{namespace}/{name.lstrip("/")}'


def shared_topic(key: str) -> bool:
    """Whether every run on the domain publishes topic `key` under one absolute name (/tf, /diagnostics)."""
    name = topic(key).name
    return name.startswith('/') and name != RUN_CLOCK


FRAME_PREFIX_AUTO = 'auto'
"""The nodes' `frame_prefix` default: the prefix of their namespace (`resolve_frame_prefix`)."""


def resolve_frame_prefix(parameter: str, namespace: str) -> str:
    """Return the TF frame prefix of a node in `namespace` with `frame_prefix` `parameter` ('auto': the namespace's)."""
    return frame_prefix_of(namespace) if parameter == FRAME_PREFIX_AUTO else parameter


def frame_prefix_of(namespace: str) -> str:
    """Return the TF frame prefix of a run in `namespace` ('iguana1/' for '/iguana1', '' for the root)."""
    return f'{namespace.strip("/")}/' if namespace.strip('/') else ''
