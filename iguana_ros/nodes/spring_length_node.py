"""Spring-length node (Section VII): reference_pose in, desired spring lengths (JointState) out."""
from __future__ import annotations

from iguana_ros.nodes.base import IguanaNode, node_main
from iguana_ros.nodes.messages import lengths_to_msg, reference_pose_from_msg
from iguana_ros.validation import FRAME_STALE, check_desired_lengths, check_frame, world_bound


class SpringLengthNode(IguanaNode):
    """Skins the reference mesh to each reference pose (DQS) and publishes the node-pair distances."""

    KIND = 'spring_length_node'

    def __init__(self, **kwargs) -> None:
        """Build the scene's soft-body model (resolution and stiffness) for its mesh and springs."""
        super().__init__(**kwargs)
        from iguana_ros.body.model import build_model
        from iguana_ros.body.spring_lengths import SpringLengthComputer

        model = build_model(self.scene.model.resolution, self.scene.model.stiffness)
        self.computer = SpringLengthComputer(model)
        self.skeleton = model.skeleton
        self.n_bones = model.skeleton.n_bones
        self.rest_lengths = model.spring_rest_lengths
        self.bound = world_bound(self.scene.terrain.extent)
        self.last_frame = -1
        self.last_msg = None
        self.lengths_pub = self.publisher('spring_rest_lengths')
        self.subscription('reference_pose', self.guarded('reference_pose', self.on_pose))
        self.get_logger().info(f'spring lengths ready: {self.computer.n_springs} springs, '
                               f'{model.n_nodes} nodes')

    def on_pose(self, msg) -> None:
        """Publish the desired lengths of the pose's frame (re-send them for a repeated frame); lengths the
        simulator would reject (`check_desired_lengths`) are not published."""
        frame, positions, rotations = reference_pose_from_msg(msg, self.n_bones, self.skeleton, self.bound)
        order = check_frame('reference_pose', frame, self.last_frame)
        if frame == self.last_frame and self.last_msg is not None:
            self.lengths_pub.publish(self.last_msg)
            return
        if order == FRAME_STALE:
            self.get_logger().warning(f'ignored stale reference_pose for frame {frame} (at {self.last_frame})')
            return
        lengths = check_desired_lengths(self.computer.lengths_from_bones(rotations, positions), self.rest_lengths)
        self.last_msg = lengths_to_msg(lengths, frame)
        self.last_frame = frame
        self.lengths_pub.publish(self.last_msg)


main = node_main(SpringLengthNode)

if __name__ == '__main__':
    main()
