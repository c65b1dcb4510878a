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
Each node as a real process on an isolated DDS domain.

Feed it inputs, check its outputs and its handling of bad input (a clear log line, the input rejected, the node still
running).
"""
from __future__ import annotations

import sys

import numpy as np
import pytest
import yaml

from iguana_ros.body.model import build_model
from iguana_ros.body.skeleton import iguana_skeleton
from iguana_ros.geometry import quat_from_yaw, yaw_of
from iguana_ros.motion.clips import load_clip_library
from iguana_ros.stages import motion_graph
from ros_harness import NodeProcess, spin_until

pytestmark = [pytest.mark.ros, pytest.mark.timeout(120)]


def _scene(tmp_path, **fields):
    """Return a small scene file (coarse model) with `fields` overriding the defaults."""
    raw = {'model': {'resolution': 'coarse'}, 'terrain': {'kind': 'flat'}, 'duration': 2.0, **fields}
    path = tmp_path / 'scene.yaml'
    path.write_text(yaml.safe_dump(raw))
    return path


def _node(kind, scene, tmp_path, **params):
    """Return a node process started with `scene` and extra parameters, waiting for its ready line."""
    args = [sys.executable, '-m', f'iguana_ros.nodes.{kind}', '--ros-args', '-p', f'scene:={scene}']
    for key, value in params.items():
        args += ['-p', f'{key}:={value}']
    ready = {'planner_node': 'planner ready', 'terrain_adaptation_node': 'terrain adaptation ready',
             'spring_length_node': 'spring lengths ready', 'simulator_node': 'simulator ready'}[kind]
    return NodeProcess(args, kind, tmp_path).start(ready=ready, timeout=90)


RAW_KEYS = frozenset({'iguana_state', 'motion_clip', 'reference_stance', 'reference_pose', 'spring_rest_lengths',
                      'foot_state', 'foot_positions'})
"""Topics a Probe collects as serialized bytes, read with the nodes' own `ros.messages.*_from_cdr`."""


class Probe:
    """Publishers and collecting subscriptions on topic-table keys, on one test node (RAW_KEYS as bytes)."""

    def __init__(self, node, executor):
        from iguana_ros.ros.endpoints import resolve
        self.node, self.executor, self.resolve = node, executor, resolve
        self.got: dict[str, list] = {}
        self.pubs = {}
        executor.add_node(node)

    def listen(self, key, copies=1):
        name, cls, qos = self.resolve(key)
        self.got[key] = []
        for _ in range(copies):
            self.node.create_subscription(cls, name, self.got[key].append, qos, raw=key in RAW_KEYS)

    def pub(self, key):
        name, cls, qos = self.resolve(key)
        self.pubs[key] = self.node.create_publisher(cls, name, qos)
        return self.pubs[key]

    def wait_matched(self, key, count=1, timeout=30.0):
        assert spin_until(self.executor, lambda: self.pubs[key].get_subscription_count() >= count, timeout)

    def deliver(self, pub, msg, timeout=30.0):
        """
        Publish `msg` with `pub` and spin until every matched reader acknowledged it.

        A reader matched from the writer's side may not have matched the writer yet (discovery is not symmetric), so
        this is what proves both sides see each other. Fast DDS acknowledges at its heartbeat (up to ~3 s).
        """
        from rclpy.duration import Duration
        pub.publish(msg)
        assert spin_until(self.executor, lambda: pub.wait_for_all_acked(Duration(seconds=0.005)),
                          timeout), f'{pub.topic_name} not acknowledged within {timeout:g} s'

    def wait(self, key, n=1, timeout=30.0):
        assert spin_until(self.executor, lambda: len(self.got[key]) >= n, timeout), f'no {key} message'
        return self.got[key]


def _lockstep_peers(make_node, executor):
    """
    Stand in for a lockstep simulator's peers, by name.

    Readers of iguana_state named planner_node and terrain_adaptation_node; the returned Probe is named
    spring_length_node (the lengths' publisher the start waits for).
    """
    for name in ('planner_node', 'terrain_adaptation_node'):
        Probe(make_node(name), executor).listen('iguana_state')
    return Probe(make_node('spring_length_node'), executor)


def _state(frame, xy=(0.0, 0.0), yaw=0.0):
    """Return a serialized iguana_state of frame `frame` (rclpy publishes bytes raw)."""
    from iguana_ros.ros.messages import state_to_cdr
    root = np.array([xy[0], xy[1], 0.075])
    return state_to_cdr(root, quat_from_yaw(yaw), np.zeros(3), np.zeros(3), frame)


