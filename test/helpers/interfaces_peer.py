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
Test helper process for test/ros/test_interfaces.py: the other end of a tf2_msgs topic or of iguana_interfaces.

Usage:
  interfaces_peer.py publish TOPIC SECONDS   publish TF_SAMPLE as tf2_msgs/msg/TFMessage every 50 ms for SECONDS
  interfaces_peer.py subscribe TOPIC SECONDS print the first TFMessage received as one JSON line, exit 0 (1: none)
  interfaces_peer.py serve SECONDS           a GoToPose action server and a Step service (see `serve`)
Each prints 'ready' once its endpoints exist; SIGINT/SIGTERM end it.
"""
import json
import signal
import sys
import threading
import time

TF_SAMPLE = [
    # (parent, child, (sec, nanosec), translation, rotation)
    ('odom', 'base_link', (12, 345), (1.5, -2.25, 0.125), (0.0, 0.0, 0.38268343236508984, 0.9238795325112867)),
    ('base_link', 'head', (12, 346), (0.3, 0.0, 0.05), (0.0, 0.0, 0.0, 1.0)),
]
"""Transforms of the TFMessage that `publish` sends and the test expects."""
STEP_DT = 1.0 / 60.0
"""Seconds a frame of the `serve` Step service advances."""
FAR = 50.0
"""A GoToPose goal further than this (m) is walked until it is cancelled (or SECONDS pass)."""


def tf_message():
    """Return a TFMessage holding TF_SAMPLE."""
    from geometry_msgs.msg import TransformStamped
    from tf2_msgs.msg import TFMessage

    msg = TFMessage()
    for parent, child, (sec, nanosec), xyz, quat in TF_SAMPLE:
        t = TransformStamped()
        t.header.frame_id, t.child_frame_id = parent, child
        t.header.stamp.sec, t.header.stamp.nanosec = sec, nanosec
        t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = xyz
        r = t.transform.rotation
        r.x, r.y, r.z, r.w = quat
        msg.transforms.append(t)
    return msg


def tf_as_list(msg) -> list:
    """Return the transforms of a TFMessage as a TF_SAMPLE-shaped list."""
    return [[t.header.frame_id, t.child_frame_id, [t.header.stamp.sec, t.header.stamp.nanosec],
             [t.transform.translation.x, t.transform.translation.y, t.transform.translation.z],
             [t.transform.rotation.x, t.transform.rotation.y, t.transform.rotation.z, t.transform.rotation.w]]
            for t in msg.transforms]


def _stop_flag() -> threading.Event:
    """Return an event that SIGINT or SIGTERM sets."""
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda _s, _f: stop.set())
    return stop


def publish(topic: str, seconds: float) -> int:
    """Publish the sample every 50 ms until stopped or `seconds` pass."""
    import rclpy
    from rclpy.signals import SignalHandlerOptions
    from tf2_msgs.msg import TFMessage

    stop = _stop_flag()
    rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
    node = rclpy.create_node('test_tf_publisher')
    publisher = node.create_publisher(TFMessage, topic, 10)
    msg = tf_message()
    print('ready', flush=True)
    deadline = time.monotonic() + seconds
    while not stop.is_set() and time.monotonic() < deadline:
        publisher.publish(msg)
        stop.wait(0.05)
    node.destroy_node()
    rclpy.try_shutdown()
    return 0


def subscribe(topic: str, seconds: float) -> int:
    """Print the first TFMessage received on `topic` as JSON: its transforms and its class's full name."""
    import rclpy
    from rclpy.signals import SignalHandlerOptions
    from tf2_msgs.msg import TFMessage

    stop = _stop_flag()
    rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
    node = rclpy.create_node('test_tf_subscriber')
    received = []
    node.create_subscription(TFMessage, topic, received.append, 10)
    print('ready', flush=True)
    deadline = time.monotonic() + seconds
    while not received and not stop.is_set() and time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.05)
    if received:
        cls = type(received[0])
        print(json.dumps({'class': f'{cls.__module__}.{cls.__name__}', 'transforms': tf_as_list(received[0])}),
              flush=True)
    node.destroy_node()
    rclpy.try_shutdown()
    return 0 if received else 1


