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

"""Record real publisher processes with `iguana bag record`, replay with `iguana bag play`, compare bytes."""
import subprocess

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
import pytest
import yaml

from iguana_ros.bag.storage import BagReader
from ros_harness import helper, IGUANA, NodeProcess, PLAY_PAUSED, read_dump

pytestmark = [pytest.mark.ros, pytest.mark.slow]

TOPIC_KEYS = ['scene_markers', 'goal_pose', 'iguana_state', 'spring_rest_lengths', 'mesh_marker']
TOPICS = ['/' + k for k in TOPIC_KEYS]


def _record_while_publishing(tmp_path, duration: float, kill_after: float | None = None):
    """Start the publisher (latched message first), then the recorder; stop or SIGKILL the recorder."""
    bag = tmp_path / 'run'
    pub = NodeProcess(helper('publish_topics.py', tmp_path / 'published.json', '--duration', duration),
                      'publisher', tmp_path).start(ready='latched published')
    rec = NodeProcess([*IGUANA, 'bag', 'record', *TOPICS, '-o', bag], 'recorder', tmp_path)
    rec.start(ready='recording to')
    with pub, rec:
        if kill_after is None:
            assert pub.wait(30) == 0, pub.output
            assert pub.wait_for_output('subscribers matched', 1), pub.output + '\nrecorder:\n' + rec.output
            assert rec.stop() == 0, rec.output
        else:
            assert pub.wait_for_output('subscribers matched', 15), pub.output
            assert not rec.wait_for_output('never printed', kill_after)
            rec.kill()
            assert pub.wait(30) == 0, pub.output
    return bag, read_dump(tmp_path / 'published.json')[0], rec


def test_record_then_play_reproduces_messages(tmp_path):
    bag, published, rec = _record_while_publishing(tmp_path, duration=2.0)
    assert set(published) == set(TOPICS) and len(published['/mesh_marker']) >= 20

    # The file reads back with mcap's own reader, CRCs validated, every message decodable.
    with open(bag / 'run.mcap', 'rb') as f:
        reader = make_reader(f, validate_crcs=True, decoder_factories=[DecoderFactory()])
        assert reader.get_header().profile == 'ros2'
        recorded, last_decoded = {}, {}
        for schema, channel, message, decoded in reader.iter_decoded_messages():
            assert schema.encoding == 'ros2msg' and channel.message_encoding == 'cdr'
            recorded.setdefault(channel.topic, []).append(message.data)
            last_decoded[channel.topic] = decoded
        summary = reader.get_summary()
    assert recorded == published, rec.output
    assert last_decoded['/mesh_marker'].type == 11 and len(last_decoded['/mesh_marker'].points) == 120
    assert last_decoded['/scene_markers'].markers[1].ns == 'terrain'
    assert last_decoded['/goal_pose'].header.frame_id == 'world'
    qos = {ch.topic: yaml.safe_load(ch.metadata['offered_qos_profiles'])
           for ch in summary.channels.values()}
    assert qos['/scene_markers'][0]['durability'] == 'transient_local'
    assert qos['/goal_pose'][0]['durability'] == 'volatile'
    assert all(ch.metadata['topic_type_hash'].startswith('RIHS01_') for ch in summary.channels.values())
    marker_schema = next(s for s in summary.schemas.values() if s.name == 'visualization_msgs/msg/MarkerArray')
    assert '\n' + '=' * 80 + '\nMSG: visualization_msgs/Marker\n' in marker_schema.data.decode()

    meta = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert meta['version'] == 9 and meta['storage_identifier'] == 'mcap'
    assert meta['relative_file_paths'] == ['run.mcap']
    assert meta['message_count'] == sum(map(len, published.values()))
    counts = {t['topic_metadata']['name']: t['message_count'] for t in meta['topics_with_message_count']}
    latched = next(t['topic_metadata'] for t in meta['topics_with_message_count']
                   if t['topic_metadata']['name'] == '/scene_markers')
    assert latched['offered_qos_profiles'][0]['durability'] == 'transient_local'
    assert set(latched['offered_qos_profiles'][0]) == {
        'history', 'depth', 'reliability', 'durability', 'deadline', 'lifespan', 'liveliness',
        'liveliness_lease_duration', 'avoid_ros_namespace_conventions'}
    assert counts == {t: len(v) for t, v in published.items()}

    # Replay to a real subscriber process: same bytes, and the latched topic is offered latched again.
    n_total = sum(map(len, published.values()))
    sub = NodeProcess(helper('dump_subscriber.py', tmp_path / 'replayed.json', *TOPIC_KEYS,
                             '--expect', n_total, '--resume-player'), 'subscriber', tmp_path).start(ready='subscribed')
    with sub:
        player = subprocess.run([*IGUANA, 'bag', 'play', bag, '--rate', '4', *PLAY_PAUSED], capture_output=True,
                                text=True, timeout=100)
        assert player.returncode == 0, player.stderr
        assert f'published {n_total} messages' in player.stdout
        assert sub.wait(20) == 0, sub.output
    replayed, extra = read_dump(tmp_path / 'replayed.json')
    assert replayed == published
    assert extra['publisher_durability']['/scene_markers'] == ['transient_local']
    assert extra['publisher_durability']['/goal_pose'] == ['volatile']


def test_killed_recorder_leaves_readable_prefix(tmp_path):
    bag, published, _rec = _record_while_publishing(tmp_path, duration=3.5, kill_after=2.5)
    assert not (bag / 'metadata.yaml').exists()
    refused = subprocess.run([*IGUANA, 'bag', 'info', bag], capture_output=True, text=True, timeout=30)
    assert refused.returncode == 1 and 'truncated' in refused.stderr and '--allow-damaged' in refused.stderr
    info = subprocess.run([*IGUANA, 'bag', 'info', bag, '--allow-damaged'], capture_output=True, text=True,
                          timeout=30)
    assert info.returncode == 0, info.stderr
    first = info.stdout.splitlines()[0]
    assert first.startswith('truncated:') and 'recovered' in first
    reader = BagReader(bag)
    recovered: dict = {}
    for msg in reader.messages():
        recovered.setdefault(msg.topic, []).append(msg.data)
    assert reader.truncated
    n = sum(map(len, recovered.values()))
    assert f'recovered {n} messages' in first
    # At most ~1 s (one chunk age) of the 2.5 s before the kill may be lost.
    assert len(recovered.get('/mesh_marker', [])) >= 15
    assert recovered['/scene_markers'] == published['/scene_markers']
    for topic, messages in recovered.items():
        assert messages == published[topic][:len(messages)], topic
