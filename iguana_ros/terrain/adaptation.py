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
Motion adaptation for terrain (Section VI): plane fitting, then residual fitting of feet and tail.

A clip pose was captured over a flat floor at z = 0. The *residual height* of a foot (or of the tail tip) is
its height above that floor in the clip pose. Its *target* on the terrain is the point straight below or above
it on the terrain surface, raised by the residual height along the world up axis (+z). Vertical, not along the
terrain normal, because residual heights were measured vertically over the capture floor and a height field is
a function of (x, y): the target keeps the foot's (x, y), so fitting does not drag feet sideways on a slope,
and its clearance along the normal is still `h cos(slope) >= 0`.

*Plane fitting* (VI-A) moves the whole pose rigidly: the SVD (Kabsch) rotation and translation that best
map the four clip feet to their four targets, applied to the root. *Residual fitting* (VI-B) then runs an
inverse kinematics over the leg, tail, neck and head joints (bounded by the joint limits) and a small root
lift, so that the feet and the tail tip reach their targets re-projected under the plane-fitted pose, no joint
sinks into the terrain, and the pose stays close to the plane-fitted one. The paper minimises this objective
with L-BFGS; here it is a sum of squares minimised by a compiled bounded Gauss–Newton (Levenberg–Marquardt)
whose FK, residuals and Jacobian read the height field directly (the kernels are in terrain/ik_kernels.py): 3
evaluations per trot frame where scipy's L-BFGS-B needed ~15, ending as low or lower (tested). Each frame
warm-starts from the previous frame's joint corrections (`AdaptationState`).

Flat ground needs neither step: a flat terrain at height 0 leaves the pose exactly unchanged, a flat
terrain at height c only raises the root by c.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from iguana_ros.body.skeleton import FEET, FOOT_PIVOTS, Skeleton
from iguana_ros.errors import IguanaError, InputError
from iguana_ros.geometry import (matrix_to_quat, quat_conjugate, quat_from_rotvec, quat_mul, quat_normalize,
                                 quat_rotate, quat_to_matrix, quat_to_rotvec, quats_between, rigid_fit)
from iguana_ros.jit import ensure_fresh_kernel_cache
from iguana_ros.terrain.heightfield import HeightField
from iguana_ros.terrain.ik_kernels import bounded_gauss_newton, fk_kernel, gauss_newton_system

TAIL_TIP_BONE = 'tail_tip'
"""Bone whose joint is the tail point with a residual height."""

IK_BONE_PREFIXES = ('shoulder_', 'elbow_', 'wrist_', 'hip_', 'knee_', 'ankle_', 'tail_', 'neck', 'head')
"""Bones that residual fitting may rotate (those with children and a non-zero joint range)."""


@dataclass(frozen=True)
class AdaptationSettings:
    """Weights and limits of residual fitting; position errors are measured in units of `length_scale`."""

    length_scale: float = 0.01
    """m; a position error of this size costs `weight` (keeps the objective near 1)."""
    stance_foot_weight: float = 1.0
    swing_foot_weight: float = 0.3
    tail_weight: float = 0.3
    pose_weight: float = 0.5
    """Cost per rad² of joint rotation-vector change from the plane-fitted pose."""
    lift_weight: float = 0.05
    """Cost per `length_scale`² of root lift."""
    penetration_weight: float = 30.0
    """Cost per `length_scale`² of a joint below terrain + clearance."""
    clearance: float = 0.003
    """m kept between a joint and the terrain; less for a joint already closer (a foot or the tail tip: at
    most its residual height), never below the surface."""
    max_root_lift: float = 0.03
    """m the root may be raised or lowered by residual fitting."""
    max_tail_press: float = 0.02
    """m the tail may be pressed into the terrain: a clip's negative tail-tip residual height (a weight-bearing
    tail) is kept down to this depth, a deeper one (a tail dug into the floor) is lifted to it."""
    max_iterations: int = 200
    gradient_tolerance: float = 1e-7
    function_tolerance: float = 1e-5


