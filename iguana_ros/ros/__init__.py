"""The ROS adapter layer: topic names, message classes and QoS from msg_configs/topics.yaml (`endpoints`), numpy <->
message conversions (`conversions`), the pipeline's values as the topic table's messages with validation
(`messages`). Nodes, bag tools and the supervisor import ROS plumbing from here, never from each other."""
