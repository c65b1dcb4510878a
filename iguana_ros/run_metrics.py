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

"""Locomotion metrics of a pipeline run: landmarks of the soft body (node groups by bone) -> metrics."""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from iguana_ros.body.feet import contact_offsets, foot_groups, foot_heights, foot_probe, group_centroids, skinned_meshes
from iguana_ros.body.model import build_model
from iguana_ros.body.spring_lengths import SpringLengthComputer
from iguana_ros.geometry import quat_from_yaw, quat_rotate, yaw_of
from iguana_ros.metrics import (gait_metrics, GaitMetrics, goal_arrival, locomotion_metrics, LocomotionMetrics, N_FEET,
                                rigid_fit_errors)
from iguana_ros.scene import terrain_from_spec

TRUNK = ('pelvis', 'spine_3', 'spine_5')
LIMB_CHAINS = (('shoulder_fl', 'elbow_fl', 'wrist_fl'), ('shoulder_fr', 'elbow_fr', 'wrist_fr'),
               ('hip_hl', 'knee_hl', 'ankle_hl'), ('hip_hr', 'knee_hr', 'ankle_hr'), ('pelvis', 'spine_5'))
"""Bone groups whose consecutive landmark distances should barely change (Section IX)."""


def bone_node_groups(model, bones: tuple) -> list[np.ndarray]:
    """Return indices of the nodes skinned mostly to each bone of `bones`."""
    dominant = model.skin_bones[np.arange(model.n_nodes), np.argmax(model.skin_weights, axis=1)]
    return [np.flatnonzero(dominant == model.skeleton.index(b)) for b in bones]


def metrics_of_run(result, scene, library: dict | None = None) -> LocomotionMetrics:
    """
    Return the LocomotionMetrics of a RunResult for the last goal of `scene` (no goal: none reached, no distance).

    The gait figures are against the reference (clips from `library`, default the shipped clip library); foot slip per
    stride (four feet summed) is that of the walk, until the goal is reached.
    """
    model = build_model(scene.model.resolution, scene.model.stiffness)
    terrain = terrain_from_spec(scene.terrain)
    nodes = result.node_positions
    feet = foot_groups(model)
    heights, foot_contact, soles = foot_probe(nodes, result.contacts, feet, terrain, contact_offsets(model))
    foot_xy = soles[..., :2]
    trunk = group_centroids(nodes, bone_node_groups(model, TRUNK))
    chain_bones = tuple(b for chain in LIMB_CHAINS for b in chain)
    groups = bone_node_groups(model, chain_bones)
    landmarks = group_centroids(nodes, groups)
    reference = reference_mesh(model, result)
    reference_landmarks = group_centroids(reference, groups)
    pairs, k = [], 0
    for chain in LIMB_CHAINS:
        pairs += [(k + i, k + i + 1) for i in range(len(chain) - 1)]
        k += len(chain)
    goal = scene_goal(scene)
    up = quat_rotate(result.root_orientations, np.array([0.0, 0.0, 1.0]))
    gait = run_gait_metrics(model, result, scene, reference, heights, foot_xy, foot_contact, goal, library, terrain)
    destination = scene.destination
    goal_yaw = None if destination is None or destination.yaw_deg is None else np.radians(destination.yaw_deg)
    metrics = locomotion_metrics(result.times, result.root_positions, yaw_of(result.root_orientations), up, goal,
                                 scene.goal_radius, foot_xy, foot_contact, len(result.clip_history), trunk,
                                 landmarks, reference_landmarks, np.array(pairs), gait, goal_yaw,
                                 np.radians(scene.goal_yaw_tolerance_deg), [f for f, _ in result.clip_history],
                                 scene_waypoints(scene))
    # slip over the walk only: strides spent standing at the goal would dilute it
    return dataclasses.replace(metrics, foot_slip_per_stride=float(np.sum(gait.slip_per_foot_per_stride)))


