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
Footskate cleanup (motion.cleanup).

The stride transform, planted targets on hand-made foot tracks with known answers, the shipped (cleaned) clip library,
and cut_clip's `clean` switch.
"""
import numpy as np
import pytest

from iguana_ros.body.skeleton import forward_kinematics
from iguana_ros.geometry import quat_rotate
from iguana_ros.motion.cleanup import (floor_pivot_heights, FOOT_PIVOTS, MIN_SWING_CLEARANCE, planted_foot_targets,
                                       stride_transform, StrideTransform, TAIL_TIP_HEIGHT)
from iguana_ros.motion.clips import canonical, cut_clip, load_clip_library, make_cyclic, repeated_clip
from iguana_ros.motion.dofs import iguana_body_model
from iguana_ros.motion.gait import generate_take, SYNTHETIC_TAKES
from iguana_ros.motion.segmentation import detect_contacts, stride_boundaries

STRIDE = StrideTransform(origin=np.array([0.1, -0.2]), target=np.array([0.4, 0.3]), turn=0.7)


def test_stride_transform_round_trip_origin_and_a_quarter_turn():
    points = np.random.default_rng(3).normal(size=(5, 2, 3))
    for times in (1, 2, 3):
        assert STRIDE.apply(STRIDE.apply(points, times), -times) == pytest.approx(points, abs=1e-12)
        assert STRIDE.apply(points, times) == pytest.approx(STRIDE.apply(STRIDE.apply(points, times - 1), 1))
    assert STRIDE.apply(points, 0) == pytest.approx(points)
    assert STRIDE.apply(np.array([0.1, -0.2, 0.05])) == pytest.approx([0.4, 0.3, 0.05])
    quarter = StrideTransform(origin=np.zeros(2), target=np.array([1.0, 0.0]), turn=np.pi / 2)
    assert quarter.apply(np.array([0.1, 0.0, 0.05])) == pytest.approx([1.0, 0.1, 0.05])
    assert quarter.apply(np.array([0.1, 0.0, 0.05]), 2) == pytest.approx([0.9, 1.0, 0.05])
    assert quarter.apply(np.array([1.0, 0.1, 0.05]), -1) == pytest.approx([0.1, 0.0, 0.05])


def test_stride_transform_of_a_clip_reads_the_root_of_its_end_frames():
    dofs = iguana_body_model().dofs
    theta = np.zeros((3, dofs.n_dof))
    theta[:, [dofs.index('root_x'), dofs.index('root_y'), dofs.index('root_yaw')]] = [[0.1, -0.2, 0.3],
                                                                                      [9.0, 9.0, 9.0],
                                                                                      [0.4, 0.3, 1.0]]
    stride = stride_transform(theta, dofs)
    assert stride.origin == pytest.approx([0.1, -0.2]) and stride.target == pytest.approx([0.4, 0.3])
    assert stride.turn == pytest.approx(0.7)


N = 12
"""Frames of the synthetic stride below (it holds N + 1)."""
FLOOR = np.array([0.007, 0.007, 0.006])
SEAM = np.array([0.3, 0.0, -0.3, 0.0, 0.3, 0.0, -0.3])
"""Skate noise (in units of 1 cm) along x of the 7 frames of a stance; it sums to zero, so the mean of the
stance is the point it skates around."""


def _swing(a: np.ndarray, b: np.ndarray, s: np.ndarray, z0: float, lift: float) -> np.ndarray:
    """Points `(len(s), 3)`: straight from xy `a` to `b`, at height z0 + lift * sin(pi s)."""
    xy = a[None] + s[:, None] * (b - a)[None]
    return np.concatenate([xy, (z0 + lift * np.sin(np.pi * s))[:, None]], axis=1)


def _synthetic_stride(stride: StrideTransform) -> tuple:
    """
    (feet `(N+1, 3, 3)`, contacts `(N+1, 3)`) of a skating stride; the known answers are in the tests.

    fl: stance 9..N-1 + 0..3 across the seam around q0, a swing 4..8 peaking 3 cm above the floor at frame 6.
    fr: stance 3..9 around q1, a low (1.2 cm) swing 10..N-1 + 0..2 across the seam, peaking at frame 0 = N.
    hl: never swings, wandering around.
    Stance heights are off the floor by a few mm; the raw frame N is junk (the cleanup ignores it).
    """
    feet = np.full((N + 1, 3, 3), np.nan)
    contacts = np.ones((N + 1, 3), bool)
    noise = 0.01 * np.stack([SEAM, np.zeros(7)], axis=1)
    q0, q1 = np.array([0.25, 0.08]), np.array([-0.1, -0.06])
    # fl: the seam stance, in time order frames 9, 10, 11 of the previous stride, then 0..3 of this one
    seam = np.concatenate([q0 + noise, (FLOOR[0] + 0.001 * np.array([4, 1, 2, 3, 1, 2, 2]))[:, None]], axis=1)
    feet[9:N, 0] = stride.apply(seam[:3])
    feet[0:4, 0] = seam[3:]
    s = np.arange(1, 6) / 6.0
    feet[4:9, 0] = _swing(seam[-1, :2], feet[9, 0, :2], s, FLOOR[0] + 0.003, 0.03)
    contacts[4:9, 0] = False
    # fr: a stance 3..9, then a swing to the stride-moved copy of that stance's first frame
    feet[3:10, 1] = np.concatenate([q1 + noise, (FLOOR[1] + 0.001 * np.array([2, 3, 4, -1, 5, 0, 2]))[:, None]],
                                   axis=1)
    swing = _swing(feet[9, 1, :2], stride.apply(feet[3, 1])[:2], s, FLOOR[1] + 0.002, 0.012)
    feet[10:N, 1] = swing[:2]
    feet[0:3, 1] = stride.apply(swing[2:], -1)
    contacts[[10, 11, 0, 1, 2], 1] = False
    # hl: stands throughout while its marker wanders
    feet[:, 2] = np.random.default_rng(5).normal([0.0, 0.1, FLOOR[2]], 0.004, size=(N + 1, 3))
    contacts[N] = contacts[0]
    return feet, contacts


TURNING = StrideTransform(origin=np.zeros(2), target=np.array([0.10, 0.02]), turn=0.2)


def test_planted_targets_pin_every_stance_and_close_the_seam():
    feet, contacts = _synthetic_stride(TURNING)
    out = planted_foot_targets(feet, contacts, FLOOR, TURNING)
    assert out.shape == feet.shape
    assert out[N] == pytest.approx(TURNING.apply(out[0]), abs=1e-12)  # cyclic: frame N = frame 0 moved
    # fl's stance across the seam: frames 0..3 on q0, 9..N on the next stride's copy of q0, on the floor
    q0 = np.array([0.25, 0.08, FLOOR[0]])
    assert out[0:4, 0] == pytest.approx(np.tile(q0, (4, 1)), abs=1e-12)
    assert out[9:N + 1, 0] == pytest.approx(np.tile(TURNING.apply(q0), (4, 1)), abs=1e-12)
    # fr's stance 3..9 on q1 at floor height
    assert out[3:10, 1] == pytest.approx(np.tile([-0.1, -0.06, FLOOR[1]], (7, 1)), abs=1e-12)
    # hl never lifts: planted for the whole stride (frame N is the stride's move of it)
    assert out[:N, 2] == pytest.approx(np.tile(out[0, 2], (N, 1)), abs=1e-12) and out[0, 2, 2] == FLOOR[2]


def test_planted_targets_rejoin_and_lift_the_swings():
    feet, contacts = _synthetic_stride(TURNING)
    out = planted_foot_targets(feet, contacts, FLOOR, TURNING)
    s = np.arange(1, 6) / 6.0
    # fl's swing is 3 cm high already: its lift-off (+2 mm) and touchdown (+4 mm) offsets are blended out
    # (smoothstep, 1/2 each at mid-swing s = 1/2): the peak stays 3 cm above the floor
    assert out[6, 0, 2] - FLOOR[0] == pytest.approx(0.03, abs=1e-12)
    assert np.max(out[4:9, 0, 2]) == out[6, 0, 2]
    # the whole swing: 3 mm + 3 cm sin(pi s) raw, minus 2 mm (1 - e) + 4 mm e, e = 3s^2 - 2s^3 (e(1/3) = 7/27)
    e = s * s * (3 - 2 * s)
    assert out[4:9, 0, 2] - FLOOR[0] == pytest.approx(0.001 + 0.03 * np.sin(np.pi * s) - 0.002 * e, abs=1e-12)
    assert out[5, 0, 2] - FLOOR[0] == pytest.approx(0.001 + 0.015 * np.sqrt(3) - 0.002 * 7 / 27, abs=1e-12)
    # and at mid-swing the planar fix is the mean of the lift-off and touchdown fixes: the stance ends 3 mm
    # behind q0 (fix +n) and starts 3 mm ahead of it, in the next stride's heading (fix -R n)
    n = 0.003 * np.array([1.0, 0.0])
    rn = 0.003 * np.array([np.cos(TURNING.turn), np.sin(TURNING.turn)])
    assert out[6, 0, :2] == pytest.approx(feet[6, 0, :2] + 0.5 * (n - rn), abs=1e-12)
    # fr's 1.2 cm swing across the seam is raised by a sine bump to exactly MIN_SWING_CLEARANCE at mid-swing
    # (frame 0 = N): 2 mm offset removed, 1.2 cm + 0.8 cm sin(pi s) -> 2 cm sin(pi s) above the floor
    unrolled = np.concatenate([out[10:N, 1, 2], out[0:3, 1, 2]])
    assert unrolled - FLOOR[1] == pytest.approx(MIN_SWING_CLEARANCE * np.sin(np.pi * s), abs=1e-12)
    assert out[N, 1, 2] - FLOOR[1] == pytest.approx(MIN_SWING_CLEARANCE, abs=1e-9)
    # a higher minimum lifts it further; a lower one leaves the (re-joined) 1.2 cm swing as it is
    high = planted_foot_targets(feet, contacts, FLOOR, TURNING, min_clearance=0.05)
    low = planted_foot_targets(feet, contacts, FLOOR, TURNING, min_clearance=0.005)
    assert high[0, 1, 2] - FLOOR[1] == pytest.approx(0.05, abs=1e-9)
    assert low[0, 1, 2] - FLOOR[1] == pytest.approx(0.012, abs=1e-12)


def test_a_foot_that_never_swings_stays_at_its_mean():
    standing = StrideTransform(origin=np.zeros(2), target=np.zeros(2), turn=0.0)
    feet = np.random.default_rng(7).normal([0.2, -0.1, 0.01], 0.005, size=(N + 1, 2, 3))
    out = planted_foot_targets(feet, np.ones((N + 1, 2), bool), np.array([0.007, 0.006]), standing)
    for k, floor in enumerate([0.007, 0.006]):
        planted = [*feet[:N, k, :2].mean(axis=0), floor]  # frame N is frame 0 moved, not a sample
        assert out[:, k] == pytest.approx(np.tile(planted, (N + 1, 1)), abs=1e-12)


@pytest.fixture(scope='module')
def library():
    return load_clip_library()


def _one_cycle(clip, skeleton):
    """
    Return foot pivots `(N, 4, 3)`, their bones' world rotations `(N, 4, 4)` and stance flags `(N, 4)` of a played clip.

    The clip is played with its local rotations (flat soles included) and unrolled into the next stride, per foot from
    its first lift-off (so no stance or swing is cut by the window).
    """
    n = clip.n_frames
    roots, rotations = repeated_clip(clip, 2)
    joints, world = forward_kinematics(skeleton, roots, rotations)
    bones = skeleton.indices(list(FOOT_PIVOTS))
    flags = np.concatenate([clip.contacts, clip.contacts[1:]])
    for k in range(4):
        lifts = [f for f in range(n) if flags[f - 1 if f else n - 1, k] and not flags[f, k]]
        start = lifts[0] if lifts else 0
        window = slice(start, start + n + (not lifts))
        yield k, joints[window, bones[k]], world[window, bones[k]], flags[window, k]


def _runs(flags):
    """(first, last) of every run of True in `flags (n,)`."""
    edges = np.diff(np.concatenate([[0], flags.astype(int), [0]]))
    return zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1)


@pytest.mark.parametrize('name', ['forward', 'turn_left', 'turn_right', 'idle'])
def test_shipped_clips_plant_their_stance_feet_flat_on_the_floor(library, name):
    """
    Each stance foot's pivot (wrist/ankle joint) stands still at its floor height and its sole is flat.

    Flat: the pivot bone's up axis is the world's. Measured after the cleanup: pivot travel per stance <= 0.6 mm (idle:
    its never-lifting feet follow its 0.3 mm stride at the seam, <= 1.9 mm), heights within 0.53 mm (turn_left hl at its
    last stance frame, the leg at its reach), tilt 0. Before the cleanup the foot markers travelled 3.9-29.9 mm per
    stance, heights -6.7..+7.0 mm.
    """
    model = iguana_body_model()
    floor = floor_pivot_heights(model)
    limit = 0.0025 if name == 'idle' else 0.001
    for k, pivots, world, stance in _one_cycle(library[name], model.skeleton):
        for a, b in _runs(stance):
            travel = np.sum(np.linalg.norm(np.diff(pivots[a:b + 1, :2], axis=0), axis=1))
            assert travel < limit, (name, k, a, b, travel)
        assert np.abs(pivots[stance, 2] - floor[k]).max() < 1e-3, (name, k)
        up = quat_rotate(world[stance], np.array([0.0, 0.0, 1.0]))
        assert up[:, 2].min() > np.cos(np.radians(0.1)), (name, k)


@pytest.mark.parametrize('name', ['forward', 'turn_left', 'turn_right'])
def test_shipped_walking_clips_lift_every_swing(library, name):
    """
    Every swing of a walking clip peaks at least MIN_SWING_CLEARANCE above the floor.

    The sine bump is scaled so the peak frame reaches it, and a swing hardly dips below it: at a lift-off where the leg
    is stretched to its reach the pivot stays up to 3.2 mm low for a frame (turn_left fr; forward fl 0.6 mm).
    """
    model = iguana_body_model()
    floor = floor_pivot_heights(model)
    swings = 0
    for k, pivots, _, stance in _one_cycle(library[name], model.skeleton):
        for a, b in _runs(~stance):
            swings += 1
            assert pivots[a:b + 1, 2].max() - floor[k] > MIN_SWING_CLEARANCE - 5e-4, (name, k, a, b)
            assert pivots[a:b + 1, 2].min() - floor[k] > -0.004, (name, k, a, b)
    assert swings >= 4


def test_cut_clip_cleans_only_the_legs_and_the_tail_pitch():
    model = iguana_body_model()
    take = generate_take(SYNTHETIC_TAKES[0])
    contacts = detect_contacts(take.markers[:, :4], take.frame_rate)
    b = stride_boundaries(contacts)
    start, end = int(b[3]), int(b[4])
    raw = cut_clip('forward', take.theta, contacts, start, end, clean=False)
    clean = cut_clip('forward', take.theta, contacts, start, end)
    assert np.array_equal(raw.theta, canonical(make_cyclic(take.theta, start, end, model.dofs), model.dofs))
    limbs = ('shoulder', 'elbow', 'hip', 'knee')
    legs = [i for i, dof in enumerate(model.dofs.names) if dof.split('_')[0] in limbs]
    assert len(legs) == 12
    tail = model.dofs.index('tail_pitch_base')
    trunk = np.setdiff1d(np.arange(model.dofs.n_dof), legs + [tail])
    assert np.array_equal(clean.theta[:, trunk], raw.theta[:, trunk])
    assert np.abs(clean.theta[:, legs] - raw.theta[:, legs]).max() > 0.01
    tip = model.state(clean.theta).positions[:, model.skeleton.index('tail_tip'), 2]
    assert tip == pytest.approx(np.full(len(tip), TAIL_TIP_HEIGHT), abs=1e-5)   # the tail rests, pressed
    assert not np.any(clean.contacts & ~raw.contacts)    # stances may only lose unreachable end frames
    held = clean.contacts[1:] & clean.contacts[:-1]
    pivots = forward_kinematics(model.skeleton, clean.root_positions, clean.local_rotations)[0][
        :, model.skeleton.indices(list(FOOT_PIVOTS))]
    assert np.linalg.norm(np.diff(pivots[..., :2], axis=0), axis=2)[held].max() < 1e-4