@dataclass
class AdaptationState:
    """Warm start carried between frames: the previous solution's joint corrections and solver counts."""

    correction: np.ndarray | None = None
    iterations: int = 0
    evaluations: int = 0


@dataclass(frozen=True)
class PlaneFit:
    """Plane-fitted pose: root `(3,)`, local rotations `(n_bones, 4)`, the rigid motion R `(3, 3)`, t `(3,)`."""

    root_position: np.ndarray
    local_rotations: np.ndarray
    rotation: np.ndarray
    translation: np.ndarray
    foot_targets: np.ndarray
    """`(4, 3)` targets the rigid fit aimed at (terrain under the clip feet + residual heights)."""


@dataclass(frozen=True)
class AdaptedPose:
    """A terrain-adapted pose and its world bone frames, plus the targets it was fitted to."""

    root_position: np.ndarray
    """`(3,)` m."""
    local_rotations: np.ndarray
    """`(n_bones, 4)` xyzw, root entry = world orientation."""
    joint_positions: np.ndarray
    """`(n_bones, 3)` world joint positions, m."""
    joint_rotations: np.ndarray
    """`(n_bones, 4)` world bone orientations."""
    foot_targets: np.ndarray = field(default_factory=lambda: np.zeros((4, 3)))
    """`(4, 3)` foot targets of residual fitting (zeros when nothing was fitted)."""
    tail_target: np.ndarray = field(default_factory=lambda: np.zeros(3))
    """`(3,)` tail-tip target of residual fitting."""


def pose_kinematics(skeleton: Skeleton, root_position: np.ndarray, local_rotations: np.ndarray) -> tuple:
    """World joint positions `(n_bones, 3)` and rotations `(n_bones, 4)` of one pose (compiled FK)."""
    positions = np.empty((skeleton.n_bones, 3))
    rotations = np.empty((skeleton.n_bones, 4))
    fk_kernel(np.ascontiguousarray(root_position, dtype=float),
              np.ascontiguousarray(local_rotations, dtype=float), skeleton.parents,
              np.ascontiguousarray(skeleton.offsets), positions, rotations)
    return positions, rotations


# --------------------------------------------------------------------------------------------- plane fitting

PLANE_FIT_BIAS = 1e-6
"""`geometry.rigid_fit` identity bias of the plane fit: four feet on a line still get the smallest rotation."""


def terrain_targets(terrain: HeightField, points: np.ndarray, residual_heights: np.ndarray) -> np.ndarray:
    """Points `(n, 3)` projected vertically onto the terrain and raised by their residual heights `(n,)`."""
    points = np.asarray(points, dtype=float)
    out = points.copy()
    out[:, 2] = terrain.height(points[:, :2]) + residual_heights
    return out


def residual_heights_of(skeleton: Skeleton, root_position: np.ndarray, local_rotations: np.ndarray) -> tuple:
    """
    Residual heights of the clip pose: feet `(4,)` (>= 0) and tail tip (float), z above the capture floor.

    The tail tip's may be negative: a clip whose tail bears weight presses it into the floor
    (`motion.cleanup.TAIL_TIP_HEIGHT`), and the adapted tail is pressed as deep into the terrain.
    """
    positions = pose_kinematics(skeleton, root_position, local_rotations)[0]
    z = positions[skeleton.indices(list(FEET) + [TAIL_TIP_BONE]), 2]
    return np.maximum(z[:4], 0.0), float(z[4])


