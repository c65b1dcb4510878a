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
End to end.

A lockstep run of the four node processes equals `pipeline.run` of the same scene bit for bit, its summary's gait
figures (read from the bag) equal the library run's, and its bag replays to a real subscriber -- three tests reading one
shared run (`shared_run`); the one-process, killed and realtime runs start their own.
"""
from __future__ import annotations

import numpy as np
import pytest
import yaml

from iguana_ros.bag.trajectory import read_root_trajectory
from iguana_ros.constants import FRAME_RATE
from iguana_ros.pipeline import run as run_pipeline
from iguana_ros.run_metrics import metrics_of_run
from iguana_ros.scene import load_scene
from iguana_ros.supervisor.run import run_scene, RunOptions
from ros_harness import IGUANA, NodeProcess, PLAY_PAUSED, resume_player, spin_until

pytestmark = [pytest.mark.ros, pytest.mark.slow, pytest.mark.timeout(300)]

FRAMES = 12


def scene_file_text() -> str:
    """Return the e2e scene: coarse body, gentle seeded hills (adaptation on), a goal ahead on the left."""
    return yaml.safe_dump({
        'name': 'e2e', 'model': {'resolution': 'coarse'},
        'terrain': {'kind': 'hills', 'amplitude': 0.02, 'wavelength': 1.0, 'seed': 3},
        'goals': [{'x': 0.3, 'y': 1.0, 'at': 0.0}], 'duration': FRAMES / FRAME_RATE})


@pytest.fixture(scope='module')
def scene_file(tmp_path_factory):
    path = tmp_path_factory.mktemp('scene') / 'e2e.yaml'
    path.write_text(scene_file_text())
    return path


@pytest.fixture(scope='module')
def library_run(scene_file):
    return run_pipeline(load_scene(str(scene_file)))


WALK_FRAMES = 60
"""The shared run: 2 s over the same hills, a route of two waypoints ending with a heading (sent on `route`)."""


@pytest.fixture(scope='module')
def walk_file(tmp_path_factory):
    """Return the e2e hills and a route, 2 s: long enough for the gait figures (>= 2 strides) of the summary."""
    raw = yaml.safe_load(scene_file_text())
    del raw['goals']
    path = tmp_path_factory.mktemp('scene') / 'walk.yaml'
    route = [{'x': 0.3, 'y': 0.5}, {'x': 0.3, 'y': 1.0, 'yaw_deg': 90.0}]
    path.write_text(yaml.safe_dump({**raw, 'name': 'walk', 'route': route, 'duration': WALK_FRAMES / FRAME_RATE}))
    return path


@pytest.fixture(scope='module')
def shared_run(walk_file, tmp_path_factory):
    """
    Return one recorded lockstep run of the four node processes (`iguana run`) as (summary, bag path).

    It is shared by the tests that only read its summary and its bag.
    """
    bag = tmp_path_factory.mktemp('run') / 'run'
    return run_scene(RunOptions(scene=str(walk_file), record=bag, timeout=240)), bag


@pytest.fixture(scope='module')
def walk_library_run(walk_file):
    return run_pipeline(load_scene(str(walk_file)))


def _assert_roots_equal_library(bag, frames, library_run):
    """
    Assert that the bag's iguana_state roots are the library run's, bit for bit.

    State k is the root after k frames.
    """
    times, roots = read_root_trajectory(bag)
    assert np.allclose(times, np.arange(frames + 1) / FRAME_RATE)
    assert np.array_equal(roots[1:], library_run.root_positions)


def test_lockstep_nodes_equal_library_run(shared_run, walk_library_run):
    summary, bag = shared_run
    assert summary.exit_code == 0, summary.message
    assert summary.simulated_s == pytest.approx(WALK_FRAMES / FRAME_RATE)
    _assert_roots_equal_library(bag, WALK_FRAMES, walk_library_run)


def test_one_process_lockstep_equals_library_run(tmp_path, scene_file, library_run):
    bag = tmp_path / 'run'
    summary = run_scene(RunOptions(scene=str(scene_file), record=bag, single_process=True, timeout=240))
    assert summary.exit_code == 0, summary.message
    assert summary.simulated_s == pytest.approx(FRAMES / FRAME_RATE)
    _assert_roots_equal_library(bag, FRAMES, library_run)


def test_lockstep_run_summary_has_the_gait_figures_of_the_library_run(shared_run, walk_file, walk_library_run):
    summary, _ = shared_run
    assert summary.exit_code == 0, summary.message
    expected = metrics_of_run(walk_library_run, load_scene(str(walk_file)))
    gait = summary.gait
    assert gait.missing_topics == [] and gait.notes == [], gait.lines()
    assert gait.strides == expected.strides >= 2 and gait.metrics.swings > 0
    for name in ('stance_fraction', 'reference_stance_fraction', 'swing_clearance', 'swings_clear_fraction',
                 'swings', 'slip_per_foot_per_stride', 'speed_fraction', 'foot_height_error'):
        np.testing.assert_allclose(getattr(gait.metrics, name), getattr(expected.gait, name), rtol=0, atol=1e-9,
                                   err_msg=name)
    lines = summary.lines()
    assert any(line.startswith('  stance fraction fl ') and '(clip ' in line for line in lines), lines
    assert any(line.startswith('  speed: ') and "% of the clips'" in line for line in lines), lines
    cpu = summary.cpu_ms_per_frame                  # every process of the run, sampled while it stepped
    assert set(cpu) == {'simulator_node', 'planner_node', 'terrain_adaptation_node', 'spring_length_node', 'recorder',
                        'iguana run'}, cpu
    assert cpu['simulator_node'] > 0.0 and all(ms >= 0.0 for ms in cpu.values()), cpu
    assert any(line.startswith('CPU per frame while stepping: ') for line in lines), lines


def test_recorded_run_replays(shared_run, make_node, executor):
    from iguana_ros.ros.endpoints import resolve
    summary, bag = shared_run
    assert summary.exit_code == 0, summary.message
    node = make_node('replay_listener')
    executor.add_node(node)
    got = {'iguana_state': [], 'scene_markers': []}
    for key in got:
        name, cls, qos = resolve(key)
        qos.depth = 100  # the listener keeps every replayed message even if it is briefly slow
        node.create_subscription(cls, name, got[key].append, qos)
    # Only the two topics listened to, so the player starts once both are matched (with all 13 it waited out its
    # timeout for topics nobody reads); paused until this listener has matched the player on its side too (a
    # volatile reader that matches the player late misses the first states).
    names = ['/' + resolve(k)[0].lstrip('/') for k in got]
    play = NodeProcess([*IGUANA, 'bag', 'play', str(bag), '--rate', '5', '--topics', *names, *PLAY_PAUSED],
                       'play', bag.parent).start()
    with play:
        resume_player(node, names, lambda: executor.spin_once(timeout_sec=0.02),
                      playing=lambda: bool(got['iguana_state']))
        assert spin_until(executor, lambda: len(got['iguana_state']) >= WALK_FRAMES + 1, 60), play.output
        assert spin_until(executor, lambda: len(got['scene_markers']) >= 1, 10), play.output
        assert play.wait(60) == 0, play.output
    from iguana_ros.ros.conversions import odometry_to_numpy
    replayed = np.array([odometry_to_numpy(m)[0] for m in got['iguana_state']])
    recorded = read_root_trajectory(bag)[1]
    assert np.array_equal(replayed, recorded), (replayed.shape, recorded.shape, replayed[:3], recorded[:3])


@pytest.mark.long
def test_node_killed_mid_run_stops_the_run_and_keeps_the_bag(tmp_path, scene_file):
    from iguana_ros.bag.storage import summarize
    from iguana_ros.errors import IguanaError
    from iguana_ros.supervisor.run import SceneRun
    long_scene = tmp_path / 'long.yaml'
    raw = yaml.safe_load(scene_file.read_text())
    long_scene.write_text(yaml.safe_dump({**raw, 'duration': 30.0}))
    run = SceneRun(RunOptions(scene=str(long_scene), record=tmp_path / 'bag', timeout=240))
    try:
        run.start()
        run.send_goals()
        sim = run.simulator()
        assert spin_wait(lambda: 'frame' in run.children['planner_node'].output, 90)
        run.children['spring_length_node'].kill()
        with pytest.raises(IguanaError, match='spring_length_node exited with status -9'):
            run.wait()
        assert sim.running  # the other nodes keep running until iguana run stops them
    finally:
        run.stop()
    summary = summarize(tmp_path / 'bag')
    assert not summary.truncated
    counts = {t.name: t.message_count for t in summary.topics}
    assert counts['/iguana_state'] >= 1 and counts['/mesh_marker'] >= 1


def spin_wait(predicate, timeout):
    from iguana_ros.supervisor.process import wait_for
    return wait_for(predicate, timeout, period=0.1)


def test_realtime_mode_runs_paced_and_records_every_frame(tmp_path, scene_file):
    summary = run_scene(RunOptions(scene=str(scene_file), mode='realtime', record=tmp_path / 'bag',
                                   timeout=240))
    assert summary.exit_code == 0, summary.message
    times, roots = read_root_trajectory(tmp_path / 'bag')
    assert np.allclose(times, np.arange(FRAMES + 1) / FRAME_RATE)
    assert np.all(np.isfinite(roots))
    # paced by the wall clock: it cannot finish faster than real time
    assert summary.wall_s >= 0.9 * FRAMES / FRAME_RATE
