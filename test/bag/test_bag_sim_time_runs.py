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
Bags on simulated time, against real processes.

A lockstep `iguana run` records on simulated time (its bag lasts as long as the simulated run), `iguana bag play
--clock` of it gives a plain rclpy subscriber one strictly increasing /clock, a standalone `iguana bag record
--use-sim-time` stamps from the graph's /clock, and a wall-time bag still plays with the player's own clock.
"""
import struct
import subprocess

import pytest

from iguana_ros.bag.sim_time import clock_ns
from iguana_ros.bag.storage import BagReader, summarize
from iguana_ros.constants import FRAME_RATE
from ros_harness import helper, IGUANA, NodeProcess, PLAY_PAUSED, read_dump

pytestmark = [pytest.mark.ros, pytest.mark.slow, pytest.mark.timeout(300)]

DURATION_S = 2.0
FRAME_NS = round(1e9 / FRAME_RATE)
SIMULATOR_TOPICS = ('/iguana_state', '/foot_state', '/foot_positions', '/mesh_marker')
"""Topics the simulator publishes after the /clock of their frame, stamped with that frame's time."""


def _stamp_ns(data: bytes) -> int:
    """header.stamp of a serialized message whose first field is a std_msgs/Header (little-endian CDR)."""
    sec, nanosec = struct.unpack_from('<iI', data, 4)
    return sec * 1_000_000_000 + nanosec


def _in_order(got: list, sent: list) -> bool:
    """Whether `got` is `sent` with some messages left out (order kept)."""
    rest = iter(sent)
    return all(any(data == s for s in rest) for data in got)


def _strictly_increasing(values: list[int]) -> bool:
    return all(b > a for a, b in zip(values, values[1:]))


@pytest.fixture(scope='module')
def run_bag(tmp_path_factory):
    """Run a lockstep `iguana run flat_walk --duration 2` (a child process, as a user runs it); return its bag."""
    bag = tmp_path_factory.mktemp('simtime') / 'walk'
    done = subprocess.run([*IGUANA, 'run', 'flat_walk', '--duration', str(DURATION_S), '--record', str(bag),
                           '--progress-every', '0'], capture_output=True, text=True, timeout=240)
    assert done.returncode == 0, done.stdout + done.stderr
    assert f'run completed: {DURATION_S:.2f} of {DURATION_S:.2f} s simulated' in done.stdout, done.stdout
    return bag


def test_lockstep_run_bag_lasts_its_simulated_duration(run_bag):
    summary = summarize(run_bag)
    assert summary.sound and summary.time_base == 'simulated'
    duration_ns = summary.end_ns - summary.start_ns
    assert abs(duration_ns - DURATION_S * 1e9) <= FRAME_NS, (summary.start_ns, summary.end_ns)
    # The simulator's messages are logged at the simulated time of their frame (their header stamp).
    off = {}
    for msg in BagReader(run_bag).messages():
        if msg.topic in SIMULATOR_TOPICS:
            off[msg.topic] = max(off.get(msg.topic, 0), abs(msg.log_time - _stamp_ns(msg.data)))
    assert set(off) == set(SIMULATOR_TOPICS) and max(off.values()) <= FRAME_NS, off
    info = subprocess.run([*IGUANA, 'bag', 'info', str(run_bag)], capture_output=True, text=True, timeout=60)
    assert info.returncode == 0, info.stderr
    assert 'Time base:         simulated (/clock)' in info.stdout
    duration = float(info.stdout.split('Duration:')[1].split('s')[0])
    assert abs(duration - DURATION_S) <= 1 / FRAME_RATE, info.stdout


def _play_to_subscriber(bag, tmp_path, keys: list[str], expect: int | None, *play_args) -> tuple[dict, str]:
    """
    Play `bag` to a dump_subscriber process of topic `keys`: (what it received, the player's output).

    The player starts paused and the subscriber resumes it once its readers see every publisher (a volatile reader
    that matches the player late misses the first messages). The subscriber stops once it has `expect` messages, or
    (None) when stopped after the player ended (every reliable message acknowledged).
    """
    sub = NodeProcess(helper('dump_subscriber.py', tmp_path / 'replayed.json', *keys, '--expect', expect or 0,
                             '--resume-player'), 'subscriber', tmp_path).start(ready='subscribed')
    with sub:
        player = subprocess.run([*IGUANA, 'bag', 'play', str(bag), *play_args, *PLAY_PAUSED],
                                capture_output=True, text=True, timeout=120)
        assert player.returncode == 0, player.stdout + player.stderr
        # (the player ended once every subscriber acknowledged every message, or after 2 s: a subscriber still
        # running 10 s later lacks messages, superseded ones of a latched topic at least; stopped, it dumps them)
        done = expect and sub.wait_for_output('received', 10)
        assert (sub.wait(30) if done else sub.stop()) == 0, sub.output + player.stdout
    assert 'resumed the player: playing' in sub.output, sub.output
    return read_dump(tmp_path / 'replayed.json')[0], player.stdout + player.stderr


