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
Bag fault-injection suite, short version.

A bag recorded by `iguana bag record` from a real publisher process, seeded random truncations and byte corruptions of
its MCAP and damaged metadata.yaml variants. The long version is `iguana bench faults bags`
(iguana_lab/faults/bag_files.py).
"""
import subprocess

from mcap.reader import make_reader
import pytest

from iguana_lab.faults.bag_files import reference, run_suite
from iguana_ros.bag.storage import BagReader
from iguana_ros.cli import main
from ros_harness import helper, IGUANA, NodeProcess, PLAY_PAUSED, read_dump

pytestmark = [pytest.mark.ros, pytest.mark.slow, pytest.mark.long]

TOPIC_KEYS = ['scene_markers', 'goal_pose', 'iguana_state', 'spring_rest_lengths', 'mesh_marker']
TRIALS = 20
"""Truncations and corruptions each (the benchmark runs 100 + 100)."""


@pytest.fixture(scope='module')
def recorded(tmp_path_factory):
    """(bag directory, {topic: [bytes]} published) of a 2 s recording with a chunk every 0.1 s."""
    tmp = tmp_path_factory.mktemp('faults')
    bag = tmp / 'run'
    pub = NodeProcess(helper('publish_topics.py', tmp / 'published.json', '--duration', 2.0),
                      'publisher', tmp).start(ready='latched published')
    rec = NodeProcess([*IGUANA, 'bag', 'record', *('/' + k for k in TOPIC_KEYS), '-o', bag, '--chunk-age', '0.1'],
                      'recorder', tmp).start(ready='recording to')
    with pub, rec:
        assert pub.wait(30) == 0, pub.output
        assert pub.wait_for_output('subscribers matched', 1), pub.output
        assert rec.stop() == 0, rec.output
    return bag, read_dump(tmp / 'published.json')[0]


def test_recorded_bag_is_sound_and_the_reference_agrees(recorded):
    bag, published = recorded
    ref = reference(bag)
    assert len(ref.chunks) >= 10 and ref.decoded_channels == len(TOPIC_KEYS)
    recovered = [(m.topic, m.data) for m in BagReader(bag).messages()]
    assert sorted(recovered) == sorted((t, d) for t, msgs in published.items() for d in msgs)
    assert sum(ref.all_messages.values()) == len(recovered)


@pytest.mark.timeout(120)
def test_bag_fault_suite_short(recorded):
    bag, _ = recorded
    figures = run_suite(bag, truncations=TRIALS, corruptions=TRIALS, seed=12, timeout_s=20.0, iguana=main)
    assert figures['trials']['truncate'] == TRIALS and figures['trials']['metadata'] >= 10
    assert figures['failures'] == [] and figures['survived_total'] == figures['trials_total']
    assert figures['exit_0_on_damage'] == 0 and figures['tracebacks'] == 0 and figures['hangs'] == 0
    assert figures['lost_intact_messages'] == 0 and figures['wrong_messages'] == 0
    assert figures['recovered_intact_messages'] == figures['intact_messages'] > 0


def test_play_with_allow_damaged_publishes_every_intact_chunk(recorded, tmp_path):
    src, published = recorded
    bag = tmp_path / src.name
    bag.mkdir()
    for f in src.iterdir():
        (bag / f.name).write_bytes(f.read_bytes())
    mcap = bag / 'run.mcap'
    with open(mcap, 'rb') as f:
        chunks = make_reader(f).get_summary().chunk_indexes
    hit = chunks[len(chunks) // 3]
    raw = bytearray(mcap.read_bytes())
    raw[hit.chunk_start_offset + hit.chunk_length // 2] ^= 0x5A
    mcap.write_bytes(bytes(raw))
    expected = {}
    reader = BagReader(bag)
    for msg in reader.messages():
        expected.setdefault(msg.topic, []).append(msg.data)
    assert reader.damaged and sum(map(len, expected.values())) < sum(map(len, published.values()))
    late = list(BagReader(src).messages())[-1]
    assert late.data in expected[late.topic]              # the chunks after the damaged one are there

    refused = subprocess.run([*IGUANA, 'bag', 'play', bag], capture_output=True, text=True, timeout=30)
    assert refused.returncode == 1 and len(refused.stderr.strip().splitlines()) == 1, refused.stderr
    assert 'damaged' in refused.stderr and 'published' not in refused.stdout

    n_expected = sum(map(len, expected.values()))
    sub = NodeProcess(helper('dump_subscriber.py', tmp_path / 'replayed.json', *TOPIC_KEYS, '--expect', n_expected,
                             '--resume-player'), 'subscriber', tmp_path).start(ready='subscribed')
    with sub:
        player = subprocess.run([*IGUANA, 'bag', 'play', bag, '--allow-damaged', '--rate', '4', *PLAY_PAUSED],
                                capture_output=True, text=True, timeout=100)
        assert player.returncode == 0, player.stderr
        assert f'published {n_expected} messages' in player.stdout
        assert 'damaged' in player.stderr and 'warning' in player.stderr
        assert sub.wait(20) == 0, sub.output
    replayed, _ = read_dump(tmp_path / 'replayed.json')
    assert replayed == expected


def test_bench_faults_bags_prints_the_figures(recorded, capsys):
    bag, _ = recorded
    rc = main(['bench', 'faults', 'bags', str(bag), '--truncations', '3', '--corruptions', '3', '--seed', '5'])
    out, err = capsys.readouterr()
    assert rc == 0, out + err
    assert 'truncate     3 trials,    3 survived' in out and 'exit 0 on damage 0, tracebacks 0, hangs 0' in out
    assert '(lost 0); wrong 0' in out
