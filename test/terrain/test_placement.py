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

"""A body set down on the terrain: turned, moved, and its lowest node at the asked clearance."""
import numpy as np

from iguana_ros.terrain.heightfield import HeightField
from iguana_ros.terrain.placement import place_on_terrain

REST = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.1]])


def test_turns_moves_and_lifts_onto_a_slope():
    slope = HeightField.tilted_plane(20.0)
    placed = place_on_terrain(REST, slope, xy=(2.0, 0.0), yaw=np.pi / 2, lift_only=True)
    np.testing.assert_allclose(placed[:, :2], [[2.0, 0.0], [2.0, 1.0]], atol=1e-15)
    gap = placed[:, 2] - slope.height(placed[:, :2])
    assert gap.min() == 0.0 and np.all(gap >= 0.0)


def test_clearance_sets_the_lowest_node_and_lift_only_never_lowers():
    flat = HeightField.flat()
    high = REST + [0.0, 0.0, 0.5]
    np.testing.assert_allclose(place_on_terrain(high, flat, clearance=1e-3)[:, 2], [1e-3, 0.101], rtol=0, atol=1e-15)
    np.testing.assert_array_equal(place_on_terrain(high, flat, lift_only=True), high)   # already clear: kept
    np.testing.assert_array_equal(place_on_terrain(REST - [0.0, 0.0, 0.2], flat, lift_only=True), REST)
