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
Parametric trotting-lizard gait.

The synthetic 'capture subject' whose markers stand in for the paper's unpublished iguana capture.

A take is generated in the active-DOF parametrisation of `iguana_ros.motion.dofs`: a root path (straight or
curved) driven by a speed factor `s(t)` in [0, 1] (0 = standing, 1 = steady trot), a trot with diagonal foot
pairs (FL+HR, then FR+HL half a stride later), lateral trunk bending as a standing wave with nodes at the
girdles (Ritter 1992), a travelling wave of tail sway, a head that counter-rotates to hold its heading, and
feet that stay fixed in the world during stance and follow a raised arc in swing. Leg angles come from a
small per-leg IK that puts each foot marker on its target.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from iguana_ros.constants import (FAST_DUTY_FACTOR, FAST_STRIDE_FREQUENCY, FAST_TURN_PER_STRIDE, FRAME_RATE,
                                  PELVIC_YAW_AMPLITUDE, PIVOT_CENTRE, PIVOT_DUTY_FACTOR, PIVOT_TURN_BEND,
                                  PIVOT_TURN_PER_STRIDE, SHARP_DUTY_FACTOR,
                                  SHARP_TURN_BEND, SHARP_TURN_PER_STRIDE, TROT_DUTY_FACTOR,
                                  TROT_STRIDE_FREQUENCY, TROT_STRIDE_LENGTH, WALK_DUTY_FACTOR, WALK_STRIDE_FREQUENCY,
                                  WALK_STRIDE_LENGTH)
from iguana_ros.errors import IguanaError
from iguana_ros.geometry import quat_to_rotvec
from iguana_ros.motion.dofs import BodyModel, iguana_body_model, LEGS, local_rotations

FOOT_PHASE = {'fl': 0.0, 'hr': 0.0, 'fr': 0.5, 'hl': 0.5}
"""Phase (fraction of a stride) of each foot's touchdown: a trot, FL+HR then FR+HL."""
_FINE = 8  # oversampling of the root-path integration grid


@dataclass(frozen=True)
class GaitParameters:
    """Trot and posture parameters; literature values via `iguana_ros.constants`, the rest assumptions."""

    stride_frequency: float = TROT_STRIDE_FREQUENCY
    duty_factor: float = TROT_DUTY_FACTOR
    stride_length: float = TROT_STRIDE_LENGTH
    swing_height: float = 0.02
    stance_shift: tuple = (-0.03, -0.03, -0.02, -0.02)
    """Fore-aft shift (m) of each foot's mid-stance position from the rest pose (fl, fr, hl, hr)."""
    swing_outward: tuple = (0.6, 0.6, 0.1, 0.1)
    """Outward (lateral) swing excursion per metre of foot lift: sprawling limbs swing on a lateral arc."""
    pelvis_yaw_amplitude: float = PELVIC_YAW_AMPLITUDE
    turn_bend: float = 0.5
    """Fraction of each stride's heading change held as a static trunk bend toward the turn."""
    tail_yaw_amplitudes: tuple = (0.10, 0.16, 0.22)
    """Tail sway amplitude (rad) at the base, mid and tip control points."""
    tail_wave_lag: tuple = (0.0, 0.15, 0.30)
    """Phase lag (strides) of the tail wave at the control points: a wave travelling to the tip."""
    tail_pitch: tuple = (-0.045, 0.02)
    """Tail pitch (rad) at base and tip: the tail droops toward the floor."""
    neck_pitch: float = -0.12
    root_bob: float = 0.002
    root_roll_amplitude: float = 0.035
    root_pitch_amplitude: float = 0.015
    spine_pitch_amplitude: float = 0.01
    idle_tail_amplitude: float = 0.06
    idle_head_amplitude: float = 0.15
    idle_frequency: float = 0.3


