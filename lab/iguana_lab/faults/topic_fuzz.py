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
Topic fault injection: seeded bad messages on every topic a node subscribes to, while a real lockstep run goes on.

Each fuzz message is a valid message of its topic with one fault: NaN, Inf, a huge value, a negative length or
stamp, a wrong length, a wrong frame_id, a non-unit quaternion, a torque, or a stale or future stamp (content
otherwise valid, stamped far behind or far ahead of the simulated frame). Every one of them must be rejected or
ignored, so a fuzzed run must complete, no node may die, nothing non-finite may be published, and the run must
equal the library run of its scene bit for bit (nothing bad was simulated). `fuzz_run` checks all of it from the
run's recorded bag: the fuzzer's own messages (recorded too) are taken out by their bytes, every float of every
other message is scanned, and the root trajectory is compared with `pipeline.run`.
"""
from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
import math
from pathlib import Path
import sys
import time

import numpy as np

from iguana_ros.constants import FRAME_RATE, MAX_FRAME_GAP

FUZZ_KINDS = {
    'goal_pose': ('nan', 'inf', 'huge', 'wrong_frame', 'negative_stamp'),
    'push': ('nan', 'inf', 'huge', 'torque', 'wrong_frame'),
    'motion_clip': ('nan', 'inf', 'huge', 'wrong_length', 'wrong_frame', 'bad_quaternion', 'stale', 'future'),
    'reference_pose': ('nan', 'inf', 'huge', 'wrong_length', 'wrong_frame', 'bad_quaternion', 'stale', 'future'),
    'spring_rest_lengths': ('nan', 'inf', 'huge', 'negative', 'zero', 'wrong_length', 'stale', 'future'),
    'iguana_state': ('nan', 'inf', 'huge', 'wrong_frame', 'bad_quaternion', 'stale', 'future'),
}
"""The faults injected on each subscribed topic (topic-table key -> fault kinds)."""

STALE_FRAMES = 40
"""A stale stamp is this many frames behind the newest /clock frame (or negative while the run is younger): more
than any node can lag behind the simulator (a planner is at most one stride, 20 frames, behind)."""

WRONG_FRAMES = ('World', 'base_link', 'iguana/base_link', 'wing', 'map ')
"""Wrong frame_ids (map and odom are goal frames; for push: regions that are not node tags)."""


@dataclass
class FuzzContext:
    """Valid contents the faults start from: the scene's model, skeleton, a placed clip, a bone pose."""

    rest_lengths: np.ndarray
    skeleton: object
    clip: object
    joints: np.ndarray
    rotations: np.ndarray
    half_extent: float
    frame: int = 0

    @classmethod
    def for_scene(cls, scene) -> 'FuzzContext':
        """Contents for a run of `scene` (its model's rest lengths, the forward clip at the scene's start)."""
        from iguana_ros.body.model import build_model
        from iguana_ros.stages import motion_graph
        from iguana_ros.terrain.adaptation import pose_kinematics
        model = build_model(scene.model.resolution, scene.model.stiffness)
        clip = motion_graph().align('forward', np.array([scene.start.x, scene.start.y]),
                                    math.radians(scene.start.yaw_deg))
        joints, rotations = pose_kinematics(model.skeleton, clip.root_positions[0], clip.local_rotations[0])
        return cls(np.asarray(model.spring_rest_lengths, float), model.skeleton, clip, joints, rotations,
                   scene.terrain.extent / 2.0)


def _stamp_frame(kind: str, ctx: FuzzContext, rng: np.random.Generator) -> int:
    """
    Return the frame a fuzz message is stamped with.

    Stale, future, or (any other fault) the next frame, where a message with valid content would be used.
    """
    if kind == 'stale':
        return ctx.frame - STALE_FRAMES - int(rng.integers(0, 100))
    if kind == 'future':
        return ctx.frame + 10 * MAX_FRAME_GAP + int(rng.integers(0, 10 ** 6))
    return ctx.frame + 1


def _set_stamp(header, frame: int) -> None:
    """Header stamp of `frame` (negative frames give negative seconds, as a broken clock would)."""
    ns = int(round(frame / FRAME_RATE * 1e9))
    header.stamp.sec, header.stamp.nanosec = ns // 1_000_000_000, ns % 1_000_000_000


