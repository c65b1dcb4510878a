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
A world's node run (`iguana run` of a scene with `characters`): one simulator of every body, a process per character.

Three coarse iguanas: a walker that does not keep clear walks into one standing across its way, and a third crosses
their path keeping clear of both. The run equals `world.run_world` bit for bit for every character (so each planner
heard the others as the library's does), records the contact frame for frame, and keeps each character's topics and
TF frames under its name.
"""
from __future__ import annotations

import dataclasses

from diagnostic_msgs.msg import DiagnosticArray
import numpy as np
import pytest
from rclpy.serialization import deserialize_message
import yaml

from iguana_ros.bag.storage import BagReader
from iguana_ros.bag.trajectory import read_root_trajectory, read_topics, root_trajectory
from iguana_ros.errors import InputError
from iguana_ros.ros.body_contacts import body_contacts_from_msg
from iguana_ros.ros.cdr import tf_message_from_cdr
from iguana_ros.scene import load_scene
from iguana_ros.supervisor.run import run_scene, RunOptions
from iguana_ros.world import run_world

pytestmark = [pytest.mark.ros, pytest.mark.slow, pytest.mark.timeout(400)]

NAMES = ('walker', 'stander', 'dodger')


def trio_scene() -> dict:
    """Return the scene: the walker bumps the stander (16 frames of contact), the dodger keeps clear of both."""
    return {'name': 'trio', 'terrain': {'kind': 'flat'}, 'model': {'resolution': 'coarse'}, 'duration': 3.0,
            'characters': [
                {'name': 'walker', 'start': {'x': -0.55, 'y': 0.0}, 'goals': [{'x': 0.8, 'y': 0.0}],
                 'avoid_others': False},
                {'name': 'stander', 'start': {'x': 0.1, 'y': 0.0, 'yaw_deg': 90.0}},
                {'name': 'dodger', 'start': {'x': 0.0, 'y': 0.7, 'yaw_deg': -90.0}, 'goals': [{'x': 0.0, 'y': -0.9}]}]}


@pytest.fixture(scope='module')
def trio(tmp_path_factory):
    """Return (scene file, the library's WorldResult, the node run's summary, its bag)."""
    folder = tmp_path_factory.mktemp('trio')
    path = folder / 'trio.yaml'
    path.write_text(yaml.safe_dump(trio_scene()))
    library = run_world(load_scene(str(path)))
    summary = run_scene(RunOptions(scene=str(path), record=folder / 'bag', timeout=300))
    return path, library, summary, folder / 'bag'


def test_every_character_of_the_node_run_is_the_library_worlds_bit_for_bit(trio):
    _, library, summary, bag = trio
    assert summary.exit_code == 0, summary.message
    assert summary.simulated_s == pytest.approx(3.0)
    for name in NAMES:
        times, roots, _ = root_trajectory(read_topics(bag, ['iguana_state'], f'/{name}').messages['iguana_state'])
        assert len(roots) == 91 and np.array_equal(roots[1:], library.characters[name].root_positions), name


def test_the_dodger_plans_round_the_others_so_the_parity_has_teeth(trio):
    path, library, _, _ = trio
    careless = load_scene(str(path))
    careless = dataclasses.replace(careless, characters=tuple(
        dataclasses.replace(c, avoid_others=c.name != 'dodger' and c.avoid_others) for c in careless.characters))
    blind = run_world(careless)
    assert not np.array_equal(blind.characters['dodger'].root_positions, library.characters['dodger'].root_positions)


def test_the_contact_is_recorded_frame_for_frame_as_the_library_world_has_it(trio):
    _, library, summary, bag = trio
    recorded = [p for data in read_topics(bag, ['body_contacts'], '').messages['body_contacts']
                for p in body_contacts_from_msg(deserialize_message(data, DiagnosticArray))]
    expected = [(c.frame, NAMES[p.a], NAMES[p.b], p.nodes, p.max_depth, p.normal_force)
                for c in library.contacts for p in c.pairs]
    assert len(library.contacts) >= 5
    assert [tuple(r) for r in recorded] == expected                  # float figures bit for bit (repr)
    assert summary.body_contact_frames == len(library.contacts)
    assert 0 < summary.body_contact_max_depth <= 0.005               # neither passes through the other


def test_each_character_has_its_topics_frames_and_summary_under_its_name(trio):
    _, _, summary, bag = trio
    topics = {m.topic for m in BagReader(bag).messages()}
    for name in NAMES:
        assert {f'/{name}/iguana_state', f'/{name}/mesh_marker', f'/{name}/motion_clip',
                f'/{name}/spring_rest_lengths', f'/{name}/reference_pose'} <= topics, topics
    assert {'/clock', '/tf', '/tf_static', '/scene_markers', '/body_contacts'} <= topics
    assert '/iguana_state' not in topics and not any(t.endswith('/clock') and t != '/clock' for t in topics)
    children = {child for data in read_topics(bag, ['tf', 'tf_static'], '').messages['tf']
                for _, _, child, _, _ in tf_message_from_cdr(data)}
    statics = {(parent, child) for data in read_topics(bag, ['tf_static'], '').messages['tf_static']
               for _, parent, child, _, _ in tf_message_from_cdr(data)}
    assert {f'{name}/base_link' for name in NAMES} <= children and 'base_link' not in children
    assert {('world', f'{name}/odom') for name in NAMES} <= statics, statics
    with pytest.raises(InputError, match=r'holds iguana_state of several characters .* \(/dodger, /stander, /walker\)'):
        read_root_trajectory(bag)                                    # which iguana? never the states mixed
    assert list(summary.characters) == list(NAMES)
    assert summary.characters['walker'].gait is not None and summary.characters['walker'].gait.metrics is not None
    assert not summary.reached_goal and np.isnan(summary.time_to_goal)        # not every one arrived: no time
    assert summary.final_goal_distance == max(summary.characters[n].final_goal_distance for n in ('walker', 'dodger'))
    lines = '\n'.join(summary.lines())
    assert 'body contact: ' in lines and 'dodger: goal not reached' in lines


def test_a_world_of_one_character_runs_under_its_name(tmp_path):
    """A `characters` list of one: its topics under its name, its planner with no one to hear (avoid_others on)."""
    path = tmp_path / 'solo.yaml'
    path.write_text(yaml.safe_dump({**trio_scene(), 'name': 'solo', 'duration': 0.5,
                                    'characters': [trio_scene()['characters'][2]]}))
    summary = run_scene(RunOptions(scene=str(path), record=tmp_path / 'bag', timeout=300))
    assert summary.exit_code == 0, summary.message
    assert list(summary.characters) == ['dodger'] and summary.simulated_s == pytest.approx(0.5)
    states = read_topics(tmp_path / 'bag', ['iguana_state'], '/dodger').messages['iguana_state']
    times, roots, _ = root_trajectory(states)
    assert np.array_equal(roots[1:], run_world(load_scene(str(path))).characters['dodger'].root_positions)
