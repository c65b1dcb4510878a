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

"""Full-body IK against the generator's DOFs, and stride segmentation against its true touchdowns."""
import numpy as np
import pytest

from iguana_ros.errors import InputError
from iguana_ros.motion.capture import synthesize_capture
from iguana_ros.motion.dofs import iguana_body_model
from iguana_ros.motion.gait import generate_take, SYNTHETIC_TAKES, TakeSpec
from iguana_ros.motion.ik import solve_ik
from iguana_ros.motion.segmentation import detect_contacts, stride_boundaries, touchdowns


@pytest.fixture(scope='module')
def take():
    return generate_take(TakeSpec('short_turn', 2.0, turn_per_stride=0.2))


def test_ik_recovers_generator_dofs_noise_free(take):
    result = solve_ik(take.markers)
    err = result.theta - take.theta
    rms_deg = np.degrees(np.sqrt(np.mean(err[:, 3:] ** 2)))
    assert rms_deg < 2.0
    assert np.sqrt(np.mean(err[:, :3] ** 2)) < 1e-3  # root position within 1 mm
    assert result.marker_rms_mm < 0.5


def test_ik_tracks_noisy_gappy_capture(take):
    observed = synthesize_capture(take, 11)
    observed[20:32, iguana_body_model().markers.index('HEAD')] = np.nan  # a long head gap too
    result = solve_ik(observed)
    assert np.isnan(observed).any()
    assert result.marker_rms_mm < 5.0
    assert np.all(np.isfinite(result.theta))
    model = iguana_body_model()
    assert np.all(result.theta[:, 3:] >= model.dofs.lower[3:] - 1e-9)
    assert np.all(result.theta[:, 3:] <= model.dofs.upper[3:] + 1e-9)
    # through a 0.4 s gap of the only head marker the neck angles are interpolated (smoothness prior):
    # the head oscillation is cut, but the head stays within a few cm of the truth
    head = model.markers.index('HEAD')
    gap_err = np.linalg.norm(model.marker_positions(result.theta)[20:32, head] - take.markers[20:32, head], axis=-1)
    assert gap_err.max() < 0.03


def test_ik_rejects_bad_shapes():
    with pytest.raises(InputError, match='shape'):
        solve_ik(np.zeros((5, 3, 3)))


def test_segmentation_finds_true_touchdowns_within_one_frame():
    take = generate_take(SYNTHETIC_TAKES[0])
    contacts = detect_contacts(take.markers[:, :4], take.frame_rate)
    assert (contacts == take.contacts).mean() > 0.95
    for i, leg in enumerate(('fl', 'fr', 'hl', 'hr')):
        found, true = touchdowns(contacts[:, i]), take.touchdown_frames(leg)
        true = true[true >= 1]
        assert len(found) == len(true)
        assert np.abs(found - true).max() <= 1
    bounds = stride_boundaries(contacts)
    true = take.touchdown_frames('fl')
    true = true[true >= 1]
    assert len(bounds) == len(true) and np.abs(bounds - true).max() <= 1


def test_segmentation_of_standing_has_no_strides():
    take = generate_take(SYNTHETIC_TAKES[3])
    contacts = detect_contacts(take.markers[:, :4], take.frame_rate)
    assert contacts.all() and stride_boundaries(contacts).size == 0
