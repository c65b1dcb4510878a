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

"""`iguana motion calibrate`'s tours on a standard-library process pool (no Dask): order, progress, failures."""
import pytest

from iguana_ros.clip_calibration import _tours, calibration_scenes, measure_tour

SCRIPT = ('start', 'walk', 'stop')
"""A short tour: three strides."""


def test_tours_run_in_spawned_processes_and_equal_the_in_process_tour():
    scenes = calibration_scenes()[:2]
    seen = []
    rows = _tours(scenes, SCRIPT, 2, lambda result, done, total: seen.append((done, total)))
    assert sorted(seen) == [(1, 2), (2, 2)]
    assert rows == [measure_tour(scene, SCRIPT) for scene in scenes]
    assert [row['clip'] for row in rows[0]][:2] == ['start', 'walk']


def test_a_failing_tour_names_its_scene():
    scenes = calibration_scenes()[:1]
    with pytest.raises(RuntimeError, match='calibration run calibrate_level failed'):
        _tours(scenes, ('start', 'no_such_clip'), 1)
