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

"""rclpy QoS profiles <-> rosbag2's offered_qos_profiles dicts, and rosbag2's adaptation rules."""
from __future__ import annotations

from rclpy.duration import Duration
from rclpy.qos import (DurabilityPolicy, HistoryPolicy, LivelinessPolicy, QoSProfile,
                       ReliabilityPolicy)

from iguana_ros.bag.storage import INFINITE_DURATION
from iguana_ros.ros.endpoints import qos_profile
from iguana_ros.topics import default_topics

_INFINITE_NS = INFINITE_DURATION['sec'] * 1_000_000_000 + INFINITE_DURATION['nsec']
RECORD_DEPTH = 100
"""History depth of the recorder's subscriptions (absorbs bursts between executor turns)."""
PLAY_VOLATILE_DEPTH = 300
"""Least history depth of the player's reliable volatile publishers (10 s of 30 Hz frames; offer_profile)."""


def _duration_dict(duration: Duration) -> dict:
    """{'sec', 'nsec'} of an rclpy Duration; infinite or unset-as-infinite -> rosbag2's infinite."""
    ns = duration.nanoseconds
    if ns >= _INFINITE_NS or ns < 0:
        return dict(INFINITE_DURATION)
    return {'sec': ns // 1_000_000_000, 'nsec': ns % 1_000_000_000}


def _policy_name(policy) -> str:
    """'reliable', 'transient_local', 'keep_last', … as rmw_qos_*_to_str writes them."""
    return policy.name.lower()


def profile_to_dict(profile: QoSProfile) -> dict:
    """rosbag2 (metadata v9) dict of a QoS profile: policies as strings, durations as sec/nsec."""
    return {'history': _policy_name(profile.history), 'depth': int(profile.depth),
            'reliability': _policy_name(profile.reliability),
            'durability': _policy_name(profile.durability),
            'deadline': _duration_dict(profile.deadline), 'lifespan': _duration_dict(profile.lifespan),
            'liveliness': _policy_name(profile.liveliness),
            'liveliness_lease_duration': _duration_dict(profile.liveliness_lease_duration),
            'avoid_ros_namespace_conventions': bool(profile.avoid_ros_namespace_conventions)}


def _policy(enum, value, default):
    """Enum member from a v9 string or a pre-v9 integer; `default` if unknown."""
    try:
        return enum(int(value)) if isinstance(value, int) else enum[str(value).upper()]
    except (KeyError, ValueError):
        return default


def request_profile(offered: list[QoSProfile]) -> QoSProfile:
    """Subscription QoS that matches every publisher (rosbag2's adapt_request_to_offers)."""
    reliable = bool(offered) and all(p.reliability == ReliabilityPolicy.RELIABLE for p in offered)
    latched = bool(offered) and all(p.durability == DurabilityPolicy.TRANSIENT_LOCAL for p in offered)
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=RECORD_DEPTH,
                      reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
                      durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE)


def table_request_profile(name: str) -> QoSProfile | None:
    """
    Subscription QoS of a topic of msg_configs/topics.yaml named `name` (its reliability and durability), else None.

    The recorder asks this of the package's own topics rather than adapting to the first publisher it sees: a stranger's
    transient-local publisher of goal_pose seen first made it ask transient-local, and the run's volatile goal
    publisher then never matched it (`iguana bench faults strays`: a run waited 60 s for its goal).
    """
    spec = next((t for t in default_topics().values() if '/' + t.name.lstrip('/') == name), None)
    if spec is None:
        return None
    profile = qos_profile(spec.qos)
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=RECORD_DEPTH, reliability=profile.reliability,
                      durability=profile.durability)


def offer_profile(recorded: list[dict], default_depth: int = 10) -> QoSProfile:
    """
    Return publisher QoS for replay from the recorded offers (rosbag2's adapt_offer_to_recorded_offers).

    Reliability and durability are kept when all recorded publishers agree (a latched topic stays
    latched); history is keep_last with the recorded depth, or `default_depth` where DDS did not
    report one. Mixed offers fall back to reliable/volatile. A reliable volatile topic keeps at least
    PLAY_VOLATILE_DEPTH: a message lost on the way is re-sent only while the writer still holds it, and a subscriber
    starved of CPU asks for it late (depth 10 lost 4 iguana_state frames at --rate 2 on a loaded machine). Depth is
    not matched between writer and reader, and a volatile writer lets a message go once every reader has it, so
    nothing else changes; a latched topic keeps its depth (what a late joiner gets).
    """
    rel = {_policy(ReliabilityPolicy, p.get('reliability'), ReliabilityPolicy.RELIABLE)
           for p in recorded}
    dur = {_policy(DurabilityPolicy, p.get('durability'), DurabilityPolicy.VOLATILE) for p in recorded}
    depths = [int(p.get('depth') or 0) for p in recorded]
    depth = max(depths) if depths and max(depths) > 0 else default_depth
    known = {ReliabilityPolicy.RELIABLE, ReliabilityPolicy.BEST_EFFORT}
    reliability = rel.pop() if len(rel) == 1 and rel <= known else ReliabilityPolicy.RELIABLE
    durability = (dur.pop() if len(dur) == 1 and dur <= {DurabilityPolicy.VOLATILE,
                                                         DurabilityPolicy.TRANSIENT_LOCAL}
                  else DurabilityPolicy.VOLATILE)
    if reliability == ReliabilityPolicy.RELIABLE and durability == DurabilityPolicy.VOLATILE:
        depth = max(depth, PLAY_VOLATILE_DEPTH)
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=depth, reliability=reliability,
                      durability=durability, liveliness=LivelinessPolicy.AUTOMATIC)
