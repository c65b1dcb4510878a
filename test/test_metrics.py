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

"""Locomotion metrics on hand-made trajectories with known answers."""
from dataclasses import asdict, fields
import json

import numpy as np
import pytest

from iguana_ros import metrics as m


def test_path_goal_and_speed_on_a_straight_walk():
    t = np.linspace(0.0, 10.0, 301)
    xy = np.stack([0.3 * t, np.zeros_like(t)], axis=1)
    assert m.path_length(xy) == pytest.approx(3.0)
    reached, when, final = m.goal_arrival(t, xy, np.array([3.0, 0.0]), 0.15)
    assert reached and when == pytest.approx(2.85 / 0.3, abs=0.04) and final == pytest.approx(0.0)
    assert m.mean_forward_speed(t, xy, np.zeros_like(t)) == pytest.approx(0.3)
    assert m.mean_forward_speed(t, xy, np.full_like(t, np.pi)) == pytest.approx(-0.3)


def test_foot_slip_counts_only_travel_in_contact():
    xy = np.zeros((5, 1, 2))
    xy[:, 0, 0] = [0.0, 0.01, 0.03, 0.10, 0.20]
    contact = np.array([[1], [1], [1], [0], [0]], bool)
    assert m.foot_slip(xy, contact, n_strides=2) == pytest.approx(0.03 / 2)


def test_lateral_bending_amplitude():
    phase = np.linspace(0, 2 * np.pi, 200)
    bend = np.radians(12.0) * np.sin(phase)
    pelvis = np.zeros((200, 3))
    mid = np.tile([0.1, 0.0, 0.0], (200, 1))
    shoulders = mid + 0.1 * np.stack([np.cos(bend), np.sin(bend), 0 * bend], axis=1)
    assert m.lateral_bending(pelvis, mid, shoulders) == pytest.approx(12.0, abs=0.05)


def test_inter_joint_variation_and_fall():
    lm = np.zeros((3, 2, 3))
    lm[:, 1, 0] = [0.1, 0.105, 0.098]
    ref = np.zeros((3, 2, 3))
    ref[:, 1, 1] = 0.1  # same lengths, other direction: only lengths count
    assert m.inter_joint_variation(lm, ref, np.array([[0, 1]])) == pytest.approx(0.05)
    assert m.inter_joint_variation(ref, ref, np.array([[0, 1]])) == 0.0
    up = np.tile([0.0, 0.0, 1.0], (4, 1))
    assert not m.fell(up)
    up[2] = [np.sin(1.2), 0.0, np.cos(1.2)]
    assert m.fell(up)


def test_stuck_only_while_goal_active():
    t = np.linspace(0, 10, 101)
    moving = 3.0 - 0.3 * t
    assert not m.stuck(t, moving, 0.15)
    stalled = np.where(t < 4, 3.0 - 0.3 * t, 3.0 - 1.2)
    assert m.stuck(t, stalled, 0.15)


def test_slip_per_foot_counts_each_foot_between_contact_frames():
    xy = np.zeros((4, 2, 2))
    xy[:, 0, 0] = [0.0, 0.01, 0.03, 0.06]  # slides 1 cm in contact, then 2 + 3 cm around a lift-off
    xy[:, 1] = [[0.0, 0.0], [0.03, 0.04], [0.03, 0.04], [0.03, 0.10]]  # 5 cm + 0 + 6 cm, always in contact
    contact = np.array([[1, 1], [1, 1], [0, 1], [1, 1]], bool)
    assert m.slip_per_foot(xy, contact, n_strides=2) == pytest.approx([0.005, 0.055])
    assert m.slip_per_foot(xy, contact, n_strides=0) == pytest.approx([0.01, 0.11])  # no stride: per run
    assert m.foot_slip(xy, contact, n_strides=2) == pytest.approx(0.06)


def test_stance_fractions():
    contact = np.array([[1, 0, 1], [1, 0, 0], [1, 1, 0], [1, 0, 0]], bool)
    assert m.stance_fractions(contact) == pytest.approx([1.0, 0.25, 0.25])
    assert m.stance_fractions(np.zeros((0, 4), bool)) == pytest.approx([0.0] * 4)


