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
Image and animation writers.

PNG (one frame), GIF (Pillow, one median-cut palette) and MP4 (H.264, imageio-ffmpeg).
"""
from __future__ import annotations

from collections.abc import Iterable
import itertools
from pathlib import Path

import numpy as np

from iguana_ros.errors import InputError

EXTENSIONS = ('.png', '.gif', '.mp4')
"""Output formats of `iguana render`, by file extension."""

KEY_COLOR_ROWS = 12
"""Rows of each key colour appended to the frame a GIF palette is built from."""

MP4_QUALITY = 7
"""imageio-ffmpeg quality for libx264 (0-10, 10 best)."""


def output_kind(path: str | Path) -> str:
    """'png', 'gif' or 'mp4' from the extension of `path`; InputError naming the file otherwise."""
    suffix = Path(path).suffix.lower()
    if suffix not in EXTENSIONS:
        raise InputError(f'output {path} has extension {suffix or "(none)"!r}; expected one of '
                         f'{", ".join(EXTENSIONS)}')
    return suffix[1:]


def gif_durations_ms(n_frames: int, fps: float) -> list[int]:
    """Per-frame GIF delays (ms, multiples of 10) whose running sum tracks frame k at k / fps seconds."""
    edges = np.round(np.arange(n_frames + 1) * 100.0 / fps) * 10.0
    return [max(10, int(d)) for d in np.diff(edges)]


def write_png(path: str | Path, image: np.ndarray) -> Path:
    """Write one uint8 RGB image `(H, W, 3)` as PNG; returns the path."""
    from PIL import Image

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(image).save(path, optimize=True)
    return path


def gif_palette(first: np.ndarray, key_colors: Iterable = ()):
    """
    Return a median-cut 256-colour palette image for a whole GIF.

    The first frame `(H, W, 3)` uint8 plus a block of each of `key_colors` (RGB in [0, 1]: trail, goals) so rare colours
    keep an entry.
    """
    from PIL import Image

    blocks = [np.broadcast_to(np.round(np.asarray(c, dtype=float)[:3] * 255).astype(np.uint8),
                              (KEY_COLOR_ROWS, first.shape[1], 3)) for c in key_colors]
    return Image.fromarray(np.concatenate([first, *blocks], axis=0)).quantize(256, method=Image.Quantize.MEDIANCUT)


def write_gif(path: str | Path, frames: Iterable[np.ndarray], fps: float, key_colors: Iterable = ()) -> int:
    """Write uint8 RGB frames `(H, W, 3)` as a looping GIF at `fps` with one shared palette; returns the count."""
    from PIL import Image

    stream = iter(frames)
    first = next(stream, None)
    if first is None:
        raise InputError(f'no frames to write to {path}')
    palette = gif_palette(first, key_colors)
    images = [Image.fromarray(f).quantize(palette=palette, dither=Image.Dither.NONE)
              for f in itertools.chain([first], stream)]
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    images[0].save(path, save_all=True, append_images=images[1:], loop=0,
                   duration=gif_durations_ms(len(images), fps), disposal=1, optimize=True)
    return len(images)


def write_mp4(path: str | Path, frames: Iterable[np.ndarray], fps: float) -> int:
    """Write uint8 RGB frames `(H, W, 3)` (even H and W) as H.264 MP4 at `fps`; returns the number of frames."""
    import imageio_ffmpeg

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    writer = None
    count = 0
    try:
        for frame in frames:
            if writer is None:
                h, w = frame.shape[:2]
                if h % 2 or w % 2:
                    raise InputError(f'MP4 frames must have an even width and height, got {w}x{h}')
                writer = imageio_ffmpeg.write_frames(str(path), (w, h), fps=fps, codec='libx264',
                                                     pix_fmt_out='yuv420p', quality=MP4_QUALITY,
                                                     macro_block_size=1, ffmpeg_log_level='error')
                writer.send(None)
            writer.send(np.ascontiguousarray(frame))
            count += 1
    finally:
        if writer is not None:
            writer.close()
    if count == 0:
        raise InputError(f'no frames to write to {path}')
    return count