def _bad_value(kind: str, rng: np.random.Generator) -> float:
    """NaN, ±Inf or a huge finite value (1e6 .. 1e300)."""
    sign = float(rng.choice([-1.0, 1.0]))
    if kind == 'nan':
        return float('nan')
    if kind == 'inf':
        return sign * float('inf')
    return sign * 10.0 ** float(rng.uniform(6, 300))


def _message(key: str, data: bytes):
    """Return the rclpy message object of topic `key` that serialized `data` holds (to set one bad field in)."""
    from rclpy.serialization import deserialize_message

    from iguana_ros.ros.endpoints import resolve
    return deserialize_message(data, resolve(key)[1])


def _corrupt_point(point, kind: str, rng: np.random.Generator, attrs=('x', 'y', 'z')) -> None:
    """Set one of `attrs` of a Point/Vector3/Quaternion to a bad value."""
    setattr(point, str(rng.choice(attrs)), _bad_value(kind, rng))


def _goal(kind: str, ctx: FuzzContext, rng: np.random.Generator):
    from iguana_ros.nodes.goal_sender import goal_message
    msg = goal_message(*rng.uniform(-ctx.half_extent, ctx.half_extent, 2).tolist(), float(rng.uniform(-180, 180)))
    if kind in ('nan', 'inf'):
        _corrupt_point(msg.pose.orientation if rng.random() < 0.3 else msg.pose.position, kind, rng)
    elif kind == 'huge':
        msg.pose.position.x = float(rng.choice([-1.0, 1.0])) * 10.0 ** float(rng.uniform(2, 300))
    elif kind == 'wrong_frame':
        msg.header.frame_id = str(rng.choice(WRONG_FRAMES + ('',)))
    else:  # negative_stamp
        msg.header.stamp.sec = -int(rng.integers(1, 10 ** 6))
    return msg


def _push(kind: str, ctx: FuzzContext, rng: np.random.Generator):
    from geometry_msgs.msg import WrenchStamped
    msg = WrenchStamped()
    msg.header.frame_id = 'trunk_left'
    msg.wrench.force.y = -40.0
    if kind in ('nan', 'inf'):
        _corrupt_point(msg.wrench.torque if rng.random() < 0.3 else msg.wrench.force, kind, rng)
    elif kind == 'huge':
        _corrupt_point(msg.wrench.force, kind, rng)
    elif kind == 'torque':
        _corrupt_point(msg.wrench.torque, 'huge', rng) if rng.random() < 0.5 else setattr(msg.wrench.torque, 'z', 1.0)
    else:  # wrong_frame: not a node tag
        msg.header.frame_id = str(rng.choice(WRONG_FRAMES))
    return msg


def _clip(kind: str, ctx: FuzzContext, rng: np.random.Generator):
    from iguana_ros.ros.messages import clip_to_cdr
    msg = _message('motion_clip', clip_to_cdr(ctx.clip, ctx.skeleton, 0))
    _set_stamp(msg.header, _stamp_frame(kind, ctx, rng))
    point = msg.points[int(rng.integers(len(msg.points)))]
    transform = point.transforms[int(rng.integers(len(point.transforms)))]
    if kind in ('nan', 'inf'):
        _corrupt_point(transform.rotation if rng.random() < 0.5 else transform.translation, kind, rng,
                       ('x', 'y', 'z'))
    elif kind == 'huge':
        _corrupt_point(point.transforms[0].translation if rng.random() < 0.5 else transform.translation, kind, rng)
    elif kind == 'wrong_length':
        choice = int(rng.integers(3))
        if choice == 0:
            point.transforms = point.transforms[:-1]
        elif choice == 1:
            msg.points = msg.points[:1]
        else:
            msg.joint_names = msg.joint_names[:-1]
    elif kind == 'wrong_frame':
        msg.header.frame_id = str(rng.choice(WRONG_FRAMES + ('',)))
    elif kind == 'bad_quaternion':
        q = transform.rotation
        q.x, q.y, q.z, q.w = (0.0, 0.0, 0.0, 0.0) if rng.random() < 0.5 else (q.x * 2, q.y * 2, q.z * 2, q.w * 2 + 1)
    return msg