def test_planner_turns_toward_a_goal_on_its_left(tmp_path, make_node, executor):
    from iguana_ros.nodes.goal_sender import goal_message
    from iguana_ros.ros.messages import clip_from_cdr
    from iguana_ros.ros.messages import reference_stance_from_cdr
    probe = Probe(make_node('probe'), executor)
    probe.listen('motion_clip')
    probe.listen('reference_stance')
    probe.listen('accepted_goals')
    goal_pub, state_pub = probe.pub('goal_pose'), probe.pub('iguana_state')
    with _node('planner_node', _scene(tmp_path), tmp_path) as planner:
        probe.wait_matched('goal_pose')
        probe.wait_matched('iguana_state')
        bad = goal_message(0.0, 1.0)
        bad.pose.position.x = float('nan')  # a user's broken goal: the node must reject it
        goal_pub.publish(bad)
        wrong_frame = goal_message(1.0, 1.0, frame_id='base_link')
        goal_pub.publish(wrong_frame)
        goal_pub.publish(goal_message(0.3, 2.0))
        # the state goes out once the planner lists the goal (after the two bad ones, same publisher, in order)
        assert spin_until(executor, lambda: any(len(m.poses) == 1 for m in probe.got['accepted_goals']), 30)
        state_pub.publish(_state(0))
        clip_msg = probe.wait('motion_clip')[0]
        stance_msg = probe.wait('reference_stance')[0]
        assert planner.running
    start, clip = clip_from_cdr(clip_msg, iguana_skeleton())
    assert start == 0
    # the stance flags of frame 0: the chosen library clip's first contacts
    library_clip = load_clip_library()[planner.output.split("frame 0: clip '")[1].split("'")[0]]
    assert reference_stance_from_cdr(stance_msg)[0] == 0
    assert np.array_equal(reference_stance_from_cdr(stance_msg)[1], library_clip.contacts[0])
    turn = yaw_of(clip.local_rotations[-1, 0]) - yaw_of(clip.local_rotations[0, 0])
    assert turn > 0.1, f'expected a left turn, heading change {turn:.3f} rad'
    assert 'rejected goal_pose' in planner.output and 'non-finite' in planner.output
    assert "frame_id 'base_link'" in planner.output


def test_terrain_node_puts_stance_feet_on_a_tilted_plane(tmp_path, make_node, executor):
    from iguana_ros.body.skeleton import FOOT_PIVOTS, forward_kinematics
    from iguana_ros.ros.messages import clip_to_cdr, reference_pose_from_cdr
    from iguana_ros.scene import load_scene, terrain_from_spec
    from iguana_ros.body.skeleton import FEET
    from iguana_ros.terrain.adaptation import AdaptationSettings, residual_heights_of
    scene_file = _scene(tmp_path, terrain={'kind': 'tilted', 'slope_deg': 12.0, 'direction_deg': 30.0})
    skeleton = iguana_skeleton()
    graph = motion_graph()
    clip = graph.align('forward', np.array([0.0, 0.0]), 0.0)
    probe = Probe(make_node('probe'), executor)
    probe.listen('reference_pose')
    clip_pub, state_pub = probe.pub('motion_clip'), probe.pub('iguana_state')
    with _node('terrain_adaptation_node', scene_file, tmp_path) as node:
        probe.wait_matched('motion_clip')
        probe.wait_matched('iguana_state')
        clip_pub.publish(clip_to_cdr(clip, skeleton, 0))
        state_pub.publish(_state(0))
        msg = probe.wait('reference_pose')[0]
        assert node.running
    frame, joints, _ = reference_pose_from_cdr(msg, skeleton.n_bones)
    assert frame == 0
    terrain = terrain_from_spec(load_scene(str(scene_file)).terrain)
    feet_h, _ = residual_heights_of(skeleton, clip.root_positions[0], clip.local_rotations[0])
    stance = feet_h < 0.006
    assert stance.any()
    # stance soles stand on the plane as on the capture floor: their pivots (wrist/ankle joints) are as far
    # above it along its normal as above the floor in the clip (the sole turned parallel to the slope)
    pivots = skeleton.indices(list(FOOT_PIVOTS))
    clip_pivots = forward_kinematics(skeleton, clip.root_positions[0], clip.local_rotations[0])[0][pivots]
    above = (joints[pivots, 2] - terrain.height(joints[pivots, :2])) * terrain.normal(joints[pivots, :2])[:, 2]
    assert np.all(np.abs(above[stance] - clip_pivots[stance, 2]) < 0.002)
    # nothing sinks in, but the pressed tail (at most max_tail_press) and the foot end sites in the soles
    depth = joints[:, 2] - terrain.height(joints[:, :2])
    tail = np.array([name.startswith('tail_') for name in skeleton.names])
    foot = np.isin(np.arange(skeleton.n_bones), skeleton.indices(list(FEET)))
    assert np.all(depth[~tail & ~foot] > -1e-3)
    assert np.all(depth[tail] > -AdaptationSettings().max_tail_press - 2e-3) and np.all(depth[foot] > -3e-3)


