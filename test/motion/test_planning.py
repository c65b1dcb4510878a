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
The motion-graph search on the shipped library, walked kinematically.

Each stride moves the pose by what the search itself predicts (the tracking figures), so these tests check the
search and its bookkeeping, not the soft body: random goals near and far in every direction are reached without
circling, headings within tolerance, routes in order, on level ground and on a slope.
"""
import math

import numpy as np
import pytest

from iguana_ros.geometry import wrap_angle
from iguana_ros.motion.clips import load_clip_library
from iguana_ros.motion.planning import clip_table, MotionPlanner, rest_steps, STAND, Target
from iguana_ros.motion.tracking import load_tracking
from iguana_ros.terrain.heightfield import HeightField


@pytest.fixture(scope='module')
def table():
    tracking = load_tracking()
    return clip_table(load_clip_library(), tracking.clips, tracking.carry)


def walk(planner: MotionPlanner, targets: list, pose=(0.0, 0.0, 0.0), strides: int = 80, noise: float = 0.0,
         seed: int = 0):
    """Play the planner's first clip from `pose` until it rests at the last target; (poses, clips, waypoint index)."""
    rng = np.random.default_rng(seed)
    pose, current, poses, clips, index = np.array(pose, float), None, [], [], 0
    for _ in range(strides):
        while index < len(targets) - 1 and targets[index].distance(pose[:2]) <= targets[index].radius:
            index += 1
        if index == len(targets) - 1 and targets[index].reached(pose) and \
                (current is None or planner.table.exit_gait[planner.table.index(current)] == 0):
            break
        plan = planner.plan(pose, current, targets[index:])
        assert plan.clips, 'the search found no clip to play'
        new = planner.predict(plan.first, pose) + noise * rng.normal(size=3) * np.array([0.01, 0.01, 0.03])
        planner.observe(plan.first, pose, new)
        pose, current = new, plan.first
        poses.append(pose)
        clips.append(current)
    return np.array(poses), clips, index


def test_the_graph_of_the_library_follows_its_gaits(table):
    names = table.names
    after = {n: {names[j] for j in np.flatnonzero(table.successors[table.index(n)])} for n in ('idle', 'forward')}
    assert after['idle'] == {'idle', 'start'}
    assert {'forward', 'turn_left', 'turn_right', 'trot_to_walk', 'trot_to_fast'} == after['forward']
    assert {names[j] for j in np.flatnonzero(table.successors[table.index(None)])} == {'idle', 'start'}
    steps = rest_steps(table)
    assert names[steps[table.index('forward')]] == 'trot_to_walk'
    assert names[steps[table.index('walk')]] == 'stop'
    assert names[steps[table.index(None)]] == 'idle'


def test_gait_table_orders_speeds_and_turn_rates(table):
    g = table.gaits
    speed = dict(zip(g.names, g.speed))
    rate = dict(zip(g.names, g.turn_rate))
    assert speed[STAND] == 0.0 < speed['walk'] < speed['trot'] < speed['fast']
    assert rate['walk'] > rate['trot'] > 0.0          # turns on the spot are the quickest turns
    assert g.switch_time[g.names.index('walk'), g.names.index('fast')] > 0.0


@pytest.mark.parametrize('seed', range(6))
def test_random_goals_near_and_far_are_reached_without_circling(table, seed):
    rng = np.random.default_rng(seed)
    for _ in range(4):
        distance, bearing = rng.uniform(0.4, 4.5), rng.uniform(-math.pi, math.pi)
        goal = Target((distance * math.cos(bearing), distance * math.sin(bearing)), radius=0.2)
        poses, clips, _ = walk(MotionPlanner(table), [goal], noise=1.0, seed=seed)
        assert goal.reached(poses[-1]), (goal, clips)
        turned = np.abs(np.sum(wrap_angle(np.diff(poses[:, 2]))))
        assert turned < 2 * math.pi, clips                 # never a full turn on the way
        path = np.sum(np.hypot(*np.diff(poses[:, :2], axis=0).T))
        if distance >= 2.0:
            assert path < 1.3 * distance, clips


def test_headings_are_reached_at_rest(table):
    rng = np.random.default_rng(3)
    for _ in range(6):
        yaw = rng.uniform(-math.pi, math.pi)
        goal = Target((rng.uniform(-1.5, 1.5), rng.uniform(-1.5, 1.5)), yaw, radius=0.2,
                      yaw_tolerance=math.radians(30.0))
        poses, clips, _ = walk(MotionPlanner(table), [goal])
        assert goal.reached(poses[-1]) and clips[-1] in ('stop', 'idle'), clips
        assert goal.heading_error(poses[-1, 2]) <= math.radians(30.0)


def test_a_route_is_followed_in_order(table):
    points = [(1.0, 0.0), (1.0, 1.0), (0.0, 1.0), (-0.6, 0.2)]
    targets = [Target(p, radius=0.2, final=k == len(points) - 1) for k, p in enumerate(points)]
    poses, clips, index = walk(MotionPlanner(table), targets, strides=120)
    assert index == len(points) - 1 and targets[-1].reached(poses[-1])
    first = [int(np.argmax(np.hypot(*(poses[:, :2] - p).T) <= 0.2)) for p in points]
    assert first == sorted(first) and first[0] > 0


