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
`iguana render BAG -o FILE.gif|.mp4|.png`: headless rendering of a recorded run (mesh, terrain, goal, trail).

A world's bag: every character is drawn, the cameras follow the first by name or `--character NAME`.
"""
from __future__ import annotations

import argparse
import math

DEFAULT_FPS = 15.0
DEFAULT_SIZE = '640x400'
CAMERAS = ('follow', 'side', 'top', 'orbit')  # iguana_ros.render.camera.PRESETS (not imported: keeps --help fast)
FRAME_TOLERANCE_S = 0.5
"""`--frame T` fails when the nearest recorded frame is further than this from T (s)."""


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the `render` sub-command."""
    p = subparsers.add_parser('render', help='render a recorded run to a PNG frame, a GIF or an MP4',
                              description='Draw the iguana surface (mesh_marker) on the terrain and goal '
                                          '(scene_markers) with the root trail (iguana_state), headless; of '
                                          'a world, every character.')
    p.add_argument('bag', metavar='BAG', help='bag directory or .mcap file')
    p.add_argument('-o', '--output', required=True, metavar='FILE', help='output .png (one frame), .gif or .mp4')
    p.add_argument('--camera', default=CAMERAS[0], choices=CAMERAS,
                   help='follow (default: behind-left, above, tracking the root), side, top (static, whole '
                        'run), orbit (circles the root)')
    p.add_argument('--character', default=None, metavar='NAME',
                   help="a world's bag: the character the cameras follow and whose frame times are rendered "
                        '(default: the first by name; every character is drawn, the followed one with the orange '
                        'trail)')
    p.add_argument('--fps', type=float, default=DEFAULT_FPS, metavar='F',
                   help=f'frames per second of the animation, subsampling the recording (default {DEFAULT_FPS:g})')
    p.add_argument('--start', type=float, default=0.0, metavar='S', help='first second to render (default 0)')
    p.add_argument('--end', type=float, default=math.inf, metavar='S', help='last second to render (default: end)')
    p.add_argument('--size', default=DEFAULT_SIZE, metavar='WxH', help=f'image size in pixels (default {DEFAULT_SIZE})')
    p.add_argument('--frame', type=float, default=None, metavar='T',
                   help='.png only: the frame nearest T seconds (default: the last frame)')
    p.add_argument('--no-trail', action='store_true', help='do not draw the path of the root')
    p.add_argument('--allow-damaged', action='store_true',
                   help='render the frames of every intact chunk of a damaged or truncated bag (default: exit 1)')
    p.add_argument('--quiet', '-q', action='store_true', help='no progress bars')
    p.set_defaults(func=run)


def parse_size(text: str, even: bool = False) -> tuple[int, int]:
    """(width, height) from 'WxH' (16..4096 each; rounded up to even numbers if `even`); InputError otherwise."""
    from iguana_ros.errors import InputError

    parts = text.lower().split('x')
    if len(parts) != 2 or not all(p.strip().isdigit() for p in parts):
        raise InputError(f'--size {text!r} is not of the form WIDTHxHEIGHT, e.g. 640x400')
    w, h = (int(p) for p in parts)
    if not (16 <= w <= 4096 and 16 <= h <= 4096):
        raise InputError(f'--size {text}: width and height must be within 16..4096 pixels')
    return (w + w % 2, h + h % 2) if even else (w, h)


def _check_times(args: argparse.Namespace) -> None:
    """`InputError` for a non-finite or non-positive --fps, or a bad --start/--end/--frame."""
    from iguana_ros.errors import InputError

    if not (math.isfinite(args.fps) and args.fps > 0):
        raise InputError(f'--fps is {args.fps}; expected a positive number of frames per second')
    if not (math.isfinite(args.start) and args.start >= 0) or math.isnan(args.end) or args.end <= args.start:
        raise InputError(f'--start {args.start} / --end {args.end}: expected 0 <= start < end seconds')
    if args.frame is not None and not (math.isfinite(args.frame) and args.frame >= 0):
        raise InputError(f'--frame is {args.frame}; expected a time in seconds >= 0')


def _progress_bar(desc: str, quiet: bool, total: int | None = None, unit: str = 'frame'):
    """Return a tqdm bar on stderr (disabled when quiet or when stderr is not a terminal)."""
    from tqdm import tqdm
    return tqdm(total=total, desc=desc, unit=unit, disable=True if quiet else None, leave=False,
                dynamic_ncols=True)


