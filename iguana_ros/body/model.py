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
The soft-body iguana model: mesh, masses, springs, stiffness, surface, tags, skin weights; cached on disk.

`build_model(resolution, stiffness)` returns a frozen `IguanaModel` of read-only arrays. The geometry of a
resolution is cached as `.npz` under `$IGUANA_CACHE_DIR`, else `$XDG_CACHE_HOME/iguana_ros`, else
`~/.cache/iguana_ros`, keyed by a hash of the resolution, a format version and the source text of every
module the geometry depends on; a changed input gives a new key, a corrupt file is rebuilt with a warning.
The stiffness preset is applied on load (it is cheap).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache
import hashlib
import os
from pathlib import Path
import time
import warnings

import numpy as np

from iguana_ros.body import mesh as mesh_mod
from iguana_ros.body.markers import iguana_markers, MarkerSet
from iguana_ros.body.mesh import (boundary_triangles, candidate_nodes, dihedral_angles, PART_LIMB0, PART_MAIN,
                                  radius_ratios, RESOLUTIONS, tet_volumes, tetrahedralize)
from iguana_ros.body.shape import BodyShape, iguana_shape, main_cross_section
from iguana_ros.body.skeleton import rest_joint_positions, Skeleton
from iguana_ros.body.skinning_weights import skin_weights
from iguana_ros.body.springs import spring_lengths, tet_springs
from iguana_ros.body.stiffness import (PRESETS, spring_stiffness, stiffness_preset, youngs_moduli)
from iguana_ros.constants import BODY_MASS
from iguana_ros.errors import InputError

FORMAT_VERSION = 1
"""Version of the cached geometry layout; bump it when the arrays change meaning."""
FOOT_CONTACT_HEIGHT = 0.004
"""Limb nodes lower than this (m) form the foot sole: the contact/friction region (soles lie on z = 0)."""

FLANK_FRACTION = 0.35
"""Trunk surface nodes with |y| above this fraction of the local half-width are flank (push) nodes."""
_SOURCES = ('shape.py', 'mesh.py', 'springs.py', 'skinning_weights.py', 'model.py', 'skeleton.py',
            'markers.py')
_GEOMETRY_KEYS = ('rest_positions', 'tets', 'node_part', 'node_mass', 'springs', 'spring_rest_lengths',
                  'surface_triangles', 'skin_bones', 'skin_weights', 'tag_names', 'tag_masks',
                  'build_seconds', 'iterations')
LIMB_TAGS = ('foot_fl', 'foot_fr', 'foot_hl', 'foot_hr')


@dataclass(frozen=True)
class IguanaModel:
    """
    Tetrahedral soft-body iguana in the rest pose (SI units, read-only arrays; see module docstring).

    rest_positions `(n_nodes, 3)` m; tets `(n_tets, 4)`; node_mass `(n_nodes,)` kg; springs `(n_springs, 2)`;
    spring_rest_lengths, spring_stiffness `(n_springs,)` m, N/m; youngs_modulus `(n_tets,)` Pa;
    surface_triangles `(n_tris, 3)` outward; node_tags name -> `(n_nodes,)` bool; skin_bones, skin_weights
    `(n_nodes, k)`; node_part `(n_nodes,)` (0 main body, 1..4 limbs fl, fr, hl, hr).
    """

    rest_positions: np.ndarray
    tets: np.ndarray
    node_mass: np.ndarray
    springs: np.ndarray
    spring_rest_lengths: np.ndarray
    spring_stiffness: np.ndarray
    youngs_modulus: np.ndarray
    poisson_ratio: float
    surface_triangles: np.ndarray
    node_tags: dict
    skin_bones: np.ndarray
    skin_weights: np.ndarray
    skeleton: Skeleton
    markers: MarkerSet
    resolution: str
    stiffness: str
    node_part: np.ndarray
    build_seconds: float
    from_cache: bool
    contact_offset: np.ndarray | None = None
    info: dict = field(default_factory=dict)

    @property
    def n_nodes(self) -> int:
        """Return number of mesh nodes."""
        return len(self.rest_positions)

    def summary(self) -> dict:
        """Return counts, worst element quality, mass, size and build time of the model."""
        p, t = self.rest_positions, self.tets
        dih = np.degrees(dihedral_angles(p, t))
        extent = p.max(axis=0) - p.min(axis=0)
        return {
            'resolution': self.resolution, 'stiffness': self.stiffness,
            'nodes': self.n_nodes, 'tets': len(t), 'springs': len(self.springs),
            'surface_triangles': len(self.surface_triangles),
            'min_dihedral_deg': float(dih.min()), 'max_dihedral_deg': float(dih.max()),
            'min_radius_ratio': float(radius_ratios(p, t).min()),
            'min_tet_volume_m3': float(tet_volumes(p, t).min()),
            'mass_kg': float(self.node_mass.sum()), 'length_m': float(extent[0]),
            'width_m': float(extent[1]), 'height_m': float(extent[2]),
            'tag_counts': {k: int(v.sum()) for k, v in self.node_tags.items()},
            'build_seconds': self.build_seconds, 'from_cache': self.from_cache,
            'repair_iterations': int(self.info.get('iterations', 0)),
        }