def _flags(*rows: str) -> np.ndarray:
    """Stance flags `(n_frames, n_feet)` from one string per foot ('S' stance, 'w' swing)."""
    return np.array([[c == 'S' for c in row] for row in rows]).T


def test_swing_intervals_skip_swings_at_the_run_edges():
    contact = _flags('SSwwSSwwwS',   # two inner swings
                     'wwSSwSSSSw',   # swings at both edges dropped, the one-frame swing kept
                     'SSSSSSSSSS',   # never swings
                     'wwwwwwwwww')   # one swing spanning the whole run: not inside it
    assert m.swing_intervals(contact) == [[(2, 3), (6, 8)], [(4, 4)], [], []]


def test_mid_swing_clearance_is_the_peak_over_the_middle_half():
    contact = _flags('SSwwwwwwwwSSwS', 'SSSSSSSSSSSSSS')
    height = np.zeros((14, 2))
    height[2:10, 0] = [0.5, 0.5, 0.01, 0.03, 0.02, 0.015, 0.4, 0.4]  # 8 frames: quarters 2..3 and 8..9 ignored
    height[12, 0] = 0.007                                            # one-frame swing: that frame
    height[:, 1] = 0.3                                               # no swing: nothing counted
    clearances = m.mid_swing_clearances(height, contact)
    assert clearances[0] == pytest.approx([0.03, 0.007])
    assert clearances[1].size == 0


def test_speed_fraction():
    assert m.speed_fraction(np.array([0.1, 0.2]), np.array([0.15, 0.25])) == pytest.approx(0.75)
    assert np.isnan(m.speed_fraction(np.array([0.1, 0.2]), np.zeros(2)))
    assert np.isnan(m.speed_fraction(np.zeros(0), np.zeros(0)))


def _rotation(axis, angle: float) -> np.ndarray:
    """Rotation matrix about unit `axis` by `angle` rad (Rodrigues)."""
    k = np.asarray(axis, float) / np.linalg.norm(axis)
    hat = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * hat + (1 - np.cos(angle)) * hat @ hat


def test_rigid_fit_error_ignores_rigid_motion_and_measures_the_deformation():
    a, d = 0.1, 0.02
    octahedron = a * np.concatenate([np.eye(3), -np.eye(3)])  # nodes +x, +y, +z, -x, -y, -z
    weights = np.array([3.0, 1.0, 1.0, 3.0, 1.0, 1.0])
    stretched = octahedron.copy()
    stretched[[0, 3], 0] *= (a + d) / a  # both x nodes pushed out by d: the best fit is still the identity
    rot, shift = _rotation([1.0, 2.0, -0.5], 0.8), np.array([0.3, -1.2, 0.05])
    nodes = np.stack([octahedron @ rot.T + shift, stretched @ rot.T + shift, stretched])
    errors = m.rigid_fit_errors(nodes, np.stack([octahedron] * 3), weights)
    # weighted RMS: two of the nodes (weight 3 each of a total 10) off by d
    assert errors == pytest.approx([0.0, np.sqrt(0.6) * d, np.sqrt(0.6) * d], abs=1e-12)
    scaled = m.rigid_fit_errors(1.1 * octahedron[None], octahedron[None], np.ones(6))
    assert scaled == pytest.approx([0.1 * a])  # every node off by 10 % of its radius a


def _gait_case() -> dict:
    """Return a hand-made 8-frame, 4-foot run and its reference; the expected figures are in the test."""
    reference_contact = _flags('SwwwwSSS',   # fl: one swing 1..4, middle half 2..3
                               'SSwSSwSS',   # fr: one-frame swings at 2 and 5
                               'wwSSwwSS',   # hl: edge swing dropped; swing 4..5, all of it the middle
                               'SSSSSSSS')   # hr: no swing
    height = np.zeros((8, 4))
    height[:, 0] = [0, 0.5, 0.02, 0.015, 0.5, 0, 0, 0]
    height[[2, 5], 1] = [0.03, 0.005]
    height[:, 2] = [0.3, 0.3, 0, 0, 0.01, 0.004, 0, 0]  # 0.01 is exactly SWING_CLEARANCE: clear
    reference_height = height.copy()
    reference_height[:, 0] -= 0.003                      # fl always 3 mm above its reference
    reference_height[:, 1] += 0.004 * (-1) ** np.arange(8)  # fr 4 mm off, alternating
    reference_height[3, 2] -= 0.008                      # hl 8 mm off in one frame of 8
    foot_contact = reference_contact.copy()
    foot_contact[[0, 1], 3] = False
    foot_xy = np.zeros((8, 4, 2))
    foot_xy[:, 0, 0] = 0.01 * np.arange(8)               # fl slides 1 cm a frame; in contact 5->6->7
    return {'foot_contact': foot_contact, 'reference_contact': reference_contact, 'foot_height': height,
            'reference_foot_height': reference_height, 'foot_xy': foot_xy, 'n_strides': 2,
            'stride_progress': np.array([0.2, 0.1]), 'stride_reference': np.array([0.2, 0.2]),
            'shape_errors': 0.001 * np.arange(11)}