def test_on_a_slope_the_gain_of_the_tracking_figures_is_used(table):
    slope = HeightField.tilted_plane(15.0, (1.0, 0.0))
    planner = MotionPlanner(table, slope)
    grad = planner.gradient(np.array([[0.0, 0.0, math.pi / 2]]))[0]
    assert grad[0] == pytest.approx(0.0, abs=1e-9) and grad[1] == pytest.approx(-math.tan(math.radians(15.0)), rel=1e-6)
    level = MotionPlanner(table).predict('forward', np.zeros(3))
    assert not np.allclose(planner.predict('forward', np.array([0.0, 0.0, math.pi / 2])), level)
    goal = Target((0.0, 3.0), radius=0.2)
    poses, clips, _ = walk(planner, [goal])
    assert goal.reached(poses[-1]), clips


def test_online_correction_follows_the_error_within_its_limit(table):
    planner = MotionPlanner(table)
    j = table.index('pivot_left')
    start = np.zeros(3)
    predicted = planner.predict('pivot_left', start)
    short = predicted.copy()
    short[2] -= 0.2                                     # the body turned 0.2 rad less than predicted
    planner.observe('pivot_left', start, short)
    assert planner.correction[j, 2] == pytest.approx(-0.1, abs=1e-6)   # rate 0.5
    for _ in range(20):
        planner.observe('pivot_left', start, predicted + np.array([0.0, 0.0, -3.0]))
    assert planner.correction[j, 2] == pytest.approx(-planner.params.correction_limit[2])


def test_targets_count_heading_only_when_asked():
    any_heading = Target((1.0, 0.0), None, radius=0.2)
    facing = Target((1.0, 0.0), 0.0, radius=0.2, yaw_tolerance=0.3)
    ignored = Target((1.0, 0.0), 0.0, radius=0.2, yaw_tolerance=math.inf)
    assert any_heading.reached(np.array([1.1, 0.0, 3.0])) and ignored.reached(np.array([1.1, 0.0, 3.0]))
    assert not facing.reached(np.array([1.1, 0.0, 3.0])) and facing.reached(np.array([1.1, 0.0, 0.2]))
    assert not Target((1.0, 0.0), 0.0, radius=0.2, yaw_tolerance=0.3, final=False).wants_heading


def test_a_stride_costs_for_passing_near_another_body_and_nothing_clear_of_it():
    from iguana_ros.motion.planning import MovingObstacles, PlannerParams
    p = PlannerParams()
    start, end = np.array([[0.0, 0.0, 0.0], [0.0, 2.0, 0.0]]), np.array([[1.0, 0.0, 0.0], [1.0, 2.0, 0.0]])
    t0, t1 = np.zeros(2), np.ones(2)
    standing = MovingObstacles(np.array([[0.5, 0.0]]), np.zeros((1, 2)))
    through, clear = standing.cost(start, end, t0, t1, p)
    assert through == pytest.approx(p.obstacle_cost) and clear == 0.0          # its root on the way: full cost
    coming = MovingObstacles(np.array([[0.5, 2.5]]), np.array([[0.0, -0.5]]))  # reaches y = 2 at t = 1 s
    assert coming.cost(start, end, t0, t1, p)[1] > 0.0 and coming.cost(start, end, t0 + 5, t1 + 5, p)[1] >= 0.0
    assert MovingObstacles(np.zeros((0, 2)), np.zeros((0, 2))).cost(start, end, t0, t1, p).tolist() == [0.0, 0.0]


def test_a_way_round_a_standing_body_keeps_it_on_the_left_and_none_is_planned_round_a_moving_one():
    """Every walker passes on the same hand (a roundabout, not a standoff), whichever side of the line it is on."""
    from iguana_ros.motion.planning import MovingObstacles, PlannerParams
    p = PlannerParams()
    target = np.array([2.0, 0.0])
    for xy in (np.array([0.0, 0.1]), np.array([0.0, -0.1])):
        past = MovingObstacles(np.array([[1.0, 0.0]]), np.zeros((1, 2))).way_round(xy, target, p)
        assert past is not None and past[1] < -p.clearance and abs(past[0] - 1.0) < 0.1   # beside it, on its right
    back = MovingObstacles(np.array([[1.0, 0.0]]), np.zeros((1, 2))).way_round(np.array([2.0, 0.0]), np.zeros(2), p)
    assert back[1] > p.clearance                                                        # walking -x: its right is +y
    xy = np.array([0.0, 0.1])
    assert MovingObstacles(np.array([[1.0, 0.0]]), np.array([[0.3, 0.0]])).way_round(xy, target, p) is None
    assert MovingObstacles(np.array([[1.0, 2.0]]), np.zeros((1, 2))).way_round(xy, target, p) is None   # not in the way
    assert MovingObstacles(np.array([[-1.0, 0.0]]), np.zeros((1, 2))).way_round(xy, target, p) is None  # behind
