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
The shipped RViz2 config and Foxglove layout parse, agree with msg_configs/topics.yaml and are installed.

They name only topics, types and QoS that msg_configs/topics.yaml declares (every plotted field exists in its message
type), send goals the planner accepts, and are installed under share/iguana_ros/.
"""
from __future__ import annotations

import json
from pathlib import Path
import re
import runpy

import pytest
import yaml

from iguana_ros.constants import BASE_FRAME, WORLD_FRAME
from iguana_ros.topics import default_topics
from ros_harness import REPO

RVIZ = REPO / 'rviz' / 'iguana.rviz'
FOXGLOVE = REPO / 'foxglove' / 'iguana_layout.json'

RVIZ_TYPES = {
    'rviz_default_plugins/Marker': 'visualization_msgs/msg/Marker',
    'rviz_default_plugins/MarkerArray': 'visualization_msgs/msg/MarkerArray',
    'rviz_default_plugins/Odometry': 'nav_msgs/msg/Odometry',
    'rviz_default_plugins/PoseArray': 'geometry_msgs/msg/PoseArray',
    'rviz_default_plugins/Path': 'nav_msgs/msg/Path',
    'rviz_default_plugins/SetGoal': 'geometry_msgs/msg/PoseStamped',
}
"""Message type of each RViz2 display or tool class with a topic (rviz_default_plugins' plugin description)."""

RVIZ_NO_TOPIC = {'rviz_default_plugins/Grid', 'rviz_default_plugins/TF', 'rviz_default_plugins/Interact',
                 'rviz_default_plugins/MoveCamera', 'rviz_default_plugins/Select', 'rviz_default_plugins/FocusCamera',
                 'rviz_default_plugins/Measure'}

RVIZ_QOS = {'Durability Policy': ('durability', {'Volatile': 'volatile', 'Transient Local': 'transient_local'}),
            'Reliability Policy': ('reliability', {'Reliable': 'reliable', 'Best Effort': 'best_effort'}),
            'History Policy': ('history', {'Keep Last': 'keep_last', 'Keep All': 'keep_all'})}


def table_by_name() -> dict:
    """{absolute topic name: TopicSpec} of msg_configs/topics.yaml."""
    return {('' if spec.name.startswith('/') else '/') + spec.name: spec for spec in default_topics().values()}


def rviz_items() -> list[dict]:
    """Every display and tool of the RViz2 config."""
    manager = yaml.safe_load(RVIZ.read_text())['Visualization Manager']
    return manager['Displays'] + manager['Tools']


def test_rviz_config_parses_and_names_declared_topics_types_and_qos():
    config = yaml.safe_load(RVIZ.read_text())
    assert config['Visualization Manager']['Global Options']['Fixed Frame'] == WORLD_FRAME
    table = table_by_name()
    used = {}
    for item in rviz_items():
        cls = item['Class']
        if cls in RVIZ_NO_TOPIC:
            assert 'Topic' not in item, item
            continue
        assert cls in RVIZ_TYPES, f'unknown RViz2 class {cls}'
        topic = item['Topic']
        spec = table.get(topic['Value'])
        assert spec is not None, f'{topic["Value"]} is not in msg_configs/topics.yaml'
        assert spec.type == RVIZ_TYPES[cls], (topic['Value'], cls, spec.type)
        for key, (field, words) in RVIZ_QOS.items():
            assert words[topic[key]] == getattr(spec.qos, field), (topic['Value'], key)
        assert topic['Depth'] == spec.qos.depth, topic['Value']
        used[spec.key] = cls
    assert used == {'mesh_marker': 'rviz_default_plugins/Marker', 'scene_markers': 'rviz_default_plugins/MarkerArray',
                    'iguana_state': 'rviz_default_plugins/Odometry', 'foot_positions': 'rviz_default_plugins/PoseArray',
                    'accepted_goals': 'rviz_default_plugins/Path', 'goal_pose': 'rviz_default_plugins/SetGoal'}


def message_class(type_name: str) -> type:
    """Message class of 'pkg/msg/Type' (or 'pkg/Type' as get_fields_and_field_types names them)."""
    from iguana_ros.ros.endpoints import message_class as resolve_class
    package, *_, name = type_name.split('/')
    return resolve_class(f'{package}/msg/{name}')


def field_type(type_name: str, fields: list[str]) -> str:
    """
    Type name of the field at `fields` (e.g. ['poses[0]', 'position', 'x']) of message type `type_name`.

    AssertionError if a field does not exist or is indexed without being a sequence.
    """
    current = type_name
    for part in fields:
        name, index = re.fullmatch(r'(\w+)(?:\[(\d+)\])?', part).groups()
        known = message_class(current).get_fields_and_field_types()
        assert name in known, f'{current} has no field {name!r} (it has {sorted(known)})'
        current = known[name]
        if index is not None:
            found = re.fullmatch(r'sequence<(.+?)(?:, \d+)?>|(.+)\[\d+\]', current)
            assert found, f'{part}: {current} is not a sequence'
            current = found.group(1) or found.group(2)
    return current


def test_foxglove_layout_parses_and_names_declared_topics_and_fields():
    layout = json.loads(FOXGLOVE.read_text())
    table = table_by_name()
    panels = layout['configById']
    three_d = panels['3D!iguana']
    assert three_d['followTf'] == BASE_FRAME
    assert {'/mesh_marker', '/scene_markers', '/iguana_state'} <= set(three_d['topics'])
    for name in three_d['topics']:
        assert name in table, f'{name} is not in msg_configs/topics.yaml'
    publish = three_d['publish']
    assert publish['type'] == 'pose' and table[publish['poseTopic']].key == 'goal_pose'
    assert set(publish) == {'type', 'poseTopic'}           # no undeclared click/estimate topics
    plotted = []
    for key in ('Plot!speed', 'Plot!slip'):
        for path in panels[key]['paths']:
            topic, *fields = path['value'].split('.')
            fields = [f for f in fields if not f.startswith('@')]   # .@derivative is a plot modifier
            assert topic in table, f'{topic} is not in msg_configs/topics.yaml'
            assert field_type(table[topic].type, fields) in ('double', 'float'), path['value']
            assert path['timestampMethod'] == 'headerStamp'           # simulated time, as the bag's stamps
            plotted.append(topic)
    assert {'/iguana_state', '/foot_positions', '/foot_state'} <= set(plotted)
    goal = panels['Publish!goal']
    assert table[goal['topicName']].type == goal['datatype']


def layout_panels(node) -> list[str]:
    """Panel ids in a Foxglove layout tree."""
    if isinstance(node, str):
        return [node]
    return layout_panels(node['first']) + layout_panels(node['second'])


def test_foxglove_layout_tree_shows_every_panel_once():
    layout = json.loads(FOXGLOVE.read_text())
    shown = layout_panels(layout['layout'])
    assert sorted(shown) == sorted(layout['configById']) and len(set(shown)) == len(shown)
    assert {panel.split('!')[0] for panel in shown} == {'3D', 'Plot', 'Publish'}


def fill(msg, values: dict):
    """Set the fields of ROS message `msg` from a nested dict as Foxglove's Publish panel sends it."""
    for name, value in values.items():
        assert hasattr(msg, name), f'{type(msg).__name__} has no field {name!r}'
        if isinstance(value, dict):
            fill(getattr(msg, name), value)
        else:
            setattr(msg, name, value)
    return msg


def test_foxglove_goal_is_one_the_planner_accepts():
    from iguana_ros.ros.messages import goal_from_msg
    from iguana_ros.scene import load_scene
    goal = json.loads(FOXGLOVE.read_text())['configById']['Publish!goal']
    msg = fill(message_class(goal['datatype'])(), json.loads(goal['value']))
    goal = goal_from_msg(msg, load_scene('hills').terrain.extent / 2.0)
    assert goal.at == 0.0 and goal.xy.tolist() == [2.0, 0.5]


def test_layouts_are_installed_under_share(monkeypatch, capsys):
    import setuptools
    captured = {}
    monkeypatch.setattr(setuptools, 'setup', lambda **kw: captured.update(kw))
    monkeypatch.chdir(REPO)
    runpy.run_path(str(REPO / 'setup.py'))
    installed = {str(Path(folder) / Path(f).name) for folder, files in captured['data_files'] for f in files}
    assert {'share/iguana_ros/rviz/iguana.rviz', 'share/iguana_ros/foxglove/iguana_layout.json'} <= installed
    from iguana_ros.cli import main
    assert main(['layout', 'rviz']) == 0 and Path(capsys.readouterr().out.strip()) == RVIZ
    assert main(['layout', 'foxglove']) == 0 and Path(capsys.readouterr().out.strip()) == FOXGLOVE


@pytest.mark.parametrize('layout', [RVIZ, FOXGLOVE])
def test_layouts_draw_in_the_world_frame_and_follow_base_link(layout):
    text = layout.read_text()
    frames = set(re.findall(r'"?(?:Fixed Frame|frame_id|frameId)"?:\s*"?([\w/]+)', text))
    assert frames == {WORLD_FRAME}, frames
    followed = set(re.findall(r'"?(?:Target Frame|followTf)"?:\s*"?([\w/]+)', text))
    assert followed == {BASE_FRAME}, followed              # the camera follows the simulated root on /tf


def test_rviz_shows_the_tf_tree_and_foxglove_follows_the_pose_of_base_link():
    config = yaml.safe_load(RVIZ.read_text())['Visualization Manager']
    assert any(item['Class'] == 'rviz_default_plugins/TF' and item['Enabled'] for item in config['Displays'])
    assert config['Views']['Current']['Target Frame'] == BASE_FRAME
    panel = next(c for c in json.loads(FOXGLOVE.read_text())['configById'].values() if 'followTf' in c)
    assert (panel['followTf'], panel['followMode']) == (BASE_FRAME, 'follow-pose')
