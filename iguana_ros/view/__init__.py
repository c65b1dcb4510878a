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
`iguana view`: the iguana in a browser (viser), live from the running nodes or from a recorded bag.

- `scene.py`: what is drawn at one moment (`ViewFrame`) from the run so far (`RunView`), ROS-free.
- `playback.py`: the bag timeline's clock (play, pause, scrub, speed), ROS-free.
- `bag_source.py`: a bag read into a `RunView`.
- `live.py`: an rclpy node feeding a `RunView` and publishing goal_pose / push.
- `server.py`: the viser web page (scene nodes, panel, timeline, clicks).
"""
