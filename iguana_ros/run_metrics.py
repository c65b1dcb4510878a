"""Locomotion metrics of a pipeline run: landmarks of the soft body (node groups by bone) -> metrics."""
from __future__ import annotations

import dataclasses

import numpy as np

from iguana_ros.body.model import build_model
from iguana_ros.body.spring_lengths import SpringLengthComputer
from iguana_ros.geometry import quat_from_yaw, quat_rotate, yaw_of
from iguana_ros.metrics import (GaitMetrics, LocomotionMetrics, gait_metrics, goal_arrival, locomotion_metrics,
                                rigid_fit_errors)
from iguana_ros.physics.simulator import contact_offsets
from iguana_ros.terrain.from_scene import terrain_from_spec

FEET = ('foot_fl', 'foot_fr', 'foot_hl', 'foot_hr')
TRUNK = ('pelvis', 'spine_3', 'spine_5')
LIMB_CHAINS = (('shoulder_fl', 'elbow_fl', 'wrist_fl'), ('shoulder_fr', 'elbow_fr', 'wrist_fr'),
               ('hip_hl', 'knee_hl', 'ankle_hl'), ('hip_hr', 'knee_hr', 'ankle_hr'), ('pelvis', 'spine_5'))
"""Bone groups whose consecutive landmark distances should barely change (Section IX)."""


def bone_node_groups(model, bones: tuple) -> list[np.ndarray]:
    """Indices of the nodes skinned mostly to each bone of `bones`."""
    dominant = model.skin_bones[np.arange(model.n_nodes), np.argmax(model.skin_weights, axis=1)]
    return [np.flatnonzero(dominant == model.skeleton.index(b)) for b in bones]


def group_centroids(node_positions: np.ndarray, groups: list[np.ndarray]) -> np.ndarray:
    """Centroids `(n_frames, n_groups, 3)` of node groups over node trajectories `(n_frames, n, 3)`."""
    return np.stack([node_positions[:, g].mean(axis=1) for g in groups], axis=1)


def metrics_of_run(result, scene, library: dict | None = None) -> LocomotionMetrics:
    """LocomotionMetrics of a RunResult for the last goal of `scene` (no goal: distance to the start), with
    the gait figures against the reference (clips from `library`, default the shipped clip library); foot slip
    per stride (four feet summed) is that of the walk, until the goal is reached."""
    model = build_model(scene.model.resolution, scene.model.stiffness)
    nodes = result.node_positions
    feet = [np.flatnonzero(model.node_tags[f]) for f in FEET]
    foot_xy = group_centroids(nodes, feet)[..., :2]
    foot_contact = np.stack([result.contacts[:, f].any(axis=1) for f in feet], axis=1)
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
    goal = np.array([scene.goals[-1].x, scene.goals[-1].y]) if scene.goals else np.array(
        [scene.start.x, scene.start.y])
    up = quat_rotate(result.root_orientations, np.array([0.0, 0.0, 1.0]))
    gait = run_gait_metrics(model, result, scene, reference, feet, foot_xy, foot_contact, goal, library)
    metrics = locomotion_metrics(result.times, result.root_positions, yaw_of(result.root_orientations), up, goal,
                                 scene.goal_radius, foot_xy, foot_contact, len(result.clip_history), trunk,
                                 landmarks, reference_landmarks, np.array(pairs), gait)
    # slip over the walk only: strides spent standing at the goal would dilute it
    return dataclasses.replace(metrics, foot_slip_per_stride=float(np.sum(gait.slip_per_foot_per_stride)))


def foot_heights(node_positions: np.ndarray, feet: list[np.ndarray], terrain, offset: np.ndarray) -> np.ndarray:
    """Height (m) of each foot's lowest sole point (node minus its contact `offset (n_nodes,)`) above the
    terrain, `(n_frames, n_feet)`."""
    out = np.empty((len(node_positions), len(feet)))
    for k, idx in enumerate(feet):
        sole = node_positions[:, idx]
        ground = terrain.height(sole[..., :2].reshape(-1, 2)).reshape(sole.shape[:2])
        out[:, k] = np.min(sole[..., 2] - offset[idx] - ground, axis=1)
    return out


def stride_progress(result, library: dict, until_frame: int) -> tuple:
    """Per walking stride completed before `until_frame`: the body's root progress along the clip's
    displacement and the clip's displacement, both `(n_strides,)` m."""
    starts = [f for f, _ in result.clip_history] + [len(result.times)]
    progress, reference = [], []
    for (start, name), end in zip(result.clip_history, starts[1:]):
        clip = library.get(name)
        if clip is None or end > until_frame or end - start < clip.n_frames:
            continue
        d_ref = np.asarray(clip.root_displacement, float)[:2]
        if np.hypot(*d_ref) < 1e-6:
            continue                                 # idle: nothing to keep up with
        before = result.root_positions[start - 1] if start > 0 else result.root_positions[0]
        heading = yaw_of(result.root_orientations[start - 1] if start > 0 else result.root_orientations[0])
        turn = heading - yaw_of(clip.local_rotations[0, 0])
        direction = quat_rotate(quat_from_yaw(turn), np.array([*d_ref, 0.0]))[:2] / np.hypot(*d_ref)
        progress.append(float((result.root_positions[end - 1, :2] - before[:2]) @ direction))
        reference.append(float(np.hypot(*d_ref)))
    return np.array(progress), np.array(reference)


def run_gait_metrics(model, result, scene, reference: np.ndarray, feet: list[np.ndarray], foot_xy: np.ndarray,
                     foot_contact: np.ndarray, goal: np.ndarray, library: dict | None) -> GaitMetrics:
    """GaitMetrics of a run's walk (its frames until the goal is reached): per-foot contact, clearance, slip
    and height error, speed, shape error."""
    if library is None:
        from iguana_ros.motion.clips import load_clip_library
        library = load_clip_library()
    terrain = terrain_from_spec(scene.terrain)
    reached, t_goal, _ = goal_arrival(result.times, result.root_positions[:, :2], goal, scene.goal_radius)
    until = int(np.searchsorted(result.times, t_goal)) + 1 if reached else len(result.times)
    walk = slice(0, until)
    offset = contact_offsets(model)
    heights = foot_heights(result.node_positions[walk], feet, terrain, offset)
    reference_heights = foot_heights(reference[walk], feet, terrain, offset)
    progress, clip_displacement = stride_progress(result, library, until)
    shape = rigid_fit_errors(result.node_positions[walk], reference[walk], np.ones(model.n_nodes))
    strides = sum(1 for start, _ in result.clip_history if start < until)
    return gait_metrics(foot_contact[walk], result.reference_contacts[walk], heights, reference_heights,
                        foot_xy[walk], strides, progress, clip_displacement, shape)


def reference_mesh(model, result) -> np.ndarray:
    """The reference mesh skinned (DQS) to each frame's adapted pose, `(n_frames, n_nodes, 3)`."""
    computer = SpringLengthComputer(model)
    return np.stack([computer.skin_bones_to(rot, pos)
                     for pos, rot in zip(result.reference_joints, result.reference_rotations)])
