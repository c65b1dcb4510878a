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
The interface packages that tools/build_interfaces.py builds (tf2_msgs, iguana_interfaces) work in rclpy and in bags.

A TFMessage crosses DDS between two processes started without any ROS variable of a sourced setup; a GoToPose
goal is accepted, sends feedback and succeeds, another is cancelled, one is rejected; Step answers; TFMessages
written to MCAP (the project's BagWriter and mcap_ros2's writer) decode with rosbags and with mcap_ros2.
The DDS traffic stays on this run's domain (test/conftest.py: ROS_DOMAIN_ID, localhost discovery, Fast DDS).
"""
import importlib.util
import json
import os
from pathlib import Path
import subprocess
import sys

import pytest

pytest.importorskip('rclpy')
try:
    from geometry_msgs.msg import PoseStamped  # noqa: E402, I100
    from iguana_interfaces.action import GoToPose  # noqa: E402
    from iguana_interfaces.srv import Step  # noqa: E402
    from tf2_msgs.msg import TFMessage  # noqa: E402
except ImportError as exc:  # the ROS wheels are there, the interfaces were not built
    pytest.fail(f'{exc}: build the interface packages with `make install` '
                f'({sys.executable} tools/build_interfaces.py)', pytrace=False)

import rclpy  # noqa: E402, I100
from rclpy.action import ActionClient  # noqa: E402
from rclpy.serialization import deserialize_message, serialize_message  # noqa: E402

from iguana_ros.bag.schema import message_definition  # noqa: E402, I100
from iguana_ros.bag.storage import BagWriter  # noqa: E402
from ros_harness import HELPERS, spin_until  # noqa: E402

sys.path.insert(0, str(HELPERS))
import interfaces_peer  # noqa: E402, I100

pytestmark = pytest.mark.ros

TF_TYPE = 'tf2_msgs/msg/TFMessage'
EXPECTED = json.loads(json.dumps(interfaces_peer.TF_SAMPLE))
"""TF_SAMPLE as it comes back through JSON (tuples as lists)."""


def _fresh_env() -> dict:
    """
    Return this environment as a new shell of the venv has it: no LD_LIBRARY_PATH of the wheels' bootstrapper.

    (ros_wheels_bootstrapper re-executes each Python of the venv with LD_LIBRARY_PATH set; removing what it set
    shows that a child needs nothing sourced.) The domain, discovery range and RMW of test/conftest.py stay.
    """
    env = dict(os.environ)
    if importlib.util.find_spec('ros_wheels_bootstrapper') is not None:
        env.pop('_ROS_WHEELS_BOOTSTRAP_COMPLETE', None)
        env.pop('LD_LIBRARY_PATH', None)
    for name in ('AMENT_PREFIX_PATH', 'PYTHONPATH'):
        env.pop(name, None)
    assert env['ROS_AUTOMATIC_DISCOVERY_RANGE'] == 'LOCALHOST' and env['RMW_IMPLEMENTATION'] == 'rmw_fastrtps_cpp'
    assert env['ROS_DOMAIN_ID']
    return env


def _peer(*args) -> subprocess.Popen:
    """Start test/helpers/interfaces_peer.py with `args` (output in .stdout, text)."""
    return subprocess.Popen([sys.executable, str(HELPERS / 'interfaces_peer.py'), *map(str, args)],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=_fresh_env(),
                            cwd=str(HELPERS))


def _stop(proc: subprocess.Popen) -> str:
    """Terminate `proc` if it still runs; return its output."""
    if proc.poll() is None:
        proc.terminate()
    try:
        out, _ = proc.communicate(timeout=15)
    except subprocess.TimeoutExpired:
        proc.kill()
        out, _ = proc.communicate()
    return out or ''


def _ready(proc: subprocess.Popen, timeout: float = 30.0) -> None:
    """Wait for the peer's 'ready' line; fail with its output if it exits first or takes longer."""
    import selectors
    import time
    selector = selectors.DefaultSelector()
    selector.register(proc.stdout, selectors.EVENT_READ)
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if selector.select(timeout=0.5):
            line = proc.stdout.readline()
            if line.strip() == 'ready':
                return
            if not line and proc.poll() is not None:
                break
    pytest.fail(f'peer {proc.args[2:]} not ready: {_stop(proc)}')


def _assert_sample(transforms: list) -> None:
    """Check that the transforms are TF_SAMPLE's (floats compared exactly: they went through CDR float64)."""
    assert transforms == EXPECTED


# (i) a TFMessage between two processes


@pytest.mark.timeout(90)
def test_tf_message_crosses_dds_between_two_processes():
    subscriber = _peer('subscribe', '/tf', 40)
    publisher = None
    try:
        _ready(subscriber)
        publisher = _peer('publish', '/tf', 45)
        _ready(publisher)
        out, _ = subscriber.communicate(timeout=45)
        assert subscriber.returncode == 0, f'no TFMessage received: {out}'
        received = json.loads(out.strip().splitlines()[-1])
        assert received['class'] == 'tf2_msgs.msg._tf_message.TFMessage'
        _assert_sample(received['transforms'])
    finally:
        _stop(subscriber)
        if publisher is not None:
            _stop(publisher)


