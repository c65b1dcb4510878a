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
Test helper process: subscribes raw to topic keys of the table and dumps what it receives.

Usage: dump_subscriber.py DUMP_FILE KEY [KEY ...] [--expect N] [--resume-player]
Prints 'subscribed' once its subscriptions exist; exits on SIGINT/SIGTERM, or once N messages came. With
--resume-player it waits until it sees a publisher of every topic (its readers have matched them: a volatile reader
that matches late misses what came before), then calls the paused `iguana bag play --start-paused` to play.
The dump also records, per topic, the durability offered by the publisher it heard from. Its readers keep at least
N messages each: with the table's depth (10), a burst replayed at --rate 4 overflowed a reader's history while this
process was slow to take (161 of 162 received under load). Stopped by a signal, it takes what its readers hold first.
"""
import argparse
from pathlib import Path
import signal
import sys

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

MIN_DEPTH = 1000
"""Least history of each reader: without --expect, a reader of depth 5 (mesh_marker's) overflowed under load."""


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument('dump')
    parser.add_argument('keys', nargs='+')
    parser.add_argument('--expect', type=int, default=0)
    parser.add_argument('--resume-player', action='store_true')
    args = parser.parse_args()

    import rclpy
    from rclpy.signals import SignalHandlerOptions

    from iguana_ros.ros.endpoints import resolve
    from ros_harness import resume_player, write_dump

    stop = [False]
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda _s, _f: stop.__setitem__(0, True))
    rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
    node = rclpy.create_node('test_dump_subscriber')
    records, durability = [], {}

    def on_message(name: str, data: bytes) -> None:
        records.append((name, bytes(data)))
        if name not in durability:
            durability[name] = sorted({i.qos_profile.durability.name.lower()
                                       for i in node.get_publishers_info_by_topic(name)})

    topics = []
    for key in args.keys:
        name, cls, qos = resolve(key)
        qos.depth = max(qos.depth, args.expect, MIN_DEPTH)  # a recorder's: a burst (--rate 4) must not overflow
        topics.append('/' + name.lstrip('/'))
        node.create_subscription(cls, topics[-1], lambda d, n=topics[-1]: on_message(n, d), qos, raw=True)
    print('subscribed', flush=True)
    if args.resume_player:
        answer = resume_player(node, topics, lambda: rclpy.spin_once(node, timeout_sec=0.02),
                               playing=lambda: bool(records))
        print(f'resumed the player: {answer}', flush=True)
    while not stop[0] and not (args.expect and len(records) >= args.expect):
        rclpy.spin_once(node, timeout_sec=0.05)
    while stop[0]:          # stopped: take what the readers hold already (acknowledged to the player, not yet taken)
        before = len(records)
        rclpy.spin_once(node, timeout_sec=0.2)
        if len(records) == before:
            break
    write_dump(args.dump, records, {'publisher_durability': durability})
    print(f'received {len(records)} messages', flush=True)
    node.destroy_node()
    rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())
