"""Builds the height field a scene names (flat, tilted plane, hills, steps, noise, height-map file)."""
from __future__ import annotations

import numpy as np

from iguana_ros.scene import TerrainSpec
from iguana_ros.terrain.heightfield import HeightField


def terrain_from_spec(spec: TerrainSpec) -> HeightField:
    """The HeightField of a scene's terrain; `spec.extent` is the side of the square (m), centred on 0."""
    half = spec.extent / 2.0
    if spec.kind == 'flat':
        return HeightField.flat(extent=half)
    if spec.kind == 'tilted':
        d = np.radians(spec.direction_deg)
        return HeightField.tilted_plane(spec.slope_deg, (np.cos(d), np.sin(d)), extent=half)
    if spec.kind == 'hills':
        return HeightField.hills(spec.amplitude, spec.wavelength, spec.seed, extent=half)
    if spec.kind == 'steps':
        return HeightField.steps(spec.block_size, spec.step_min, spec.step_max, spec.seed, extent=half,
                                 spacing=spec.spacing)
    if spec.kind == 'noise':
        return HeightField.noise(spec.amplitude, spec.wavelength, spec.seed, extent=half, spacing=spec.spacing)
    return HeightField.from_file(spec.file, scale=spec.scale, spacing=spec.spacing)