def plane_fit(skeleton: Skeleton, terrain: HeightField, root_position: np.ndarray,
              local_rotations: np.ndarray, foot_residual_heights: np.ndarray) -> PlaneFit:
    """Rigidly move a clip pose so its 4 feet best match terrain + residual heights (Section VI-A)."""
    root_position = np.asarray(root_position, dtype=float)
    local_rotations = np.asarray(local_rotations, dtype=float)
    positions = pose_kinematics(skeleton, root_position, local_rotations)[0]
    feet = positions[skeleton.indices(list(FEET))]
    targets = terrain_targets(terrain, feet, np.maximum(foot_residual_heights, 0.0))
    # the fit of the targets onto the feet, transposed: the very rotation taking the feet onto the targets, in the
    # arithmetic the plane fit has always had (terrain runs keep their bits; they are chaotic in the last bit)
    back, _ = rigid_fit(targets, feet, identity_bias=PLANE_FIT_BIAS)
    rotation = back.T.copy()                    # C order, as the product below has always taken it
    translation = targets.mean(axis=0) - rotation @ feet.mean(axis=0)
    fitted = local_rotations.copy()
    fitted[0] = quat_mul(matrix_to_quat(rotation), local_rotations[0])
    return PlaneFit(rotation @ root_position + translation, fitted, rotation, translation, targets)


# ------------------------------------------------------------------------------------------ residual fitting

def ik_bones(skeleton: Skeleton) -> np.ndarray:
    """Return indices of the bones residual fitting rotates: legs, tail, neck, head (with children and a range)."""
    has_child = np.zeros(skeleton.n_bones, dtype=bool)
    has_child[skeleton.parents[skeleton.parents >= 0]] = True
    movable = np.ptp(skeleton.limits, axis=2).max(axis=1) > 0
    chosen = [i for i, name in enumerate(skeleton.names)
              if name.startswith(IK_BONE_PREFIXES) and has_child[i] and movable[i] and i > 0]
    return np.array(chosen, dtype=np.int64)


class _ResidualProblem:
    """The arrays of one residual-fitting solve, bound to the compiled objective."""

    def __init__(self, skeleton: Skeleton, terrain: HeightField, root_position: np.ndarray,
                 local_rotations: np.ndarray, targets: np.ndarray, weights: np.ndarray,
                 clearance: np.ndarray, settings: AdaptationSettings) -> None:
        ensure_fresh_kernel_cache()                  # the objective calls heightfield's kernel
        self.var_bones = ik_bones(skeleton)
        self.var_of = np.full(skeleton.n_bones, -1, dtype=np.int64)
        self.var_of[self.var_bones] = np.arange(len(self.var_bones))
        self.x_ref = np.append(quat_to_rotvec(local_rotations[self.var_bones]).ravel(), 0.0)
        self.positions = np.empty((skeleton.n_bones, 3))
        inv_scale2 = 1.0 / settings.length_scale ** 2
        self.args = (self.var_bones, self.var_of, np.asarray(root_position, dtype=float),
                     np.ascontiguousarray(quat_to_matrix(local_rotations)), skeleton.parents,
                     np.ascontiguousarray(skeleton.offsets), skeleton.indices(list(FEET) + [TAIL_TIP_BONE]),
                     targets, weights, self.x_ref, settings.pose_weight, settings.lift_weight, clearance,
                     settings.penetration_weight, inv_scale2, settings.length_scale, *terrain.kernel_args())
        """The compiled objective's problem arguments (between x and the joint positions it fills)."""
        self.lift_scale = settings.length_scale
        self.bounds = self._bounds(skeleton.limits[self.var_bones], settings.max_root_lift / self.lift_scale)

    def _bounds(self, limits: np.ndarray, max_lift: float) -> tuple:
        """Joint-limit box (lo, hi) `(n_x,)` widened to contain the plane-fitted pose itself, plus the lift."""
        lo = np.minimum(limits[..., 0].ravel(), self.x_ref[:-1])
        hi = np.maximum(limits[..., 1].ravel(), self.x_ref[:-1])
        return np.append(lo, -max_lift), np.append(hi, max_lift)

    def __call__(self, x: np.ndarray) -> tuple:
        """Objective and gradient `(n_x,)` at `x (n_x,)`."""
        hess, grad = np.empty((len(x), len(x))), np.empty(len(x))
        f = gauss_newton_system(np.asarray(x, dtype=float), *self.args, self.positions, hess, grad)
        return f, 2.0 * grad

    def solve(self, x0: np.ndarray, settings: AdaptationSettings) -> tuple:
        """(x `(n_x,)`, iterations, evaluations) of the bounded Gauss–Newton minimisation from `x0`."""
        x, _f, iterations, evaluations = bounded_gauss_newton(
            np.array(x0, dtype=float), *self.bounds, settings.max_iterations, settings.gradient_tolerance,
            settings.function_tolerance, *self.args, self.positions)
        return x, int(iterations), int(evaluations)

    def start(self, correction: np.ndarray | None) -> np.ndarray:
        """Warm start: the plane-fitted pose plus last frame's correction, clipped into the bounds."""
        if correction is None or correction.shape != self.x_ref.shape:
            return self.x_ref.copy()
        return np.clip(self.x_ref + correction, *self.bounds)

    def pose(self, x: np.ndarray, root_position: np.ndarray, local_rotations: np.ndarray) -> tuple:
        """(root `(3,)`, local rotations `(n_bones, 4)`) of solution `x`."""
        local = np.array(local_rotations, dtype=float)
        local[self.var_bones] = quat_from_rotvec(x[:-1].reshape(-1, 3))
        root = np.array(root_position, dtype=float)
        root[2] += x[-1] * self.lift_scale
        return root, local


