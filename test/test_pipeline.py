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

"""The ROS-free frame loop: stages wire together, runs are deterministic, pushes and goals take effect."""
import dataclasses
from types import SimpleNamespace

import numpy as np
import pytest

from iguana_ros import pipeline, stages
from iguana_ros.body.skeleton import iguana_skeleton
from iguana_ros.geometry import quat_from_yaw, quat_identity
from iguana_ros.scene import parse_scene, PushSpec


def _synthetic_library(n=12):
    """Two tiny clips on the real skeleton: standing still and a lateral trunk wiggle."""
    sk = iguana_skeleton()

    def clip(name, bend, step):
        local = quat_identity((n, sk.n_bones))
        t = np.arange(n) / (n - 1)
        for i in range(1, 6):
            local[:, sk.index(f'spine_{i}')] = quat_from_yaw(bend * np.sin(2 * np.pi * t))
        return SimpleNamespace(name=name, root_positions=np.tile(sk.offsets[0], (n, 1)),
                               local_rotations=local, contacts=np.ones((n, 4), bool),
                               root_displacement=np.array([step, 0.0]), heading_change=0.0)
    return {'idle': clip('idle', 0.0, 0.0), 'wiggle': clip('wiggle', 0.15, 0.05)}


@pytest.fixture(scope='module')
def coarse_scene():
    return parse_scene({'terrain': {'kind': 'flat'}, 'model': {'resolution': 'coarse'},
                        'goals': [{'x': 1.0, 'y': 0.0}], 'duration': 0.5}, 'test')


def _run(scene, frames):
    pipe = pipeline.build_pipeline(scene, library=_synthetic_library())
    roots = [pipe.step()[0] for _ in range(frames)]
    return pipe, np.array(roots)


def test_loop_runs_and_is_deterministic(coarse_scene):
    pipe_a, roots_a = _run(coarse_scene, 8)
    pipe_b, roots_b = _run(coarse_scene, 8)
    assert np.all(np.isfinite(roots_a))
    assert np.array_equal(pipe_a.simulator.sim.positions, pipe_b.simulator.sim.positions)
    assert pipe_a.planner.history[0] == (0, 'wiggle')  # goal ahead: the moving clip, not idle
    assert not pipe_a.adaptation.enabled  # flat ground builds no adaptation


def test_push_forces_sum_to_the_push_on_its_region():
    from iguana_ros.body.model import build_model
    model = build_model('coarse')
    push = PushSpec(at=1.0, force=(0.0, -40.0, 0.0), duration=0.1, region='trunk_left')
    assert stages.push_forces(model, (push,), 0.5) is None
    forces = stages.push_forces(model, (push,), 1.05)
    assert np.allclose(forces.sum(axis=0), [0.0, -40.0, 0.0])
    assert np.all(forces[~model.node_tags['trunk_left']] == 0.0)
    assert stages.push_forces(model, (push,), 1.1) is None


def test_scene_goal_schedule(coarse_scene):
    scene = dataclasses.replace(coarse_scene, goals=parse_scene(
        {'goals': [{'x': 1.0, 'y': 0.0, 'at': 0.0}, {'x': 0.0, 'y': 2.0, 'at': 0.1}]}).goals)
    planner = pipeline.build_pipeline(scene, library=_synthetic_library()).planner
    planner.activate_due_goals(0.0)
    assert np.allclose(planner.goal, [1.0, 0.0])
    planner.activate_due_goals(3 / 30)
    assert np.allclose(planner.goal, [0.0, 2.0])
    planner.schedule_goal(np.array([5.0, 5.0]), at=0.0)  # interactive goal: due at once
    planner.activate_due_goals(3 / 30)
    assert np.allclose(planner.goal, [5.0, 5.0])


def test_stride_lookahead_on_a_thread_equals_frames_computed_on_demand():
    """
    Adapted poses of a stride computed ahead on the worker thread are the numbers the loop computes frame by frame.

    The thread computes them while the body steps; the loop without it gives the same numbers: the same warm-start
    chain, over three strides with adaptation on.
    """
    scene = parse_scene({'terrain': {'kind': 'hills', 'amplitude': 0.08}, 'model': {'resolution': 'coarse'},
                         'goals': [{'x': 1.0, 'y': 0.3}], 'duration': 2.5}, 'test')
    runs = []
    for threaded in (True, False):
        pipe = pipeline.build_pipeline(scene, lookahead=threaded)
        try:
            frames = [pipe.step() for _ in range(70)]
        finally:
            pipe.close()
        runs.append((frames, pipe.simulator.sim.positions.copy(), list(pipe.planner.history)))
    (ahead, x_ahead, clips_ahead), (demand, x_demand, clips_demand) = runs
    assert pipe.adaptation.enabled and len(clips_demand) >= 3, clips_demand
    assert clips_ahead == clips_demand
    for a, b in zip(ahead, demand):
        assert all(np.array_equal(u, v) for u, v in zip(a, b))
    assert np.array_equal(x_ahead, x_demand)


def test_a_strides_first_frame_is_computed_by_the_caller_and_calls_never_overlap():
    """
    `StrideLookahead.start` returns with the stride's first frame done (no hand-over to the worker and back).

    A restart while the worker computes the earlier stride waits for that frame: the adaptation's warm start is
    shared, so no two adaptation calls may run at once (each call here is slowed to 20 ms to make an overlap show).
    The worker's frame 1 is held until the restart has begun, so the restart surely lands inside it.
    """
    import threading
    import time
    from iguana_ros.stages import StrideLookahead
    scene = parse_scene({'terrain': {'kind': 'hills', 'amplitude': 0.08}, 'model': {'resolution': 'coarse'},
                         'goals': [{'x': 1.0, 'y': 0.3}], 'duration': 2.5}, 'test')
    pipe = pipeline.build_pipeline(scene, lookahead=False)
    try:
        pipe.step()
        clip = pipe.planner.clip
    finally:
        pipe.close()
    calls = []
    restarts = []
    restarting = threading.Event()                   # set when a restart finds frames of the earlier stride pending

    class Slow(StrideLookahead):
        def compute(self, clip, index):
            begin = time.perf_counter()
            if threading.current_thread().name.startswith('lookahead') and not calls[1:]:
                assert restarting.wait(timeout=30), 'the restart never began'   # hold frame 1 until it does
            time.sleep(0.02)
            frame = super().compute(clip, index)
            calls.append((begin, time.perf_counter(), threading.current_thread().name))
            return frame

        def _drop_pending(self):
            if self._pending:
                restarts.append(time.perf_counter())
                restarting.set()
            super()._drop_pending()

    ahead = Slow(pipe.adaptation, pipe.springs)
    try:
        ahead.start(clip, 0)
        assert ahead.ready(0) and ahead._pending[0].done()
        assert calls[0][2] == threading.current_thread().name
        ahead.start(clip, 5)                         # the worker is inside frame 1, held until this restart begins
        assert ahead.ready(5) and ahead.take(5).lengths.shape == (len(pipe.springs.springs),)
        ahead.take(6)
    finally:
        ahead.close()
    calls.sort()
    worker_frame_1 = calls[1]
    assert worker_frame_1[2].startswith('lookahead') and worker_frame_1[0] < restarts[0] < worker_frame_1[1], calls
    assert len(calls) >= 4 and all(a[1] <= b[0] for a, b in zip(calls, calls[1:])), calls