def _reference_pose(kind: str, ctx: FuzzContext, rng: np.random.Generator):
    from iguana_ros.ros.messages import reference_pose_to_cdr
    joints, rotations = ctx.joints.copy(), ctx.rotations.copy()
    bone = int(rng.integers(len(joints)))
    if kind == 'wrong_length':
        keep = int(rng.integers(0, len(joints)))
        joints, rotations = (joints[:keep], rotations[:keep]) if rng.random() < 0.5 else (
            np.vstack([joints, joints[:3]]), np.vstack([rotations, rotations[:3]]))
    elif kind == 'bad_quaternion':
        rotations[bone] *= 0.0 if rng.random() < 0.5 else 1.5
    msg = _message('reference_pose', reference_pose_to_cdr(joints, rotations, 0))
    _set_stamp(msg.header, _stamp_frame(kind, ctx, rng))
    if kind in ('nan', 'inf'):
        pose = msg.poses[bone]
        _corrupt_point(pose.orientation if rng.random() < 0.5 else pose.position, kind, rng)
    elif kind == 'huge':
        _corrupt_point(msg.poses[bone].position, kind, rng)
    elif kind == 'wrong_frame':
        msg.header.frame_id = str(rng.choice(WRONG_FRAMES + ('',)))
    return msg


def _lengths(kind: str, ctx: FuzzContext, rng: np.random.Generator):
    from iguana_ros.ros.messages import lengths_to_cdr
    lengths = ctx.rest_lengths.copy()
    some = rng.random(len(lengths)) < rng.uniform(0.001, 1.0)
    some[int(rng.integers(len(lengths)))] = True
    if kind == 'huge':
        lengths[some] = 10.0 ** rng.uniform(2, 300) if rng.random() < 0.5 else 1e6
    elif kind == 'negative':
        lengths[some] = -lengths[some]
    elif kind == 'zero':
        lengths[some] = 0.0
    elif kind == 'wrong_length':
        lengths = lengths[:int(rng.integers(0, len(lengths)))] if rng.random() < 0.5 else np.concatenate(
            [lengths, lengths[:int(rng.integers(1, 50))]])
    msg = _message('spring_rest_lengths', lengths_to_cdr(lengths, 0))
    _set_stamp(msg.header, _stamp_frame(kind, ctx, rng))
    if kind in ('nan', 'inf'):
        msg.position[int(rng.integers(len(msg.position)))] = _bad_value(kind, rng)
    return msg


def _state(kind: str, ctx: FuzzContext, rng: np.random.Generator):
    from iguana_ros.ros.messages import state_to_cdr
    msg = _message('iguana_state', state_to_cdr(ctx.clip.root_positions[0], np.array([0.0, 0.0, 0.0, 1.0]),
                                                np.zeros(3), np.zeros(3), 0))
    _set_stamp(msg.header, _stamp_frame(kind, ctx, rng))
    if kind in ('nan', 'inf'):
        where = int(rng.integers(3))
        target = (msg.pose.pose.position, msg.pose.pose.orientation, msg.twist.twist.linear)[where]
        _corrupt_point(target, kind, rng)
    elif kind == 'huge':
        _corrupt_point(msg.pose.pose.position, kind, rng)
    elif kind == 'wrong_frame':
        msg.header.frame_id = str(rng.choice(WRONG_FRAMES + ('',)))
    elif kind == 'bad_quaternion':
        q = msg.pose.pose.orientation
        q.x, q.y, q.z, q.w = (0.0, 0.0, 0.0, 0.0) if rng.random() < 0.5 else (0.0, 0.0, 0.5, 2.0)
    return msg


_BUILDERS = {'goal_pose': _goal, 'push': _push, 'motion_clip': _clip, 'reference_pose': _reference_pose,
             'spring_rest_lengths': _lengths, 'iguana_state': _state}