def test_terrain_node_publishes_a_stride_ahead_up_to_lookahead_frames(tmp_path, make_node, executor):
    """
    A clip's stride goes out in frame order as it is adapted, at most lookahead_frames past the latest iguana_state.

    A repeated state gets the poses from its frame on again, after the poses published before it (one writer's
    messages arrive in order, so nothing past the bound was sent before that repeat).
    """
    from iguana_ros.ros.messages import clip_to_cdr, reference_pose_from_cdr
    scene_file = _scene(tmp_path, terrain={'kind': 'tilted', 'slope_deg': 8.0})
    skeleton = iguana_skeleton()
    clip = motion_graph().align('forward', np.array([0.0, 0.0]), 0.0)     # frames 0..19
    probe = Probe(make_node('probe'), executor)
    probe.listen('reference_pose')
    clip_pub, state_pub = probe.pub('motion_clip'), probe.pub('iguana_state')

    def frames():
        return [reference_pose_from_cdr(p, skeleton.n_bones)[0] for p in probe.got['reference_pose']]
    with _node('terrain_adaptation_node', scene_file, tmp_path, lookahead_frames=5) as node:
        probe.wait_matched('motion_clip')
        probe.wait_matched('iguana_state')
        clip_pub.publish(clip_to_cdr(clip, skeleton, 0))
        assert spin_until(executor, lambda: 5 in frames(), 30), node.output     # no state yet: frames 0..5
        probe.deliver(state_pub, _state(3))
        assert spin_until(executor, lambda: 8 in frames(), 30), node.output
        state_pub.publish(_state(3))                                            # a repeat: poses 3..8 again
        assert spin_until(executor, lambda: frames().count(8) == 2, 30), node.output
        assert frames() == list(range(9)) + list(range(3, 9))
        state_pub.publish(_state(14))
        assert spin_until(executor, lambda: 19 in frames(), 30), node.output
        assert node.running
    assert frames() == list(range(9)) + list(range(3, 9)) + list(range(9, 20))


def test_terrain_node_holds_poses_until_a_reader_matches(tmp_path, make_node, executor):
    """Poses adapted before any reference_pose reader matched are held, and go out in order once one matches."""
    from iguana_ros.ros.messages import clip_to_cdr, reference_pose_from_cdr
    scene_file = _scene(tmp_path, terrain={'kind': 'tilted', 'slope_deg': 8.0})
    skeleton = iguana_skeleton()
    clip = motion_graph().align('forward', np.array([0.0, 0.0]), 0.0)     # frames 0..19
    probe = Probe(make_node('probe'), executor)
    clip_pub, state_pub = probe.pub('motion_clip'), probe.pub('iguana_state')
    with _node('terrain_adaptation_node', scene_file, tmp_path, lookahead_frames=5) as node:
        probe.wait_matched('motion_clip')
        probe.wait_matched('iguana_state')
        probe.deliver(clip_pub, clip_to_cdr(clip, skeleton, 0))             # acknowledged: the node has both
        probe.deliver(state_pub, _state(0))
        spin_until(executor, lambda: False, 1.0)                            # its poses are adapted meanwhile
        probe.listen('reference_pose')
        assert spin_until(executor, lambda: len(probe.got['reference_pose']) >= 6, 30), node.output
        spin_until(executor, lambda: False, 0.3)
        assert node.running
    assert [reference_pose_from_cdr(p, skeleton.n_bones)[0] for p in probe.got['reference_pose']] == list(range(6))