def build_model(resolution: str = 'medium', stiffness: str = 'normal', cache: bool = True) -> IguanaModel:
    """
    Return the iguana model at `resolution` (coarse|medium|fine|finer), stiffness preset `stiffness` (normal|softer).

    Cached in memory and on disk unless `cache` is False (then always rebuilt, nothing written).
    """
    if resolution not in RESOLUTIONS:
        raise InputError(f'unknown mesh resolution {resolution!r}; expected one of: {", ".join(RESOLUTIONS)}')
    stiffness_preset(stiffness)
    if not cache:
        return _assemble(build_geometry(resolution), resolution, stiffness, from_cache=False)
    return _cached_model(resolution, stiffness)


@lru_cache(maxsize=8)
def _cached_model(resolution: str, stiffness: str) -> IguanaModel:
    """Model from the disk cache (building and storing it on a miss)."""
    geometry, from_cache = load_or_build_geometry(resolution)
    return _assemble(geometry, resolution, stiffness, from_cache)


def cache_dir() -> Path:
    """Directory of the model cache: $IGUANA_CACHE_DIR, $XDG_CACHE_HOME/iguana_ros or ~/.cache/iguana_ros."""
    if os.environ.get('IGUANA_CACHE_DIR'):
        return Path(os.environ['IGUANA_CACHE_DIR'])
    base = os.environ.get('XDG_CACHE_HOME') or str(Path.home() / '.cache')
    return Path(base) / 'iguana_ros'


def cache_key(resolution: str) -> str:
    """Hex hash of the geometry's build inputs: resolution, format version, body module sources."""
    h = hashlib.sha256(f'{FORMAT_VERSION}:{resolution}:{RESOLUTIONS[resolution]}'.encode())
    here = Path(mesh_mod.__file__).parent
    for name in _SOURCES:
        h.update((here / name).read_bytes())
    return h.hexdigest()[:20]


def cache_path(resolution: str) -> Path:
    """File that holds (or will hold) the cached geometry of `resolution`."""
    return cache_dir() / f'model-{resolution}-{cache_key(resolution)}.npz'


def load_or_build_geometry(resolution: str) -> tuple:
    """(geometry dict, loaded_from_cache): read the cache file, else build and write it atomically."""
    path = cache_path(resolution)
    if path.exists():
        try:
            with np.load(path, allow_pickle=False) as data:
                geometry = {k: data[k] for k in _GEOMETRY_KEYS}
            _check_geometry(geometry)
            return geometry, True
        except Exception as exc:  # noqa: BLE001 - any unreadable cache file is rebuilt
            warnings.warn(f'model cache {path} is unreadable ({exc}); rebuilding it', stacklevel=2)
    geometry = build_geometry(resolution)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(f'.tmp{os.getpid()}.npz')
        np.savez(tmp, **geometry)
        os.replace(tmp, path)
    except OSError as exc:
        warnings.warn(f'could not write the model cache {path} ({exc}); continuing without it', stacklevel=2)
    return geometry, False


def _check_geometry(g: dict) -> None:
    """Raise ValueError if cached arrays are inconsistent or non-finite."""
    n = len(g['rest_positions'])
    if g['tets'].max() >= n or g['springs'].max() >= n or len(g['node_mass']) != n:
        raise ValueError('index out of range')
    if not all(np.all(np.isfinite(g[k])) for k in ('rest_positions', 'node_mass', 'skin_weights')):
        raise ValueError('non-finite values')