def fuzz_message(key: str, kind: str, ctx: FuzzContext, rng: np.random.Generator):
    """One message of topic `key` with fault `kind` (one of FUZZ_KINDS[key]), drawn with `rng`."""
    if kind not in FUZZ_KINDS[key]:
        raise ValueError(f'fault {kind!r} is not one of {FUZZ_KINDS[key]} for {key}')
    return _BUILDERS[key](kind, ctx, rng)


FRAME_STAMPED = ('motion_clip', 'reference_pose', 'spring_rest_lengths', 'iguana_state')
"""Fuzzed topics whose header stamp names a frame (goal_pose's is an adoption time, push's is not read)."""


def prepared_fault(key: str, kind: str, ctx: FuzzContext, rng: np.random.Generator) -> tuple[bytes, int | None]:
    """
    Return one fault built ahead, so that publishing it during the run costs a byte copy (see `restamped`).

    It is (serialized bytes, stamp offset in frames from the frame it goes out at, or None to keep its stamp).
    """
    from rclpy.serialization import serialize_message
    at = ctx.frame
    ctx.frame = 0
    try:
        msg = fuzz_message(key, kind, ctx, rng)
    finally:
        ctx.frame = at
    data = serialize_message(msg)
    data += b'\x00' * (-len(data) % 4)  # as Fast DDS pads it on the wire (and the bag records it)
    offset = None
    if key in FRAME_STAMPED:
        offset = int(round((msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9) * FRAME_RATE))
    return data, offset


