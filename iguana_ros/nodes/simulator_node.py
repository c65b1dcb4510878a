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
Simulator node (Section V).

Its inputs are spring_rest_lengths and push; its outputs are mesh_marker, scene_markers, iguana_state, foot_state,
foot_positions, /clock, /tf (odom -> base_link and the feet) and /tf_static (world -> odom). `lockstep` advances a
frame only when that frame's lengths arrive; `realtime` paces to the wall clock with the latest lengths. Its services
sim/pause, sim/resume, sim/step and sim/reset control the frame loop in both modes (`stages.SimControl`,
`SimulatorStage.reset`).

A scene with a `characters` list is one world (`world.BodyWorld`: the bodies stepped together, in contact): each
character's topics are under its name (`iguana_b/iguana_state`, `iguana_b/spring_rest_lengths`, ...), its frames
`iguana_b/odom` -> `iguana_b/base_link`, the clock and services are the world's, and a lockstep frame is simulated once
every character's lengths of it are in (as `world.run_world` steps, bit for bit); a frame with body-body contact is
published on body_contacts.
"""
from __future__ import annotations

import time

import numpy as np
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.clock import Clock, ClockType
from rclpy.task import Future
from visualization_msgs.msg import Marker

from iguana_ros.body.feet import FootProbe
from iguana_ros.constants import FRAME_RATE, WORLD_FRAME
from iguana_ros.errors import IguanaError
from iguana_ros.nodes.base import IguanaNode, node_main, READER_HOLD_LIMIT_S, ReaderCount
from iguana_ros.physics.errors import SimulationDiverged
from iguana_ros.ros.body_contacts import body_contacts_msg
from iguana_ros.ros.cdr import TriangleListMarkerWriter
from iguana_ros.ros.conversions import frame_stamp, marker_array_msg, triangle_list_marker
from iguana_ros.ros.endpoints import RECORDER_NODE_NAME, resolve, resolve_service
from iguana_ros.ros.messages import (clock_to_cdr, foot_positions_to_cdr, foot_state_to_cdr, frame_of_cdr,
                                     goal_from_msg, lengths_from_cdr, push_from_cdr, route_from_msg, state_to_cdr)
from iguana_ros.ros.run_events import EVENT_BODY_LOST, EVENT_PAUSED, EVENT_RESET, EVENT_RESUMED
from iguana_ros.ros.tf import body_tf_to_cdr, static_tf_to_cdr, tf_frames
from iguana_ros.scene import Scene
from iguana_ros.stages import SimControl, simulator_stage, SimulatorStage
from iguana_ros.topics import topic
from iguana_ros.validation import check_frame, FRAME_STALE
from iguana_ros.visuals import body_colors, terrain_mesh
from iguana_ros.world import BodyWorld

WATCHDOG_PERIOD = 0.1
"""Wall seconds between lockstep timeout checks."""

FINISH_ACK_TIMEOUT = 2.0
"""Seconds the simulator waits at the end for subscribers (e.g. the recorder) to acknowledge its last frame."""

GOAL_MARKER_RADIUS = 0.05
"""Radius of the goal sphere in scene_markers, m."""

RECORDED_FROM_START = ('iguana_state', 'mesh_marker', 'clock', 'foot_state', 'foot_positions', 'motion_clip',
                       'reference_pose', 'reference_stance', 'tf')
"""Topics the bag recorder must subscribe to before frame 0 (with wait_for_recorder): the run's summary reads
the gait figures from them."""

WORLD_TOPICS = ('clock', 'tf')
"""Of RECORDED_FROM_START, the topics of the world (one for every body)."""


class SimBody:
    """
    One body of the simulator node: its stage, its topics (relative names under `prefix`), TF frames and inputs.

    A lone iguana's topics are the node's own (`iguana_state`); a world's character `iguana_b` has `iguana_b/...`.
    """

    def __init__(self, node: SimulatorNode, name: str, scene: Scene, stage: SimulatorStage, prefix: str,
                 frame_prefix: str) -> None:
        """Take the body's stage; make its publishers and subscriptions under `prefix` and its TF frame names."""
        self.node, self.name, self.scene, self.stage, self.prefix = node, name, scene, stage, prefix
        self.model = stage.model
        self.n_springs = len(self.model.springs)
        self.probe = FootProbe(self.model, stage.terrain)
        self.frames = tf_frames(frame_prefix)
        self.tf_frame = -1                            # newest frame on /tf: a re-sent state sends no repeated stamp
        self.mesh_writer = TriangleListMarkerWriter(self.model.surface_triangles, self.model.n_nodes, WORLD_FRAME,
                                                    name)
        self.latest_lengths: np.ndarray | None = None
        self.pending_lengths: dict[int, np.ndarray] = {}
        self.goals: list[np.ndarray] = [np.array([g.x, g.y]) for g in scene.goals + scene.route]
        self.goals_received = 0
        self.rejected_lengths = ''
        self.state_readers = ReaderCount(node, 'iguana_state', prefix)
        self.state_pub = self.state_readers.publisher
        self.mesh_pub = node.publisher('mesh_marker', prefix)
        self.foot_pub = node.publisher('foot_state', prefix)
        self.foot_positions_pub = node.publisher('foot_positions', prefix)
        self.publishers_by_key = {'iguana_state': self.state_pub, 'mesh_marker': self.mesh_pub,
                                  'foot_state': self.foot_pub, 'foot_positions': self.foot_positions_pub}
        self.lengths_sub = node.subscription('spring_rest_lengths',
                                             node.guarded(f'{prefix}spring_rest_lengths', self.on_lengths),
                                             raw=True, prefix=prefix)
        node.subscription('push', node.guarded(f'{prefix}push', self.on_push), raw=True, prefix=prefix)
        node.subscription('goal_pose', node.guarded(f'{prefix}goal_pose', self.on_goal), prefix=prefix)
        node.subscription('route', node.guarded(f'{prefix}route', self.on_route), prefix=prefix)

    def on_lengths(self, data: bytes) -> None:
        """
        Keep a frame's lengths until the simulator reaches that frame; lockstep: advance once the frame's are all in.

        Lengths may arrive ahead of their frame (the terrain adaptation adapts a stride ahead); the first lengths of a
        frame are the ones simulated. Realtime: each frame takes the newest lengths not ahead of it. Lengths outside
        the model's bounds are rejected: the frame is not simulated with them (lockstep waits on).
        """
        try:
            frame, lengths = lengths_from_cdr(data, self.n_springs, self.model.spring_rest_lengths)
        except IguanaError as exc:
            self.rejected_lengths = f'frame {frame_of_cdr(data)}: {exc}'
            raise
        node = self.node
        if check_frame('spring_rest_lengths', frame, self.stage.frame) == FRAME_STALE:
            node.health.late += 1
            if node.mode == 'lockstep':
                node.get_logger().warning(f'ignored stale {self.prefix}spring_rest_lengths for frame {frame} '
                                          f'(simulating frame {self.stage.frame})')
            return
        self.pending_lengths.setdefault(frame, lengths)
        if node.mode == 'lockstep' and frame == self.stage.frame:
            node.advance_signal.trigger()

    def realtime_lengths(self) -> np.ndarray | None:
        """Return the newest kept lengths not ahead of the current frame (dropping older ones), else the last used."""
        due = [f for f in self.pending_lengths if f <= self.stage.frame]
        if due:
            self.latest_lengths = self.pending_lengths[max(due)]
            for f in due:
                del self.pending_lengths[f]
        return self.latest_lengths

    def on_push(self, data: bytes) -> None:
        """Apply a push (world-frame force on the tagged region named by header.frame_id) from the next frame."""
        request = push_from_cdr(data)
        push = self.stage.add_push(request.force, request.region, self.node.param('push_duration'), request.torque)
        self.node.get_logger().info(f'push {list(push.force)} N on {self.prefix}{push.region} for '
                                    f'{push.duration:g} s')

    def on_goal(self, msg) -> None:
        """Show a new goal in scene_markers (the planner's rules: `goal_from_msg`)."""
        self.show_goals([goal_from_msg(msg, self.node.half_extent).xy])

    def on_route(self, msg) -> None:
        """Show a new route's waypoints in scene_markers (the planner's rules: `route_from_msg`)."""
        self.show_goals([np.array(w[:2]) for w in route_from_msg(msg, self.node.half_extent).waypoints])

    def show_goals(self, places: list) -> None:
        """Count a goal or route message; add the places `(2,)` not shown yet to the goal spheres."""
        self.goals_received += 1
        new = [xy for xy in places if not any(np.allclose(xy, g) for g in self.goals)]
        if new:
            self.goals.extend(new)
            self.node.publish_scene_markers()

    def expect_peers(self, namespace: str | None, hearing: list[str]) -> None:
        """
        Name the lockstep peers this body waits for: its character's nodes in `namespace` (None: any namespace).

        `hearing` names the namespaces of the other characters' planners that plan with this body's state.
        """
        self.peer_namespace = namespace
        self.hearing = hearing

    def peers_listed(self) -> bool:
        """
        Whether this body's planner, terrain adaptation and hearing planners read its state, and its lengths come.

        Each from the node of that name in its namespace (a world's: the character's; a lone iguana's: any).
        """
        node = self.node
        readers = {(info.node_namespace, info.node_name)
                   for info in node.get_subscriptions_info_by_topic(self.state_pub.topic_name)}
        writers = {(info.node_namespace, info.node_name)
                   for info in node.get_publishers_info_by_topic(resolve('spring_rest_lengths', self.prefix)[0])}
        return (self._listed(topic('iguana_state').subscriber_nodes, readers)
                and all((ns, 'planner_node') in readers for ns in self.hearing)
                and self._listed(topic('spring_rest_lengths').publisher_nodes, writers))

    def _listed(self, names, endpoints: set) -> bool:
        """Whether every node of `names` has an endpoint among (namespace, name) `endpoints`, in its namespace."""
        if self.peer_namespace is None:
            return set(names) <= {name for _, name in endpoints}
        return all((self.peer_namespace, name) in endpoints for name in names)

    def recorded_names(self) -> list[str]:
        """Return this body's topics the recorder must read from frame 0 (its own publishers' names as remapped)."""
        return [self.publishers_by_key[key].topic_name if key in self.publishers_by_key
                else resolve(key, self.prefix)[0]
                for key in RECORDED_FROM_START if key not in WORLD_TOPICS]

    def publish_state(self, frame: int) -> None:
        """iguana_state, the foot probe, /tf and (every n frames) the mesh marker of the current frame."""
        root, orientation = self.stage.root_pose()
        linear, angular = self.stage.root_twist()
        self.state_pub.publish(state_to_cdr(root, orientation, linear, angular, frame, self.frames.base))
        heights, contact, soles = self.probe.body(self.stage.sim.positions, self.stage.sim.in_contact)
        if frame > self.tf_frame:                     # tf2 warns on a repeated stamp (TF_REPEATED_DATA)
            self.tf_frame = frame
            self.node.tf_pub.publish(body_tf_to_cdr(self.frames, root, orientation, soles, frame))
        self.foot_pub.publish(foot_state_to_cdr(heights, contact, frame))
        self.foot_positions_pub.publish(foot_positions_to_cdr(soles, frame))
        if frame % self.node.param('mesh_every_n_frames') == 0:
            self.mesh_pub.publish(self.mesh_writer.write(
                self.stage.sim.positions, body_colors(self.model.n_nodes, self.stage.sim.in_contact),
                frame_stamp(frame)))


