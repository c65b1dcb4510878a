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

"""Terrain adaptation node (Section VI): motion_clip + iguana_state in, reference_pose (and its bones on /tf) out."""
from __future__ import annotations

from iguana_ros.errors import IguanaError, InputError
from iguana_ros.nodes.base import FrameGate, IguanaNode, node_main, ReaderHold, RESEND_FRAMES
from iguana_ros.ros.messages import clip_from_cdr, reference_pose_to_cdr, state_from_cdr
from iguana_ros.ros.tf import bones_tf_to_cdr, tf_frames
from iguana_ros.stages import adaptation_stage, StrideLookahead
from iguana_ros.validation import check_frame, FRAME_NEW, world_bound

CLIP_QUEUE_DEPTH = 10
"""History depth of the motion_clip reader: the topic's depth 1 (latched) would let a burst from another publisher
push the planner's clip out of the queue before it is taken (the lockstep run then stalls at that stride)."""


class TerrainAdaptationNode(IguanaNode):
    """
    Adapts each stride's clip to the terrain and publishes its bone frames, frame by frame.

    A stride's poses depend only on its clip and the adaptation's warm start, never on the body, so they are adapted
    on a worker thread as soon as the clip arrives (`StrideLookahead`) and published in frame order up to
    `lookahead_frames` past the latest iguana_state: the spring lengths are then waiting at the simulator when it
    reaches their frame. Poses go out only once the topic's declared readers (`topics.yaml`: the spring-length node)
    are in this node's graph and every reader it lists is matched (a burst published before the spring-length node's
    subscription matched was lost, and the simulator then waited a lockstep timeout).
    A repeated iguana_state (the simulator re-sends it after a lockstep timeout) gets the poses from its frame on again.
    """

    KIND = 'terrain_adaptation_node'

    def __init__(self, **kwargs) -> None:
        """Build the scene's adaptation stage (`stages.adaptation_stage`; the parameter may turn it on or off)."""
        super().__init__(**kwargs)
        choice = self.param('adaptation')
        self.stage = adaptation_stage(self.scene, None if choice == 'scene' else choice == 'on')
        self.skeleton = self.stage.skeleton
        self.lookahead = StrideLookahead(self.stage)
        self.lookahead.load_kernels()                # before the first clip arrives, not during its stride
        self.lookahead_frames = self.param('lookahead_frames')
        self.bound = world_bound(self.scene.terrain.extent)
        self.newest_clip = -1
        self.next_frame = 0
        self.sent: dict[int, object] = {}
        self.reader_hold = ReaderHold(self, 'reference_pose', retry=self.publish_ready)
        self.pose_pub = self.reader_hold.publisher
        self.tf_pub = self.publisher('tf')
        self.frames = tf_frames(self.frame_prefix(), self.skeleton.names)
        self.state_gate = FrameGate(self, 'iguana_state')
        self.ready_signal = self.create_guard_condition(self.publish_ready)
        self.subscription('motion_clip', self.guarded('motion_clip', self.on_clip), raw=True, depth=CLIP_QUEUE_DEPTH)
        self.subscription('iguana_state', self.guarded('iguana_state', self.on_state), raw=True)
        self.get_logger().info(f'terrain adaptation ready ({"on" if self.stage.enabled else "off"})')

    def on_clip(self, data: bytes) -> None:
        """Adapt the new stride's frames on the worker thread; each is published once ready and due."""
        start, clip = clip_from_cdr(data, self.skeleton, self.bound)    # serialized: read with numpy
        newest = max(self.newest_clip, self.next_frame - 1)
        if check_frame('motion_clip', start, newest) != FRAME_NEW:
            raise InputError(f'motion_clip starts at frame {start}, not after the newest clip (frame '
                             f'{self.newest_clip}) and the last frame published ({self.next_frame - 1}): stale')
        self.newest_clip = start
        self.next_frame = start
        self.lookahead.start(clip, start, on_ready=self.ready_signal.trigger)
        self.publish_ready()

    def on_state(self, msg) -> None:
        """Let the poses up to `lookahead_frames` past this frame go out; re-send them from a repeated frame on."""
        frame, _root, _orientation = state_from_cdr(msg, self.bound)
        if self.state_gate.admit(frame):
            self.state_gate.handled(frame)
        elif frame == self.state_gate.last_frame:
            for sent in range(frame, self.next_frame):  # any of them may be lost; the repeat asks for the first
                if sent in self.sent:
                    self.pose_pub.publish(self.sent[sent])
        self.publish_ready()

    def publish_ready(self) -> None:
        """Publish, in frame order, every adapted pose of the stride that is due (at most lookahead_frames ahead)."""
        due = max(self.state_gate.last_frame, 0) + self.lookahead_frames
        if not (self.next_frame <= due and self.lookahead.ready(self.next_frame)):
            return
        if not self.reader_hold.ready():             # offered again every UNMATCHED_RETRY_S until it is
            return
        while self.next_frame <= due and self.lookahead.ready(self.next_frame):
            frame = self.next_frame
            self.next_frame = frame + 1
            try:
                reference = self.lookahead.take(frame)
            except IguanaError as exc:
                self.get_logger().error(f'no reference pose for frame {frame}: {exc}')
                continue
            self.sent[frame] = reference_pose_to_cdr(reference.joints, reference.rotations, frame)
            while len(self.sent) > RESEND_FRAMES:
                del self.sent[next(iter(self.sent))]
            self.pose_pub.publish(self.sent[frame])
            self.tf_pub.publish(bones_tf_to_cdr(self.frames, reference.joints, reference.rotations, frame))

    def destroy_node(self) -> None:
        """Stop the lookahead's worker thread, then leave the graph."""
        self.lookahead.close()
        super().destroy_node()


main = node_main(TerrainAdaptationNode)

if __name__ == '__main__':
    main()
