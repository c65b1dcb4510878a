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
Test helper process: publishes several topics of the table as serialized bytes and dumps them.

Usage: publish_topics.py DUMP_FILE [--duration S] [--rate HZ] [--wait-subscribers S] [--clock]
1. publishes scene_markers (transient-local) once and prints 'latched published';
2. waits until the periodic topics have a subscriber (e.g. a recorder), up to --wait-subscribers;
3. publishes goal_pose, iguana_state, spring_rest_lengths and mesh_marker at --rate for --duration s,
   writing each message's bytes to DUMP_FILE as it goes (so a killed run still leaves a prefix); with --clock,
   /clock first in each frame, at the frames' stamps (100 s + i / rate), like the simulator.
Every message is serialized here, zero-padded to a multiple of 4 bytes (as Fast DDS delivers it)
and published raw, so the bytes on the wire are exactly the dump.
"""
import argparse
from pathlib import Path
import sys

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))


def build_messages(i: int, t: float) -> dict:
    """Messages of frame i at time t (s) for each periodic topic key."""
    import numpy as np

    from iguana_ros.geometry import quat_from_yaw
    from iguana_ros.ros import conversions as cv
    from iguana_ros.ros.cdr import triangle_list_marker_cdr
    rng = np.random.default_rng(i)
    verts = rng.random((30, 3))
    tris = rng.integers(0, 30, (40, 3))
    return {
        'goal_pose': cv.pose_stamped_msg([i * 0.1, -i * 0.2, 0.0], quat_from_yaw(0.1 * i), t),
        'iguana_state': cv.odometry_msg(rng.random(3), [0, 0, 0, 1], rng.random(3), rng.random(3), t),
        'spring_rest_lengths': cv.joint_state_msg(rng.random(50), t),
        'mesh_marker': triangle_list_marker_cdr(verts, tris, rng.random((30, 4)), t),
    }


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument('dump')
    parser.add_argument('--duration', type=float, default=2.0)
    parser.add_argument('--rate', type=float, default=20.0)
    parser.add_argument('--wait-subscribers', type=float, default=15.0)
    parser.add_argument('--clock', action='store_true')
    args = parser.parse_args()

    import time

    import numpy as np
    import rclpy
    from rclpy.duration import Duration
    from rclpy.serialization import serialize_message
    from rosgraph_msgs.msg import Clock

    from iguana_ros.ros import conversions as cv
    from iguana_ros.ros.endpoints import resolve
    from ros_harness import wait_for, write_dump

    rclpy.init()
    node = rclpy.create_node('test_publisher')
    pubs = {key: node.create_publisher(cls, name, qos) for key, (name, cls, qos) in
            ((k, resolve(k)) for k in ('scene_markers', 'goal_pose', 'iguana_state',
                                       'spring_rest_lengths', 'mesh_marker', *(['clock'] if args.clock else [])))}
    records = []

    def send(key: str, msg) -> None:
        data = msg if isinstance(msg, bytes) else serialize_message(msg)
        data += b'\x00' * (-len(data) % 4)  # Fast DDS pads payloads to 4 bytes on the wire
        pubs[key].publish(data)
        records.append(('/' + resolve(key)[0].lstrip('/'), data))

    ground = cv.triangle_list_marker(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]]), np.array([[0, 1, 2]]),
                                     np.full((3, 4), 0.5), 0.0, ns='terrain')
    send('scene_markers', cv.marker_array_msg([ground], delete_all_first=True))
    write_dump(args.dump, records)
    print('latched published', flush=True)
    periodic = [k for k in pubs if k != 'scene_markers']
    wait_for(lambda: all(pubs[k].get_subscription_count() > 0 for k in periodic), args.wait_subscribers)
    print('subscribers matched' if all(pubs[k].get_subscription_count() > 0 for k in periodic)
          else 'no subscribers', flush=True)
    t0 = time.monotonic()
    i = 0
    while time.monotonic() - t0 < args.duration:
        if args.clock:
            send('clock', Clock(clock=cv.time_to_msg(100.0 + i / args.rate)))
        for key, msg in build_messages(i, 100.0 + i / args.rate).items():
            send(key, msg)
        write_dump(args.dump, records)
        i += 1
        time.sleep(max(0.0, t0 + i / args.rate - time.monotonic()))
    ack_deadline = time.monotonic() + 3.0  # shared: a killed subscriber never acknowledges
    for pub in pubs.values():
        pub.wait_for_all_acked(Duration(seconds=max(ack_deadline - time.monotonic(), 0.01)))
    print(f'done {len(records)} messages', flush=True)
    node.destroy_node()
    rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())
