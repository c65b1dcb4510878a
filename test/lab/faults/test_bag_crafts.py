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
Bags whose CRCs hold but whose contents lie (issue 30, item 6 and the decompression caveats).

A channel id defined twice (first `/iguana_state` Odometry, then `/mesh_marker` Marker) was reported sound by `bag
info`, and `bag play` published the Marker payloads as Odometry; a 135 kB zstd chunk declaring 4 GiB took 4.2 GB to
read, an lz4 chunk 3.4 GB. The whole suite: `iguana bench faults crafted`.
"""
from __future__ import annotations

import pytest

from iguana_lab.faults.bag_crafts import craft_trial, crafted_suite, CRAFTS, PEAK_LIMIT_MB
from iguana_ros.bag.storage import BagReader


def test_a_channel_defined_twice_is_damage_and_its_later_messages_are_not_decoded_as_the_first_type(tmp_path):
    row = craft_trial('channel_redefined', 'info', tmp_path)
    assert not row.problems, row
    assert row.exit_code == 1 and 'channel 1 defined twice' in row.line and 'not attributed' in row.line
    reader = BagReader(tmp_path / 'channel_redefined.mcap')
    kept = [(m.topic, len(m.data)) for m in reader.messages()]
    assert kept and all(topic == '/mesh_marker' for topic, _ in kept)     # channel 2's: the redefined id's are gone
    assert not reader.health.sound


def test_an_identical_channel_record_again_is_sound(tmp_path):
    row = craft_trial('channel_repeated', 'info', tmp_path)
    assert not row.problems and row.exit_code == 0, row


@pytest.mark.parametrize('craft', ['zstd_bomb_declared', 'lz4_bomb_understated'])
def test_a_decompression_bomb_is_damage_read_in_bounded_memory(tmp_path, craft):
    row = craft_trial(craft, 'info', tmp_path)
    assert not row.problems, row
    assert row.exit_code == 1 and 'chunk unreadable' in row.line and row.peak_mb < PEAK_LIMIT_MB


@pytest.mark.long
def test_every_crafted_bag_through_every_reader(tmp_path):
    result = crafted_suite(tmp_path)
    print({k: v for k, v in result.items() if k != 'rows'})
    assert result['trials'] == 3 * len(CRAFTS)
    assert result['survived'] == result['trials'], [r for r in result['rows'] if r['problems']]
    assert result['peak_mb'] < PEAK_LIMIT_MB
