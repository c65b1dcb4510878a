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
The foot probe and the gait figures of per-frame tracks.

They are the pieces a node run's summary shares with `metrics_of_run`.
"""
import math

import numpy as np

from iguana_ros.body.feet import foot_groups, foot_probe, FootProbe
from iguana_ros.body.model import build_model
from iguana_ros.metrics import gait_metrics
from iguana_ros.run_metrics import (GaitTracks, Stride, stride_progress,
                                    tracks_gait_metrics)
from iguana_ros.terrain.heightfield import HeightField


def test_one_frame_probe_equals_the_probe_of_a_trajectory():
    model = build_model('coarse')
    rng = np.random.default_rng(3)
    nodes = model.rest_positions[None] + rng.normal(scale=0.01, size=(5, model.n_nodes, 3))
    contacts = rng.random((5, model.n_nodes)) < 0.3
    terrain = HeightField.flat()
    probe = FootProbe(model, terrain)
    heights, contact, soles = foot_probe(nodes, contacts, foot_groups(model), terrain, probe.offset)
    for f in range(5):
        h, c, s = probe.body(nodes[f], contacts[f])
        assert np.array_equal(h, heights[f]) and np.array_equal(c, contact[f]) and np.array_equal(s, soles[f])
    feet = foot_groups(model)
    lowest = [np.min(nodes[2, idx, 2] - probe.offset[idx]) for idx in feet]
    assert np.allclose(heights[2], lowest)
    assert np.allclose(soles[2, 1], nodes[2, feet[1]].mean(axis=0))


def test_tracks_gait_metrics_blank_only_the_figures_of_unknown_tracks():
    n = 40
    t = (np.arange(n) + 1) / 30.0
    root = np.zeros((n, 3))
    root[:, 0] = 0.01 * np.arange(n)
    quat = np.tile([0.0, 0.0, 0.0, 1.0], (n, 1))
    stance = np.ones((n, 4), bool)
    stance[10:20, 0] = False
    contact = stance.copy()
    heights = np.where(stance, 0.0, 0.02)
    xy = np.zeros((n, 4, 2))
    strides = [Stride(0, 20, np.array([0.2, 0.0]), 0.0), Stride(20, 20, np.array([0.2, 0.0]), 0.0)]
    full = GaitTracks(t, root, quat, contact, heights, xy, stance, heights, strides)
    gait = tracks_gait_metrics(full, n)
    progress, clip = stride_progress(strides, root, quat, n)
    expected = gait_metrics(contact, stance, heights, heights, xy, 2, progress, clip, np.zeros(0))
    assert all(_same(getattr(gait, k), v) for k, v in vars(expected).items())
    assert gait.swings == 1 and gait.swing_clearance[0] == 0.02
    no_stance = tracks_gait_metrics(GaitTracks(t, root, quat, contact, heights, xy, None, heights, strides), n)
    assert all(math.isnan(v) for v in no_stance.reference_stance_fraction + no_stance.swing_clearance)
    assert math.isnan(gait.shape_error_median) and math.isnan(gait.shape_error_p90)  # no shape errors given
    assert no_stance.swings == 0 and math.isnan(no_stance.swings_clear_fraction)
    assert _same(no_stance.stance_fraction, gait.stance_fraction) and no_stance.speed_fraction == gait.speed_fraction
    assert _same(no_stance.foot_height_error, gait.foot_height_error)
    no_strides = tracks_gait_metrics(GaitTracks(t, root, quat, contact, heights, xy, stance, heights, None), n)
    assert math.isnan(no_strides.speed_fraction) and all(math.isnan(v) for v in no_strides.slip_per_foot_per_stride)
    assert _same(no_strides.swing_clearance, gait.swing_clearance)


def _same(a, b) -> bool:
    """Equal, NaN equal to NaN."""
    return np.array_equal(np.asarray(a, float), np.asarray(b, float), equal_nan=True)
