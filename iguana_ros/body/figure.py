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

"""Picture of the iguana model: surface mesh, skeleton and markers seen from the side and from above."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from iguana_ros.body.markers import marker_positions
from iguana_ros.body.skeleton import bone_segments, rest_joint_positions
from iguana_ros.errors import InputError

_VIEWS = (('side (x forward, z up)', 0, 2, 1), ('top (x forward, y left)', 0, 1, 2))


def render_model(model, path: str | Path, dpi: int = 110) -> Path:
    """Draw `model` (an IguanaModel) to the image file `path` (.png/.jpg/.pdf/.svg); returns the path."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    from matplotlib.collections import LineCollection, PolyCollection

    path = Path(path)
    if path.suffix.lower() not in ('.png', '.jpg', '.jpeg', '.pdf', '.svg'):
        raise InputError(f'render output {path} must end in .png, .jpg, .pdf or .svg')
    p = model.rest_positions
    tris = model.surface_triangles
    joints = rest_joint_positions(model.skeleton)
    segs, _ = bone_segments(model.skeleton, joints)
    root, local = model.skeleton.rest_pose()
    markers = marker_positions(model.skeleton, model.markers, root, local)
    fig, axes = plt.subplots(2, 1, figsize=(10, 6.4), constrained_layout=True)
    for ax, (title, a, b, depth) in zip(axes, _VIEWS):
        order = np.argsort(p[tris, depth].mean(axis=1))
        if depth == 1:
            order = order[::-1]  # side view from the right (-y): draw far (left) triangles first
        shade = _shade(p, tris[order], depth, toward=-1.0 if depth == 1 else 1.0)
        ax.add_collection(PolyCollection(p[tris[order]][:, :, [a, b]], facecolors=plt.cm.Greens(shade),
                                         edgecolors=(0.1, 0.3, 0.1, 0.35), linewidths=0.3))
        ax.add_collection(LineCollection(segs[:, :, [a, b]], colors='#5a2d0c', linewidths=1.6))
        ax.plot(joints[:, a], joints[:, b], 'o', ms=2.5, color='#5a2d0c')
        ax.plot(markers[:, a], markers[:, b], 'o', ms=5, color='#d62728', mec='k', mew=0.5)
        feet = model.node_tags['feet']
        ax.plot(p[feet, a], p[feet, b], 's', ms=2.5, color='#1f77b4')
        ax.set_aspect('equal')
        ax.autoscale_view()
        ax.set_title(title, fontsize=9)
        ax.set_xlabel('x (m)', fontsize=8)
        ax.set_ylabel('zy'[depth == 2] + ' (m)', fontsize=8)
        ax.tick_params(labelsize=7)
    s = model.summary()
    fig.suptitle(f"iguana model '{model.resolution}': {s['nodes']} nodes, {s['tets']} tets, "
                 f"{s['springs']} springs, min dihedral {s['min_dihedral_deg']:.1f} deg  "
                 f'(red: markers, brown: skeleton, blue: sole nodes)', fontsize=9)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return path


def _shade(points: np.ndarray, tris: np.ndarray, depth: int, toward: float) -> np.ndarray:
    """Lambert-like shade in [0.25, 0.75] `(n_tris,)` of triangles facing the viewer along axis `depth`."""
    a, b, c = (points[tris[:, k]] for k in range(3))
    n = np.cross(b - a, c - a)
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    return 0.25 + 0.5 * np.clip(toward * n[:, depth], 0.0, 1.0)
