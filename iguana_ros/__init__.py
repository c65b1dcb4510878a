"""iguana_ros: soft-body iguana character control (Kwon, Kim, Lee, IEEE Access 2018) for ROS 2."""

__version__ = '0.1.0'