def test_terrain_node_does_not_wait_for_a_reader_that_cannot_match(tmp_path, make_node, executor):
    """A reader asking for transient-local poses is reported incompatible and not waited for: the others get them."""
    from rclpy.qos import DurabilityPolicy
    from iguana_ros.ros.messages import clip_to_cdr, reference_pose_from_cdr
    scene_file = _scene(tmp_path, terrain={'kind': 'tilted', 'slope_deg': 8.0})
    skeleton = iguana_skeleton()
    clip = motion_graph().align('forward', np.array([0.0, 0.0]), 0.0)     # frames 0..19
    probe = Probe(make_node('spring_length_node'), executor)      # the declared reader, listening twice
    name, cls, qos = probe.resolve('reference_pose')
    qos.durability = DurabilityPolicy.TRANSIENT_LOCAL
    probe.node.create_subscription(cls, name, lambda _m: None, qos)
    probe.listen('reference_pose')
    clip_pub, state_pub = probe.pub('motion_clip'), probe.pub('iguana_state')
    with _node('terrain_adaptation_node', scene_file, tmp_path, lookahead_frames=5) as node:
        probe.wait_matched('motion_clip')
        probe.wait_matched('iguana_state')
        probe.deliver(clip_pub, clip_to_cdr(clip, skeleton, 0))
        # reported incompatible, not waited for: out before READER_HOLD_LIMIT_S (5 s)
        assert spin_until(executor, lambda: len(probe.got['reference_pose']) >= 6, 3), node.output
        for frame in range(1, 4):                    # later poses are not held again
            probe.deliver(state_pub, _state(frame))
            assert spin_until(executor, lambda: len(probe.got['reference_pose']) >= 6 + frame, 0.5), node.output
        assert node.running
    assert [reference_pose_from_cdr(p, skeleton.n_bones)[0] for p in probe.got['reference_pose']] == list(range(9))


def test_terrain_node_waits_for_the_declared_reader_not_just_any(tmp_path, make_node, executor, ros_context):
    """
    A matched reader is not enough while the spring-length node (reference_pose's declared reader) is not in the graph.

    In a run, the recorder matched first, the poses went out, and the spring-length node missed frame 0: a 10 s lockstep
    timeout. Once it is listed and matched, poses go out.
    """
    from rclpy.parameter import Parameter
    from iguana_ros.nodes.terrain_adaptation_node import TerrainAdaptationNode
    node = TerrainAdaptationNode(context=ros_context,
                                 parameter_overrides=[Parameter('scene', value=str(_scene(tmp_path)))])
    executor.add_node(node)
    try:
        probe = Probe(make_node('probe'), executor)
        probe.listen('reference_pose')
        assert spin_until(executor, lambda: node.pose_pub.get_subscription_count() >= 1, 30)
        assert not node.reader_hold.readers_matched()
        springs = Probe(make_node('spring_length_node'), executor)
        springs.listen('reference_pose')
        listed = lambda: {i.node_name for i in node.get_subscriptions_info_by_topic(node.pose_pub.topic_name)}  # noqa
        assert spin_until(executor, lambda: node.pose_pub.get_subscription_count() >= 2
                          and 'spring_length_node' in listed(), 30)
        node.reader_hold.held_since = None           # not by the hold's time limit
        assert node.reader_hold.readers_matched()
    finally:
        executor.remove_node(node)
        node.destroy_node()


