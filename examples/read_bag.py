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
Example 3: read a recorded bag into numpy arrays with an independent reader (`mcap` + `mcap-ros2-support`).

Every `iguana run` records a rosbag2-compatible MCAP bag (`bags/<scene>_<date>_<time>/`). This script reads it
without iguana_ros's own bag code — the way any other tool would — into arrays of the root trajectory and the
feet, prints what it found, and writes them as `.npz` (and, with --csv, one CSV row per frame, e.g. for
`pandas.read_csv`).

    python examples/read_bag.py bags/hills_20260101_120000
    python examples/read_bag.py bags/hills_20260101_120000 --csv root.csv -o run.npz
"""
from __future__ import annotations

import argparse
from dataclasses import dataclass
from pathlib import Path

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
import numpy as np

FEET = ('fl', 'fr', 'hl', 'hr')
"""Order of the feet in foot_state and foot_positions."""


@dataclass
class Walk:
    """
    Arrays of one recorded run.

    State rows (N frames): time `(N,)` s, root position `(N, 3)` m, orientation `(N, 4)` xyzw, linear velocity `(N, 3)`
    m/s; foot rows (M frames): time `(M,)` s, sole height `(M, 4)` m above the terrain, contact `(M, 4)` bool, sole
    centroid `(M, 4, 3)` m; goals `(G, 2)` m.
    """

    time: np.ndarray
    position: np.ndarray
    orientation: np.ndarray
    velocity: np.ndarray
    foot_time: np.ndarray
    foot_height: np.ndarray
    foot_contact: np.ndarray
    foot_position: np.ndarray
    goals: np.ndarray


def mcap_file(bag: Path) -> Path:
    """Return the .mcap of a bag directory (DIR/DIR.mcap or its one .mcap), or `bag` itself if it is a file."""
    bag = Path(bag)
    if bag.is_file():
        return bag
    named = bag / f'{bag.name}.mcap'
    found = [named] if named.is_file() else sorted(bag.glob('*.mcap'))
    if not found:
        raise SystemExit(f'read_bag: no .mcap file in {bag}')
    return found[0]


def stamp(header) -> float:
    """Return a header stamp in seconds."""
    return header.stamp.sec + header.stamp.nanosec * 1e-9


def one_per_frame(messages: list) -> list:
    """Return the first message of each header stamp: a lockstep run re-sends a frame (same stamp) to a slow peer."""
    seen: set = set()
    kept = []
    for msg in messages:
        key = (msg.header.stamp.sec, msg.header.stamp.nanosec)
        if key not in seen:
            seen.add(key)
            kept.append(msg)
    return kept


def read_walk(bag: Path) -> Walk:
    """Decode /iguana_state, /foot_state, /foot_positions and /accepted_goals of `bag` into a Walk."""
    rows: dict[str, list] = {'/iguana_state': [], '/foot_state': [], '/foot_positions': [], '/accepted_goals': []}
    with open(mcap_file(bag), 'rb') as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        for _schema, channel, _message, msg in reader.iter_decoded_messages(topics=list(rows)):
            rows[channel.topic].append(msg)
    state, feet, soles = (one_per_frame(rows[t]) for t in ('/iguana_state', '/foot_state', '/foot_positions'))
    pose = [(m.pose.pose.position, m.pose.pose.orientation, m.twist.twist.linear) for m in state]
    goals = [(p.pose.position.x, p.pose.position.y) for p in rows['/accepted_goals'][-1].poses] \
        if rows['/accepted_goals'] else []
    return Walk(
        time=np.array([stamp(m.header) for m in state]),
        position=np.array([[p.x, p.y, p.z] for p, _, _ in pose]).reshape(-1, 3),
        orientation=np.array([[q.x, q.y, q.z, q.w] for _, q, _ in pose]).reshape(-1, 4),
        velocity=np.array([[v.x, v.y, v.z] for _, _, v in pose]).reshape(-1, 3),
        foot_time=np.array([stamp(m.header) for m in feet]),
        foot_height=np.array([list(m.position) for m in feet]).reshape(-1, len(FEET)),
        foot_contact=np.array([list(m.effort) for m in feet]).reshape(-1, len(FEET)) > 0.5,
        foot_position=np.array([[[p.position.x, p.position.y, p.position.z] for p in m.poses]
                                for m in soles]).reshape(-1, len(FEET), 3),
        goals=np.array(goals, float).reshape(-1, 2))


def write_csv(walk: Walk, path: Path) -> Path:
    """One row per state frame: t, x, y, z, vx, vy, vz (and per foot: height, contact where the frames match)."""
    columns = [walk.time, *walk.position.T, *walk.velocity.T]
    header = ['t', 'x', 'y', 'z', 'vx', 'vy', 'vz']
    if len(walk.foot_time) == len(walk.time) and np.allclose(walk.foot_time, walk.time):
        columns += [*walk.foot_height.T, *walk.foot_contact.T.astype(float)]
        header += [f'height_{f}' for f in FEET] + [f'contact_{f}' for f in FEET]
    np.savetxt(path, np.column_stack(columns), delimiter=',', header=','.join(header), comments='', fmt='%.6g')
    return path


def main(argv: list[str] | None = None) -> int:
    """Read the bag, print a summary, save the arrays."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('bag', type=Path, help='bag directory (or its .mcap file)')
    parser.add_argument('-o', '--output', type=Path, default=None, help='save the arrays as .npz')
    parser.add_argument('--csv', type=Path, default=None, help='save one row per frame as CSV')
    args = parser.parse_args(argv)

    walk = read_walk(args.bag)
    if len(walk.time) == 0:
        raise SystemExit(f'read_bag: {args.bag} holds no /iguana_state messages')
    travelled = np.linalg.norm(np.diff(walk.position[:, :2], axis=0), axis=1).sum()
    print(f'{len(walk.time)} states from t={walk.time[0]:.2f} to {walk.time[-1]:.2f} s; root moved '
          f'{travelled:.2f} m to ({walk.position[-1, 0]:.2f}, {walk.position[-1, 1]:.2f}); top speed '
          f'{np.linalg.norm(walk.velocity[:, :2], axis=1).max():.3f} m/s')
    if len(walk.foot_time):
        stance = ' '.join(f'{f} {walk.foot_contact[:, k].mean():.2f}' for k, f in enumerate(FEET))
        print(f'{len(walk.foot_time)} foot frames; fraction in contact: {stance}')
    for k, (x, y) in enumerate(walk.goals):
        print(f'goal {k}: ({x:.2f}, {y:.2f}), {np.hypot(*(walk.position[-1, :2] - (x, y))):.2f} m from the end')
    if args.output is not None:
        np.savez(args.output, **vars(walk))
        print(f'arrays: {args.output}')
    if args.csv is not None:
        print(f'csv: {write_csv(walk, args.csv)}')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