@dataclass(frozen=True)
class Stride:
    """
    One stride of a run.

    The frame its clip starts, the frames it advances, and the clip's root displacement `(2,)` m with the heading (rad)
    of its first frame, both in one frame of reference (canonical for a library clip, the world for a placed one);
    displacement None = unknown clip.
    """

    start: int
    n_frames: int
    displacement: np.ndarray | None
    heading: float = 0.0


def library_strides(clip_history: list, library: dict) -> list[Stride]:
    """Strides of a run's clip history (start frame, clip name) from the clips of `library`."""
    out = []
    for start, name in clip_history:
        clip = library.get(name)
        out.append(Stride(int(start), 0, None) if clip is None else Stride(
            int(start), clip.n_frames, np.asarray(clip.root_displacement, float)[:2],
            float(yaw_of(clip.local_rotations[0, 0]))))
    return out


def stride_progress(strides: list[Stride], root_positions: np.ndarray, root_orientations: np.ndarray,
                    until_frame: int) -> tuple:
    """
    Per walking stride of `strides` completed before `until_frame`.

    The body's root progress along the clip's displacement and the clip's displacement, both `(n_strides,)` m, from the
    root after each frame of the run `(n_frames, 3)`, `(n_frames, 4)`.
    """
    starts = [s.start for s in strides] + [len(root_positions)]
    progress, reference = [], []
    for stride, end in zip(strides, starts[1:]):
        start = stride.start
        if stride.displacement is None or end > until_frame or end - start < stride.n_frames:
            continue
        d_ref = stride.displacement
        if np.hypot(*d_ref) < 1e-6:
            continue                                 # idle: nothing to keep up with
        before = root_positions[start - 1] if start > 0 else root_positions[0]
        heading = yaw_of(root_orientations[start - 1] if start > 0 else root_orientations[0])
        turn = heading - stride.heading
        direction = quat_rotate(quat_from_yaw(turn), np.array([*d_ref, 0.0]))[:2] / np.hypot(*d_ref)
        progress.append(float((root_positions[end - 1, :2] - before[:2]) @ direction))
        reference.append(float(np.hypot(*d_ref)))
    return np.array(progress), np.array(reference)


def walk_frames(times: np.ndarray, root_positions: np.ndarray, goal: np.ndarray | None, goal_radius: float) -> tuple:
    """
    (frames of a run's walk, whether it reached the goal).

    Until (and with) the first frame within `goal_radius` of `goal` (2,), else (or with no goal, None) every frame of
    `times (n,)`, root `(n, 3)`.
    """
    if goal is None:
        return len(times), False
    reached, t_goal, _ = goal_arrival(times, root_positions[:, :2], goal, goal_radius)
    return (int(np.searchsorted(times, t_goal)) + 1 if reached else len(times)), reached


def scene_goal(scene) -> np.ndarray | None:
    """
    Return the goal `(2,)` a run of `scene` is measured against.

    Its last goal or its route's last waypoint (None without either: none is reached).
    """
    destination = scene.destination
    return None if destination is None else np.array([destination.x, destination.y])


def scene_waypoints(scene) -> np.ndarray | None:
    """Return the route `(k, 2)` a run of `scene` follows (None for a scene of goals)."""
    return np.array([[w.x, w.y] for w in scene.route]) if scene.route else None


@dataclass
class GaitTracks:
    """
    Per-frame arrays of a run for its gait figures.

    Row f = the body after frame f (times `(F,)` s, root `(F, 3)`, `(F, 4)`, foot probe) and the reference of frame f
    (the clip's stance flags, reference foot heights); None = not known (e.g. a topic missing from a node run's bag).
    """

    times: np.ndarray
    root_positions: np.ndarray
    root_orientations: np.ndarray
    foot_contact: np.ndarray | None = None       # (F, 4) bool
    foot_heights: np.ndarray | None = None       # (F, 4) m
    foot_xy: np.ndarray | None = None            # (F, 4, 2) m, sole centroids
    reference_contacts: np.ndarray | None = None  # (F, 4) bool
    reference_heights: np.ndarray | None = None  # (F, 4) m
    strides: list | None = None                  # [Stride]

    def missing(self) -> set[str]:
        """Names of the tracks that are not known."""
        return {f.name for f in dataclasses.fields(self) if getattr(self, f.name) is None}


