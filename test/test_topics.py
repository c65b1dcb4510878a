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

"""The topic table in msg_configs/ parses, and bad tables give errors naming file and field."""
import pytest

from iguana_ros.topics import (action, default_interfaces, default_topics, load_interfaces, load_topics, service, topic,
                               TopicConfigError)

DESIGN_KEYS = {'goal_pose', 'motion_clip', 'reference_pose', 'spring_rest_lengths', 'iguana_state',
               'mesh_marker', 'scene_markers', 'push', 'clock'}
PROBE_KEYS = {'foot_state', 'foot_positions', 'reference_stance'}
"""Per-frame gait probes the run summary reads from the bag."""
CONFIRM_KEYS = {'accepted_goals', 'route', 'planner_status'}
"""The planner's latched echo of the goals it accepted (iguana goal and iguana run wait for it), the route it follows
and where it is on it (the commander's feedback)."""
EVENT_KEYS = {'run_events', 'diagnostics'}
"""What the node processes report about themselves (start-up milestones, clips) for iguana run's progress."""
DOCTOR_KEYS = {'doctor_ping', 'doctor_pong'}
"""`iguana doctor`'s loopback between two processes."""
TF_KEYS = {'tf', 'tf_static'}
"""The iguana's frames, as tf2 expects them (absolute names)."""
WORLD_KEYS = {'body_contacts'}
"""What a world of several characters adds: body-body contact per frame."""


def test_table_has_every_design_topic():
    assert set(default_topics()) == (DESIGN_KEYS | PROBE_KEYS | CONFIRM_KEYS | EVENT_KEYS | DOCTOR_KEYS | TF_KEYS
                                     | WORLD_KEYS)


def test_latched_topics_are_transient_local():
    assert topic('scene_markers').qos.durability == 'transient_local'
    assert topic('motion_clip').qos.durability == 'transient_local'
    assert topic('accepted_goals').qos.durability == 'transient_local'
    assert topic('clock').name == '/clock'


def test_probe_topics_are_reliable_volatile_and_sent_every_frame_like_the_state():
    for key in PROBE_KEYS:
        assert topic(key).qos == topic('iguana_state').qos and topic(key).rate_hz == 30.0
        assert 'position' in topic(key).description or 'pose' in topic(key).description


def test_unknown_key_lists_known_keys():
    with pytest.raises(KeyError, match='goal_pose'):
        topic('nope')


@pytest.mark.parametrize('body, field', [
    ('topics: {a: {name: a, type: std_msgs/msg/String}}', "'qos'"),
    ('topics: {a: {name: a, type: String, qos: {}}}', 'topics.a.type'),
    ('topics: {a: {name: a, type: std_msgs/msg/String, qos: {reliability: maybe}}}',
     'topics.a.qos.reliability'),
    ('topics: {a: {name: a, type: std_msgs/msg/String, qos: {depth: 0}}}', 'topics.a.qos.depth'),
    ('[1, 2', 'cannot read'),
])
def test_bad_table_names_file_and_field(tmp_path, body, field):
    path = tmp_path / 'topics.yaml'
    path.write_text(body)
    with pytest.raises(TopicConfigError, match=field) as info:
        load_topics(path)
    assert str(path) in str(info.value)


def test_ros_profiles_resolve():
    endpoints = pytest.importorskip('iguana_ros.ros.endpoints')
    from rclpy.qos import DurabilityPolicy
    for key in DESIGN_KEYS | PROBE_KEYS:
        name, cls, qos = endpoints.resolve(key)
        assert name and cls.__name__ == topic(key).type.split('/')[-1]
    assert endpoints.resolve('scene_markers')[2].durability == DurabilityPolicy.TRANSIENT_LOCAL


def test_services_and_actions_are_declared_with_their_types_and_servers():
    sim = {'sim_pause', 'sim_resume', 'sim_step', 'sim_reset'}
    assert set(default_interfaces('services')) == sim | {'bag_player_resume'}
    assert service('sim_step').type == 'iguana_interfaces/srv/Step'
    assert all(default_interfaces('services')[key].server == 'simulator_node' for key in sim)
    assert not any(s.name.startswith('/') for s in default_interfaces('services').values())
    assert service('bag_player_resume').server.startswith('iguana bag play')
    assert action('go_to_pose').server == 'planner_node'
    with pytest.raises(KeyError, match='sim_pause'):
        service('nope')


def test_services_and_actions_resolve_to_importable_classes():
    from iguana_ros.ros.endpoints import resolve_action, resolve_service
    name, cls = resolve_service('sim_reset')
    assert name == 'sim/reset' and hasattr(cls, 'Request')
    name, cls = resolve_action('go_to_pose')
    assert name == 'go_to_pose' and hasattr(cls, 'Feedback')


@pytest.mark.parametrize('body, field', [
    ('services: {a: {name: a, type: std_srvs/srv/Trigger}}', "'server'"),
    ('services: {a: {name: a, type: std_srvs/msg/Trigger, server: s}}', 'services.a.type'),
    ('services: {a: {name: a, type: std_srvs/srv/Trigger, server: s, port: 3}}', 'unknown fields'),
    ('services: [a]', '"services:" must be a mapping'),
])
def test_bad_service_tables_name_the_field(tmp_path, body, field):
    path = tmp_path / 'topics.yaml'
    path.write_text('topics: {}\n' + body + '\n')
    with pytest.raises(TopicConfigError, match=field):
        load_interfaces('services', path)


def test_iguana_topics_lists_the_services_and_the_action_with_their_servers(cli):
    code, out, _ = cli(['topics'])
    lines = out.splitlines()
    assert code == 0 and len(lines) == len(default_topics()) + len(default_interfaces('services')) + 1
    assert any(line.startswith('sim/step ') and 'iguana_interfaces/srv/Step' in line and 'simulator_node' in line
               for line in lines)
    assert any(line.startswith('go_to_pose ') and 'action' in line and 'planner_node' in line for line in lines)