def test_gait_metrics_on_a_hand_made_run():
    g = m.gait_metrics(**_gait_case())
    assert g.stance_fraction == pytest.approx((0.5, 0.75, 0.5, 0.75))
    assert g.reference_stance_fraction == pytest.approx((0.5, 0.75, 0.5, 1.0))
    assert g.swing_clearance[:3] == pytest.approx((0.02, 0.0175, 0.01)) and np.isnan(g.swing_clearance[3])
    assert m.SWING_CLEARANCE == 0.01
    assert g.swings == 4 and g.swings_clear_fraction == pytest.approx(0.75)  # 0.005 is the one low swing
    assert g.slip_per_foot_per_stride == pytest.approx((0.01, 0.0, 0.0, 0.0))
    assert g.speed_fraction == pytest.approx(0.75)
    assert g.shape_error_median == pytest.approx(0.005) and g.shape_error_p90 == pytest.approx(0.009)
    assert g.foot_height_error == pytest.approx((0.003, 0.004, 0.008 / np.sqrt(8), 0.0))


def test_gait_metrics_of_an_empty_run_are_nan_not_errors():
    g = m.gait_metrics(np.zeros((0, 4), bool), np.zeros((0, 4), bool), np.zeros((0, 4)), np.zeros((0, 4)),
                       np.zeros((0, 4, 2)), 0, np.zeros(0), np.zeros(0), np.zeros(0))
    assert g.swings == 0 and np.isnan(g.swings_clear_fraction) and np.isnan(g.speed_fraction)
    assert np.isnan(g.shape_error_median) and np.isnan(g.foot_height_error).all()


def test_as_dict_flattens_the_gait_figures_into_json_values():
    gait = m.gait_metrics(**_gait_case())
    run = m.LocomotionMetrics(reached_goal=False, time_to_goal=float('nan'), final_goal_distance=1.5,
                              path_length=2.0, mean_forward_speed=0.1, foot_slip_per_stride=0.01,
                              lateral_bending_amplitude_deg=8.0, inter_joint_distance_variation=0.02,
                              fell=False, stuck=True, strides=2, gait=gait)
    d = run.as_dict()
    assert 'gait' not in d and d['time_to_goal'] is None and d['strides'] == 2 and d['stuck'] is True
    assert d['stance_fraction'] == pytest.approx([0.5, 0.75, 0.5, 0.75])
    assert d['swing_clearance'][:3] == pytest.approx([0.02, 0.0175, 0.01]) and d['swing_clearance'][3] is None
    assert d['foot_height_error'] == pytest.approx([0.003, 0.004, 0.008 / np.sqrt(8), 0.0])
    assert d['swings'] == 4 and d['swings_clear_fraction'] == pytest.approx(0.75)
    assert json.loads(json.dumps(d, allow_nan=False)) == d  # plain lists, floats, None only
    plain = m.LocomotionMetrics(**{**asdict(run), 'gait': None}).as_dict()
    assert set(d) - set(plain) == {f.name for f in fields(m.GaitMetrics)}


def test_stride_averaged_path_takes_out_the_sway_not_the_way():
    t = np.arange(301) / 30.0
    straight = np.stack([0.25 * t, 0.02 * np.sin(2 * np.pi * 1.5 * t)], axis=1)     # 2 cm sway at the trot's 1.5 Hz
    assert m.path_length(straight) > 1.1 * 0.25 * t[-1]
    assert m.stride_path_length(straight) == pytest.approx(0.25 * t[-1], rel=0.01)
    corner = np.concatenate([np.stack([np.linspace(0, 1, 60), np.zeros(60)], 1),
                             np.stack([np.ones(60), np.linspace(0, 1, 60)], 1)])
    assert 1.85 < m.stride_path_length(corner) <= m.path_length(corner) == pytest.approx(2.0, rel=0.01)