def test_lockstep_start_waits_for_its_readers_to_match(tmp_path, make_node, executor, ros_context, monkeypatch):
    """
    The simulator starts once its peers are listed by name and every listed reader matched.

    Strangers' readers and a stranger's lengths publisher do not stand in for the planner, the terrain adaptation and
    the spring-length node.

    A listed reader that cannot match (it asks for transient-local states from the volatile writer) is reported
    incompatible and does not hold the start; a listed reader neither matched nor incompatible holds it for
    READER_HOLD_LIMIT_S only.
    """
    from types import SimpleNamespace
    from rclpy.parameter import Parameter
    from rclpy.qos import DurabilityPolicy
    from iguana_ros.nodes import simulator_node
    from iguana_ros.nodes.simulator_node import SimulatorNode
    node = SimulatorNode(context=ros_context, parameter_overrides=[Parameter('scene', value=str(_scene(tmp_path)))])
    executor.add_node(node)
    body = node.bodies[0]                                         # a scene of one iguana: one body, the node's topics
    try:
        assert not node.lockstep_peers_ready()
        strangers = Probe(make_node('echo'), executor)           # `ros2 topic echo`, Foxglove: not peers
        strangers.listen('iguana_state', copies=2)
        strangers.pub('spring_rest_lengths')
        assert spin_until(executor, lambda: len(node.get_subscriptions_info_by_topic(strangers.resolve(
            'iguana_state')[0])) >= 2 and body.lengths_sub.get_publisher_count() >= 1, 30)
        assert not node.lockstep_peers_ready()                   # two readers and a writer, none of them the peers
        peers = [Probe(make_node(name), executor) for name in ('planner_node', 'terrain_adaptation_node')]
        for peer in peers:
            peer.listen('iguana_state')
        assert not node.lockstep_peers_ready()                   # the lengths' publisher is not spring_length_node
        Probe(make_node('spring_length_node'), executor).pub('spring_rest_lengths')
        state = peers[0].resolve('iguana_state')
        assert spin_until(executor, lambda: node.lockstep_peers_ready(), 30)
        assert body.state_pub.get_subscription_count() >= 2
        name, cls, qos = state
        qos.durability = DurabilityPolicy.TRANSIENT_LOCAL
        stranger = make_node('stranger')
        stranger.create_subscription(cls, name, lambda _m: None, qos)
        assert spin_until(executor, lambda: len(node.get_subscriptions_info_by_topic(name)) >= 3, 30)
        assert spin_until(executor, lambda: body.state_readers.incompatible >= 1, 30)
        node.peers_listed_since = None
        assert node.lockstep_peers_ready()           # listed, reported incompatible: not waited for
        body.state_readers.incompatible = 0          # as if it had not been reported yet
        clock = [1000.0]                             # the hold's clock, moved by hand
        monkeypatch.setattr(simulator_node, 'time', SimpleNamespace(monotonic=lambda: clock[0]))
        node.peers_listed_since = None
        assert not node.lockstep_peers_ready()       # listed, neither matched nor incompatible: held ...
        clock[0] = 1000.0 + simulator_node.READER_HOLD_LIMIT_S - 2 ** -10
        assert not node.lockstep_peers_ready()
        clock[0] = 1000.0 + simulator_node.READER_HOLD_LIMIT_S
        assert node.lockstep_peers_ready()           # ... for READER_HOLD_LIMIT_S only
    finally:
        executor.remove_node(node)
        node.destroy_node()


def test_spring_node_holds_lengths_until_the_simulator_reader_matches(tmp_path, make_node, executor, ros_context,
                                                                      monkeypatch):
    """
    Lengths wait for spring_rest_lengths' declared reader (the simulator node), not just any matched reader.

    On CI the spring-length node published frame 0 before its writer had matched the simulator's reader, and the
    simulator waited a 10 s lockstep timeout. Once it is listed and matched, the held lengths go out in frame order.
    """
    from rclpy.parameter import Parameter
    from iguana_ros.nodes import base
    from iguana_ros.nodes.spring_length_node import SpringLengthNode
    from iguana_ros.ros.messages import lengths_from_cdr, reference_pose_to_cdr
    from iguana_ros.terrain.adaptation import pose_kinematics
    monkeypatch.setattr(base, 'READER_HOLD_LIMIT_S', 120.0)  # released by the match, not by the hold's time limit
    clip = motion_graph().align('forward', np.array([0.0, 0.0]), 0.0)
    node = SpringLengthNode(context=ros_context, parameter_overrides=[Parameter('scene', value=str(_scene(tmp_path)))])
    executor.add_node(node)
    try:
        probe = Probe(make_node('probe'), executor)
        probe.listen('spring_rest_lengths')
        assert spin_until(executor, lambda: node.lengths_pub.get_subscription_count() >= 1, 30)
        for frame in (0, 1):
            joints, rotations = pose_kinematics(node.skeleton, clip.root_positions[frame],
                                                clip.local_rotations[frame])
            node.on_pose(reference_pose_to_cdr(joints, rotations, frame))
        spin_until(executor, lambda: False, 0.5)
        assert probe.got['spring_rest_lengths'] == [] and len(node.held) == 2
        simulator = Probe(make_node('simulator_node'), executor)
        simulator.listen('spring_rest_lengths')
        assert spin_until(executor, lambda: len(simulator.got['spring_rest_lengths']) >= 2, 30)
        spin_until(executor, lambda: len(probe.got['spring_rest_lengths']) >= 2, 5)
        n_springs = node.computer.n_springs
        for got in (simulator.got, probe.got):
            assert [lengths_from_cdr(m, n_springs)[0] for m in got['spring_rest_lengths']] == [0, 1]
    finally:
        executor.remove_node(node)
        node.destroy_node()