def residual_fit(skeleton: Skeleton, terrain: HeightField, root_position: np.ndarray,
                 local_rotations: np.ndarray, foot_residual_heights: np.ndarray, tail_residual_height: float,
                 stance: np.ndarray | None = None, state: AdaptationState | None = None,
                 settings: AdaptationSettings | None = None) -> AdaptedPose:
    """
    IK moving feet and tail tip of a plane-fitted pose to their terrain targets (Section VI-B), bounded Gauss–Newton.

    `foot_residual_heights (4,)`, `stance (4,)` bool (None: all stance); `state` is updated for warm starts.
    """
    settings = settings or AdaptationSettings()
    state = state if state is not None else AdaptationState()
    local_rotations = np.asarray(local_rotations, dtype=float)
    positions = pose_kinematics(skeleton, root_position, local_rotations)[0]
    points = positions[skeleton.indices(list(FEET) + [TAIL_TIP_BONE])]
    heights = np.append(np.maximum(foot_residual_heights, 0.0), max(tail_residual_height, -settings.max_tail_press))
    targets = terrain_targets(terrain, points, heights)
    stance = np.ones(4, dtype=bool) if stance is None else np.asarray(stance, dtype=bool)
    weights = np.append(np.where(stance, settings.stance_foot_weight, settings.swing_foot_weight),
                        settings.tail_weight)
    clearance = np.clip(positions[:, 2] - terrain.height(positions[:, :2]), 0.0, settings.clearance)
    clearance[skeleton.indices(list(FEET) + [TAIL_TIP_BONE])] = np.minimum(settings.clearance, heights)
    tail = np.array([name.startswith('tail_') for name in skeleton.names])
    clearance[tail] = np.minimum(clearance[tail], heights[4])   # a pressed tail may sink as deep as its tip
    problem = _ResidualProblem(skeleton, terrain, root_position, local_rotations, targets, weights,
                               clearance, settings)
    x, iterations, evaluations = problem.solve(problem.start(state.correction), settings)
    if not np.all(np.isfinite(x)):
        raise IguanaError('residual fitting produced a non-finite pose; check the clip pose and terrain')
    state.correction = x - problem.x_ref
    state.iterations, state.evaluations = iterations, evaluations
    root, local = problem.pose(x, root_position, local_rotations)
    joint_positions, joint_rotations = pose_kinematics(skeleton, root, local)
    return AdaptedPose(root, local, joint_positions, joint_rotations, targets[:4], targets[4])


# ------------------------------------------------------------------------------------------------- both