def test_play_clock_of_a_run_gives_one_strictly_increasing_clock(run_bag, tmp_path):
    from iguana_ros.topics import default_topics
    summary = summarize(run_bag)
    keys = {'/' + spec.name.lstrip('/'): key for key, spec in default_topics().items()}
    counts = {t.name: t.message_count for t in summary.topics}
    assert set(counts) <= set(keys), counts
    # Every topic of the bag, as a user plays it, to one plain rclpy subscriber process.
    replayed, out = _play_to_subscriber(run_bag, tmp_path, [keys[name] for name in counts], summary.message_count,
                                        '--clock', '--rate', '2')
    assert 'the recorded /clock is the clock' in out, out
    # Every message of every topic, but of a latched topic (transient_local, keep_last 1: planner_status,
    # motion_clip, accepted_goals) only the last is owed: DDS keeps the newest of a keep-last history, and one lost
    # on the way under load (5 busy processes on 2 cores: 4 of 12 runs) is overwritten by the next before a re-send.
    # (A topic the recorder found only after a short run ended, spring_rest_lengths at times, is in it with 0.)
    recorded: dict = {}
    for msg in BagReader(run_bag).messages():
        recorded.setdefault(msg.topic, []).append(msg.data)
    latched = {name for name, key in keys.items()
               if default_topics()[key].qos.durability == 'transient_local' and default_topics()[key].qos.depth == 1}
    assert latched & set(recorded) >= {'/planner_status', '/motion_clip'}, latched
    assert {name for name, v in replayed.items()} == {name for name, v in recorded.items() if v}
    for name, sent in recorded.items():
        got = replayed.get(name, [])
        if name in latched:
            assert got and got[-1] == sent[-1] and _in_order(got, sent), (name, len(got), len(sent), out)
        else:
            lost = [i for i, data in enumerate(sent) if data not in got]
            assert got == sent, f'{name}: {len(got)} of {len(sent)}, lost the messages {lost}\n{out}'
    clocks = [clock_ns(data) for data in replayed['/clock']]
    assert len(clocks) == counts['/clock'] == round(DURATION_S * FRAME_RATE) + 1
    assert _strictly_increasing(clocks), clocks
    assert clocks[0] == 0 and clocks[-1] == round(DURATION_S * 1e9)


TOPIC_KEYS = ['scene_markers', 'goal_pose', 'iguana_state', 'spring_rest_lengths', 'mesh_marker']


def _record_publisher(tmp_path, *record_args, clock: bool = False, duration: float = 1.5):
    """`iguana bag record` of the publish_topics.py helper (frames stamped 100 s + i / 20 Hz): (bag, published)."""
    bag = tmp_path / 'rec'
    topics = ['/' + k for k in TOPIC_KEYS] + (['/clock'] if clock else [])
    pub = NodeProcess(helper('publish_topics.py', tmp_path / 'published.json', '--duration', duration,
                             *(['--clock'] if clock else [])), 'publisher', tmp_path).start(ready='latched published')
    rec = NodeProcess([*IGUANA, 'bag', 'record', *topics, '-o', bag, *record_args], 'recorder', tmp_path)
    rec.start(ready='recording to')
    with pub, rec:
        assert pub.wait(30) == 0, pub.output
        assert pub.wait_for_output('subscribers matched', 1), pub.output + '\nrecorder:\n' + rec.output
        assert rec.stop() == 0, rec.output
    return bag, read_dump(tmp_path / 'published.json')[0], rec.output


def test_standalone_record_with_use_sim_time_stamps_from_the_graphs_clock(tmp_path):
    bag, published, out = _record_publisher(tmp_path, '--use-sim-time', clock=True)
    assert 'on simulated time (/clock)' in out
    summary = summarize(bag)
    assert summary.sound and summary.time_base == 'simulated'
    logs: dict = {}
    for msg in BagReader(bag).messages():
        logs.setdefault(msg.topic, []).append((msg.log_time, msg.data))
    assert {t: [d for _, d in v] for t, v in logs.items()} == published
    first_clock = clock_ns(published['/clock'][0])
    assert first_clock == 100 * 1_000_000_000
    # The latched scene came before any /clock: held, and logged at the first /clock (not at 0).
    assert [t for t, _ in logs['/scene_markers']] == [first_clock]
    # Each frame's state is logged at its /clock (published just before it), within a frame (20 Hz) under load.
    for t, data in logs['/iguana_state']:
        assert abs(_stamp_ns(data) - t) <= 50_000_000, (t, _stamp_ns(data))
    assert summary.start_ns == first_clock and summary.end_ns == clock_ns(published['/clock'][-1])


def test_wall_time_bag_says_wall_and_plays_with_the_players_own_clock(tmp_path):
    bag, published, out = _record_publisher(tmp_path)
    assert 'simulated' not in out
    summary = summarize(bag)
    assert summary.sound and summary.time_base == 'wall' and summary.start_ns > 1_600_000_000 * 10 ** 9
    info = subprocess.run([*IGUANA, 'bag', 'info', str(bag)], capture_output=True, text=True, timeout=60)
    assert info.returncode == 0 and 'Time base:         wall (receive time)' in info.stdout, info.stdout
    replayed, out = _play_to_subscriber(bag, tmp_path, ['clock', *TOPIC_KEYS], None, '--clock')
    assert 'the bag has no /clock: the player publishes one from the bag time' in out, out
    assert {t: v for t, v in replayed.items() if t != '/clock'} == published
    clocks = [clock_ns(data) for data in replayed['/clock']]
    assert len(clocks) >= 10 and _strictly_increasing(clocks), clocks
    assert summary.start_ns <= clocks[0] and clocks[-1] <= summary.end_ns