GAIT_NEEDS = {
    'stance_fraction': {'foot_contact'}, 'reference_stance_fraction': {'reference_contacts'},
    'swing_clearance': {'foot_heights', 'reference_contacts'},
    'swings_clear_fraction': {'foot_heights', 'reference_contacts'},
    'swings': {'foot_heights', 'reference_contacts'},
    'slip_per_foot_per_stride': {'foot_contact', 'foot_xy', 'strides'}, 'speed_fraction': {'strides'},
    'shape_error_median': {'shape_errors'}, 'shape_error_p90': {'shape_errors'},
    'foot_height_error': {'foot_heights', 'reference_heights'}}
"""The tracks each GaitMetrics figure is computed from (shape errors need every node's position)."""


def tracks_gait_metrics(tracks: GaitTracks, until: int, shape_errors: np.ndarray | None = None) -> GaitMetrics:
    """
    `GaitMetrics` of the first `until` frames (the walk) of `tracks`, with the rigid-fit shape errors of those frames.

    A figure whose tracks (GAIT_NEEDS) are not known is NaN (per foot: NaN each; swings: 0).
    """
    n = len(tracks.times)
    walk = slice(0, until)

    def known(value, placeholder):
        return placeholder if value is None else value
    strides = known(tracks.strides, [])
    progress, clip_displacement = stride_progress(strides, tracks.root_positions, tracks.root_orientations, until)
    gait = gait_metrics(known(tracks.foot_contact, np.zeros((n, N_FEET), bool))[walk],
                        known(tracks.reference_contacts, np.ones((n, N_FEET), bool))[walk],
                        known(tracks.foot_heights, np.zeros((n, N_FEET)))[walk],
                        known(tracks.reference_heights, np.zeros((n, N_FEET)))[walk],
                        known(tracks.foot_xy, np.zeros((n, N_FEET, 2)))[walk],
                        sum(1 for s in strides if s.start < until), progress, clip_displacement,
                        known(shape_errors, np.zeros(0)))
    missing = tracks.missing() | ({'shape_errors'} if shape_errors is None else set())
    blank = {name: _unknown(getattr(gait, name)) for name, needs in GAIT_NEEDS.items() if needs & missing}
    return dataclasses.replace(gait, **blank)


def _unknown(value):
    """Return the 'not known' value of a GaitMetrics field like `value`."""
    if isinstance(value, tuple):
        return tuple(float('nan') for _ in value)
    return 0 if isinstance(value, int) else float('nan')


def run_gait_metrics(model, result, scene, reference: np.ndarray, heights: np.ndarray, foot_xy: np.ndarray,
                     foot_contact: np.ndarray, goal: np.ndarray | None, library: dict | None, terrain) -> GaitMetrics:
    """
    Return the `GaitMetrics` of a run's walk (its frames until the goal is reached).

    The figures are per-foot contact, clearance, slip and height error, speed and shape error.
    """
    if library is None:
        from iguana_ros.motion.clips import load_clip_library
        library = load_clip_library()
    until, _ = walk_frames(result.times, result.root_positions, goal, scene.goal_radius)
    walk = slice(0, until)
    tracks = GaitTracks(result.times, result.root_positions, result.root_orientations, foot_contact, heights,
                        foot_xy, result.reference_contacts,
                        foot_heights(reference, foot_groups(model), terrain, contact_offsets(model)),
                        library_strides(result.clip_history, library))
    shape = rigid_fit_errors(result.node_positions[walk], reference[walk], np.ones(model.n_nodes))
    return tracks_gait_metrics(tracks, until, shape)


def reference_mesh(model, result) -> np.ndarray:
    """Return the reference mesh skinned (DQS) to each frame's adapted pose, `(n_frames, n_nodes, 3)`."""
    return skinned_meshes(SpringLengthComputer(model), result.reference_joints, result.reference_rotations)