def restamped(data: bytes, frame: int) -> bytes:
    """Return `data` (a serialized message whose first field is a std_msgs/Header) with its stamp set to `frame`."""
    import struct
    ns = int(round(frame / FRAME_RATE * 1e9))
    out = bytearray(data)
    struct.pack_into('<iI', out, 4, ns // 1_000_000_000, ns % 1_000_000_000)
    return bytes(out)


def fuzzed_readers() -> dict[str, int]:
    """
    Subscriptions each fuzzed topic has in a run.

    The nodes the topic table names as its subscribers, and the bag recorder.
    """
    from iguana_ros.supervisor.run import NODE_KINDS
    from iguana_ros.topics import topic
    return {key: 1 + sum(1 for who in topic(key).subscribers if who.split()[0] in NODE_KINDS) for key in FUZZ_KINDS}


def fault_plan(n_messages: int, rng: np.random.Generator) -> list[tuple[str, str]]:
    """
    `n_messages` (topic key, fault kind) pairs.

    Every pair of FUZZ_KINDS once (in random order) before any repeats, then random pairs.
    """
    pairs = [(key, kind) for key, kinds in FUZZ_KINDS.items() for kind in kinds]
    order = [pairs[i] for i in rng.permutation(len(pairs))]
    extra = [pairs[i] for i in rng.integers(0, len(pairs), max(0, n_messages - len(pairs)))]
    return (order + extra)[:n_messages]


class TopicFuzzer:
    """
    Publishes the faults of a plan as the run advances.

    It publishes `before` faults once its publishers are matched with every node that reads them (and the recorder) and
    the simulator's /clock is heard, then `per_frame` more for each frame /clock reports, each stamped relative to that
    frame. Run in a process of its own (`main`), as a foreign publisher would be; it keeps the serialized bytes of
    everything it sent.
    """

    def __init__(self, ctx: FuzzContext, plan: list[tuple[str, str]], seed: int, per_frame: int = 1,
                 before: int = 0) -> None:
        """Fuzz with `plan` (see `fault_plan`), contents drawn from `seed` and built here, before the run."""
        self.ctx, self.plan, self.per_frame, self.before = ctx, plan, max(1, per_frame), before
        rng = np.random.default_rng(seed)
        self.prepared = [prepared_fault(key, kind, ctx, rng) for key, kind in plan]
        self.sent: list[tuple[str, bytes]] = []
        self.counts: Counter = Counter()
        self.stopped = False

    @property
    def done(self) -> bool:
        """Whether the whole plan has been sent."""
        return len(self.sent) >= len(self.plan)

    def run(self, on_matched=lambda: None) -> None:
        """Publish the plan (until `stopped` is set); `on_matched()` once every reader is matched."""
        import rclpy
        from rclpy.executors import SingleThreadedExecutor

        from iguana_ros.errors import InputError
        from iguana_ros.ros.endpoints import resolve
        from iguana_ros.ros.messages import clock_frame_from_cdr

        node = rclpy.create_node('iguana_topic_fuzzer')
        pubs, names = {}, {}
        for key in FUZZ_KINDS:
            name, cls, qos = resolve(key)
            pubs[key] = node.create_publisher(cls, name, qos)
            names[key] = pubs[key].topic_name
        clock_name, clock_cls, clock_qos = resolve('clock')

        def on_clock(data: bytes) -> None:
            try:
                self.ctx.frame = max(self.ctx.frame, clock_frame_from_cdr(data))
            except InputError:
                pass
        clock = node.create_subscription(clock_cls, clock_name, on_clock, clock_qos, raw=True)
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        readers = fuzzed_readers()
        matched = False
        while not self.stopped and not matched:
            matched = node.count_publishers(clock.topic_name) >= 1 and all(
                pubs[key].get_subscription_count() >= readers[key] for key in FUZZ_KINDS)
            executor.spin_once(timeout_sec=0.02)
        if matched:
            on_matched()
        while not self.stopped and not self.done:
            due = min(len(self.plan), self.before + self.per_frame * self.ctx.frame)
            while len(self.sent) < due:
                key, kind = self.plan[len(self.sent)]
                data, offset = self.prepared[len(self.sent)]
                if offset is not None:
                    data = restamped(data, self.ctx.frame + offset)
                pubs[key].publish(data)
                self.sent.append((names[key], data))
                self.counts[(key, kind)] += 1
            executor.spin_once(timeout_sec=0.005)
        executor.shutdown()
        node.destroy_node()


def main(argv: list[str] | None = None) -> int:
    """
    `python -m iguana_lab.faults.topic_fuzz SCENE DUMP --seed S --messages N --per-frame K --before B`.

    Fuzz a run of SCENE; prints 'fuzzer matched' when every reader is matched and writes what it sent to DUMP (JSON)
    when the plan is done or on SIGINT / SIGTERM.
    """
    import argparse
    import base64
    import json
    import signal

    import rclpy
    from rclpy.signals import SignalHandlerOptions

    from iguana_ros.scene import load_scene

    parser = argparse.ArgumentParser(prog='topic_fuzz')
    parser.add_argument('scene')
    parser.add_argument('dump', type=Path)
    parser.add_argument('--seed', type=int, default=0)
    parser.add_argument('--messages', type=int, default=200)
    parser.add_argument('--per-frame', type=int, default=1)
    parser.add_argument('--before', type=int, default=0)
    args = parser.parse_args(argv)
    scene = load_scene(args.scene)
    rng = np.random.default_rng(args.seed)
    fuzzer = TopicFuzzer(FuzzContext.for_scene(scene), fault_plan(args.messages, rng), args.seed + 1,
                         args.per_frame, args.before)
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: setattr(fuzzer, 'stopped', True))
    rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
    try:
        fuzzer.run(lambda: print('fuzzer matched', flush=True))
    finally:
        args.dump.write_text(json.dumps({
            'sent': [[topic, base64.b64encode(data).decode()] for topic, data in fuzzer.sent],
            'counts': [[key, kind, n] for (key, kind), n in fuzzer.counts.items()]}))
        rclpy.try_shutdown()
    print(f'fuzzer sent {len(fuzzer.sent)} faults', flush=True)
    return 0


def read_fuzz_dump(path: Path) -> tuple[list[tuple[str, bytes]], Counter]:
    """(sent (topic, bytes), counts {(key, kind): n}) of a dump written by `main`."""
    import base64
    import json
    data = json.loads(Path(path).read_text())
    return ([(topic, base64.b64decode(b64)) for topic, b64 in data['sent']],
            Counter({(key, kind): n for key, kind, n in data['counts']}))


# ------------------------------------------------------------------------------------------ the recorded bag