GAITS = {
    'walk': (WALK_STRIDE_FREQUENCY, WALK_DUTY_FACTOR, WALK_STRIDE_LENGTH),
    'pivot': (FAST_STRIDE_FREQUENCY, PIVOT_DUTY_FACTOR, WALK_STRIDE_LENGTH),
    'sharp': (WALK_STRIDE_FREQUENCY, SHARP_DUTY_FACTOR, WALK_STRIDE_LENGTH),
    'trot': (TROT_STRIDE_FREQUENCY, TROT_DUTY_FACTOR, TROT_STRIDE_LENGTH),
    'fast': (FAST_STRIDE_FREQUENCY, FAST_DUTY_FACTOR, TROT_STRIDE_LENGTH),
}
"""The named gaits of the motion library: (stride frequency Hz, duty factor, stride length m); all keep the trot's
diagonal footfalls."""


@dataclass(frozen=True)
class TakeSpec:
    """
    One synthetic take.

    Duration (s), heading change per stride at full speed (rad, + = left), the speed factor as piecewise-linear
    knots `((time s, factor), ...)` smoothed over ~0.3 s, the gait as knots `((time s, name in GAITS), ...)` blended
    likewise (empty: the `GaitParameters` given to `generate_take` throughout), the fraction of the stride length the
    root moves forward (0: a turn on the spot), the distance (m) ahead of the pelvis of the point the body turns
    about, and the fraction of the turn held as a static trunk bend (None: the `GaitParameters`' `turn_bend`).
    """

    name: str
    duration: float
    turn_per_stride: float = 0.0
    speed_knots: tuple = ((0.0, 1.0),)
    phase_offset: float = 0.37
    gait_knots: tuple = ()
    forward: float = 1.0
    pivot_centre: float = 0.0
    turn_bend: float | None = None


def _walk_strides(k: float) -> float:
    """Time (s) of the k-th stride start of a walk take with phase offset 0 (a FL+HR touchdown)."""
    return k / WALK_STRIDE_FREQUENCY


SYNTHETIC_TAKES = (
    TakeSpec('trot_straight', 7.0),
    TakeSpec('trot_turn_left', 7.0, turn_per_stride=np.radians(15.0)),
    TakeSpec('trot_turn_right', 7.0, turn_per_stride=-np.radians(15.0)),
    TakeSpec('stand', 4.0, speed_knots=((0.0, 0.0),)),
    TakeSpec('stand_trot_stand', 9.0,
             speed_knots=((0.0, 0.0), (1.2, 0.0), (2.6, 1.0), (6.0, 1.0), (7.4, 0.0), (9.0, 0.0))),
    TakeSpec('walk_straight', 7.0, gait_knots=((0.0, 'walk'),)),
    TakeSpec('pivot_left', 7.0, turn_per_stride=PIVOT_TURN_PER_STRIDE, gait_knots=((0.0, 'pivot'),),
             forward=0.0, pivot_centre=PIVOT_CENTRE, turn_bend=PIVOT_TURN_BEND),
    TakeSpec('pivot_right', 7.0, turn_per_stride=-PIVOT_TURN_PER_STRIDE, gait_knots=((0.0, 'pivot'),),
             forward=0.0, pivot_centre=PIVOT_CENTRE, turn_bend=PIVOT_TURN_BEND),
    TakeSpec('walk_sharp_left', 7.0, turn_per_stride=SHARP_TURN_PER_STRIDE, gait_knots=((0.0, 'sharp'),),
             turn_bend=SHARP_TURN_BEND),
    TakeSpec('walk_sharp_right', 7.0, turn_per_stride=-SHARP_TURN_PER_STRIDE, gait_knots=((0.0, 'sharp'),),
             turn_bend=SHARP_TURN_BEND),
    TakeSpec('trot_fast', 7.0, gait_knots=((0.0, 'fast'),)),
    TakeSpec('trot_fast_left', 7.0, turn_per_stride=FAST_TURN_PER_STRIDE, gait_knots=((0.0, 'fast'),)),
    TakeSpec('trot_fast_right', 7.0, turn_per_stride=-FAST_TURN_PER_STRIDE, gait_knots=((0.0, 'fast'),)),
    TakeSpec('stand_walk_stand', 8.0, phase_offset=0.0, gait_knots=((0.0, 'walk'),),
             speed_knots=((0.0, 0.0), (_walk_strides(2), 0.0), (_walk_strides(3), 1.0), (_walk_strides(6), 1.0),
                          (_walk_strides(7), 0.0), (8.0, 0.0))),
    TakeSpec('gait_changes', 14.0, phase_offset=0.0,
             gait_knots=((0.0, 'walk'), (_walk_strides(3), 'walk'), (_walk_strides(3) + 0.75, 'trot'),
                         (5.5, 'trot'), (6.2, 'fast'), (8.6, 'fast'), (9.3, 'trot'), (11.2, 'trot'),
                         (11.9, 'walk'))),
)
"""The shipped takes: the trot straight, turning left and right, standing still, a start-stop transition; the slow
walk straight, turning on the spot and sharply both ways; the fast trot straight and turning both ways; the walk from
and to a stand; and a take that changes gait walk -> trot -> fast -> trot -> walk."""