def build_geometry(resolution: str) -> dict:
    """Build every stiffness-independent array of the model at `resolution` (no cache)."""
    start = time.perf_counter()
    shape = iguana_shape()
    prm = RESOLUTIONS[resolution]
    tet_mesh = tetrahedralize(shape, candidate_nodes(shape, prm), prm.chord_tolerance,
                              prm.fill_rounds, max_iterations=prm.repair_iterations,
                              improve_rounds=prm.improve_rounds, improve_deg=prm.improve_deg)
    points, tets = tet_mesh.points, tet_mesh.tets
    springs = tet_springs(tets)
    bones, weights = skin_weights(shape, points, tet_mesh.part)
    surface = boundary_triangles(tets)
    tags = node_tags(shape, points, tet_mesh.part, surface)
    geometry = {
        'rest_positions': points, 'tets': tets, 'node_part': tet_mesh.part,
        'node_mass': lumped_masses(points, tets, BODY_MASS), 'springs': springs,
        'spring_rest_lengths': spring_lengths(points, springs), 'surface_triangles': surface,
        'skin_bones': bones, 'skin_weights': weights,
        'tag_names': np.array(list(tags)), 'tag_masks': np.array(list(tags.values())),
        'iterations': np.array(tet_mesh.iterations),
    }
    geometry['build_seconds'] = np.array(time.perf_counter() - start)
    return geometry


def lumped_masses(points: np.ndarray, tets: np.ndarray, total_mass: float) -> np.ndarray:
    """Node masses `(n_nodes,)` kg: a quarter of each tet's volume per vertex, scaled to `total_mass`."""
    vol = tet_volumes(points, tets)
    mass = np.bincount(tets.ravel(), weights=np.repeat(vol / 4.0, 4), minlength=len(points))
    return mass * (total_mass / mass.sum())


def node_tags(shape: BodyShape, points: np.ndarray, part: np.ndarray, surface: np.ndarray) -> dict:
    """Boolean node masks `(n_nodes,)`: feet soles per limb, feet, tail, trunk flanks, head, legs, ..."""
    sk = shape.skeleton
    joints = rest_joint_positions(sk)
    x_tail, x_neck = joints[sk.index('tail_1'), 0], joints[sk.index('neck'), 0]
    main = part == PART_MAIN
    on_surface = np.zeros(len(points), bool)
    on_surface[surface.ravel()] = True
    tags = {}
    for i, name in enumerate(LIMB_TAGS):
        tags[name] = (part == PART_LIMB0 + i) & (points[:, 2] < FOOT_CONTACT_HEIGHT)
    tags['feet'] = np.any([tags[n] for n in LIMB_TAGS], axis=0)
    tags['legs'] = part >= PART_LIMB0
    tags['tail'] = main & (points[:, 0] < x_tail)
    tags['head'] = main & (points[:, 0] > x_neck)
    tags['trunk'] = main & ~tags['tail'] & ~tags['head']
    _, ry, _ = main_cross_section(shape, points[:, 0])
    flank = tags['trunk'] & on_surface
    tags['trunk_left'] = flank & (points[:, 1] > FLANK_FRACTION * ry)
    tags['trunk_right'] = flank & (points[:, 1] < -FLANK_FRACTION * ry)
    tags['surface'] = on_surface
    return tags


def sole_pad_offsets(rest_positions: np.ndarray, sole: np.ndarray) -> np.ndarray:
    """
    Contact offsets `(n_nodes,)` m: each sole node's rest height above z = 0, zero elsewhere.

    A foot pad: every sole node touches the ground at the sole plane. The mesh puts only 2-3 of a foot's 7-10
    sole nodes on z = 0 and the rest 2-4 mm above, so without it a loaded foot stands on two or three points.
    """
    offset = np.zeros(len(rest_positions))
    offset[sole] = np.maximum(rest_positions[sole, 2], 0.0)
    return offset


def _assemble(g: dict, resolution: str, stiffness: str, from_cache: bool) -> IguanaModel:
    """Freeze the geometry arrays and add the stiffness of `stiffness`."""
    preset = PRESETS[stiffness]
    legs = g['node_part'] >= PART_LIMB0
    arrays = {k: np.array(g[k]) for k in ('rest_positions', 'tets', 'node_mass', 'springs',
                                          'spring_rest_lengths', 'surface_triangles', 'skin_bones',
                                          'skin_weights', 'node_part')}
    arrays['spring_stiffness'] = spring_stiffness(preset, arrays['spring_rest_lengths'], arrays['springs'], legs)
    arrays['youngs_modulus'] = youngs_moduli(preset, arrays['tets'], legs)
    tags = {str(k): np.array(m, dtype=bool) for k, m in zip(g['tag_names'], g['tag_masks'])}
    arrays['contact_offset'] = sole_pad_offsets(arrays['rest_positions'], tags['feet'])
    for arr in list(arrays.values()) + list(tags.values()):
        arr.setflags(write=False)
    shape = iguana_shape()
    return IguanaModel(**arrays, poisson_ratio=preset.poisson_ratio, node_tags=tags, skeleton=shape.skeleton,
                       markers=iguana_markers(), resolution=resolution, stiffness=stiffness,
                       build_seconds=float(g['build_seconds']), from_cache=from_cache,
                       info={'iterations': int(g['iterations'])})
