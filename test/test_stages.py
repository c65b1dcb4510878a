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
The stage factories.

What each builds from a scene and the options a node's parameters set; the rules the library loop and the nodes share
(stride end, goal adoption, root twist).
"""
import numpy as np
import pytest

from iguana_ros import stages
from iguana_ros.constants import FRAME_RATE
from iguana_ros.parameters import node_parameters
from iguana_ros.pipeline import build_pipeline
from iguana_ros.scene import parse_scene


def _scene(**fields):
    raw = {'terrain': {'kind': 'hills', 'amplitude': 0.02, 'wavelength': 1.0}, 'model': {'resolution': 'coarse'},
           'goals': [{'x': 1.0, 'y': 0.0}], 'goal_radius': 0.3, 'duration': 0.5, **fields}
    return parse_scene(raw, 'test')


def test_blend_frames_default_is_the_declared_parameter_and_build_pipeline_honours_it():
    declared = node_parameters('planner_node')['blend_frames'].default
    assert stages.motion_graph().blend_frames == declared
    assert build_pipeline(_scene()).planner.graph.blend_frames == declared
    assert build_pipeline(_scene(), blend_frames=0).planner.graph.blend_frames == 0
    assert stages.planner_stage(_scene(), blend_frames=7).graph.blend_frames == 7


def test_goal_radius_zero_means_the_scenes():
    assert stages.planner_stage(_scene()).goal_radius == 0.3
    assert stages.planner_stage(_scene(), goal_radius=0.5).goal_radius == 0.5
    assert stages.planner_stage(_scene()).yaw_tolerance == pytest.approx(np.radians(30.0))
    assert stages.planner_stage(_scene(), yaw_tolerance=0.2).yaw_tolerance == 0.2


def test_a_goal_stamped_by_a_wall_clock_is_adopted_now():
    planner = stages.planner_stage(_scene())
    assert planner.accept_goal(np.array([1.0, 2.0]), 4.0) == 4.0            # simulated time: kept
    planner.frame = 90                                                        # 3 s simulated
    wall = 1.7e9                                                              # seconds since 1970
    assert planner.accept_goal(np.array([0.5, 0.5]), wall) == 0.0
    assert planner.accept_goal(np.array([0.5, 0.5]), 3.0 + stages.MAX_SCHEDULE_AHEAD) > 0.0   # just inside
    planner.activate_due_goals(0.0)
    np.testing.assert_array_equal(planner.goal, [0.5, 0.5])


def test_stride_end_rule():
    """A clip of 5 poses started at frame 10 covers frames 10..13; frame 14 (its last pose) starts the next."""
    assert [stages.stride_ended(10, 5, f) for f in (10, 13, 14, 15)] == [False, False, True, True]


def test_adaptation_stage_follows_scene_parameter_and_ground():
    assert stages.adaptation_stage(_scene()).enabled
    assert not stages.adaptation_stage(_scene(), enabled=False).enabled
    assert not stages.adaptation_stage(_scene(adaptation=False)).enabled
    assert stages.adaptation_stage(_scene(adaptation=False), enabled=True).enabled
    flat = stages.adaptation_stage(_scene(terrain={'kind': 'flat'}), enabled=True)
    assert not flat.enabled and flat.terrain.is_flat


def test_simulator_stage_fidelity_and_start_pose():
    scene = _scene(start={'x': 0.5, 'y': -0.2, 'yaw_deg': 90.0})
    sim = stages.simulator_stage(scene)
    from iguana_ros.physics.fidelity import get_fidelity
    assert sim.sim.fidelity == get_fidelity(scene.fidelity)
    assert stages.simulator_stage(scene, 'fast').sim.fidelity == get_fidelity('fast') != get_fidelity(scene.fidelity)
    root, quat = sim.root_pose()
    assert np.hypot(root[0] - 0.5, root[1] + 0.2) < 0.2
    from iguana_ros.geometry import yaw_of
    assert float(yaw_of(quat)) == pytest.approx(np.pi / 2, abs=1e-6)


def test_reset_puts_the_body_back_at_its_start_and_then_it_moves_as_a_fresh_one():
    scene = _scene(pushes=[{'at': 0.05, 'force': [0.0, -20.0, 0.0], 'region': 'trunk_left', 'duration': 0.2},
                           {'at': 0.4, 'force': [0.0, 20.0, 0.0], 'region': 'trunk_left', 'duration': 0.1}])
    fresh, used = stages.simulator_stage(scene), stages.simulator_stage(scene)
    start = fresh.sim.positions.copy()
    rng = np.random.default_rng(3)
    lengths = [fresh.model.spring_rest_lengths * rng.uniform(0.95, 1.05, len(fresh.model.springs)) for _ in range(5)]
    for desired in lengths:
        used.advance(desired)                        # frames 1-5 with the first push acting
    used.add_push(np.array([0.0, 5.0, 0.0]), 'trunk_right', 0.5)
    used.reset()
    assert used.frame == 5 and used.time == pytest.approx(5 / FRAME_RATE) and used.resets == 1   # time goes on
    assert np.array_equal(used.sim.positions, start) and not np.any(used.sim.velocities)
    assert used.live_pushes == [] and [p.at for p in used.pushes] == [0.4]    # the later scene push is kept
    assert np.array_equal(used.root_pose()[0], fresh.root_pose()[0])
    fresh.pushes = used.pushes = ()                  # the same dynamics from here: no push on either
    for desired in lengths:
        fresh.advance(desired)
        used.advance(desired)
    assert np.array_equal(used.sim.positions, fresh.sim.positions)   # bit for bit, as from frame 0


def test_sim_control_pauses_steps_exact_frames_and_resumes():
    control = stages.SimControl()
    assert control.may_advance(0)
    control.pause()
    assert not control.may_advance(7)
    assert control.step(7, 3) == 10
    assert [control.may_advance(f) for f in (7, 8, 9, 10)] == [True, True, True, False]
    assert not control.step_done(9) and control.step_done(10) and not control.may_advance(10)
    assert control.step_until is None and control.paused
    control.step(10, 5)
    control.pause()                                  # a pause ends a running step
    assert not control.may_advance(10) and control.step_until is None
    control.resume()
    assert control.may_advance(10) and not control.step_done(11)
    with pytest.raises(stages.InputError, match='at least 1 frame'):
        control.step(0, 0)
    assert stages.SimControl(paused=True).may_advance(0) is False


def test_root_twist_of_a_rigid_motion():
    """Nodes moving rigidly (v = v_c + ω × (x − c) about the root region's centre c): the twist is (v_c, ω)."""
    sim = stages.simulator_stage(_scene(terrain={'kind': 'flat'}))
    tracker, x = sim.tracker, sim.sim.positions
    w = tracker.weights / tracker.weights.sum()
    centre = w @ x[tracker.nodes]
    v_c, omega = np.array([0.3, -0.1, 0.05]), np.array([0.2, -0.4, 1.5])
    linear, angular = tracker.root_twist(x, v_c + np.cross(omega, x - centre))
    np.testing.assert_allclose(linear, v_c, atol=1e-12)
    np.testing.assert_allclose(angular, omega, atol=1e-9)


def test_rigid_velocity_of_a_collinear_group_is_the_least_norm_spin():
    """Nodes on a line: a spin about the line moves nothing, so the twist's ω has no component along it."""
    from iguana_ros.body.root_tracking import rigid_velocity
    x = np.outer(np.linspace(-0.2, 0.3, 6), [1.0, 0.0, 0.0]) + [0.1, 0.2, 0.3]
    omega = np.array([0.5, 0.0, 1.0])
    centre = x.mean(axis=0)
    linear, angular = rigid_velocity(x, 0.2 + np.cross(omega, x - centre), np.ones(6))
    np.testing.assert_allclose(linear, 0.2, atol=1e-12)
    np.testing.assert_allclose(angular, [0.0, 0.0, 1.0], atol=1e-9)


def test_build_pipeline_shares_one_model_and_terrain():
    pipe = build_pipeline(_scene())
    assert pipe.adaptation.terrain is pipe.simulator.terrain
    assert pipe.simulator.model is stages.scene_model(pipe.scene)
    assert pipe.planner.frame == -1 and pipe.simulator.time == 0.0
    pipe.step()
    assert pipe.planner.frame == 0 and pipe.simulator.time == pytest.approx(1 / FRAME_RATE)


def test_load_kernels_changes_no_state():
    """A stage whose kernels were loaded gives the same numbers as one whose first frame loads them."""
    scene = _scene()
    loaded, fresh = build_pipeline(scene, lookahead=False), build_pipeline(scene, lookahead=False)
    fresh_sim = stages.simulator_stage(scene)                 # never loaded by build_pipeline
    loaded.load_kernels()                                     # twice over: build_pipeline loaded them already
    loaded.simulator.load_kernels()
    assert loaded.simulator.sim.stats['steps'] == 0 and loaded.simulator.sim.time == 0.0
    np.testing.assert_array_equal(loaded.simulator.sim.positions, fresh_sim.sim.positions)
    np.testing.assert_array_equal(loaded.simulator.sim.velocities, fresh_sim.sim.velocities)
    try:
        for _ in range(3):
            for got, want in zip(loaded.step(), fresh.step()):
                np.testing.assert_array_equal(got, want)
        np.testing.assert_array_equal(loaded.simulator.sim.positions, fresh.simulator.sim.positions)
    finally:
        loaded.close()
        fresh.close()


LOADED_FIRST_FRAMES = """
from iguana_ros.pipeline import build_pipeline
from iguana_ros.scene import load_scene
from iguana_ros.warmup import kernel_signatures
pipe = build_pipeline(load_scene('hills'))
before = kernel_signatures()
for _ in range(3):
    pipe.step()
pipe.close()
print(sorted(k for k, v in kernel_signatures().items() if before.get(k) != v))
"""


def test_the_first_frames_of_a_built_pipeline_load_no_kernel():
    """`build_pipeline` loads every kernel a frame uses (in a fresh process): the first frames add no signature."""
    import subprocess
    import sys
    done = subprocess.run([sys.executable, '-c', LOADED_FIRST_FRAMES], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip().splitlines()[-1] == '[]', done.stdout


def test_root_pose_is_fitted_once_per_state_of_the_body():
    """The stage keeps the fit while the body has not changed (advance or reset), and hands out copies."""
    stage = stages.simulator_stage(_scene())
    calls = []
    fit = stage.tracker.root_pose
    stage.tracker.root_pose = lambda positions: calls.append(1) or fit(positions)
    first = stage.root_pose()
    first[0][:] = np.nan                             # a caller's copy
    again = stage.root_pose()
    assert len(calls) == 1 and np.all(np.isfinite(again[0]))
    stage.advance(None)
    moved = stage.root_pose()
    assert len(calls) == 2
    np.testing.assert_array_equal(moved[0], fit(stage.sim.positions)[0])
    stage.sim.reset()
    np.testing.assert_array_equal(stage.root_pose()[1], fit(stage.sim.positions)[1])
    assert len(calls) == 3


def _drive(stage, moves: bool, strides: int, start=(0.0, 0.0, 0.0)):
    """Play `stage`'s clips kinematically (each stride moves the pose as the search predicts, or not at all)."""
    from iguana_ros.geometry import quat_from_yaw
    pose, frame = np.array(start, float), 0
    for _ in range(strides):
        clip = stage.update(frame, np.array([pose[0], pose[1], 0.1]), quat_from_yaw(pose[2]))
        assert clip is not None
        if moves:
            pose = stage.planner.predict(clip.name, pose)
        frame += len(clip.root_positions) - 1
        if stage.finished:
            break
    return pose


def test_the_planner_stage_follows_a_route_reports_waypoints_and_comes_to_rest():
    stage = stages.planner_stage(_scene(terrain={'kind': 'flat'}), goal_radius=0.2)
    stage.schedule_route(stage.route_targets([(1.0, 0.0, None), (1.0, 1.0, None), (0.0, 1.0, np.pi)]))
    pose = _drive(stage, moves=True, strides=150)
    kinds = [e.kind for e in stage.events]
    assert kinds[:2] == ['waypoint', 'waypoint'] and 'arrived' in kinds and stage.finished, stage.events
    assert stage.status().state == 'arrived' and stage.status().waypoint == 2
    assert np.hypot(pose[0], pose[1] - 1.0) <= 0.2 and abs(np.angle(np.exp(1j * (pose[2] - np.pi)))) <= np.pi / 6
    assert stage.history[-1][1] == 'idle' and all(0 < s < 0.1 for s in stage.plan_seconds)


def test_a_body_that_does_not_move_is_reported_stuck_and_recovered_by_detours():
    stage = stages.planner_stage(_scene(terrain={'kind': 'flat'}), goal_radius=0.2)
    stage.set_goal(np.array([2.0, 0.0]))
    _drive(stage, moves=False, strides=40)
    stuck = [e for e in stage.events if e.kind in ('stuck', 'circling')]
    assert len(stuck) >= 2 and 'detour' in stuck[0].detail and 'slow walk' in stuck[1].detail, stage.events
    assert stage.recovery >= 2 and stage.status().state == 'recovering'
    assert not any(name.startswith('fast') for _, name in stage.history[-8:])   # level 2: the slow walk


def test_a_new_goal_replaces_a_route_and_a_scheduled_one_waits_for_its_time():
    stage = stages.planner_stage(_scene(terrain={'kind': 'flat'}))
    stage.schedule_route(stage.route_targets([(1.0, 0.0, None), (2.0, 0.0, 0.5)]))
    stage.schedule_goal(np.array([-1.0, 0.0]), at=2.0, yaw=1.0)
    stage.activate_due_goals(0.0)
    assert len(stage.targets) == 2 and not stage.targets[0].final and stage.targets[1].yaw == 0.5
    assert stage.targets[0].yaw is None                         # only the last waypoint keeps its heading
    stage.activate_due_goals(2.0)
    assert len(stage.targets) == 1 and stage.targets[0].xy == (-1.0, 0.0) and stage.targets[0].yaw == 1.0


def test_a_goal_task_succeeds_where_the_planner_rests_with_its_own_tolerance():
    stage = stages.planner_stage(_scene(terrain={'kind': 'flat'}), goal_radius=0.2)
    task = stages.GoalTask(stage, (1.0, 0.0), 0.0, radius=0.3)
    assert task.target.radius == 0.3 and task.target.yaw_tolerance == stage.yaw_tolerance
    assert task.progress((0.0, 0.0)) == stages.GoalProgress(1.0, 0.0, 0, 'scheduled for t=0.00 s')
    pose = _drive(stage, moves=True, strides=60)
    outcome = task.update(pose[:2])
    assert outcome.kind == 'succeeded' and outcome.reached and outcome.distance <= 0.3, outcome
    assert outcome.time_elapsed == stage.frame / FRAME_RATE > 0 and task.progress(pose[:2]).strides > 2


def _stride(stage, frame: int) -> int:
    """Play one stride of `stage` with the body standing at the origin; return the next stride's first frame."""
    from iguana_ros.geometry import quat_from_yaw
    clip = stage.update(frame, np.array([0.0, 0.0, 0.1]), quat_from_yaw(0.0))
    return frame + len(clip.root_positions) - 1


def test_a_newer_goal_replaces_a_task_and_a_cancelled_task_brings_the_planner_to_rest():
    stage = stages.planner_stage(_scene(terrain={'kind': 'flat'}), goal_radius=0.2)
    first = stages.GoalTask(stage, (2.0, 0.0), 0.0)
    frame = _stride(stage, _stride(stage, 0))
    assert first.update((0.5, 0.0)) is None and first.progress((0.5, 0.0)).status == 'walking'
    stage.accept_goal(np.array([0.0, 2.0]), 0.0)                     # a goal_pose goal
    second = stages.GoalTask(stage, (-2.0, 0.0), 0.0, yaw=0.5)
    frame = _stride(stage, frame)
    assert first.update((0.5, 0.0)).kind == 'replaced' and second.update((0.5, 0.0)) is None
    outcome = second.cancel((0.5, 0.0))
    assert outcome.kind == 'canceled' and not outcome.reached and outcome.distance == 2.5
    assert second.cancel((0.0, 0.0)) is outcome and not stage.targets   # decided once; the planner has no goal
    for _ in range(6):
        frame = _stride(stage, frame)
    assert stage.history[-1][1] == 'idle' and stage.status().state == 'idle'
    later = stages.GoalTask(stage, (1.0, 1.0), 100.0)
    assert later.cancel((0.0, 0.0)).kind == 'canceled' and stage.route_state(later.number) == 'done'


def test_a_goal_task_without_progress_ends_and_the_planner_drops_it():
    stage = stages.planner_stage(_scene(terrain={'kind': 'flat'}), goal_radius=0.2)
    task = stages.GoalTask(stage, (2.0, 0.0), 0.0)
    frame, outcome = 0, None
    from iguana_ros.geometry import quat_from_yaw
    while outcome is None and frame < 3000:
        clip = stage.update(frame, np.array([0.0, 0.0, 0.1]), quat_from_yaw(0.0))   # the body never moves
        frame += 1
        outcome = task.update((0.0, 0.0)) if clip is not None else None
    assert outcome.kind == 'no_progress' and not stage.targets, outcome
    assert stage.recovery_params.window * stages.GIVE_UP_RECOVERY == 32 and '32 strides' in outcome.reason


def test_other_bodies_are_kept_by_frame_until_everyone_is_heard_and_none_make_no_obstacles():
    from iguana_ros.stages import OtherBodies
    others = OtherBodies(['b', 'c'], window=15)
    others.add('c', 4, np.array([1.0, 2.0]), np.array([0.1, 0.0]))
    assert not others.ready(4) and others.missing(4) == ['b']
    others.add('b', 4, np.array([3.0, 4.0]), np.array([0.0, 0.2]))
    others.add('b', 4, np.array([9.0, 9.0]), np.array([9.0, 9.0]))        # a re-sent state: the first one counts
    others.add('b', 5, np.array([3.1, 4.0]), np.array([0.0, 0.2]))
    assert others.ready(4) and not others.ready(5)
    seen = others.obstacles(4)                       # no frame 0 heard: each body's own velocity
    assert np.array_equal(seen.xy, [[3.0, 4.0], [1.0, 2.0]]) and np.array_equal(seen.velocity, [[0.0, 0.2], [0.1, 0.0]])
    alone = OtherBodies([], window=15)
    assert alone.ready(7) and alone.obstacles(7).xy.shape == (0, 2)


def test_a_body_that_went_nowhere_over_the_window_stands_while_a_walker_moves_at_its_velocity():
    from iguana_ros.stages import OtherBodies
    others = OtherBodies(['walker', 'pivot'], window=15)
    for f in range(40):
        sway = 0.01 * np.sin(f)                                  # swaying at up to 0.3 m/s, going nowhere
        others.add('walker', f, np.array([0.01 * f, 0.0]), np.array([0.3, 0.05]))
        others.add('pivot', f, np.array([sway, 0.0]), np.array([0.3 * np.cos(f), 0.0]))
    seen = others.obstacles(39)
    assert np.array_equal(seen.velocity[0], [0.3, 0.05])        # moving: its root's velocity as heard
    assert np.array_equal(seen.velocity[1], [0.0, 0.0])         # 3.7 cm in 0.5 s: it stands (way_round sees it)
    assert min(others.by_frame) == 24                           # older frames forgotten
    assert np.array_equal(others.obstacles(39, ['pivot']).xy, [[0.01 * np.sin(39), 0.0]])