class SimulatorNode(IguanaNode):
    """Runs the soft body (or a world's bodies, in contact) and publishes what it does."""

    KIND = 'simulator_node'
    SERVES_WORLD = True

    def __init__(self, **kwargs) -> None:
        """Build the model, terrain and simulator the scene names (a body per character); wait for peers in lockstep."""
        super().__init__(**kwargs)
        scene = self.scene
        fidelity = scene.fidelity if self.param('fidelity') == 'scene' else self.param('fidelity')
        stages = [simulator_stage(one, fidelity) for _, one in self.characters]
        for stage in stages:
            stage.load_kernels()                     # before the start handshake, not in the first frame
        self.world = BodyWorld(stages)
        self.world.load_kernels()
        self.stage = stages[0]
        self.model, self.terrain = self.stage.model, self.stage.terrain
        self.load_detail = 'model from cache' if self.model.from_cache else 'model built'
        self.mode = self.param('mode')
        duration = self.param('duration') or scene.duration
        self.end_frame = int(round(duration * FRAME_RATE))
        self.half_extent = scene.terrain.extent / 2.0
        self.peers_listed_since: float | None = None
        self.recorder_listed_since: float | None = None
        self.started = False
        self.control = SimControl(paused=self.param('start_paused'))
        self.health.paused = self.control.paused
        self.step_waiters: list[Future] = []
        self.timeouts = 0
        self.wait_since = time.monotonic()
        self.wall_start = time.monotonic()
        self._make_io(stages)
        self.advance_signal = self.create_guard_condition(self.advance_due)
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        period = WATCHDOG_PERIOD if self.mode == 'lockstep' else 1.0 / FRAME_RATE
        self.timer = self.create_timer(period, self.on_timer, clock=steady)
        bodies = (f'{len(stages)} bodies in one world ({", ".join(b.name for b in self.bodies)}) of '
                  if self.in_world else '')
        self.get_logger().info(
            f'simulator ready: {bodies}{self.model.n_nodes} nodes, {len(self.model.tets)} tets, '
            f'{len(self.model.springs)} springs, {fidelity} fidelity, {self.mode} mode, {duration:g} s'
            + (', paused until sim/resume or sim/step' if self.control.paused else ''))

    def destroy_node(self) -> None:
        """Stop the world's helper threads, then destroy the node."""
        self.world.close()
        super().destroy_node()

    def _make_io(self, stages: list[SimulatorStage]) -> None:
        """Make the world's publishers (clock, tf, scene markers), services, and each body's topics."""
        self.clock_pub = self.publisher('clock')
        self.tf_pub = self.publisher('tf')
        self.scene_pub = self.publisher('scene_markers')
        self.contacts_pub = self.publisher('body_contacts') if self.in_world else None
        base = self.frame_prefix()
        self.bodies = [SimBody(self, name, one, stage, f'{name}/' if self.in_world else '',
                               f'{base}{name}/' if self.in_world else base)
                       for (name, one), stage in zip(self.characters, stages)]
        root = self.get_namespace().rstrip('/')
        careful = [c.name for c in self.world_scene.characters if c.avoid_others] if len(self.bodies) > 1 else []
        for body in self.bodies:
            body.expect_peers(f'{root}/{body.name}' if self.in_world else None,
                              [f'{root}/{name}' for name in careful if name != body.name])
        self.publisher('tf_static').publish(static_tf_to_cdr([b.frames for b in self.bodies]))  # latched: world -> odom
        awaiting = ReentrantCallbackGroup()   # a step awaits its frames: its group stays busy until they are simulated
        for key, callback in (('sim_pause', self.on_pause), ('sim_resume', self.on_resume), ('sim_step', self.on_step),
                              ('sim_reset', self.on_reset)):
            name, cls = resolve_service(key)
            self.create_service(cls, name, callback, callback_group=awaiting if key == 'sim_step' else None)
        self.publish_scene_markers()

    @property
    def frame(self) -> int:
        """Return the frame every body is at."""
        return self.stage.frame

    # ------------------------------------------------------------------------------------------ stepping
    def advance_due(self) -> None:
        """
        Lockstep: simulate the current frame if every body's lengths of it are in; one frame per call.

        Never in realtime mode: there the timer paces every frame (lengths a stride ahead would be raced through).
        """
        frame = self.frame
        if self.mode != 'lockstep' or not self.control.may_advance(frame) or not self.started:
            return
        if self.exit_code or frame >= self.end_frame or not all(frame in b.pending_lengths for b in self.bodies):
            return
        self.advance([b.pending_lengths.pop(frame) for b in self.bodies])
        if all(self.frame in b.pending_lengths for b in self.bodies):
            self.advance_signal.trigger()

    def on_timer(self) -> None:
        """Start when peers are connected; lockstep watchdog; realtime pacing."""
        if not self.started:
            self.try_start()
            return
        if not self.control.may_advance(self.frame):
            self.wait_since = time.monotonic()           # paused: nothing is late
            return
        if self.mode == 'realtime':
            self.advance([b.realtime_lengths() for b in self.bodies])
            return
        waited = time.monotonic() - self.wait_since
        if waited > self.param('lockstep_timeout'):
            self.on_lockstep_timeout(waited)

    def try_start(self) -> None:
        """Begin once everything the start waits for is there (or fail at start_timeout naming what is not)."""
        missing = self.missing_peers()
        if not missing:
            self.started = True
            self.wall_start = self.wait_since = time.monotonic()
            if self.control.paused:
                self.report(EVENT_PAUSED, detail='started paused', frame=0)
            self.publish_state()
            self.advance_signal.trigger()                 # lengths of frame 0 may be in already
            return
        if time.monotonic() - self.wall_start > self.param('start_timeout'):
            self.fail(f'not started within {self.param("start_timeout"):g} s: still waiting for {missing} '
                      '(same ROS_DOMAIN_ID?)')

    def missing_peers(self) -> str:
        """Return what the start still waits for ('' when ready): lockstep peers, goals, the recorder."""
        if self.mode == 'lockstep' and not self.lockstep_peers_ready():
            return 'the planner, terrain adaptation and spring-length nodes' + (
                ' of every character' if self.in_world else '')
        received = sum(b.goals_received for b in self.bodies)
        if received < self.param('wait_for_goals'):
            return f'{self.param("wait_for_goals")} goals on goal_pose or route ({received} so far)'
        recorder_ok = not self.param('wait_for_recorder') or self.recorder_matched()
        return '' if recorder_ok else 'the bag recorder'

    def recorder_matched(self) -> bool:
        """
        Return whether the bag recorder is listed on every topic it must record from frame 0, and matched on ours.

        Listed is not enough: a writer loses what it publishes before it has matched a reader the graph already lists
        (the bag then misses the first frames). Each of this node's publishers of those topics must have matched every
        reader listed; one that does not (a stranger with an incompatible QoS) holds the start READER_HOLD_LIMIT_S only.
        """
        own = [self.clock_pub, self.tf_pub] + [pub for b in self.bodies for key, pub in b.publishers_by_key.items()
                                               if key in RECORDED_FROM_START]
        names = [self.clock_pub.topic_name, self.tf_pub.topic_name]
        names += [name for b in self.bodies for name in b.recorded_names()]
        if not all(any(info.node_name == RECORDER_NODE_NAME for info in self.get_subscriptions_info_by_topic(name))
                   for name in names):
            self.recorder_listed_since = None
            return False
        now = time.monotonic()
        self.recorder_listed_since = self.recorder_listed_since or now
        return (all(pub.get_subscription_count() >= self.count_subscribers(pub.topic_name) for pub in own)
                or now - self.recorder_listed_since >= READER_HOLD_LIMIT_S)

    def lockstep_peers_ready(self) -> bool:
        """
        Return whether every body's lockstep peers are on the graph by name and every reader of its state is settled.

        The declared readers of iguana_state (the planner's and the terrain adaptation's) and publisher of
        spring_rest_lengths, named: a stranger's reader (`ros2 topic echo`, Foxglove) must not stand in for one, or a
        state would be published to a peer not there yet and the run would wait a lockstep timeout. Every listed reader
        must be matched or report an incompatible QoS (`ReaderCount`); one that does neither holds the start for
        READER_HOLD_LIMIT_S only.
        """
        if not all(b.peers_listed() for b in self.bodies):
            self.peers_listed_since = None
            return False
        now = time.monotonic()
        self.peers_listed_since = self.peers_listed_since or now
        return (all(b.state_readers.settled() for b in self.bodies)
                or now - self.peers_listed_since >= READER_HOLD_LIMIT_S)

    def on_lockstep_timeout(self, waited: float) -> None:
        """Log, re-send the state (a peer may have missed it), give up after lockstep_max_timeouts."""
        self.timeouts += 1
        limit = self.param('lockstep_max_timeouts')
        late = [b for b in self.bodies if self.frame not in b.pending_lengths]
        rejected = '; '.join(f'{b.prefix}{b.rejected_lengths}' for b in late if b.rejected_lengths)
        why = (f'last rejected: {rejected}' if rejected
               else 'is spring_length_node running, or did a node upstream reject the state? (see their logs)')
        whose = f' of {", ".join(b.name for b in late)}' if self.in_world else ''
        self.get_logger().error(f'lockstep: no spring_rest_lengths{whose} for frame {self.frame} within '
                                f'{waited:.1f} s ({self.timeouts}/{limit}); {why}')
        if self.timeouts >= limit:
            self.fail(f'lockstep timed out {limit} times waiting for frame {self.frame}'
                      + (f' ({why})' if rejected else ''))
            return
        self.wait_since = time.monotonic()
        self.publish_state()

    def advance(self, lengths: list) -> None:
        """Simulate one frame of every body with its lengths (None: rest), publish the new states; finish at the end."""
        touched = len(self.world.contacts)
        try:
            self.world.advance(lengths)
        except SimulationDiverged as exc:
            self.fail(str(exc))
            return
        if len(self.world.contacts) > touched and self.contacts_pub is not None:
            record = self.world.contacts[-1]
            self.contacts_pub.publish(body_contacts_msg(record.frame, [b.name for b in self.bodies], record.pairs))
        self.timeouts = 0
        for body in self.bodies:
            body.rejected_lengths = ''
        self.health.frames += 1
        self.health.sim_time = self.stage.time
        self.wait_since = time.monotonic()
        self.publish_state()
        if self.control.step_done(self.frame):
            self._answer_steps()
        lost = next((b for b in self.bodies if b.stage.lost is not None), None)
        if lost is not None:
            cause = lost.stage.lost
            whose = f'{lost.name}: ' if self.in_world else ''
            self.report(EVENT_BODY_LOST, detail=f'{cause.cause}: {whose}{cause.message}', frame=self.frame)
            self.get_logger().error(f'run ended at t={self.stage.time:.2f} s: {whose}{cause.message}')
            self.finish(cause.exit_code)
        elif self.frame >= self.end_frame:
            wall = time.monotonic() - self.wall_start
            self.get_logger().info(f'scene finished: {self.stage.time:.2f} s simulated in {wall:.2f} s wall '
                                   f'(realtime factor {self.stage.time / max(wall, 1e-9):.2f})')
            self.finish(0)

    def fail(self, reason: str) -> None:
        """Log an error and stop the node with exit status 1."""
        self.get_logger().error(reason)
        self.finish(1)

    def finish(self, code: int) -> None:
        """Stop stepping, let subscribers acknowledge the last frame, and end the process's spin."""
        import rclpy
        from rclpy.duration import Duration
        self.exit_code = code
        self.timer.cancel()
        world = [self.clock_pub, self.tf_pub] + ([self.contacts_pub] if self.contacts_pub is not None else [])
        for pub in world + [p for b in self.bodies for p in b.publishers_by_key.values()]:
            pub.wait_for_all_acked(Duration(seconds=FINISH_ACK_TIMEOUT))
        rclpy.try_shutdown(context=self.context)

    # ------------------------------------------------------------------------------------------ control services
    def _at(self) -> str:
        """Return where the simulation is, for the services' messages."""
        return f'frame {self.frame} (t={self.stage.time:.3f} s)'

    def on_pause(self, request, response):
        """sim/pause: hold at the current frame."""
        self.control.pause()
        self.health.paused = True
        self._answer_steps()
        self.report(EVENT_PAUSED, frame=self.frame)
        self.get_logger().info(f'paused at {self._at()}')
        response.success, response.message = True, f'paused at {self._at()}'
        return response

    def on_resume(self, request, response):
        """sim/resume: advance again."""
        self.control.resume()
        self.health.paused = False
        self._answer_steps()
        self.wait_since = time.monotonic()
        self.advance_signal.trigger()                    # lengths of the current frame may be waiting
        self.report(EVENT_RESUMED, frame=self.frame)
        self.get_logger().info(f'resumed at {self._at()}')
        response.success, response.message = True, f'resumed at {self._at()}'
        return response

    async def on_step(self, request, response):
        """sim/step: advance exactly `frames` frames, then hold; answer once they are simulated."""
        left = self.end_frame - self.frame
        if not 1 <= request.frames <= left:
            response.success = False
            response.message = (f'cannot step {request.frames} frames at {self._at()}: between 1 and {left} '
                                f'(the scene ends at frame {self.end_frame})')
        else:
            target = self.control.step(self.frame, request.frames)
            self.get_logger().info(f'stepping {request.frames} frames from {self._at()}')
            done = Future()
            self.step_waiters.append(done)
            self.wait_since = time.monotonic()
            self.advance_signal.trigger()
            await done
            response.success = self.frame == target
            response.message = (f'stepped to {self._at()}' if response.success
                                else f'step to frame {target} interrupted at {self._at()}')
        response.frame, response.time = self.frame, self.stage.time
        return response

    def _answer_steps(self) -> None:
        """Let every waiting step request answer (its step ended, or a pause or resume interrupted it)."""
        for done in self.step_waiters:
            done.set_result(True)
        self.step_waiters = []

    def on_reset(self, request, response):
        """sim/reset: every body back at the scene's start, at rest; simulated time goes on."""
        for body in self.bodies:
            body.stage.reset()
        self.report(EVENT_RESET, detail=f'reset {self.stage.resets}', frame=self.frame)
        self.get_logger().info(f'reset to the scene start at {self._at()}')
        if self.started:
            self.publish_state()                         # the new pose now, also while paused
        response.success, response.message = True, f'reset to the scene start at {self._at()}'
        return response

    # ------------------------------------------------------------------------------------------ outputs
    def publish_state(self) -> None:
        """/clock, then every body's iguana_state, foot probe, /tf and (every n frames) mesh marker."""
        frame = self.frame
        self.clock_pub.publish(clock_to_cdr(frame))
        for body in self.bodies:
            body.publish_state(frame)

    def publish_scene_markers(self) -> None:
        """Terrain mesh and goal spheres (latched)."""
        vertices, triangles, colors = terrain_mesh(self.terrain, (self.scene.start.x, self.scene.start.y),
                                                   self.scene.terrain.extent / 2.0)
        markers = [triangle_list_marker(vertices, triangles, colors, ns='terrain')]
        for i, goal in enumerate(g for body in self.bodies for g in body.goals):
            sphere = Marker(ns='goal', id=i, type=Marker.SPHERE, action=Marker.ADD)
            sphere.header.frame_id = WORLD_FRAME
            sphere.pose.position.x, sphere.pose.position.y = float(goal[0]), float(goal[1])
            sphere.pose.position.z = float(self.terrain.height(goal[None])[0]) + GOAL_MARKER_RADIUS
            sphere.pose.orientation.w = 1.0
            sphere.scale.x = sphere.scale.y = sphere.scale.z = 2 * GOAL_MARKER_RADIUS
            sphere.color.r, sphere.color.g, sphere.color.b, sphere.color.a = 0.2, 0.4, 1.0, 1.0
            markers.append(sphere)
        self.scene_pub.publish(marker_array_msg(markers))


main = node_main(SimulatorNode)

if __name__ == '__main__':
    main()
