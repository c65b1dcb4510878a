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

"""`iguana model`: `info` prints the soft-body model's counts and quality, `render` draws it to an image."""
from __future__ import annotations

import argparse

RESOLUTION_CHOICES = ('coarse', 'medium', 'fine')
STIFFNESS_CHOICES = ('normal', 'softer')


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the `model` sub-command with its `info` and `render` actions."""
    parser = subparsers.add_parser('model', help='the tetrahedral iguana model: info, render')
    actions = parser.add_subparsers(dest='action', metavar='ACTION', required=True)
    info = actions.add_parser('info', help='print node/tet/spring counts, worst element quality, build time')
    render = actions.add_parser('render', help='draw mesh, skeleton and markers from the side and above')
    for p in (info, render):
        p.add_argument('--resolution', '-r', default='medium', help='coarse | medium (default) | fine')
        p.add_argument('--stiffness', default='normal', help='normal (default) | softer')
    info.add_argument('--rebuild', action='store_true', help='build from scratch (ignore and keep the cache)')
    info.add_argument('--json', action='store_true', help='print the summary as JSON')
    render.add_argument('-o', '--output', default='model.png', help='image file (default model.png)')
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Build (or load) the model and print its summary or render it."""
    from iguana_ros.body.model import build_model, cache_path

    if args.action == 'render':
        from iguana_ros.body.figure import render_model
        model = build_model(args.resolution, args.stiffness)
        print(render_model(model, args.output))
        return 0
    model = build_model(args.resolution, args.stiffness, cache=not args.rebuild)
    summary = model.summary()
    if args.json:
        import json
        print(json.dumps(summary, indent=2))
        return 0
    for key, value in summary.items():
        text = f'{value:.4g}' if isinstance(value, float) else value
        print(f'{key:22s} {text}')
    if not args.rebuild:
        print(f'{"cache_file":22s} {cache_path(args.resolution)}')
    return 0