def count_non_finite(msg) -> int:
    """
    Return the number of non-finite float values anywhere in a deserialized ROS message.

    Nested messages, sequences and arrays count too.
    """
    if isinstance(msg, float):
        return 0 if math.isfinite(msg) else 1
    if isinstance(msg, (np.ndarray,)) or type(msg).__name__ == 'array':
        values = np.asarray(msg)
        return int(np.count_nonzero(~np.isfinite(values))) if values.dtype.kind == 'f' else 0
    if isinstance(msg, (list, tuple)):
        return sum(count_non_finite(item) for item in msg)
    if hasattr(msg, 'get_fields_and_field_types'):
        return sum(count_non_finite(getattr(msg, name)) for name in msg.get_fields_and_field_types())
    return 0


@dataclass
class BagScan:
    """What a fuzzed run's bag holds apart from the fuzzer's own messages."""

    messages: dict[str, int] = field(default_factory=dict)
    non_finite: dict[str, int] = field(default_factory=dict)
    fuzz_recorded: int = 0
    fuzz_missing: int = 0
    fuzz_during_run: int = 0
    undecodable: dict[str, int] = field(default_factory=dict)
    states: list = field(default_factory=list)


def scan_bag(bag: str | Path, sent: list[tuple[str, bytes]]) -> BagScan:
    """
    Every recorded message that is not one of `sent` (topic, bytes), deserialized and scanned for non-finite floats.

    The iguana_state messages are kept (serialized) for the trajectory; the recorded faults are counted, and those sent
    between the first and the last /clock message (while the simulator ran; by publish times, the wall clock: a run's
    log times are simulated, and a fault received before the first /clock is logged at its time).
    """
    from rclpy.serialization import deserialize_message

    from iguana_ros.bag.storage import BagReader
    from iguana_ros.ros.endpoints import message_class

    fuzz = Counter(sent)
    scan = BagScan()
    reader = BagReader(bag)
    classes = {}
    fuzz_times, clock_times = [], []
    for record in reader.messages():
        data = bytes(record.data)
        if fuzz[(record.topic, data)] > 0:
            fuzz[(record.topic, data)] -= 1
            fuzz_times.append(record.publish_time)
            continue
        if record.topic == '/clock':
            clock_times.append(record.publish_time)
        info = reader.topic(record.channel_id)
        if info.type not in classes:
            classes[info.type] = message_class(info.type)
        scan.messages[record.topic] = scan.messages.get(record.topic, 0) + 1
        try:
            msg = deserialize_message(data, classes[info.type])
        except Exception:  # noqa: BLE001 -- counted: a message no node should have published
            scan.undecodable[record.topic] = scan.undecodable.get(record.topic, 0) + 1
            continue
        bad = count_non_finite(msg)
        if bad:
            scan.non_finite[record.topic] = scan.non_finite.get(record.topic, 0) + bad
        if record.topic == '/iguana_state':
            scan.states.append(data)
    scan.fuzz_recorded, scan.fuzz_missing = len(fuzz_times), sum(fuzz.values())
    if clock_times:
        scan.fuzz_during_run = sum(1 for t in fuzz_times if min(clock_times) <= t <= max(clock_times))
    return scan


# ------------------------------------------------------------------------------------------ one fuzzed run