def test_spring_node_with_no_reader_keeps_only_the_newest_lengths(tmp_path, executor, ros_context):
    """With nobody reading spring_rest_lengths, what is held stays bounded: the newest RESEND_FRAMES frames."""
    from rclpy.parameter import Parameter
    from iguana_ros.nodes.base import RESEND_FRAMES
    from iguana_ros.nodes.spring_length_node import SpringLengthNode
    from iguana_ros.ros.messages import frame_of_cdr, reference_pose_to_cdr
    from iguana_ros.terrain.adaptation import pose_kinematics
    clip = motion_graph().align('forward', np.array([0.0, 0.0]), 0.0)
    node = SpringLengthNode(context=ros_context, parameter_overrides=[Parameter('scene', value=str(_scene(tmp_path)))])
    try:
        joints, rotations = pose_kinematics(node.skeleton, clip.root_positions[0], clip.local_rotations[0])
        for frame in range(RESEND_FRAMES + 5):
            node.on_pose(reference_pose_to_cdr(joints, rotations, frame))
        assert [frame_of_cdr(held) for held in node.held] == list(range(5, RESEND_FRAMES + 5))
    finally:
        node.destroy_node()


def test_spring_node_lengths_equal_the_library(tmp_path, make_node, executor):
    from iguana_ros.body.spring_lengths import SpringLengthComputer
    from iguana_ros.ros.messages import lengths_from_cdr, reference_pose_to_cdr
    from iguana_ros.terrain.adaptation import pose_kinematics
    model = build_model('coarse')
    skeleton = model.skeleton
    clip = motion_graph().align('turn_left', np.array([0.4, -0.2]), 0.3)
    joints, rotations = pose_kinematics(skeleton, clip.root_positions[5], clip.local_rotations[5])
    expected = SpringLengthComputer(model).lengths_from_bones(rotations, joints)
    probe = Probe(make_node('probe'), executor)
    probe.listen('spring_rest_lengths')
    pose_pub = probe.pub('reference_pose')
    with _node('spring_length_node', _scene(tmp_path), tmp_path) as node:
        probe.wait_matched('reference_pose')
        wrong = reference_pose_to_cdr(joints[:5], rotations[:5], 3)  # too few bones
        pose_pub.publish(wrong)
        pose_pub.publish(reference_pose_to_cdr(joints, rotations, 4))
        msg = probe.wait('spring_rest_lengths')[0]
        pose_pub.publish(reference_pose_to_cdr(joints, rotations, 4))   # a repeat: the same lengths again
        again = probe.wait('spring_rest_lengths', 2)[1]
        pose_pub.publish(reference_pose_to_cdr(joints, rotations, 3))   # stale: logged, nothing published
        assert node.wait_for_output('ignored stale reference_pose for frame 3 (at 4)', 30), node.output
        assert len(probe.got['spring_rest_lengths']) == 2
        assert node.running
    assert np.array_equal(lengths_from_cdr(again, len(expected))[1], lengths_from_cdr(msg, len(expected))[1])
    frame, lengths = lengths_from_cdr(msg, len(expected))
    assert frame == 4
    assert np.array_equal(lengths, expected)
    assert 'rejected reference_pose' in node.output


