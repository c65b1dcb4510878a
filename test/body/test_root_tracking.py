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

"""The soft body's root frame follows rigid motions of the body exactly."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from iguana_ros.body.model import build_model
from iguana_ros.body.root_tracking import RootTracker


def test_root_pose_of_moved_rest_body():
    model = build_model('coarse')
    tracker = RootTracker(model)
    pos, quat = tracker.root_pose(model.rest_positions)
    assert np.allclose(pos, model.skeleton.offsets[0], atol=1e-12)
    assert np.allclose(np.abs(quat), [0, 0, 0, 1], atol=1e-12)
    rot = Rotation.from_euler('z', 75, degrees=True)
    moved = rot.apply(np.array(model.rest_positions)) + [0.5, -1.0, 0.2]
    pos, quat = tracker.root_pose(moved)
    assert np.allclose(pos, rot.apply(np.array(model.skeleton.offsets[0])) + [0.5, -1.0, 0.2])
    assert tracker.heading(moved) == pytest.approx(np.radians(75))
