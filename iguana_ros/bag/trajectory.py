"""The iguana's root trajectory (iguana_state) read back from a bag."""
from __future__ import annotations

from pathlib import Path

import numpy as np
from rclpy.serialization import deserialize_message

from iguana_ros.bag.storage import BagReader
from iguana_ros.nodes.conversions import odometry_to_numpy, time_from_msg
from iguana_ros.nodes.ros_topics import resolve


def read_root_trajectory(bag: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Times `(n,)` (header stamps, s) and root positions `(n, 3)` of every iguana_state message, in order."""
    name, cls, _ = resolve('iguana_state')
    wanted = name if name.startswith('/') else '/' + name
    rows: dict[float, np.ndarray] = {}
    for record in BagReader(bag).messages():
        if record.topic == wanted:
            msg = deserialize_message(record.data, cls)
            rows[time_from_msg(msg.header.stamp)] = odometry_to_numpy(msg)[0]
    times = np.array(sorted(rows))
    positions = np.array([rows[t] for t in times]).reshape(-1, 3)
    return times, positions
