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
`iguana bench statics`: why a model variant does or does not trot (iguana_lab.diagnostics), measured.

Support margins of the forward clip, standing sag (idle pose and a held two-foot pose), spring bending
capacity, planted feet in `flat_walk`; a readable report, or with --json one object (non-finite numbers as
null). Lengths are printed in mm, the JSON keeps SI units.
"""
from __future__ import annotations

import argparse
import json
import math
import time

from iguana_ros.cli.argtypes import positive


def register(sub) -> None:
    """Add `statics` to the `bench` sub-commands."""
    statics = sub.add_parser('statics', help='support margins, standing sag, spring capacity and planted feet '
                                             'of a model variant: why it does or does not trot')
    statics.add_argument('--mesh', choices=('coarse', 'medium', 'fine'), default='medium')
    statics.add_argument('--stiffness', choices=('normal', 'softer'), default='normal', help='stiffness preset')
    statics.add_argument('--spring-scale', type=positive('spring scale'), default=1.0,
                         help="multiply every spring's stiffness by this (default 1)")
    statics.add_argument('--leg-factor', type=positive('leg factor'), default=None,
                         help="replace the preset's leg factor (leg-leg springs; leg-trunk get its square root)")
    statics.add_argument('--seconds', type=positive('seconds'), default=4.0,
                         help='simulated seconds of the flat_walk run; each standing run lasts half (default 4)')
    statics.add_argument('--json', action='store_true', help='print one JSON object')
    statics.set_defaults(func=run_statics)


def run_statics(args: argparse.Namespace) -> int:
    """`iguana bench statics`."""
    from iguana_ros.body.model import build_model
    from iguana_lab.diagnostics import model_variant, statics_report

    start = time.perf_counter()
    model = model_variant(build_model(args.mesh, args.stiffness), args.spring_scale, args.leg_factor)
    report = statics_report(model, sag_seconds=args.seconds / 2.0, walk_seconds=args.seconds)
    report['wall_s']['total'] = time.perf_counter() - start
    if args.json:
        print(json.dumps(_jsonable(report), indent=1))
    else:
        print(format_report(report))
    return 0


def _jsonable(value):
    """`value` with NaN / infinite floats as None (JSON has no NaN), recursively through dicts and lists."""
    if isinstance(value, dict):
        return {k: _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def _mm(value: float, width: int = 6) -> str:
    """Metres as mm with one decimal, right-aligned in `width` ('-' when not finite)."""
    return f'{1e3 * value:{width}.1f}' if math.isfinite(value) else '-'.rjust(width)


def _num(value: float, fmt: str, width: int) -> str:
    """`value` formatted, right-aligned in `width` ('-' when not finite)."""
    return format(value, fmt).rjust(width) if math.isfinite(value) else '-'.rjust(width)


def format_report(report: dict) -> str:
    """Return the readable text of a `diagnostics.statics_report`."""
    m = report['model']
    lines = [f"{m['resolution']} mesh ({m['nodes']} nodes, {m['springs']} springs), preset {m['stiffness']}: "
             f"A = {m['spring_a_n_per_m'] / 1e3:g} kN/m at 2 cm, leg factor x{m['leg_factor']:g}, "
             f"{m['mass_kg']:.2f} kg", '']
    lines += _support_lines(report['support']) + [''] + _sag_lines(report['sag'], report['sag_diagonal'])
    lines += [''] + _spring_lines(report['springs']) + [''] + _planted_lines(report['planted']) + ['']
    wall = report['wall_s']
    lines.append('wall time: ' + ', '.join(f'{k} {v:.1f} s' for k, v in wall.items()))
    return '\n'.join(lines)


def _support_lines(s: dict) -> list:
    """Support-margin lines."""
    rows = s['rows']
    load = s['tail_load_median_n']
    return [
        f"Support margins, clip {s['clip']!r} ({s['diagonal_frames']} of {s['frames']} frames in a diagonal "
        f"two-foot phase): the COM lies {_mm(s['distance_mean_m'], 0)} mm (min {_mm(s['distance_min_m'], 0)}, "
        f"max {_mm(s['distance_max_m'], 0)}) outside the line between the stance feet, toward the swinging hind "
        f'foot (+ = the body rolls onto it).',
        f"  inside the triangle of the stance feet and the tail's lowest point in "
        f"{_num(100 * s['inside_tail_triangle_fraction'], '.0f', 0)} % of those frames; tail load needed for "
        f"balance {_num(load, '.1f', 0)} N median ({_num(100 * load / s['weight_n'], '.0f', 0)} % of the "
        f"{s['weight_n']:.1f} N weight)",
        '  frame stance  distance mm  tail lever mm  tail load N  in triangle',
    ] + [f"  {r['frame']:5d} {r['stance']:6s} {_mm(r['distance_m'], 12)} {_mm(r['tail_lever_m'], 14)} "
         f"{_num(r['tail_load_n'], '.2f', 12)}  {'yes' if r['inside_tail_triangle'] else 'no'}" for r in rows]


def _sag_lines(idle: dict, diagonal: dict) -> list:
    """Standing-sag lines: both runs side by side."""
    stance = '+'.join(n for n, on in zip(('fl', 'fr', 'hl', 'hr'), diagonal['stance']) if on)
    lines = [f'Standing sag: vertical offset from the reference mesh of the held pose (mm, - = lower), mean over '
             f"the last {idle['window_s']:.2f} s of {idle['seconds']:.1f} s",
             f"  {'region':12s} {'idle, 4 feet':>13s} {diagonal['clip'] + ' frame ' + str(diagonal['frame']):>17s}"
             f' ({stance} stance)']
    for region, value in idle['offset_m'].items():
        lines.append(f"  {region:12s} {_mm(value, 13)} {_mm(diagonal['offset_m'][region], 17)}")
    lines.append(f"  {'ground load N':16s}" + ''.join(f"{name.replace('foot_', ''):>7s}"
                                                      for name in idle['ground_load_n']))
    for label, run in (('idle', idle), ('diagonal', diagonal)):
        lines.append(f'  {label:16s}' + ''.join(f'{v:7.1f}' for v in run['ground_load_n'].values()))
    return lines


def _spring_lines(rows: list) -> list:
    """Spring-capacity lines."""
    lines = ['Spring bending capacity at 1 % strain across vertical planes, against the gravity moment of the '
             'part beyond (all springs | main-body springs only):',
             f"  {'plane':10s} {'x mm':>6s} {'beyond':>6s} {'gravity N m':>11s} {'springs':>7s} {'N m @1%':>8s} "
             f"{'strain %':>9s} | {'springs':>7s} {'N m @1%':>8s} {'strain %':>9s}"]
    for r in rows:
        lines.append(f"  {r['plane']:10s} {_mm(r['x_m'], 6)} {r['far_side']:>6s} {r['gravity_moment_nm']:11.3f} "
                     f"{r['springs']:7d} {r['spring_moment_nm']:8.2f} {_num(r['required_strain_percent'], '.4f', 9)}"
                     f" | {r['main_body_springs']:7d} {r['main_body_spring_moment_nm']:8.2f} "
                     f"{_num(r['main_body_required_strain_percent'], '.4f', 9)}")
    return lines


def _planted_lines(p: dict) -> list:
    """Planted-feet lines."""
    lines = [f"Planted feet, {p['scene']} {p['seconds']:.1f} s ({p['frames']} frames after {p['settle_s']:.1f} s), "
             'in the frames the clip says stance:',
             f"  {'foot':4s} {'stance':>6s} {'soles in contact':>16s} {'none':>5s} {'F_n mean N':>10s} {'F_n CV':>6s} "
             f"{'at friction limit':>17s} {'load in swing N':>15s}"]
    for foot, f in p['feet'].items():
        contact = f"{_num(f['sole_nodes_in_contact_mean'], '.1f', 0)} of {f['sole_nodes']}"
        lines.append(f"  {foot[-2:]:4s} {f['stance_frames']:6d} {contact:>16s} "
                     f"{_num(100 * f['no_contact_fraction'], '.0f', 4)}% {_num(f['normal_force_mean_n'], '.1f', 10)} "
                     f"{_num(f['normal_force_cv'], '.2f', 6)} {_num(100 * f['friction_limit_fraction'], '.0f', 16)}% "
                     f"{_num(f['swing_load_mean_n'], '.2f', 15)}")
    return lines
