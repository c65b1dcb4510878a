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

"""`iguana bench adaptation`: terrain adaptation and spring lengths per frame (iguana_lab/bench/adaptation.py)."""
from __future__ import annotations

import argparse
import json


def register(sub: argparse._SubParsersAction) -> None:
    """Add the `adaptation` benchmark under `iguana bench`."""
    parser = sub.add_parser('adaptation', help='time terrain adaptation and DQS spring lengths per frame')
    parser.add_argument('--frames', type=int, default=150, help='frames of the trot per terrain (default 150)')
    parser.add_argument('--resolution', '-r', default='medium', help='coarse | medium (default) | fine')
    parser.add_argument('--json', action='store_true', help='print the figures as JSON')
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run the benchmark and print a table or JSON."""
    from iguana_lab.bench.adaptation import benchmark_adaptation

    result = benchmark_adaptation(args.frames, args.resolution)
    if args.json:
        print(json.dumps(result, indent=2))
        return 0
    print(f'{result["resolution"]} model: {result["n_nodes"]} nodes, {result["n_springs"]} springs; '
          f'{result["frames"]} trot frames per terrain; medians, ms per frame')
    for name, fig in result.items():
        if isinstance(fig, dict):
            print(f'{name:14s} plane fit {fig["plane_fit_ms"]:6.2f}  residual fit {fig["residual_fit_ms"]:6.2f} '
                  f'(p90 {fig["residual_fit_p90_ms"]:5.1f}, {fig["evaluations_median"]:.0f} evals)  '
                  f'soles {fig["align_soles_ms"]:5.2f}  adaptation {fig["adaptation_ms"]:5.2f} '
                  f'(p90 {fig["adaptation_p90_ms"]:5.2f})  '
                  f'DQS+lengths {fig["dqs_spring_lengths_ms"]:5.2f}  frame {fig["frame_ms"]:6.2f}  '
                  f'stance foot err max {fig["stance_foot_error_max_mm"]:.2f} mm  '
                  f'min clearance {fig["min_joint_clearance_mm"]:.3f} mm')
    return 0
