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
The gait part of `iguana run`'s summary, read from a bag.

On a bag written (without DDS) from a library run's trajectories with the nodes' message conversions it equals
`metrics_of_run`; on bags lacking topics it prints the figures it can and names what is missing.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
import yaml

pytest.importorskip('rclpy')
from rclpy.serialization import deserialize_message, serialize_message  # noqa: E402, I100

from iguana_ros.bag.schema import message_definition  # noqa: E402
from iguana_ros.bag.storage import BagWriter  # noqa: E402
from iguana_ros.bag.trajectory import read_topics  # noqa: E402
from iguana_ros.body.feet import FootProbe  # noqa: E402
from iguana_ros.body.model import build_model  # noqa: E402
from iguana_ros.body.root_tracking import RootTracker  # noqa: E402
from iguana_ros.geometry import yaw_of  # noqa: E402
from iguana_ros.pipeline import run as run_pipeline  # noqa: E402
from iguana_ros.ros import messages as m  # noqa: E402
from iguana_ros.ros.endpoints import resolve  # noqa: E402
from iguana_ros.run_metrics import metrics_of_run  # noqa: E402
from iguana_ros.scene import load_scene, terrain_from_spec  # noqa: E402
from iguana_ros.stages import motion_graph  # noqa: E402
from iguana_ros.supervisor.run import RunSummary  # noqa: E402
from iguana_ros.supervisor.run_gait import GAIT_TOPICS, run_gait  # noqa: E402
from iguana_ros.terrain.placement import place_on_terrain  # noqa: E402
from iguana_ros.topics import topic  # noqa: E402

NODE_RUN_FIGURES = ('stance_fraction', 'reference_stance_fraction', 'swing_clearance', 'swings_clear_fraction',
                    'swings', 'slip_per_foot_per_stride', 'speed_fraction', 'foot_height_error')
"""GaitMetrics fields a node run has (all but the shape error)."""


@pytest.fixture(scope='module')
def walk(tmp_path_factory):
    """(scene, library run, its metrics) of 1.5 s of flat_walk on the coarse mesh."""
    path = tmp_path_factory.mktemp('scene') / 'walk.yaml'
    path.write_text(yaml.safe_dump({'name': 'walk', 'model': {'resolution': 'coarse'}, 'terrain': {'kind': 'flat'},
                                    'goals': [{'x': 2.0, 'y': 0.0, 'at': 0.0}], 'duration': 1.5}))
    scene = load_scene(str(path))
    result = run_pipeline(scene)
    return scene, result, metrics_of_run(result, scene)


def _messages(scene, result) -> dict[str, list]:
    """Return the bytes the four nodes publish for `result`, by topic key (frame 0's state: the first row's)."""
    model = build_model(scene.model.resolution, scene.model.stiffness)
    probe = FootProbe(model, terrain_from_spec(scene.terrain))
    n = len(result.times)
    out = {key: [] for key in GAIT_TOPICS}
    for frame in range(n + 1):
        row = max(frame - 1, 0)           # the body after frame `frame` is row frame - 1
        heights, contact, soles = probe.body(result.node_positions[row], result.contacts[row])
        out['iguana_state'].append(m.state_to_cdr(result.root_positions[row], result.root_orientations[row],
                                                  np.zeros(3), np.zeros(3), frame))
        out['foot_state'].append(m.foot_state_to_cdr(heights, contact, frame))
        out['foot_positions'].append(m.foot_positions_to_cdr(soles, frame))
        if frame < n:                     # the reference of frame `frame` is row frame
            out['reference_stance'].append(m.reference_stance_to_cdr(result.reference_contacts[frame], frame))
            out['reference_pose'].append(m.reference_pose_to_cdr(result.reference_joints[frame],
                                                                 result.reference_rotations[frame], frame))
    out['motion_clip'] = [m.clip_to_cdr(clip, model.skeleton, start) for start, clip in _placed_clips(scene, result)]
    return out


def _placed_clips(scene, result) -> list:
    """(start frame, placed clip) of each stride of `result`, placed as the planner placed them."""
    graph = motion_graph()
    model = build_model(scene.model.resolution, scene.model.stiffness)
    start_nodes = place_on_terrain(model.rest_positions, terrain_from_spec(scene.terrain),
                                   xy=(scene.start.x, scene.start.y), yaw=np.radians(scene.start.yaw_deg),
                                   lift_only=True)
    root0, quat0 = RootTracker(model).root_pose(start_nodes)
    out, previous = [], None
    for start, name in result.clip_history:
        root, quat = (root0, quat0) if start == 0 else (result.root_positions[start - 1],
                                                        result.root_orientations[start - 1])
        previous = graph.align(name, root[:2], float(yaw_of(quat)), previous=previous)
        out.append((start, previous))
    return out


def _write_bag(path, messages: dict[str, list]):
    """Return a bag of `messages` (topic key -> serialized messages) as the recorder writes it."""
    writer = BagWriter(path)
    for key, msgs in messages.items():
        spec = topic(key)
        name = spec.name if spec.name.startswith('/') else '/' + spec.name
        channel = writer.add_topic(name, spec.type, message_definition(spec.type))
        for i, data in enumerate(msgs):
            writer.write(channel, data, 1_000_000 + i)
    writer.close()
    return path


def _gait(tmp_path, scene, messages):
    return run_gait(read_topics(_write_bag(tmp_path / 'bag', messages), GAIT_TOPICS), scene)