def fuzz_run(scene_path: str | Path, bag: str | Path, seed: int, n_messages: int, timeout: float = 300.0,
             compare: bool = True) -> dict:
    """
    Run `scene_path` as four lockstep node processes recording to `bag` while `n_messages` faults go to every topic.

    The faults are seeded by `seed`, a tenth before frame 0, the rest spread over the first 80 % of the frames. Returns
    one plain row: the faults sent per topic, the run's exit status, whether every child lived to the end, the
    non-finite floats and undecodable messages found in what the nodes published, how many lines the nodes logged about
    bad input, and (with `compare`) whether the root trajectory equals `pipeline.run` of the scene bit for bit (nothing
    bad was simulated).
    """
    from iguana_ros.bag.trajectory import root_trajectory
    from iguana_ros.errors import IguanaError
    from iguana_ros.scene import load_scene
    from iguana_ros.supervisor.process import NodeProcess, wait_for
    from iguana_ros.supervisor.run import RunOptions, SceneRun

    scene = load_scene(str(scene_path))
    frames = int(round(scene.duration * FRAME_RATE))
    before = n_messages // 10
    per_frame = math.ceil((n_messages - before) / max(1, int(0.8 * frames)))
    run = SceneRun(RunOptions(scene=str(scene_path), record=Path(bag), timeout=timeout))
    fuzz_dir = Path(bag).with_name(Path(bag).name + '_fuzzer')
    fuzz_dir.mkdir(parents=True, exist_ok=True)
    fuzzer = NodeProcess([sys.executable, '-m', 'iguana_lab.faults.topic_fuzz', str(scene_path),
                          str(fuzz_dir / 'sent.json'), '--seed', str(seed), '--messages', str(n_messages),
                          '--per-frame', str(per_frame), '--before', str(before)], 'topic_fuzzer', fuzz_dir)
    started = time.monotonic()
    code, failure = None, ''
    try:
        run.start()
        fuzzer.start()
        if not wait_for(lambda: 'fuzzer matched' in fuzzer.output or not fuzzer.running, 120.0):
            raise IguanaError("the topic fuzzer was not matched with the run's nodes within 120 s")
        if not fuzzer.running:
            raise IguanaError(f'the topic fuzzer exited: {fuzzer.tail()}')
        run.send_goals()
        code = run.wait()
        dead = [name for name, child in run.children.items()
                if name not in ('simulator_node', 'nodes') and not child.running]
        if dead:
            failure = f'{", ".join(dead)} exited during the run'
    except IguanaError as exc:
        failure = ' '.join(str(exc).split())[:500]
    finally:
        try:
            fuzzer.stop(timeout=10.0)
        finally:
            run.stop()
    sent, counts = read_fuzz_dump(fuzz_dir / 'sent.json') if (fuzz_dir / 'sent.json').exists() else ([], Counter())
    wall = time.monotonic() - started
    scan = scan_bag(bag, sent)
    logs = '\n'.join(p.read_text(errors='replace') for p in sorted(Path(run.logs).glob('*.out')))
    row = {'scene': scene.name, 'seed': seed, 'frames': frames, 'faults_sent': len(sent),
           'faults_during_run': scan.fuzz_during_run, 'faults_per_topic': dict(Counter(k for (k, _), n in counts.items()
                                                                                       for _ in range(n))),
           'exit_code': code, 'failure': failure, 'nodes_survived': not failure and code == 0,
           'rejected_lines': logs.count('rejected '), 'ignored_lines': logs.count('ignored '),
           'tracebacks': logs.count('Traceback'), 'non_finite': scan.non_finite, 'undecodable': scan.undecodable,
           'messages_scanned': sum(scan.messages.values()), 'fuzz_recorded': scan.fuzz_recorded,
           'fuzz_not_recorded': scan.fuzz_missing,
           'wall_s': round(wall, 2), 'logs': str(run.logs), 'bag': str(bag)}
    if compare:
        from iguana_ros.pipeline import run as run_pipeline
        times, roots, _ = root_trajectory(scan.states)
        expected = run_pipeline(scene).root_positions
        row['frames_recorded'] = len(times)
        row['equal_to_library'] = bool(len(times) == frames + 1 and np.array_equal(roots[1:], expected))
    row['survived'] = bool(row['nodes_survived'] and not row['non_finite'] and not row['undecodable']
                           and not row['tracebacks'] and row.get('equal_to_library', True))
    return row


# ------------------------------------------------------------------------------------------ the suite

TERRAINS = ({'kind': 'hills', 'amplitude': 0.03, 'wavelength': 1.0}, {'kind': 'flat'},
            {'kind': 'tilted', 'slope_deg': 8.0, 'direction_deg': 30.0},
            {'kind': 'noise', 'amplitude': 0.03, 'wavelength': 0.8})
"""Terrains the trials of `topic_fault_suite` cycle through (hills and noise get the trial's seed)."""


