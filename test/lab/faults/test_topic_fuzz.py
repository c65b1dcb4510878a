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
Topic fault injection (issue 12).

Every fault the fuzzer makes is refused by the decoder of its topic (the one every node that reads the topic calls), and
a real lockstep run of the four node processes under a stream of them completes, no node dies, nothing non-finite is
published, and the run equals the library run bit for bit.
"""
from __future__ import annotations

import numpy as np
import pytest
import yaml

from iguana_lab.faults.topic_fuzz import fault_plan, FUZZ_KINDS, fuzz_message, FuzzContext, trial_scene
from iguana_ros.constants import FRAME_RATE
from iguana_ros.errors import InputError
from iguana_ros.physics.pushes import region_masses
from iguana_ros.ros import messages as m
from iguana_ros.scene import load_scene
from iguana_ros.validation import check_frame, check_push, FRAME_NEW, world_bound

SECONDS = 3.0


@pytest.fixture(scope='module')
def scene_file(tmp_path_factory):
    """
    Return the first scene of the long suite (`iguana bench faults topics`).

    Hills, a goal 1.5 m away, coarse mesh.
    """
    path = tmp_path_factory.mktemp('scene') / 'fuzz.yaml'
    path.write_text(yaml.safe_dump(trial_scene(0, 0, SECONDS, 'coarse')))
    return path


def _refused(key: str, msg, ctx: FuzzContext, model) -> bool:
    """
    Return whether the nodes reading topic `key` refuse `msg` at frame ctx.frame.

    They refuse it with an InputError, or by not using its frame: stale, or not the one the lockstep simulator waits
    for.
    """
    from rclpy.serialization import serialize_message
    bound = world_bound(2 * ctx.half_extent)
    skeleton = ctx.skeleton
    data = serialize_message(msg)          # what the nodes that read the topic raw receive
    try:
        if key == 'goal_pose':
            m.goal_from_msg(msg, ctx.half_extent)
        elif key == 'push':
            push = m.push_from_cdr(data)
            check_push(push.force, push.torque, push.region, region_masses(model.node_mass, model.node_tags), 1.0, 0.1)
        elif key == 'motion_clip':
            return check_frame('motion_clip', m.clip_from_cdr(data, skeleton, bound)[0], ctx.frame) != FRAME_NEW
        elif key == 'reference_pose':
            frame = m.reference_pose_from_cdr(data, skeleton.n_bones, skeleton, bound)[0]
            return check_frame('reference_pose', frame, ctx.frame) != FRAME_NEW
        elif key == 'spring_rest_lengths':
            return m.lengths_from_cdr(data, len(ctx.rest_lengths), ctx.rest_lengths)[0] != ctx.frame + 1
        else:
            return check_frame('iguana_state', m.state_from_cdr(data, bound)[0], ctx.frame) != FRAME_NEW
    except InputError:
        return True
    return False


def test_every_fault_of_every_topic_is_refused_by_its_decoder(scene_file):
    from iguana_ros.body.model import build_model
    scene = load_scene(str(scene_file))
    ctx = FuzzContext.for_scene(scene)
    model = build_model('coarse')
    rng = np.random.default_rng(7)
    for frame in (0, 200):
        ctx.frame = frame
        for key, kinds in FUZZ_KINDS.items():
            for kind in kinds:
                for _ in range(3):
                    assert _refused(key, fuzz_message(key, kind, ctx, rng), ctx, model), (key, kind, frame)
    plan = fault_plan(200, np.random.default_rng(0))
    pairs = {(k, kind) for k, kinds in FUZZ_KINDS.items() for kind in kinds}
    assert set(plan[:len(pairs)]) == pairs and len(plan) == 200


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.long
@pytest.mark.timeout(240)
def test_a_lockstep_run_under_topic_faults_completes_unchanged(tmp_path, scene_file):
    from iguana_lab.faults.topic_fuzz import fuzz_run
    row = fuzz_run(scene_file, tmp_path / 'bag', seed=0, n_messages=200, timeout=200)
    assert row['nodes_survived'] and row['exit_code'] == 0, row
    assert row['faults_sent'] == 200 and row['faults_during_run'] >= 150, row
    assert set(row['faults_per_topic']) == set(FUZZ_KINDS), row
    assert row['non_finite'] == {} and row['undecodable'] == {} and row['tracebacks'] == 0, row
    assert row['frames_recorded'] == int(SECONDS * FRAME_RATE) + 1 and row['equal_to_library'], row
    assert row['rejected_lines'] >= 100, row   # the nodes said what they refused
    assert row['survived']