# (ii) GoToPose and Step between a client here and a server process


@pytest.fixture(scope='module')
def server():
    proc = _peer('serve', 120)
    _ready(proc)
    yield proc
    out = _stop(proc)
    assert proc.returncode == 0, out


@pytest.fixture
def client_node(ros_context):
    node = rclpy.create_node('test_interfaces_client', context=ros_context)
    yield node
    node.destroy_node()


def _goal(x: float, tolerance: float = 0.05) -> GoToPose.Goal:
    """Return a GoToPose goal at (x, 0) in 'odom'."""
    pose = PoseStamped()
    pose.header.frame_id = 'odom'
    pose.pose.position.x = x
    pose.pose.orientation.w = 1.0
    return GoToPose.Goal(pose=pose, position_tolerance=tolerance, yaw_tolerance=0.1)


def _action_client(node) -> ActionClient:
    client = ActionClient(node, GoToPose, 'go_to_pose')
    assert client.wait_for_server(timeout_sec=30), 'no GoToPose server'
    return client


def _wait(node, future, timeout: float = 20.0):
    """Spin until `future` is done; return its result."""
    assert spin_until(node, future.done, timeout), 'timed out'
    return future.result()


def test_go_to_pose_goal_is_accepted_sends_feedback_and_succeeds(server, client_node):
    from action_msgs.msg import GoalStatus
    client = _action_client(client_node)
    feedback = []
    handle = _wait(client_node, client.send_goal_async(_goal(1.2), feedback_callback=feedback.append))
    assert handle.accepted
    response = _wait(client_node, handle.get_result_async())
    assert response.status == GoalStatus.STATUS_SUCCEEDED
    # feedback (a topic) and the result (a service) travel apart: the last feedback may come after the result
    assert spin_until(client_node, lambda: len(feedback) >= 3, 10), f'{len(feedback)} feedback messages'
    result = response.result
    assert isinstance(result, GoToPose.Result)
    assert (result.reached, result.code, result.reason, result.distance_remaining) == (True, 0, 'reached', 0.0)
    assert result.time_elapsed > 0.0
    assert [f.feedback.strides for f in feedback] == [1, 2, 3]
    assert [f.feedback.status for f in feedback] == ['walking, stride 1', 'walking, stride 2', 'walking, stride 3']
    distances = [f.feedback.distance_remaining for f in feedback]
    assert distances == sorted(distances, reverse=True) and distances[-1] == 0.0
    assert feedback[-1].feedback.current_pose.position.x == pytest.approx(1.2)
    client.destroy()


def test_go_to_pose_goal_can_be_cancelled(server, client_node):
    from action_msgs.msg import GoalStatus
    client = _action_client(client_node)
    feedback = []
    handle = _wait(client_node, client.send_goal_async(_goal(80.0), feedback_callback=feedback.append))
    assert handle.accepted
    assert spin_until(client_node, lambda: len(feedback) >= 2, 20), 'no feedback before the cancel'
    cancel = _wait(client_node, handle.cancel_goal_async())
    assert [bytes(g.goal_id.uuid) for g in cancel.goals_canceling] == [bytes(handle.goal_id.uuid)]
    response = _wait(client_node, handle.get_result_async())
    assert response.status == GoalStatus.STATUS_CANCELED
    assert (response.result.reached, response.result.code, response.result.reason) == (False, 2, 'canceled')
    assert 0.0 < response.result.distance_remaining < 80.0
    client.destroy()


def test_go_to_pose_goal_with_a_negative_tolerance_is_rejected(server, client_node):
    client = _action_client(client_node)
    handle = _wait(client_node, client.send_goal_async(_goal(1.0, tolerance=-1.0)))
    assert not handle.accepted
    client.destroy()


def test_step_service_advances_the_frame_counter(server, client_node):
    client = client_node.create_client(Step, 'step')
    assert client.wait_for_service(timeout_sec=30), 'no Step service'
    first = _wait(client_node, client.call_async(Step.Request(frames=10)))
    second = _wait(client_node, client.call_async(Step.Request(frames=5)))
    refused = _wait(client_node, client.call_async(Step.Request(frames=0)))
    # the server (one per module) keeps its counter: it starts at 0, and a repeated test finds it further on
    assert first.success and first.frame >= 10 and first.frame % 5 == 0
    assert (second.success, second.frame) == (True, first.frame + 5)
    assert second.time == pytest.approx(second.frame * interfaces_peer.STEP_DT)
    assert second.message == 'advanced 5 frames'
    assert (refused.success, refused.frame, refused.message) == (False, second.frame, 'frames must be at least 1')
    client_node.destroy_client(client)


# (iii) TFMessage in MCAP


