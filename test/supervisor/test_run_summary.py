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

"""A run's summary leaves the time it was paused out of its realtime factor."""
from pathlib import Path

import pytest

from iguana_ros.supervisor.run_summary import paused_seconds, RunSummary


def test_paused_seconds_add_the_intervals_from_each_pause_to_its_resume_or_the_end():
    assert paused_seconds([], 0.0, 10.0) == 0.0
    events = [('paused', 2.0), ('resumed', 5.0), ('paused', 7.0), ('paused', 8.0), ('resumed', 8.5)]
    assert paused_seconds(events, 0.0, 10.0) == pytest.approx(3.0 + 1.5)
    assert paused_seconds([('resumed', 1.0), ('paused', 9.0)], 0.0, 10.0) == pytest.approx(1.0)  # open at the end
    assert paused_seconds([('paused', -5.0), ('resumed', 3.0)], 1.0, 10.0) == pytest.approx(2.0)  # before the loop
    assert paused_seconds(list(reversed(events)), 0.0, 10.0) == pytest.approx(4.5)             # in time order


def test_the_summary_gives_the_realtime_factor_while_running_and_says_how_long_it_was_paused():
    summary = RunSummary('s', Path('bag'), Path('logs'), simulated_s=3.0, wall_s=18.0, reached_goal=False,
                         time_to_goal=float('nan'), final_goal_distance=float('nan'), exit_code=0, paused_s=12.0)
    assert summary.realtime_factor == pytest.approx(0.5)
    assert 'simulated 3.00 s in 18.00 s wall (12.0 s of it paused; realtime factor 0.50)' in summary.lines()
    assert 'paused' not in RunSummary('s', Path('b'), Path('l'), 3.0, 6.0, False, 0.0, 0.0, 0).lines()[2]
