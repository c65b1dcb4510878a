"""`iguana view`: the iguana in a browser (viser), live from the running nodes or from a recorded bag.

- `scene.py`: what is drawn at one moment (`ViewFrame`) from the run so far (`RunView`), ROS-free.
- `playback.py`: the bag timeline's clock (play, pause, scrub, speed), ROS-free.
- `bag_source.py`: a bag read into a `RunView`.
- `live.py`: an rclpy node feeding a `RunView` and publishing goal_pose / push.
- `server.py`: the viser web page (scene nodes, panel, timeline, clicks).
"""