def test_tf_message_schema_holds_every_nested_definition():
    text = message_definition(TF_TYPE)
    assert text.startswith('geometry_msgs/TransformStamped[] transforms')
    for nested in ('geometry_msgs/TransformStamped', 'std_msgs/Header', 'builtin_interfaces/Time',
                   'geometry_msgs/Transform', 'geometry_msgs/Vector3', 'geometry_msgs/Quaternion'):
        assert f'\nMSG: {nested}\n' in text, nested


def _rosbags_typestore(schema_text: str):
    """Return an empty rosbags typestore with the types of a ros2msg schema text (TFMessage and its dependencies)."""
    from rosbags.typesys import get_types_from_msg, get_typestore, Stores
    store = get_typestore(Stores.EMPTY)
    sections = schema_text.split('=' * 80 + '\n')
    types = get_types_from_msg(sections[0], TF_TYPE)
    for section in sections[1:]:
        header, _, body = section.partition('\n')
        package, name = header.removeprefix('MSG: ').split('/')
        types.update(get_types_from_msg(body, f'{package}/msg/{name}'))
    store.register(types)
    return store


def _rosbags_as_list(msg) -> list:
    return [[t.header.frame_id, t.child_frame_id, [t.header.stamp.sec, t.header.stamp.nanosec],
             [t.transform.translation.x, t.transform.translation.y, t.transform.translation.z],
             [t.transform.rotation.x, t.transform.rotation.y, t.transform.rotation.z, t.transform.rotation.w]]
            for t in msg.transforms]


def _mcap_ros2_decoded(path: Path) -> list:
    """Return (topic, schema name, decoded message) of every message of an MCAP file, with mcap_ros2's decoder."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    with open(path, 'rb') as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        return [(channel.topic, schema.name, decoded)
                for schema, channel, _message, decoded in reader.iter_decoded_messages()]


def test_tf_message_in_a_bag_decodes_with_rosbags_and_mcap_ros2(tmp_path):
    """Write rclpy's CDR bytes with the project's BagWriter (schema from share/tf2_msgs/msg); both readers decode."""
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import get_typestore, Stores

    data = serialize_message(interfaces_peer.tf_message())
    writer = BagWriter(tmp_path / 'tf_bag')
    channel = writer.add_topic('/tf', TF_TYPE, message_definition(TF_TYPE))
    for i in range(3):
        writer.write(channel, data, log_time=1_000_000_000 + i * 10_000_000)
    writer.close()
    mcap = tmp_path / 'tf_bag' / 'tf_bag.mcap'

    decoded = _mcap_ros2_decoded(mcap)
    assert [(topic, schema) for topic, schema, _ in decoded] == [('/tf', TF_TYPE)] * 3
    _assert_sample(interfaces_peer.tf_as_list(decoded[0][2]))

    store = _rosbags_typestore(message_definition(TF_TYPE))
    _assert_sample(_rosbags_as_list(store.deserialize_cdr(data, TF_TYPE)))

    # the whole bag (metadata.yaml + MCAP): its types only from the bag's own schema records
    with AnyReader([tmp_path / 'tf_bag'], default_typestore=get_typestore(Stores.EMPTY)) as reader:
        messages = [(conn.topic, conn.msgtype, reader.deserialize(raw, conn.msgtype))
                    for conn, _t, raw in reader.messages()]
    assert [(topic, msgtype) for topic, msgtype, _ in messages] == [('/tf', TF_TYPE)] * 3
    _assert_sample(_rosbags_as_list(messages[-1][2]))


def test_tf_message_from_mcap_ros2_writer_reads_back_in_rclpy_and_rosbags(tmp_path):
    """Write a TFMessage with mcap_ros2's own encoder; rclpy's type support and rosbags decode its bytes."""
    from mcap.reader import make_reader
    from mcap_ros2.writer import Writer

    sample = interfaces_peer.TF_SAMPLE
    as_dict = {'transforms': [
        {'header': {'stamp': {'sec': sec, 'nanosec': nanosec}, 'frame_id': parent}, 'child_frame_id': child,
         'transform': {'translation': dict(zip('xyz', xyz)), 'rotation': dict(zip('xyzw', quat))}}
        for parent, child, (sec, nanosec), xyz, quat in sample]}
    path = tmp_path / 'tf.mcap'
    with open(path, 'wb') as f:
        writer = Writer(f)
        schema = writer.register_msgdef(TF_TYPE, message_definition(TF_TYPE))
        writer.write_message('/tf', schema, as_dict, log_time=1, publish_time=1)
        writer.finish()
    with open(path, 'rb') as f:
        raw = next(iter(make_reader(f).iter_messages()))[2].data
    _assert_sample(interfaces_peer.tf_as_list(deserialize_message(raw, TFMessage)))
    _assert_sample(_rosbags_as_list(_rosbags_typestore(message_definition(TF_TYPE)).deserialize_cdr(raw, TF_TYPE)))
    _assert_sample(interfaces_peer.tf_as_list(_mcap_ros2_decoded(path)[0][2]))