@dataclass(frozen=True)
class SyntheticTake:
    """
    A generated take.

    Poses `theta (F, n_dof)`, true contacts `(F, 4)`, clean markers `(F, n_markers, 3)`, speed factor `(F,)` and
    per-foot true touchdown times (s).
    """

    name: str
    frame_rate: float
    theta: np.ndarray
    contacts: np.ndarray
    markers: np.ndarray
    speed: np.ndarray
    touchdown_times: dict = field(default_factory=dict)

    @property
    def n_frames(self) -> int:
        """Return number of frames."""
        return int(self.theta.shape[0])

    def touchdown_frames(self, leg: str) -> np.ndarray:
        """First frame index at or after each true touchdown of `leg` inside the take."""
        frames = np.ceil(np.asarray(self.touchdown_times[leg]) * self.frame_rate - 1e-9).astype(int)
        return frames[(frames >= 0) & (frames < self.n_frames)]


def _smooth(values: np.ndarray, sigma: int) -> np.ndarray:
    """Gaussian smoothing `(n,)` with edge padding, sigma in samples."""
    if sigma <= 0:
        return values
    x = np.arange(-3 * sigma, 3 * sigma + 1)
    kernel = np.exp(-0.5 * (x / sigma) ** 2)
    kernel /= kernel.sum()
    padded = np.pad(values, 3 * sigma, mode='edge')
    return np.convolve(padded, kernel, mode='valid')


@dataclass(frozen=True)
class RootPath:
    """
    Root path on a time grid `(n,)`.

    Speed factor, phase (strides), heading (rad), position xy `(n, 2)`, and the gait's duty factor `(n,)` there.
    """

    time: np.ndarray
    speed: np.ndarray
    phase: np.ndarray
    heading: np.ndarray
    xy: np.ndarray
    duty: np.ndarray

    def at(self, t: np.ndarray) -> tuple:
        """(xy `(..., 2)`, heading `(...)`) interpolated at times `t`."""
        t = np.asarray(t, dtype=float)
        xy = np.stack([np.interp(t, self.time, self.xy[:, k]) for k in range(2)], axis=-1)
        return xy, np.interp(t, self.time, self.heading)

    def time_at_phase(self, phase: np.ndarray) -> np.ndarray:
        """Return the times `(...)` s at which the stride phase reaches `phase (...)` (the phase only grows)."""
        return np.interp(phase, self.phase, self.time)


def gait_schedule(spec: TakeSpec, gait: GaitParameters, time: np.ndarray, sigma: int) -> tuple:
    """(stride frequency Hz, duty factor, stride length m), each `(n,)`, at `time (n,)` s: the spec's gait knots."""
    if not spec.gait_knots:
        return tuple(np.full(time.shape, value) for value in (gait.stride_frequency, gait.duty_factor,
                                                              gait.stride_length))
    unknown = [name for _, name in spec.gait_knots if name not in GAITS]
    if unknown:
        raise IguanaError(f'take {spec.name}: unknown gait {unknown[0]!r} (gaits: {", ".join(GAITS)})')
    at = np.array([t for t, _ in spec.gait_knots], dtype=float)
    values = np.array([GAITS[name] for _, name in spec.gait_knots], dtype=float)
    return tuple(_smooth(np.interp(time, at, values[:, k]), sigma) for k in range(3))