def test_heading_counts_for_arrival_when_asked():
    t = np.arange(5) / 30.0
    xy = np.zeros((5, 2))
    yaw = np.radians([90.0, 60.0, 40.0, 20.0, 0.0])
    assert m.goal_arrival(t, xy, np.zeros(2), 0.1)[1] == 0.0
    assert m.goal_arrival(t, xy, np.zeros(2), 0.1, yaw, 0.0, np.radians(30.0))[1] == pytest.approx(3 / 30.0)
    assert m.goal_arrival(t, xy, np.zeros(2), 0.1, yaw, 0.0, np.inf)[1] == 0.0       # inf tolerance: any heading
    assert m.heading_errors(np.array([3.0]), -3.0)[0] == pytest.approx(2 * np.pi - 6.0)


def test_circling_is_two_turns_without_getting_closer():
    turns = np.linspace(0.0, 5 * np.pi, 40)
    assert m.circling_strides(turns, np.full(40, 1.0)) > 30
    assert m.circling_strides(turns, np.linspace(3.0, 0.5, 40)) == 0                  # spiralling in: progress
    assert m.circling_strides(np.linspace(0.0, np.pi, 40), np.full(40, 1.0)) == 0


def test_no_progress_flags_stride_ends_after_a_window_without_shrinking():
    measure = np.concatenate([np.linspace(3.0, 1.0, 10), np.full(10, 1.0)])
    flags = m.no_progress(measure, window=4, progress=0.05)
    assert not flags[:12].any() and flags[14:].all()
    xy = np.array([[2.0, 0.0], [1.0, 0.0]])
    away = m.remaining_way(xy, np.array([np.pi, 0.0]), np.zeros(2), 0.2)
    assert away[0] == pytest.approx(2.0) and away[1] == pytest.approx(1.0 + m.BEARING_WEIGHT * np.pi)
    inside = m.remaining_way(np.zeros((1, 2)), np.array([0.5]), np.zeros(2), 0.2, goal_yaw=0.0)
    assert inside[0] == pytest.approx(0.5 - 1.0)


def test_route_progress_and_steering_figures_of_a_route():
    t = np.arange(0, 121) / 30.0
    xy = np.concatenate([np.stack([np.linspace(0, 1, 61), np.zeros(61)], 1),
                         np.stack([np.ones(60), np.linspace(0, 1, 61)[1:]], 1)])
    route = np.array([[1.0, 0.0], [1.0, 1.0]])
    assert m.route_progress(xy, route, 0.1)[-1] == 2
    assert m.route_progress(xy[::-1], route, 0.1)[-1] == 1       # backwards: the second is met before the first
    s = m.steering_metrics(t, xy, np.zeros(121), route, None, 0.1, np.inf, np.arange(0, 121, 20))
    assert s.route_completed and s.waypoints == 2 and s.waypoints_in_order == 2 and s.circling_strides == 0
    assert s.straight_distance == pytest.approx(1.9) and s.path_ratio_frames == pytest.approx(1.9 / 1.9, rel=0.05)


def test_the_progress_window_is_the_rule_over_the_whole_series():
    rng = np.random.default_rng(7)
    for _ in range(20):
        measure = np.cumsum(rng.normal(-0.02, 0.1, 60))
        brute = [k >= 8 and measure[k - 7:k + 1].min() >= measure[:k - 7].min() - 0.08 for k in range(60)]
        assert m.no_progress(measure, 8, 0.08).tolist() == brute


def test_a_route_ends_only_after_its_waypoints_in_order():
    t = np.arange(4) / 30.0
    xy = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [0.0, 0.0]])
    route = np.array([[0.0, 1.0], [0.0, 0.0]])               # the end is where the walk starts: not reached then
    reached, when, final = m.route_arrival(t, xy, route, 0.1)
    assert reached and when == pytest.approx(3 / 30.0) and final == 0.0
    assert m.route_arrival(t[:2], xy[:2], route, 0.1)[0] is False