def run(args: argparse.Namespace) -> int:
    """Read the bag, render the frames, write the file; print one summary line."""
    import time

    from iguana_ros.errors import InputError
    from iguana_ros.render.output import output_kind

    kind = output_kind(args.output)
    _check_times(args)
    if args.frame is not None and kind != 'png':
        raise InputError('--frame selects the frame of a .png output; for .gif/.mp4 use --start/--end')
    size = parse_size(args.size, even=(kind == 'mp4'))
    t0 = time.perf_counter()
    recorded = _read(args, kind)
    images, fps = _render(args, recorded, size)
    path, count = _write(args.output, kind, images, fps, _key_colors(recorded))
    print(f'{path}: {count} frame(s) {size[0]}x{size[1]}, camera {args.camera}'
          + (f', {fps:.3g} fps, {recorded.times[0]:.2f}-{recorded.times[-1]:.2f} s' if kind != 'png'
             else f', t = {recorded.times[0]:.2f} s')
          + f' from {recorded.mesh_topic}{_cast(recorded)} in {time.perf_counter() - t0:.1f} s')
    return 0


def _cast(recorded) -> str:
    """Return what the summary line adds for a world ('' for a lone iguana): the followed character and the others."""
    if not recorded.others:
        return ''
    return f' (following {recorded.character}; also drawn: {", ".join(o.name for o in recorded.others)})'


def _read(args: argparse.Namespace, kind: str):
    """Return the RecordedRun of the bag for the requested output."""
    import sys

    from iguana_ros.bag.frames import read_run
    from iguana_ros.errors import InputError

    with _progress_bar('reading', args.quiet, unit='msg') as bar:
        def progress(n: int, total: int) -> None:
            bar.total = total
            bar.update(n - bar.n)

        if kind == 'png':
            at = math.inf if args.frame is None else args.frame
            recorded = read_run(args.bag, at=at, progress=progress, character=args.character)
        else:
            recorded = read_run(args.bag, fps=args.fps, start=args.start, end=args.end, progress=progress,
                                character=args.character)
    if recorded.damage and not args.allow_damaged:
        from iguana_ros.bag.storage import DamagedBag
        raise DamagedBag(f'{recorded.damage}; --allow-damaged renders what was recovered')
    for note in recorded.notes:
        print(f'iguana render: note: {note}', file=sys.stderr)
    if kind == 'png' and args.frame is not None and abs(recorded.times[0] - args.frame) > FRAME_TOLERANCE_S:
        raise InputError(f'--frame {args.frame:g} s is outside the run (0 to {recorded.duration:.2f} s)')
    return recorded


def _render(args: argparse.Namespace, recorded, size: tuple[int, int]):
    """Yield (generator of uint8 frames with a progress bar, frames per second of the output)."""
    from iguana_ros.render.camera import preset_cameras
    from iguana_ros.render.renderer import Renderer

    cameras = preset_cameras(args.camera, recorded.times, recorded.root_positions, recorded.root_yaws,
                             recorded.extent_points(), size[0] / size[1])
    renderer = Renderer(recorded, *size, trail=not args.no_trail)
    fps = args.fps
    if recorded.n_frames > 1:  # recording sparser than --fps: play at the recorded pace
        mean_dt = float(recorded.times[-1] - recorded.times[0]) / (recorded.n_frames - 1)
        if mean_dt > 1.05 / fps:
            fps = 1.0 / mean_dt

    def frames():
        with _progress_bar('rendering', args.quiet, total=recorded.n_frames) as bar:
            for image in renderer.frames(cameras):
                bar.update(1)
                yield image
    return frames(), fps


def _key_colors(recorded) -> list:
    """Colours a GIF palette must hold although they cover few pixels: the trail and shaded goal colours."""
    from iguana_ros.render.renderer import AMBIENT, OTHER_TRAIL_RGB, TRAIL_RGB

    colors = [TRAIL_RGB] + ([OTHER_TRAIL_RGB] if recorded.others else [])
    for goals in recorded.goals:
        for rgba in goals.colors:
            colors += [tuple(rgba[:3] * f) for f in (AMBIENT, 0.7, 1.0)]
    return colors


def _write(output: str, kind: str, images, fps: float, key_colors: list):
    """Write the frames; (path, number of frames)."""
    from iguana_ros.render.output import write_gif, write_mp4, write_png

    if kind == 'png':
        return write_png(output, next(iter(images))), 1
    if kind == 'gif':
        return output, write_gif(output, images, fps, key_colors)
    return output, write_mp4(output, images, fps)