def root_path(spec: TakeSpec, gait: GaitParameters, frame_rate: float, margin: float = 2.0) -> RootPath:
    """Integrate speed, turn rate and stride phase on a fine grid from -margin to duration + margin s."""
    dt = 1.0 / (frame_rate * _FINE)
    time = np.arange(-margin, spec.duration + margin + dt, dt)
    knots = np.asarray(spec.speed_knots, dtype=float)
    sigma = int(0.12 / dt)
    speed = np.clip(_smooth(np.interp(time, knots[:, 0], knots[:, 1]), sigma), 0.0, 1.0)
    frequency, duty, stride = gait_schedule(spec, gait, time, sigma)
    velocity = spec.forward * stride * frequency * speed
    turn_rate = spec.turn_per_stride * frequency * speed
    lateral = -spec.pivot_centre * turn_rate  # turning about a point ahead of it, the pelvis swings outward
    heading = _cumulative(turn_rate, dt, time)
    c, s = np.cos(heading), np.sin(heading)
    xy = np.stack([_cumulative(velocity * c - lateral * s, dt, time),
                   _cumulative(velocity * s + lateral * c, dt, time)], axis=-1)
    phase = spec.phase_offset + _cumulative(frequency, dt, time)
    return RootPath(time=time, speed=speed, phase=phase, heading=heading, xy=xy, duty=duty)


def _cumulative(rate: np.ndarray, dt: float, time: np.ndarray) -> np.ndarray:
    """Trapezoid integral of `rate (n,)`, zero at t = 0."""
    integral = np.concatenate([[0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1]) * dt)])
    return integral - np.interp(0.0, time, integral)


def trunk_theta(model: BodyModel, path: RootPath, spec: TakeSpec, gait: GaitParameters,
                t: np.ndarray) -> np.ndarray:
    """Poses `(F, n_dof)` at times `t (F,)` with every DOF but the legs set by the gait."""
    d = model.dofs
    s = np.interp(t, path.time, path.speed)
    phase = np.interp(t, path.time, path.phase)
    xy, heading = path.at(t)
    wave = np.cos(2.0 * np.pi * phase)
    twice = np.cos(4.0 * np.pi * phase)
    theta = np.zeros((t.size, d.n_dof))
    theta[:, d.index('root_x')], theta[:, d.index('root_y')] = xy[:, 0], xy[:, 1]
    rest_height = model.skeleton.offsets[0, 2]
    theta[:, d.index('root_z')] = rest_height + gait.root_bob * s * twice
    pelvis = gait.pelvis_yaw_amplitude * s * wave  # + = pelvis turned left, at the FL+HR touchdown
    turn_bend = (gait.turn_bend if spec.turn_bend is None else spec.turn_bend) * spec.turn_per_stride * s
    theta[:, d.index('root_yaw')] = heading + pelvis - 0.5 * turn_bend
    theta[:, d.index('root_pitch')] = gait.root_pitch_amplitude * s * twice
    theta[:, d.index('root_roll')] = gait.root_roll_amplitude * s * np.sin(2.0 * np.pi * phase)
    bend = (-2.0 * pelvis + turn_bend) / 5.0  # standing wave, nodes at the girdles: uniform curvature
    for name in ('spine_yaw_1', 'spine_yaw_3', 'spine_yaw_5'):
        theta[:, d.index(name)] = bend
    theta[:, d.index('spine_pitch')] = gait.spine_pitch_amplitude * s * twice
    idle = 2.0 * np.pi * gait.idle_frequency * t
    # head stabilisation: undo the shoulder girdle's yaw about the heading, look a little into the turn
    shoulder_yaw = pelvis - 0.5 * turn_bend + 5.0 * bend
    theta[:, d.index('neck_yaw')] = (-shoulder_yaw + 0.5 * turn_bend
                                     + (1.0 - s) * gait.idle_head_amplitude * np.sin(0.5 * idle))
    theta[:, d.index('neck_pitch')] = gait.neck_pitch - 0.5 * theta[:, d.index('root_pitch')]
    for k, tag in enumerate(('base', 'mid', 'tip')):
        lag = 2.0 * np.pi * gait.tail_wave_lag[k]
        trot = -gait.tail_yaw_amplitudes[k] * np.cos(2.0 * np.pi * phase - lag)
        rest = gait.idle_tail_amplitude * (k + 1) / 3.0 * np.sin(idle - lag)
        theta[:, d.index(f'tail_yaw_{tag}')] = s * trot + (1.0 - s) * rest - 0.3 * turn_bend
    theta[:, d.index('tail_pitch_base')] = gait.tail_pitch[0]
    theta[:, d.index('tail_pitch_tip')] = gait.tail_pitch[1]
    return theta


