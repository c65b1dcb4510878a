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

"""Synthetic trot generator, degraded capture and C3D round trip."""
import numpy as np
import pytest

from iguana_ros.body.markers import iguana_markers
from iguana_ros.constants import TROT_DUTY_FACTOR, TROT_STRIDE_FREQUENCY, TROT_STRIDE_LENGTH
from iguana_ros.errors import InputError
from iguana_ros.motion.c3d_io import read_c3d, read_capture, write_c3d
from iguana_ros.motion.capture import CaptureQuality, synthesize_capture
from iguana_ros.motion.dofs import iguana_body_model
from iguana_ros.motion.gait import generate_take, joint_limit_violation, SYNTHETIC_TAKES, TakeSpec


@pytest.fixture(scope='module')
def straight():
    return generate_take(TakeSpec('straight', 3.0))


def test_trot_is_diagonal_with_literature_duty_factor_and_speed(straight):
    c = straight.contacts
    assert np.array_equal(c[:, 0], c[:, 3]) and np.array_equal(c[:, 1], c[:, 2])  # FL+HR, FR+HL
    assert not np.array_equal(c[:, 0], c[:, 1])
    assert c.mean() == pytest.approx(TROT_DUTY_FACTOR, abs=0.04)
    d = iguana_body_model().dofs
    travelled = straight.theta[-1, d.index('root_x')] - straight.theta[0, d.index('root_x')]
    expected = TROT_STRIDE_LENGTH * TROT_STRIDE_FREQUENCY * (straight.n_frames - 1) / straight.frame_rate
    assert travelled == pytest.approx(expected, rel=0.02)
    assert abs(straight.theta[-1, d.index('root_y')]) < 1e-9
    td = straight.touchdown_frames('fl')
    assert np.all(np.diff(td) == round(straight.frame_rate / TROT_STRIDE_FREQUENCY))


def test_stance_feet_are_planted_and_limits_hold(straight):
    model = iguana_body_model()
    feet = straight.markers[:, :4]
    still = straight.contacts[1:] & straight.contacts[:-1]
    moved = np.linalg.norm(np.diff(feet, axis=0), axis=-1)[still]
    assert moved.max() < 1e-3  # stance feet fixed in the world (foot IK to 0.5 mm)
    swing = np.linalg.norm(np.diff(feet, axis=0), axis=-1)[~straight.contacts[1:]]
    assert swing.mean() > 0.01
    assert joint_limit_violation(model, straight.theta) == 0.0


def test_turn_takes_turn_and_standing_stands():
    d = iguana_body_model().dofs
    left = generate_take(SYNTHETIC_TAKES[1])
    strides = (left.n_frames - 1) / left.frame_rate * TROT_STRIDE_FREQUENCY
    heading = left.theta[-1, d.index('root_yaw')] - left.theta[0, d.index('root_yaw')]
    # pelvis yaw also swings with the trunk bending; over ~10 strides the turn dominates
    assert heading / strides == pytest.approx(SYNTHETIC_TAKES[1].turn_per_stride, rel=0.15)
    stand = generate_take(SYNTHETIC_TAKES[3])
    assert stand.contacts.all()
    assert np.ptp(stand.markers[:, :4], axis=0).max() < 1e-6


def test_capture_degradation_is_seeded_and_sized(straight):
    a = synthesize_capture(straight, 7)
    b = synthesize_capture(straight, 7)
    assert np.array_equal(a, b, equal_nan=True)
    missing = np.isnan(a).any(axis=-1)
    assert 0.01 < missing.mean() < 0.2
    err = np.linalg.norm(a - straight.markers, axis=-1)[~missing]
    assert 1e-3 < np.sqrt(np.mean(err ** 2)) < 5e-3
    clean = synthesize_capture(straight, 7, CaptureQuality(noise_std=0.0, gap_rate=0.0, slip_std=0.0))
    assert np.allclose(clean, straight.markers)


def test_c3d_round_trip_is_identical(tmp_path, straight):
    labels = iguana_markers().labels
    data = synthesize_capture(straight, 3)
    path = tmp_path / 'take.c3d'
    write_c3d(path, labels, data, 30.0)
    got_labels, got, rate = read_c3d(path)
    assert got_labels == labels and rate == 30.0
    assert np.array_equal(np.isnan(got), np.isnan(data))
    assert np.nanmax(np.abs(got - data)) < 1e-6  # float32 millimetres
    write_c3d(tmp_path / 'again.c3d', got_labels, got, rate)
    assert np.array_equal(read_c3d(tmp_path / 'again.c3d')[1], got, equal_nan=True)  # bit-identical


def test_c3d_label_errors_name_the_labels(tmp_path):
    labels = list(iguana_markers().labels)
    data = np.zeros((3, len(labels), 3))
    bad = labels[:-1] + ['TOE_X']
    write_c3d(tmp_path / 'bad.c3d', tuple(bad), data, 30.0)
    with pytest.raises(InputError, match='missing marker labels SIDE_HR.*unknown marker labels TOE_X'):
        read_capture(tmp_path / 'bad.c3d')
    with pytest.raises(InputError, match='does not exist'):
        read_capture(tmp_path / 'none.c3d')
    (tmp_path / 'junk.c3d').write_bytes(b'not a c3d file at all' * 40)
    with pytest.raises(InputError):
        read_capture(tmp_path / 'junk.c3d')
