"""Locomotion metrics of a pipeline run: landmarks of the soft body (node groups by bone) -> metrics."""
from __future__ import annotations

import numpy as np

from iguana_ros.body.model import build_model
from iguana_ros.body.spring_lengths import SpringLengthComputer
from iguana_ros.geometry import quat_rotate, yaw_of
from iguana_ros.metrics import LocomotionMetrics, locomotion_metrics

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


def metrics_of_run(result, scene) -> LocomotionMetrics:
    """LocomotionMetrics of a RunResult for the last goal of `scene` (no goal: distance to the start)."""
    model = build_model(scene.model.resolution, scene.model.stiffness)
    nodes = result.node_positions
    feet = [np.flatnonzero(model.node_tags[f]) for f in FEET]
    foot_xy = group_centroids(nodes, feet)[..., :2]
    foot_contact = np.stack([result.contacts[:, f].any(axis=1) for f in feet], axis=1)
    trunk = group_centroids(nodes, bone_node_groups(model, TRUNK))
    chain_bones = tuple(b for chain in LIMB_CHAINS for b in chain)
    groups = bone_node_groups(model, chain_bones)
    landmarks = group_centroids(nodes, groups)
    reference_landmarks = group_centroids(reference_mesh(model, result), groups)
    pairs, k = [], 0
    for chain in LIMB_CHAINS:
        pairs += [(k + i, k + i + 1) for i in range(len(chain) - 1)]
        k += len(chain)
    goal = np.array([scene.goals[-1].x, scene.goals[-1].y]) if scene.goals else np.array(
        [scene.start.x, scene.start.y])
    up = quat_rotate(result.root_orientations, np.array([0.0, 0.0, 1.0]))
    return locomotion_metrics(result.times, result.root_positions, yaw_of(result.root_orientations), up, goal,
                              scene.goal_radius, foot_xy, foot_contact, len(result.clip_history), trunk,
                              landmarks, reference_landmarks, np.array(pairs))


def reference_mesh(model, result) -> np.ndarray:
    """The reference mesh skinned (DQS) to each frame's adapted pose, `(n_frames, n_nodes, 3)`."""
    computer = SpringLengthComputer(model)
    return np.stack([computer.skin_bones_to(rot, pos)
                     for pos, rot in zip(result.reference_joints, result.reference_rotations)])
