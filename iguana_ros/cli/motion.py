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

"""`iguana motion`: inspect the clip library, export BVH, rebuild capture -> IK -> clips from a seed."""
from __future__ import annotations

import argparse


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the `motion` sub-command and its actions."""
    parser = subparsers.add_parser('motion', help='motion data: clip table, BVH export, rebuild from a seed')
    actions = parser.add_subparsers(dest='action', metavar='ACTION', required=True)
    inspect = actions.add_parser('inspect', help='print the clip table (and per-take IK residuals)')
    inspect.add_argument('--library', help='clip library .npz (default: the shipped one)')
    inspect.set_defaults(func=run_inspect)
    export = actions.add_parser('export-bvh', help='write a clip or a whole take as BVH (Blender-viewable)')
    export.add_argument('name', metavar='CLIP|TAKE')
    export.add_argument('-o', '--output', required=True, help='output .bvh file')
    export.add_argument('--repeat', type=int, default=1, help='play a clip this many strides in a row')
    export.add_argument('--library', help='clip library .npz (default: the shipped one)')
    export.set_defaults(func=run_export)
    build = actions.add_parser('build', help='regenerate synthetic C3D captures, IK and the clip library')
    build.add_argument('--seed', type=int, default=None, help='capture noise seed (default 2018)')
    build.add_argument('--capture-dir', help='where to write the .c3d takes (default: package data)')
    build.add_argument('--library', help='where to write clips.npz (default: next to the captures)')
    build.set_defaults(func=run_build)
    calibrate = actions.add_parser('calibrate', help='measure what the soft body achieves with each clip (level '
                                                     'ground, slopes) and write the tracking figures the planner uses')
    calibrate.add_argument('-o', '--output', help='tracking file to write (default: the shipped clip_tracking.json)')
    calibrate.add_argument('--workers', type=int, default=None, help='processes (default: one per core)')
    calibrate.add_argument('--fidelity', choices=('all', 'fast', 'balanced', 'accurate'), default='all',
                           help='the fidelity presets to measure (default all; the others in the file are kept)')
    calibrate.set_defaults(func=run_calibrate)


def run_inspect(args: argparse.Namespace) -> int:
    """Print one line per clip and per take."""
    import numpy as np

    from iguana_ros.motion.clips import default_library_path, load_clip_library

    library = load_clip_library(args.library)
    print(f'{"clip":12s} {"frames":>6s} {"stride m":>8s} {"turn deg":>8s} {"duty":>5s}  source')
    for clip in library.values():
        print(f'{clip.name:12s} {clip.n_frames:6d} {clip.stride_length:8.3f} '
              f'{np.degrees(clip.heading_change):8.1f} {clip.duty_factor:5.2f}  {clip.source} '
              f'frames {clip.metadata.get("start_frame")}..{clip.metadata.get("end_frame")}')
    _print_tracking(library if args.library is None else {})
    with np.load(args.library or default_library_path()) as data:
        takes = sorted({key.split('/')[1] for key in data.files if key.startswith('take/')})
        if takes:
            print(f'\n{"take":18s} {"frames":>6s} {"missing":>8s} {"IK mm RMS":>9s}')
        for take in takes:
            print(f'{take:18s} {len(data[f"take/{take}/theta"]):6d} '
                  f'{100 * float(data[f"take/{take}/missing_fraction"]):7.1f}% '
                  f'{float(data[f"take/{take}/marker_rms_mm"]):9.2f}')
    return 0


def run_export(args: argparse.Namespace) -> int:
    """Write the named clip (repeated) or take as BVH."""
    from iguana_ros.body.skeleton import iguana_skeleton
    from iguana_ros.constants import FRAME_RATE
    from iguana_ros.errors import InputError
    from iguana_ros.motion.bvh import write_bvh
    from iguana_ros.motion.clips import load_clip_library, load_take_motions, repeated_clip
    from iguana_ros.motion.dofs import iguana_active_dofs, local_rotations, root_positions

    dofs = iguana_active_dofs()
    library = load_clip_library(args.library)
    if args.name in library:
        roots, rotations = repeated_clip(library[args.name], max(args.repeat, 1))
    else:
        takes = load_take_motions(args.library)
        if args.name not in takes:
            raise InputError(f'no clip or take named {args.name!r}; clips: {", ".join(library)}; '
                             f'takes: {", ".join(takes)}')
        roots, rotations = root_positions(dofs, takes[args.name]), local_rotations(dofs, takes[args.name])
    write_bvh(args.output, iguana_skeleton(), roots, rotations, FRAME_RATE)
    print(f'wrote {args.output}: {len(roots)} frames')
    return 0


def run_build(args: argparse.Namespace) -> int:
    """Regenerate the capture, IK and clip library."""
    from iguana_ros.motion.build_library import DEFAULT_SEED, build_library

    clips, _ = build_library(seed=DEFAULT_SEED if args.seed is None else args.seed,
                             capture_dir=args.capture_dir, library_path=args.library)
    print(f'built {len(clips)} clips: {", ".join(clips)}')
    return 0


def _print_tracking(library: dict) -> None:
    """Print what the body achieves with each clip against the clip's own stride motion (shipped library only)."""
    import numpy as np

    from iguana_ros.motion.tracking import load_tracking, tracking_presets

    tracking = load_tracking().clips if library else {}
    if not tracking:
        return
    presets = tracking_presets()
    turns = {p: load_tracking(fidelity=p).clips for p in presets}
    print(f'\n{"tracking":12s} {"nominal dx dy m, turn deg":>26s} {"balanced, level ground":>26s} {"slip m":>7s} '
          f'{"strides":>7s}  uphill / downhill / across (dx m, turn deg)  turn deg {" / ".join(presets)}')
    for name in library:
        t = tracking.get(name)
        if t is None:
            continue
        by = ' / '.join(f'{t.by_terrain[k]["motion"][0]:.3f} {np.degrees(t.by_terrain[k]["motion"][2]):+.0f}'
                        if k in t.by_terrain else '-' for k in ('uphill', 'downhill', 'cross'))
        per = ' / '.join(f'{np.degrees(turns[p][name].level[2]):+.0f}' if name in turns[p] else '-' for p in presets)
        print(f'{name:12s} {t.nominal[0]:8.3f} {t.nominal[1]:7.3f} {np.degrees(t.nominal[2]):+8.1f}  '
              f'{t.level[0]:8.3f} {t.level[1]:7.3f} {np.degrees(t.level[2]):+8.1f}  {t.slip:7.3f} {t.samples:7d}  '
              f'{by:42s}  {per}')


def run_calibrate(args: argparse.Namespace) -> int:
    """Run the calibration tours of each fidelity preset asked for and write their tracking figures."""
    from iguana_ros.clip_calibration import calibrate, write_calibration
    from iguana_ros.motion.tracking import default_tracking_path

    path = args.output or default_tracking_path()
    presets = ('fast', 'balanced', 'accurate') if args.fidelity == 'all' else (args.fidelity,)
    for fidelity in presets:
        tracking, samples = calibrate(args.workers, fidelity)
        write_calibration(path, tracking, samples, fidelity, 'normal')
        print(f'wrote {path} ({fidelity}): {len(tracking.clips)} clips from {len(samples)} strides (heading carry-over '
              f'{tracking.carry:.2f})', flush=True)
    return 0
