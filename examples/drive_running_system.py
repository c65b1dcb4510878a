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
Example 2: drive a running system from Python — send a goal, wait until the iguana is there, push it.

Start the four nodes first (in another terminal, same ROS_DOMAIN_ID), then run this script:

    iguana run flat_walk --mode realtime --duration 120     # terminal 1: the nodes, paced to the wall clock
    python examples/drive_running_system.py --ahead 0.5      # terminal 2

`IguanaCommander` (iguana_ros/nodes/commander.py) is an rclpy node of its own: `go_to` returns once the planner
has accepted the goal (it lists it on accepted_goals), `wait_until_reached` spins until the root is within the
goal radius, `push` sets the simulator's push duration and publishes a WrenchStamped on `push`.
"""
from __future__ import annotations

import argparse

import numpy as np

from iguana_ros.nodes.commander import IguanaCommander


def lateral_peak(iguana: IguanaCommander, since: float, seconds: float) -> float:
    """Largest sideways (world y) root speed m/s over `seconds` of simulated time from `since` s."""
    while iguana.state().time < since + seconds:
        pass
    return max(abs(float(s.linear_velocity[1])) for s in iguana.states_since(since))


def main(argv: list[str] | None = None) -> int:
    """Go to a goal `--ahead` m in front of the iguana (and `--side` m to its left), then push it."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--ahead', type=float, default=0.5, help='goal distance ahead of the root (world x), m')
    parser.add_argument('--side', type=float, default=0.0, help='goal offset to the left (world y), m')
    parser.add_argument('--timeout', type=float, default=60.0, help='wall seconds to wait for the goal')
    parser.add_argument('--push', type=float, default=40.0, help='push force on the left flank, N (0: no push)')
    args = parser.parse_args(argv)

    with IguanaCommander() as iguana:
        start = iguana.state(timeout=args.timeout)
        print(f't={start.time:.2f} s: root at ({start.position[0]:.2f}, {start.position[1]:.2f}) m, '
              f'heading {np.degrees(start.yaw):.0f} deg', flush=True)
        goal = start.position[:2] + [args.ahead, args.side]
        iguana.go_to(*goal, yaw=0.0)
        print(f'goal ({goal[0]:.2f}, {goal[1]:.2f}) accepted by the planner', flush=True)
        if not iguana.wait_until_reached(timeout=args.timeout):
            print(f'not reached within {args.timeout:g} s: {iguana.distance_to_goal():.2f} m to go', flush=True)
            return 1
        there = iguana.state()
        print(f't={there.time:.2f} s: reached, {iguana.distance_to_goal():.3f} m from the goal', flush=True)
        if args.push > 0:
            sent = iguana.push('trunk_left', (0.0, -args.push, 0.0), duration=0.1)
            print(f'pushed {args.push:g} N for 0.1 s: peak sideways speed {lateral_peak(iguana, sent, 0.5):.3f} m/s',
                  flush=True)
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
