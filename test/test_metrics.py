"""Locomotion metrics on hand-made trajectories with known answers."""
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
