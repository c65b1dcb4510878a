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

"""Terrain adaptation node (Section VI): motion_clip + iguana_state in, reference_pose out each frame."""
from __future__ import annotations

from iguana_ros.errors import InputError
from iguana_ros.nodes.base import FrameGate, IguanaNode, node_main
from iguana_ros.ros.messages import clip_from_msg, reference_pose_to_msg, state_from_msg
from iguana_ros.stages import adaptation_stage, stride_ended, StrideLookahead
from iguana_ros.validation import check_frame, FRAME_NEW, world_bound

MAX_CLIPS = 4
"""Placed clips kept (by start frame) for frames that arrive late."""

CLIP_QUEUE_DEPTH = 10
"""History depth of the motion_clip reader: the topic's depth 1 (latched) would let a burst from another publisher
push the planner's clip out of the queue before it is taken (the lockstep run then stalls at that stride)."""


class TerrainAdaptationNode(IguanaNode):
    """Samples the current clip at each state's frame, adapts it to the terrain, publishes bone frames."""

    KIND = 'terrain_adaptation_node'

    def __init__(self, **kwargs) -> None:
        """Build the scene's adaptation stage (`stages.adaptation_stage`; the parameter may turn it on or off)."""
        super().__init__(**kwargs)
        choice = self.param('adaptation')
        self.stage = adaptation_stage(self.scene, None if choice == 'scene' else choice == 'on')
        self.skeleton = self.stage.skeleton
        self.lookahead = StrideLookahead(self.stage)   # a stride's poses adapted while the simulator steps
        self.bound = world_bound(self.scene.terrain.extent)
        self.clips: dict[int, object] = {}
        self.pending: int | None = None
        self.pose_pub = self.publisher('reference_pose')
        self.state_gate = FrameGate(self, 'iguana_state', self.pose_pub)
        self.subscription('motion_clip', self.guarded('motion_clip', self.on_clip), depth=CLIP_QUEUE_DEPTH)
        self.subscription('iguana_state', self.guarded('iguana_state', self.on_state))
        self.get_logger().info(f'terrain adaptation ready ({"on" if self.stage.enabled else "off"})')

    def on_clip(self, msg) -> None:
        """Keep a placed clip by its start frame, then serve a frame that was waiting for it."""
        start, clip = clip_from_msg(msg, self.skeleton, self.bound)
        newest, served = max(self.clips, default=-1), self.state_gate.last_frame
        if check_frame('motion_clip', start, max(newest, served)) != FRAME_NEW:
            raise InputError(f'motion_clip starts at frame {start}, not after the newest clip (frame {newest}) '
                             f'and the last frame served ({served}): stale')
        self.clips[start] = clip
        for old in sorted(self.clips)[:-MAX_CLIPS]:
            del self.clips[old]
        self.lookahead.start(clip, start)
        self._serve_pending()

    def on_state(self, msg) -> None:
        """Publish the reference pose of the state's frame (re-send it for a repeated frame)."""
        frame, _root, _orientation = state_from_msg(msg, self.bound)
        if not self.state_gate.admit(frame):
            return
        self.pending = frame
        self._serve_pending()

    def _clip_for(self, frame: int):
        """(clip, start) whose stride covers `frame`, or None while the planner's next clip is due."""
        starts = [s for s in self.clips if s <= frame]
        if not starts:
            return None
        start = max(starts)
        clip = self.clips[start]
        return None if stride_ended(start, len(clip.root_positions), frame) else (clip, start)

    def _serve_pending(self) -> None:
        """Adapt and publish the waiting frame once its clip is known."""
        if self.pending is None:
            return
        found = self._clip_for(self.pending)
        if found is None:
            return
        clip, start = found
        frame, self.pending = self.pending, None
        reference = self.lookahead.take(frame, clip, start)
        self.state_gate.handled(frame, reference_pose_to_msg(reference.joints, reference.rotations, frame))

    def destroy_node(self) -> None:
        """Stop the lookahead's worker thread, then leave the graph."""
        self.lookahead.close()
        super().destroy_node()


main = node_main(TerrainAdaptationNode)

if __name__ == '__main__':
    main()