def test_simulator_marker_is_a_valid_triangle_list_on_the_terrain(tmp_path, make_node, executor):
    from iguana_ros.ros.conversions import triangle_list_from_marker
    from iguana_ros.ros.messages import lengths_to_cdr
    from visualization_msgs.msg import Marker
    model = build_model('coarse')
    probe = _lockstep_peers(make_node, executor)
    probe.listen('iguana_state')
    probe.listen('mesh_marker')
    probe.listen('scene_markers')
    probe.listen('foot_state')
    probe.listen('foot_positions')
    lengths_pub = probe.pub('spring_rest_lengths')
    push_pub = probe.pub('push')
    scene_file = _scene(tmp_path, terrain={'kind': 'hills', 'amplitude': 0.02, 'wavelength': 1.0})
    with _node('simulator_node', scene_file, tmp_path, lockstep_timeout=1.0, lockstep_max_timeouts=50) as sim:
        probe.wait('iguana_state', 1, timeout=60)
        probe.wait_matched('push')
        from geometry_msgs.msg import WrenchStamped
        push = WrenchStamped()
        push.header.frame_id = 'wing'  # not a node tag: rejected
        push.wrench.force.y = -40.0
        push_pub.publish(push)
        push.header.frame_id = 'trunk_left'
        push.wrench.force.y = -1000.0           # the probe's push: 163 m/s on trunk_left (13 such threw it 718 m)
        push_pub.publish(push)
        push.wrench.force.y = -40.0
        push_pub.publish(push)
        lengths_pub.publish(lengths_to_cdr(np.ones(7), 0))  # wrong length: rejected, still waiting
        lengths_pub.publish(lengths_to_cdr(np.array(model.spring_rest_lengths), 0))
        markers = probe.wait('mesh_marker', 2)
        scene = probe.wait('scene_markers')[0]
        from iguana_ros.ros.messages import foot_positions_from_cdr, foot_state_from_cdr
        after_one = {}  # the foot probe of the state after frame 0 (stamped 1)
        for key, decode in (('foot_state', foot_state_from_cdr), ('foot_positions', foot_positions_from_cdr)):
            assert spin_until(executor, lambda: any(decode(x)[0] == 1 for x in probe.got[key]), 30), key
            after_one[key] = next(decode(x) for x in probe.got[key] if decode(x)[0] == 1)
        assert sim.running
    marker = markers[-1]
    assert marker.type == Marker.TRIANGLE_LIST and marker.color.a == 1.0
    points, colors = triangle_list_from_marker(marker)
    assert len(points) == 3 * len(model.surface_triangles) == len(colors)
    assert np.all(np.isfinite(points)) and np.all(colors[:, 3] == 1.0)
    from iguana_ros.scene import load_scene, terrain_from_spec
    terrain = terrain_from_spec(load_scene(str(scene_file)).terrain)
    assert np.all(points[:, 2] - terrain.height(points[:, :2]) > -0.01)
    assert [m.ns for m in scene.markers] == ['terrain']
    _, heights, contact = after_one['foot_state']
    assert np.all(np.abs(heights) < 0.02) and contact.any()  # standing: soles on (or pressed into) the hills
    centroids = after_one['foot_positions'][1]
    assert np.all(np.abs(centroids[:, 2] - terrain.height(centroids[:, :2])) < 0.05)
    assert 'rejected spring_rest_lengths' in sim.output
    assert "rejected push: push region 'wing' is not a node tag" in sim.output
    assert 'push [0.0, -40.0, 0.0] N on trunk_left' in sim.output
    assert 'rejected push: push of 1000 N acting 0.1 s (whole frames) gives trunk_left' in sim.output


def test_simulator_keeps_lengths_that_arrive_ahead_and_simulates_them_in_order(tmp_path, make_node, executor):
    """
    Lengths for frames 2 and 1 sent before frame 0's (the adaptation runs a stride ahead): frames 0, 1, 2 step in order.

    The first lengths of a frame count (a second, different message for frame 2 is ignored); the body ends where
    the simulator stage ends with the same three frames; lengths for a frame already simulated are stale.
    """
    from iguana_ros.ros.messages import lengths_to_cdr, state_from_cdr
    from iguana_ros.stages import SimulatorStage
    from iguana_ros.terrain.heightfield import HeightField
    model = build_model('coarse')
    rest = np.array(model.spring_rest_lengths)
    frames = [rest, rest * 1.01, rest * 0.99]
    probe = _lockstep_peers(make_node, executor)
    probe.listen('iguana_state')
    lengths_pub = probe.pub('spring_rest_lengths')
    with _node('simulator_node', _scene(tmp_path), tmp_path, lockstep_timeout=1.0, lockstep_max_timeouts=100) as sim:
        probe.wait('iguana_state', 1, timeout=60)
        probe.wait_matched('spring_rest_lengths')
        probe.deliver(lengths_pub, lengths_to_cdr(frames[2], 2))
        probe.deliver(lengths_pub, lengths_to_cdr(rest * 1.05, 2))   # a second one for frame 2: ignored
        probe.deliver(lengths_pub, lengths_to_cdr(frames[1], 1))
        assert all(state_from_cdr(s)[0] == 0 for s in probe.got['iguana_state'])   # still waiting for frame 0
        lengths_pub.publish(lengths_to_cdr(frames[0], 0))
        assert spin_until(executor, lambda: any(state_from_cdr(s)[0] == 3 for s in probe.got['iguana_state']), 30)
        lengths_pub.publish(lengths_to_cdr(rest, 1))
        assert sim.wait_for_output('ignored stale spring_rest_lengths for frame 1 (simulating frame 3)', 30), sim.output
        assert sim.running
    stage = SimulatorStage(model, HeightField.flat(), 'balanced')
    for lengths in frames:
        stage.advance(lengths)
    after = next(s for s in probe.got['iguana_state'] if state_from_cdr(s)[0] == 3)
    assert np.array_equal(state_from_cdr(after)[1], stage.root_pose()[0])