def foot_targets(model: BodyModel, path: RootPath, gait: GaitParameters, t: np.ndarray) -> tuple:
    """
    Foot marker targets `(F, 4, 3)`, true contacts `(F, 4)` and touchdown times per leg at times `t`.

    Each step of a foot lands where the root path places it at mid-stance; its duty factor is the gait's at its
    touchdown. A swing lifts the foot by `gait.swing_height` times the speed factor, or more for a longer step (the
    full height at half the gait's stride length): a stepping foot lifts even where it moves little (the inner feet
    of a sharp turn), a standing one not.
    """
    rest_root, rest_local = model.skeleton.rest_pose()
    rest_theta = np.zeros((1, model.dofs.n_dof))
    rest_theta[0, :3] = rest_root
    neutral = model.marker_positions(rest_theta)[0, :4]  # FOOT_FL, FOOT_FR, FOOT_HL, FOOT_HR
    neutral[:, 0] += np.asarray(gait.stance_shift)
    phase = np.interp(t, path.time, path.phase)
    duty = np.interp(t, path.time, path.duty)
    active = np.interp(t, path.time, path.speed)
    targets = np.empty((t.size, 4, 3))
    contacts = np.empty((t.size, 4), dtype=bool)
    touchdowns = {}
    _, swing_heading = path.at(t)
    for i, leg in enumerate(LEGS):
        foot_phase = phase - FOOT_PHASE[leg]
        k = np.floor(foot_phase)
        within = foot_phase - k
        steps = np.arange(k.min() - 1, k.max() + 2)
        t_down = path.time_at_phase(steps + FOOT_PHASE[leg])
        t_mid = path.time_at_phase(steps + FOOT_PHASE[leg] + 0.5 * np.interp(t_down, path.time, path.duty))
        xy, heading = path.at(t_mid)
        c, s = np.cos(heading), np.sin(heading)
        placed = xy + np.stack([c * neutral[i, 0] - s * neutral[i, 1], s * neutral[i, 0] + c * neutral[i, 1]], -1)
        j = (k - steps[0]).astype(int)
        start, end = placed[j], placed[j + 1]
        u = np.clip((within - duty) / (1.0 - duty), 0.0, 1.0)
        ease = 0.5 * (1.0 - np.cos(np.pi * u))
        step = np.linalg.norm(end - start, axis=-1)
        lift = gait.swing_height * np.minimum(1.0, np.maximum(step / (0.5 * gait.stride_length), active))
        raise_ = lift * np.sin(np.pi * u)
        outward = np.sign(neutral[i, 1]) * gait.swing_outward[i] * raise_
        targets[:, i, 0] = start[:, 0] + ease * (end - start)[:, 0] - np.sin(swing_heading) * outward
        targets[:, i, 1] = start[:, 1] + ease * (end - start)[:, 1] + np.cos(swing_heading) * outward
        targets[:, i, 2] = neutral[i, 2] + raise_
        contacts[:, i] = (within < duty) | (lift < 0.002)
        touchdowns[leg] = t_down
    return targets, contacts, touchdowns