def test_gait_from_the_bag_equals_the_library_metrics(tmp_path, walk):
    scene, result, metrics = walk
    gait = _gait(tmp_path, scene, _messages(scene, result))
    assert gait.missing_topics == [] and gait.notes == []
    assert gait.strides == metrics.strides and gait.frames == len(result.times)
    for name in NODE_RUN_FIGURES:
        np.testing.assert_allclose(getattr(gait.metrics, name), getattr(metrics.gait, name), rtol=0, atol=1e-9,
                                   err_msg=name)
    assert math.isnan(gait.metrics.shape_error_median) and math.isnan(gait.metrics.shape_error_p90)
    text = '\n'.join(gait.lines())
    assert 'stance fraction fl ' in text and '(clip ' in text and 'swings)' in text
    assert 'speed: ' in text and 'shape error: not from a node run' in text
    assert 'n/a' not in text and 'not in the bag' not in text


def test_an_old_bag_without_the_probe_topics_prints_what_it_can(tmp_path, walk):
    scene, result, metrics = walk
    messages = _messages(scene, result)
    old = {k: messages[k] for k in ('iguana_state', 'motion_clip', 'reference_pose')}
    gait = _gait(tmp_path, scene, old)
    assert gait.missing_topics == ['foot_positions', 'foot_state', 'reference_stance']
    assert gait.metrics.speed_fraction == pytest.approx(metrics.gait.speed_fraction, abs=1e-9)
    assert all(math.isnan(v) for v in gait.metrics.stance_fraction + gait.metrics.foot_height_error)
    lines = gait.lines()
    assert '  stance fraction: n/a, needs foot_state (clip: n/a, needs reference_stance)' in lines
    assert '  mid-swing clearance: n/a, needs foot_state, reference_stance' in lines
    assert '  slip per foot per stride: n/a, needs foot_positions, foot_state' in lines
    assert any(line.startswith('  not in the bag: foot_positions, foot_state, reference_stance') for line in lines)
    assert any(line.strip().startswith('speed: ') and '%' in line for line in lines)


def test_a_bag_missing_single_topics_keeps_the_figures_of_the_others(tmp_path, walk):
    scene, result, metrics = walk
    messages = _messages(scene, result)
    del messages['reference_pose'], messages['motion_clip']
    gait = _gait(tmp_path, scene, messages)
    assert gait.missing_topics == ['motion_clip', 'reference_pose']
    np.testing.assert_allclose(gait.metrics.swing_clearance, metrics.gait.swing_clearance, atol=1e-9)
    assert math.isnan(gait.metrics.speed_fraction) and all(math.isnan(v) for v in gait.metrics.foot_height_error)
    assert all(math.isnan(v) for v in gait.metrics.slip_per_foot_per_stride)  # slip is per stride
    text = '\n'.join(gait.lines())
    assert 'foot height error: n/a, needs reference_pose' in text and 'speed: n/a, needs motion_clip' in text


def test_a_crashed_run_with_gaps_and_a_bad_message_is_summarised_with_notes(tmp_path, walk):
    scene, result, _ = walk
    messages = _messages(scene, result)
    del messages['foot_state'][10]                   # a frame the recorder lost
    bad = deserialize_message(m.foot_positions_to_cdr(np.zeros((4, 3)), 12), resolve('foot_positions')[1])
    bad.poses = bad.poses[:3]                         # three feet: rejected, not fatal
    messages['foot_positions'].append(serialize_message(bad))
    messages['iguana_state'] = messages['iguana_state'][:30]   # the run stopped at frame 29
    gait = _gait(tmp_path, scene, messages)
    assert gait.frames == 29 and not gait.reached
    assert 'foot_state: 1 of 29 frames missing (filled from the frame before)' in gait.notes
    assert 'foot_positions: 1 message(s) unreadable, skipped' in gait.notes
    assert all(np.isfinite(gait.metrics.stance_fraction))


def test_no_state_or_no_bag_gives_lines_not_a_traceback(tmp_path, walk):
    scene, _, _ = walk
    gait = _gait(tmp_path, scene, {'foot_state': []})
    assert gait.metrics is None and gait.lines() == ['gait: no figures (iguana_state is not in the bag)']
    summary = RunSummary('walk', tmp_path / 'bag', tmp_path / 'logs', 0.0, 0.0, False, float('nan'), float('nan'),
                         1, gait=gait)
    assert 'gait: no figures (iguana_state is not in the bag)' in summary.lines()


def test_read_topics_keeps_the_bytes_and_the_nodes_decoders_count_what_does_not_decode(tmp_path, walk):
    """A damaged payload or another type's bytes (a Marker on iguana_state) are skipped with a note, not raised."""
    from iguana_ros.bag.trajectory import root_trajectory
    from iguana_ros.ros.cdr import triangle_list_marker_cdr
    scene, result, _ = walk
    messages = _messages(scene, result)
    marker = triangle_list_marker_cdr(np.eye(3), np.array([[0, 1, 2]]), np.ones((3, 4)))
    messages['foot_state'].insert(0, b'\x00\x01\x00\x00\x07')
    messages['iguana_state'].insert(5, marker)
    messages['iguana_state'].insert(9, messages['iguana_state'][8][:40])
    recorded = read_topics(_write_bag(tmp_path / 'bag', messages), ['foot_state', 'iguana_state', 'push'])
    assert recorded.messages['foot_state'][0] == b'\x00\x01\x00\x00\x07' and recorded.messages['push'] == []
    assert recorded.messages['foot_state'][1:] == messages['foot_state'][1:]
    times, positions, _ = root_trajectory(recorded.messages['iguana_state'])
    assert len(times) == len(result.times) + 1 and np.array_equal(positions[1:], result.root_positions)
    gait = run_gait(read_topics(tmp_path / 'bag', GAIT_TOPICS), scene)
    assert 'foot_state: 1 message(s) unreadable, skipped' in gait.notes
    assert 'iguana_state: 2 message(s) unreadable, skipped' in gait.notes
    assert gait.frames == len(result.times)
    assert resolve('foot_state')[1].__name__ == 'JointState'