def serve(seconds: float) -> int:
    """
    Serve iguana_interfaces/action/GoToPose on 'go_to_pose' and iguana_interfaces/srv/Step on 'step'.

    GoToPose: a goal with a negative tolerance is rejected. A goal within FAR m of the origin is reached after
    three feedback messages (20 ms apart), each one stride closer; a further one is walked (feedback every 20 ms)
    until it is cancelled, then ends cancelled with `reason` 'canceled'. Step: adds `frames` to a frame counter
    and answers the counter and the time it stands for (STEP_DT a frame); 0 frames is refused.
    """
    import math

    import rclpy
    from rclpy.action import ActionServer, CancelResponse, GoalResponse
    from rclpy.callback_groups import ReentrantCallbackGroup
    from rclpy.executors import MultiThreadedExecutor
    from rclpy.signals import SignalHandlerOptions

    from iguana_interfaces.action import GoToPose
    from iguana_interfaces.srv import Step

    stop = _stop_flag()
    rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
    node = rclpy.create_node('test_interfaces_server')
    group = ReentrantCallbackGroup()
    frame = [0]

    def on_goal(goal: GoToPose.Goal) -> GoalResponse:
        ok = goal.position_tolerance >= 0.0 and goal.yaw_tolerance >= 0.0
        return GoalResponse.ACCEPT if ok else GoalResponse.REJECT

    def execute(handle) -> GoToPose.Result:
        target = handle.request.pose.pose.position
        distance = math.hypot(target.x, target.y)
        started = time.monotonic()
        far = distance > FAR
        feedback = GoToPose.Feedback()
        strides = 0
        while far or strides < 3:
            if handle.is_cancel_requested:
                handle.canceled()
                return GoToPose.Result(reached=False, code=2, reason='canceled', distance_remaining=distance,
                                       time_elapsed=time.monotonic() - started)
            if stop.is_set():
                handle.abort()
                return GoToPose.Result(reached=False, code=3, reason='server stopping')
            strides += 1
            distance = max(0.0, distance - (0.1 if far else distance / (4 - strides)))
            feedback.current_pose.position.x = target.x - distance
            feedback.current_pose.orientation.w = 1.0
            feedback.distance_remaining = distance
            feedback.time_elapsed = time.monotonic() - started
            feedback.strides = strides
            feedback.status = f'walking, stride {strides}'
            handle.publish_feedback(feedback)
            time.sleep(0.02)
        handle.succeed()
        return GoToPose.Result(reached=True, code=0, reason='reached', distance_remaining=distance,
                               time_elapsed=time.monotonic() - started)

    def on_step(request: Step.Request, response: Step.Response) -> Step.Response:
        if request.frames == 0:
            response.success, response.message = False, 'frames must be at least 1'
        else:
            frame[0] += request.frames
            response.success, response.message = True, f'advanced {request.frames} frames'
        response.frame = frame[0]
        response.time = frame[0] * STEP_DT
        return response

    server = ActionServer(node, GoToPose, 'go_to_pose', execute_callback=execute, goal_callback=on_goal,
                          cancel_callback=lambda _handle: CancelResponse.ACCEPT, callback_group=group)
    node.create_service(Step, 'step', on_step, callback_group=group)
    executor = MultiThreadedExecutor(num_threads=4)
    executor.add_node(node)
    print('ready', flush=True)
    deadline = time.monotonic() + seconds
    while not stop.is_set() and time.monotonic() < deadline:
        executor.spin_once(timeout_sec=0.05)
    stop.set()
    server.destroy()
    executor.shutdown()
    node.destroy_node()
    rclpy.try_shutdown()
    return 0


def main(argv: list[str]) -> int:
    """Dispatch to publish, subscribe or serve."""
    command, *rest = argv
    if command == 'publish':
        return publish(rest[0], float(rest[1]))
    if command == 'subscribe':
        return subscribe(rest[0], float(rest[1]))
    if command == 'serve':
        return serve(float(rest[0]))
    print(__doc__, file=sys.stderr)
    return 2


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
