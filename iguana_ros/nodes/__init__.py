"""Thin rclpy adapters over the ROS-free core; the only place (with bag/ and cli) that imports rclpy."""
