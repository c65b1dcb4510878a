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

"""`iguana topics`: print the topic, service and action tables of msg_configs/topics.yaml."""
from __future__ import annotations

import argparse

from iguana_ros.topics import default_interfaces, default_topics


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the `topics` sub-command."""
    parser = subparsers.add_parser('topics',
                                   help='list every topic (name, type, QoS, rate, who talks), service and action')
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Print one line per topic, then one per service and action."""
    for spec in default_topics().values():
        q = spec.qos
        rate = f'{spec.rate_hz:g} Hz' if spec.rate_hz else 'on event'
        print(f'{spec.name:22s} {spec.type:46s} {q.reliability}/{q.durability}/depth {q.depth:<3d} '
              f'{rate:9s} {", ".join(spec.publishers)} -> {", ".join(spec.subscribers)}')
    for section in ('services', 'actions'):
        for spec in default_interfaces(section).values():
            print(f'{spec.name:22s} {spec.type:46s} {section[:-1]:32s} {spec.server} <- {", ".join(spec.clients)}')
    return 0