def trial_scene(index: int, seed: int, seconds: float, resolution: str) -> dict:
    """Return the scene of trial `index`: a terrain of TERRAINS, a goal 1.5 m away in a seeded direction."""
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(index,)))
    terrain = dict(TERRAINS[index % len(TERRAINS)])
    if terrain['kind'] in ('hills', 'noise'):
        terrain['seed'] = int(rng.integers(0, 10 ** 6))
    heading = float(rng.uniform(0.0, 2.0 * math.pi))
    return {'name': f'topic_faults_{index:02d}', 'model': {'resolution': resolution}, 'terrain': terrain,
            'goals': [{'x': round(1.5 * math.cos(heading), 3), 'y': round(1.5 * math.sin(heading), 3), 'at': 0.0}],
            'duration': float(seconds)}


def topic_fault_suite(trials: int, seed: int, n_messages: int, seconds: float, resolution: str, workdir: Path,
                      progress=None) -> dict:
    """
    `trials` fuzzed lockstep runs (`fuzz_run`, trial i seeded `seed + i`) under `workdir`.

    The rows and the figures: trials, survived, faults sent, node log lines about them, non-finite floats and
    undecodable messages found, runs equal to the library run, wall time. `progress(row)` is called after each trial.
    """
    import yaml
    rows = []
    started = time.monotonic()
    for i in range(trials):
        folder = Path(workdir) / f'trial_{i:02d}'
        folder.mkdir(parents=True, exist_ok=True)
        scene = folder / 'scene.yaml'
        scene.write_text(yaml.safe_dump(trial_scene(i, seed, seconds, resolution)))
        row = fuzz_run(scene, folder / 'bag', seed + i, n_messages, timeout=120.0 + 30.0 * seconds)
        row['trial'] = i
        rows.append(row)
        if progress is not None:
            progress(row)
    per_topic: Counter = Counter()
    for row in rows:
        per_topic.update(row['faults_per_topic'])
    return {'trials': trials, 'survived': sum(r['survived'] for r in rows),
            'faults_sent': sum(r['faults_sent'] for r in rows), 'faults_per_topic': dict(per_topic),
            'faults_during_run': sum(r['faults_during_run'] for r in rows),
            'nodes_died_or_failed': sum(not r['nodes_survived'] for r in rows),
            'non_finite_floats': sum(sum(r['non_finite'].values()) for r in rows),
            'undecodable': sum(sum(r['undecodable'].values()) for r in rows),
            'equal_to_library': sum(bool(r.get('equal_to_library')) for r in rows),
            'rejected_lines': sum(r['rejected_lines'] for r in rows),
            'ignored_lines': sum(r['ignored_lines'] for r in rows),
            'messages_scanned': sum(r['messages_scanned'] for r in rows),
            'wall_s': round(time.monotonic() - started, 1), 'rows': rows}


def trial_line(row: dict) -> str:
    """One line per trial: scene, faults, outcome."""
    verdict = 'ok' if row['survived'] else 'FAILED: ' + '; '.join(
        part for part, bad in ((row['failure'] or f'exit {row["exit_code"]}', not row['nodes_survived']),
                               (f'non-finite {row["non_finite"]}', bool(row['non_finite'])),
                               (f'undecodable {row["undecodable"]}', bool(row['undecodable'])),
                               (f'{row["tracebacks"]} tracebacks', bool(row['tracebacks'])),
                               ('differs from the library run', not row.get('equal_to_library', True))) if bad)
    return (f'#{row["trial"]:02d} {row["scene"]}: {row["faults_sent"]} faults ({row["faults_during_run"]} during the '
            f'run), {row["rejected_lines"]} rejected / {row["ignored_lines"]} ignored lines, '
            f'{row["messages_scanned"]} messages scanned, {row["wall_s"]:.1f} s: {verdict}')


def suite_line(result: dict) -> str:
    """Return the figures in one line."""
    return (f'topic faults: {result["survived"]}/{result["trials"]} runs survived; {result["faults_sent"]} faults '
            f'sent ({result["faults_during_run"]} during the runs), {result["nodes_died_or_failed"]} runs with a '
            f'dead or failed node, {result["non_finite_floats"]} non-finite floats and {result["undecodable"]} '
            f'undecodable messages in {result["messages_scanned"]} published, {result["equal_to_library"]}/'
            f'{result["trials"]} equal to the library run; {result["wall_s"]:.0f} s wall')


if __name__ == '__main__':
    sys.exit(main())
