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

"""Spring-length node (Section VII): reference_pose in, desired spring lengths (JointState) out, frame by frame."""
from __future__ import annotations

from iguana_ros.nodes.base import FrameGate, IguanaNode, node_main, ReaderHold, RESEND_FRAMES
from iguana_ros.ros.messages import lengths_to_cdr, reference_pose_from_cdr
from iguana_ros.stages import scene_model, spring_stage
from iguana_ros.validation import check_desired_lengths, world_bound


class SpringLengthNode(IguanaNode):
    """
    Skins the reference mesh to each reference pose (DQS) and publishes the node-pair distances.

    Lengths go out in frame order once the topic's declared reader (`topics.yaml`: the simulator node) is in this
    node's graph and every reader it lists is matched or reported incompatible (`ReaderHold`): lengths published
    before this node's writer had matched the simulator's reader were lost, and the simulator waited a lockstep
    timeout for frame 0.
    """

    KIND = 'spring_length_node'

    def __init__(self, **kwargs) -> None:
        """Build the scene's spring-length stage (`stages.spring_stage`) on its soft-body model."""
        super().__init__(**kwargs)
        model = scene_model(self.scene)
        self.computer = spring_stage(self.scene, model)
        self.computer.load_kernels()                 # before the first pose arrives, not during its frame
        self.skeleton = model.skeleton
        self.n_bones = model.skeleton.n_bones
        self.rest_lengths = model.spring_rest_lengths
        self.bound = world_bound(self.scene.terrain.extent)
        self.reader_hold = ReaderHold(self, 'spring_rest_lengths', retry=self.publish_held)
        self.lengths_pub = self.reader_hold.publisher
        self.pose_gate = FrameGate(self, 'reference_pose', self.lengths_pub, keep=RESEND_FRAMES)
        self.held: list[bytes] = []                  # serialized lengths not published yet, in frame order
        self.subscription('reference_pose', self.guarded('reference_pose', self.on_pose), raw=True)
        self.get_logger().info(f'spring lengths ready: {self.computer.n_springs} springs, '
                               f'{model.n_nodes} nodes')

    def on_pose(self, data: bytes) -> None:
        """
        Publish the desired lengths of the pose's frame (re-send them for a repeated frame).

        Lengths the simulator would reject (`check_desired_lengths`) are not published.
        """
        frame, positions, rotations = reference_pose_from_cdr(data, self.n_bones, self.skeleton, self.bound)
        if not self.pose_gate.admit(frame):
            return
        lengths = check_desired_lengths(self.computer.lengths_from_bones(rotations, positions), self.rest_lengths)
        reply = lengths_to_cdr(lengths, frame)
        self.pose_gate.handled(frame, reply, publish=False)
        self.held.append(reply)
        del self.held[:-RESEND_FRAMES]              # with no reader at all, only the newest are kept
        self.publish_held()

    def publish_held(self) -> None:
        """Publish the held lengths in frame order once their readers can take them (`ReaderHold`)."""
        if not self.held or not self.reader_hold.ready():
            return
        for reply in self.held:
            self.lengths_pub.publish(reply)
        self.held.clear()


main = node_main(SpringLengthNode)

if __name__ == '__main__':
    main()
