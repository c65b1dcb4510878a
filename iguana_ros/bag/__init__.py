"""rosbag2-compatible MCAP recording, replay and inspection (storage and schema parts are ROS-free)."""