def foot_markers(model: BodyModel, theta: np.ndarray) -> np.ndarray:
    """Return the four foot-marker positions `(F, 4, 3)` of poses `theta (F, n_dof)` (fl, fr, hl, hr)."""
    return model.marker_positions(theta)[:, :4]


def leg_ik(model: BodyModel, theta: np.ndarray, targets: np.ndarray, stance: np.ndarray,
           iterations: int = 30, tolerance: float = 5e-4, effectors=foot_markers) -> np.ndarray:
    """
    Poses `(F, n_dof)` with the 12 leg DOFs set so the feet reach `targets (F, 4, 3)`.

    The feet are `effectors(model, theta) -> (F, 4, 3)` (default: the foot markers). Bounded Gauss-Newton over
    all frames at once. Stance targets (`stance (F, 4)` True) must be met within `tolerance` m; swing targets
    are a design path that joint limits may cut short (the feet follow the pose).
    """
    d = model.dofs
    legs = np.array([[d.index(n) for n in _leg_dof_names(leg)] for leg in LEGS])  # (4 legs, 3 dofs)
    theta = np.array(theta, dtype=float, copy=True)
    eps = 1e-6
    for _ in range(iterations):
        feet = effectors(model, theta)
        error = targets - feet
        jac = np.empty(error.shape + (3,))  # (F, 4, 3 xyz, 3 dofs)
        for k in range(3):
            bumped = theta.copy()
            bumped[:, legs[:, k]] += eps
            jac[..., k] = (effectors(model, bumped) - feet) / eps
        jtj = np.einsum('flik,flij->flkj', jac, jac) + 1e-6 * np.eye(3)
        step = np.linalg.solve(jtj, np.einsum('flik,fli->flk', jac, error)[..., None])[..., 0]
        theta[:, legs] = np.clip(theta[:, legs] + step, d.lower[legs], d.upper[legs])
    miss = np.linalg.norm(targets - effectors(model, theta), axis=-1)
    worst = miss[stance].max(initial=0.0)
    if worst > tolerance:
        raise IguanaError(f'a stance foot target is out of reach: foot IK error {worst * 1e3:.1f} mm '
                          '(reduce stride_length or turn_per_stride)')
    return theta


def _leg_dof_names(leg: str) -> tuple:
    """Return the three active DOFs of leg `leg`: upper yaw, upper roll, middle roll."""
    upper, middle = ('shoulder', 'elbow') if leg[0] == 'f' else ('hip', 'knee')
    return f'{upper}_yaw_{leg}', f'{upper}_roll_{leg}', f'{middle}_roll_{leg}'


def joint_limit_violation(model: BodyModel, theta: np.ndarray) -> float:
    """Largest excess (rad) of any non-root local rotation-vector component over the skeleton's limits."""
    rotvec = quat_to_rotvec(local_rotations(model.dofs, theta))[:, 1:]
    limits = model.skeleton.limits[1:]
    excess = np.maximum(rotvec - limits[..., 1], limits[..., 0] - rotvec)
    return float(max(excess.max(), 0.0))


def generate_take(spec: TakeSpec, gait: GaitParameters = GaitParameters(), frame_rate: float = FRAME_RATE,
                  model: BodyModel | None = None) -> SyntheticTake:
    """Generate the poses, true contacts and clean 15-marker trajectories of one synthetic take."""
    model = model or iguana_body_model()
    path = root_path(spec, gait, frame_rate)
    t = np.arange(int(round(spec.duration * frame_rate))) / frame_rate
    theta = trunk_theta(model, path, spec, gait, t)
    targets, contacts, touchdowns = foot_targets(model, path, gait, t)
    theta = leg_ik(model, theta, targets, contacts)
    return SyntheticTake(name=spec.name, frame_rate=frame_rate, theta=theta, contacts=contacts,
                         markers=model.marker_positions(theta), speed=np.interp(t, path.time, path.speed),
                         touchdown_times=touchdowns)
