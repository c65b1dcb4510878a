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

"""Stability at the extremes: scenarios that must stay finite and bounded or stop with `SimulationDiverged`."""
from __future__ import annotations

from dataclasses import fields

import numpy as np

from iguana_ros.constants import MAX_NODE_SPEED
from iguana_ros.physics.errors import SimulationDiverged
from iguana_ros.physics.meshes import SoftBodyMesh, tet_volumes
from iguana_ros.physics.pushes import region_force
from iguana_ros.physics.simulator import SoftBodySimulator
from iguana_ros.terrain.heightfield import HeightField
from iguana_ros.terrain.placement import place_on_terrain

REST_DEPTH_LIMIT = 0.01
"""A stable run ends with no node deeper than this below the terrain, m."""

SCENARIOS = {
    'baseline': {},
    'springs x0.01': {'spring_scale': 0.01},
    'springs x100': {'spring_scale': 100.0},
    'E 1e3 Pa': {'youngs': 1e3},
    'E 1e8 Pa': {'youngs': 1e8},
    'dt 1/4800': {'dt': 1 / 4800},
    'dt 1/60': {'dt': 1 / 60},
    'push 1000 N': {'push': 1000.0},
    'drop 1 m': {'drop': 1.0},
    'slope 45 deg': {'slope': 45.0},
    'inverted start': {'inverted': True},
    'springs x100, dt 1/60': {'spring_scale': 100.0, 'dt': 1 / 60},
    'E 1e8 Pa, dt 1/60': {'youngs': 1e8, 'dt': 1 / 60},
    'E 1e3 Pa, springs x0.01, drop 1 m': {'youngs': 1e3, 'spring_scale': 0.01, 'drop': 1.0},
    'push 1000 N, dt 1/60': {'push': 1000.0, 'dt': 1 / 60},
    'E 1e8 Pa, springs x100, slope 45 deg': {'youngs': 1e8, 'spring_scale': 100.0, 'slope': 45.0},
}
"""Named scenarios: spring stiffness ×0.01…×100, E 1e3…1e8 Pa, dt 1/4800…1/60, 1 kN push, 1 m drop,
45° slope, inverted elements at the start, and combinations of the extremes."""


def with_material(model, spring_scale: float = 1.0, youngs: float | None = None) -> SoftBodyMesh:
    """Return a copy of `model` with spring stiffness × `spring_scale` and (if given) a uniform Young's modulus."""
    values = {f.name: getattr(model, f.name) for f in fields(SoftBodyMesh)}
    values['spring_stiffness'] = np.asarray(model.spring_stiffness, dtype=float) * spring_scale
    if youngs is not None:
        values['youngs_modulus'] = np.full(len(model.tets), float(youngs))
    return SoftBodyMesh(**values)


def inverted_start(model, n_nodes: int = 3) -> np.ndarray:
    """Rest positions with the `n_nodes` highest nodes mirrored through the opposite face of one of their tets."""
    x = np.array(model.rest_positions, dtype=float)
    tets = np.asarray(model.tets)
    for node in np.argsort(-x[:, 2])[:n_nodes]:                   # a handful of nodes, once, at setup
        t, slot = np.argwhere(tets == node)[0]
        face = x[np.delete(tets[t], slot)]
        normal = np.cross(face[1] - face[0], face[2] - face[0])
        normal /= np.linalg.norm(normal)
        x[node] -= 1.5 * ((x[node] - face[0]) @ normal) * normal
    return x


PERSIST_FRAMES = 6
"""Frames (0.2 s) at the end of a scenario over which a tet counts as staying inverted: a sliver of a 1 kPa body with
springs x0.01 flips in and out while it rests on the ground after a drop (0-6 inverted in most frames, whatever the
settings); a tet inverted in every one of them did not recover."""


def run_scenario(model, name: str, seconds: float = 1.5, preset='balanced') -> dict:
    """Run scenario `name` on `model`; outcome 'stable' (with bounds measured) or 'diverged' (with the cause)."""
    spec = SCENARIOS[name]
    body = with_material(model, spec.get('spring_scale', 1.0), spec.get('youngs'))
    terrain = HeightField.tilted_plane(spec['slope']) if 'slope' in spec else HeightField.flat()
    overrides = {'dt': spec['dt']} if 'dt' in spec else {}
    sim = SoftBodySimulator(body, terrain, preset, **overrides)
    start = inverted_start(body) if spec.get('inverted') else np.array(body.rest_positions, dtype=float)
    start = place_on_terrain(start, terrain, clearance=spec.get('drop', 0.001))
    sim.reset(start)
    result = {'scenario': name, 'inverted_tets_at_start': int(np.sum(tet_volumes(start, body.tets) <= 0))}
    max_speed = 0.0
    persisting = np.ones(len(body.tets), dtype=bool)
    try:
        push = _push_forces(body, spec.get('push', 0.0))
        n_frames = int(round(seconds * 30))
        for frame in range(n_frames):  # one call per 1/30 s frame
            sim.advance_frame(None, push if (push is not None and frame < 3) else None)   # 3 frames = 0.1 s
            max_speed = max(max_speed, float(np.sqrt((sim.velocities ** 2).sum(axis=1)).max()))
            if frame >= n_frames - PERSIST_FRAMES:
                persisting &= tet_volumes(sim.positions, body.tets) <= 0
    except SimulationDiverged as exc:
        return {**result, 'outcome': 'diverged', 'cause': exc.cause, 'message': str(exc), 'max_speed': max_speed}
    x = sim.positions
    depth = terrain.height(x[:, :2]) - x[:, 2]
    return {**result, 'outcome': 'stable', 'cause': None, 'max_speed': max_speed,
            'final_speed': float(np.sqrt((sim.velocities ** 2).sum(axis=1)).max()),
            'final_max_depth': float(depth.max()), 'inverted_tets_at_end': int(np.sum(tet_volumes(x, body.tets) <= 0)),
            'inverted_tets_persisting': int(np.sum(persisting)),
            'finite': bool(np.all(np.isfinite(x))), 'speed_bound': MAX_NODE_SPEED}


def _push_forces(model, total: float):
    """`total` N to the right (−y) spread by mass over the left-flank nodes, or None."""
    if total == 0.0:
        return None
    tags = model.node_tags
    mask = tags['trunk_left'] if 'trunk_left' in tags else tags['left']
    return region_force(model.node_mass, mask, (0.0, -total, 0.0))