def test_lockstep_simulator_times_out_clearly(tmp_path, make_node, executor):
    probe = _lockstep_peers(make_node, executor)
    probe.listen('iguana_state')
    probe.pub('spring_rest_lengths')
    with _node('simulator_node', _scene(tmp_path), tmp_path, lockstep_timeout=0.5,
               lockstep_max_timeouts=2) as sim:
        probe.wait('iguana_state', 2, timeout=60)  # the state is re-sent after a timeout
        assert sim.wait(30) == 1
    assert 'lockstep: no spring_rest_lengths for frame 0' in sim.output
    assert 'lockstep timed out 2 times' in sim.output


def test_planner_holds_the_first_stride_until_the_scene_goals_arrive(tmp_path, make_node, executor):
    from iguana_ros.nodes.goal_sender import goal_message
    from iguana_ros.ros.messages import clip_from_cdr
    probe = Probe(make_node('probe'), executor)
    probe.listen('motion_clip')
    goal_pub, state_pub = probe.pub('goal_pose'), probe.pub('iguana_state')
    with _node('planner_node', _scene(tmp_path), tmp_path, wait_for_goals=1) as planner:
        probe.wait_matched('goal_pose')
        probe.wait_matched('iguana_state')
        state_pub.publish(_state(0))  # the state overtakes the goal: held, not decided
        assert planner.wait_for_output('holding iguana_state of frame 0 until 1 goals have arrived', 30), \
            planner.output
        goal_pub.publish(goal_message(0.3, 2.0))
        clip = probe.wait('motion_clip')[0]
        assert planner.running
        # the held stride was decided with the goal (else idle); the log line may follow the clip on the wire
        assert planner.wait_for_output("frame 0: clip 'start'", 10), planner.output
    assert len(probe.got['motion_clip']) == 1 and clip_from_cdr(clip, iguana_skeleton())[0] == 0


def test_realtime_simulator_paces_lengths_that_arrived_ahead(tmp_path, make_node, executor):
    """
    Lengths a stride ahead (the terrain adaptation's) are not raced through at the start of a realtime run.

    The start's trigger of the lockstep path simulated every frame whose lengths were in at once: 12 frames of a
    `realtime` run in 0.23 s of wall time under load (issue 31). Realtime frames are paced by the timer only.
    """
    import time
    from iguana_ros.nodes.goal_sender import goal_message
    from iguana_ros.ros.messages import lengths_to_cdr, state_from_cdr
    rest = np.array(build_model('coarse').spring_rest_lengths)
    probe = Probe(make_node('spring_length_node'), executor)
    arrivals = []
    name, cls, qos = probe.resolve('iguana_state')
    probe.node.create_subscription(cls, name, lambda m: arrivals.append((state_from_cdr(m)[0], time.monotonic())), qos,
                                   raw=True)
    lengths_pub, goal_pub = probe.pub('spring_rest_lengths'), probe.pub('goal_pose')
    with _node('simulator_node', _scene(tmp_path, goals=[{'x': 1.0, 'y': 0.0}]), tmp_path, mode='realtime',
               wait_for_goals=1) as sim:
        probe.wait_matched('spring_rest_lengths')
        for frame in range(29):                              # a stride and more, before the run starts
            lengths_pub.publish(lengths_to_cdr(rest, frame))
        probe.deliver(lengths_pub, lengths_to_cdr(rest, 29))   # acknowledged: all 30 are in
        probe.wait_matched('goal_pose')
        probe.deliver(goal_pub, goal_message(1.0, 0.0))
        assert spin_until(executor, lambda: any(f >= 30 for f, _ in arrivals), 30), sim.output
    first = next(t for f, t in arrivals if f == 0)
    thirtieth = next(t for f, t in arrivals if f == 30)
    assert thirtieth - first >= 0.9 * 30 / 30.0, f'30 frames in {thirtieth - first:.2f} s of wall time'