def _check_pose(skeleton: Skeleton, root_position: np.ndarray, local_rotations: np.ndarray) -> None:
    """Raise InputError unless the pose has the skeleton's shapes and finite values."""
    if root_position.shape != (3,) or local_rotations.shape != (skeleton.n_bones, 4):
        raise InputError(f'pose must be root_position (3,) and local_rotations ({skeleton.n_bones}, 4), '
                         f'got {root_position.shape} and {local_rotations.shape}')
    if not (np.all(np.isfinite(root_position)) and np.all(np.isfinite(local_rotations))):
        raise InputError('pose contains NaN or Inf')


def adapt_pose(skeleton: Skeleton, terrain: HeightField | None, root_position: np.ndarray,
               local_rotations: np.ndarray, foot_residual_heights: np.ndarray | None = None,
               tail_residual_height: float | None = None, stance: np.ndarray | None = None,
               state: AdaptationState | None = None,
               settings: AdaptationSettings | None = None) -> AdaptedPose:
    """
    Plane fitting then residual fitting of one clip pose on `terrain` (None or flat: no IK at all).

    Residual heights default to the clip pose's own heights above z = 0 (feet `(4,)`, tail tip).
    """
    root_position = np.asarray(root_position, dtype=float)
    local_rotations = np.asarray(local_rotations, dtype=float)
    _check_pose(skeleton, root_position, local_rotations)
    if terrain is None or terrain.is_flat:
        root = root_position.copy()
        if terrain is not None:
            root[2] += float(terrain.heights[0, 0])
        positions, rotations = pose_kinematics(skeleton, root, local_rotations)
        return AdaptedPose(root, local_rotations.copy(), positions, rotations)
    feet_h, tail_h = residual_heights_of(skeleton, root_position, local_rotations)
    feet_h = feet_h if foot_residual_heights is None else np.asarray(foot_residual_heights, dtype=float)
    tail_h = tail_h if tail_residual_height is None else float(tail_residual_height)
    if feet_h.shape != (4,):
        raise InputError(f'foot_residual_heights must have shape (4,) (fl, fr, hl, hr), got {feet_h.shape}')
    fit = plane_fit(skeleton, terrain, root_position, local_rotations, feet_h)
    adapted = residual_fit(skeleton, terrain, fit.root_position, fit.local_rotations, feet_h, tail_h,
                           stance=stance, state=state, settings=settings)
    return align_soles(skeleton, terrain, adapted, np.ones(4, bool) if stance is None else stance)


def align_soles(skeleton: Skeleton, terrain: HeightField, pose: AdaptedPose, stance: np.ndarray) -> AdaptedPose:
    """
    Return the pose with each stance foot's sole turned parallel to the terrain under its pivot (`stance (4,)`).

    The clips plant their soles flat on the capture floor; on a slope a horizontal sole would stand on its
    edge (on the flat-soled model, 2 of 7-10 sole nodes) and roll. The pivot bone (FOOT_PIVOTS) is turned by
    the smallest rotation taking its up axis to the terrain normal; its joint, and every joint but the
    foot's own, stay where they are.
    """
    local = np.array(pose.local_rotations, dtype=float, copy=True)
    bones = skeleton.indices(list(FOOT_PIVOTS))[np.asarray(stance, dtype=bool)]
    world = pose.joint_rotations[bones]
    up = quat_rotate(world, np.array([0.0, 0.0, 1.0]))
    turn, turned = quats_between(up, terrain.normal(pose.joint_positions[bones, :2]))
    bones, parent = bones[turned], pose.joint_rotations[skeleton.parents[bones[turned]]]
    local[bones] = quat_normalize(quat_mul(quat_conjugate(parent), quat_mul(turn[turned], world[turned])))
    positions, rotations = pose_kinematics(skeleton, pose.root_position, local)
    return dataclasses.replace(pose, local_rotations=local, joint_positions=positions, joint_rotations=rotations)
