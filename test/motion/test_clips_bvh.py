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

"""The shipped clip library, clip seams, BVH export and the `iguana motion` CLI."""
import numpy as np
import pytest

from iguana_ros.body.skeleton import forward_kinematics, iguana_skeleton
from iguana_ros.cli import main
from iguana_ros.constants import TROT_DUTY_FACTOR, TROT_STRIDE_LENGTH
from iguana_ros.errors import InputError
from iguana_ros.motion.bvh import read_bvh_positions, write_bvh
from iguana_ros.motion.clips import cut_clip, load_clip_library, planar_transform, REQUIRED_CLIPS
from iguana_ros.motion.dofs import iguana_body_model
from iguana_ros.motion.gait import generate_take, SYNTHETIC_TAKES
from iguana_ros.motion.segmentation import detect_contacts, stride_boundaries


@pytest.fixture(scope='module')
def library():
    return load_clip_library()


def test_library_has_the_planner_clips_with_consistent_fields(library):
    assert set(REQUIRED_CLIPS) <= set(library)
    n_bones = iguana_skeleton().n_bones
    for clip in library.values():
        n = clip.n_frames + 1
        assert clip.frame_rate == 30.0
        assert clip.root_positions.shape == (n, 3) and clip.local_rotations.shape == (n, n_bones, 4)
        assert clip.contacts.shape == (n, 4) and clip.contacts.dtype == bool
        assert clip.residual_heights['feet'].shape == (n, 4) and clip.residual_heights['tail_tip'].shape == (n,)
        assert np.allclose(clip.root_positions[0, :2], 0.0)
        assert abs(clip.theta[0, iguana_body_model().dofs.index('root_yaw')]) < 1e-12
        assert np.allclose(np.linalg.norm(clip.local_rotations, axis=-1), 1.0)
        pos, _ = forward_kinematics(iguana_skeleton(), clip.root_positions, clip.local_rotations)
        feet = iguana_skeleton().indices(['foot_fl', 'foot_fr', 'foot_hl', 'foot_hr'])
        assert np.allclose(pos[:, feet, 2], clip.residual_heights['feet'])
        assert clip.stride_length == pytest.approx(np.hypot(*clip.root_displacement))
    for name in ('forward', 'turn_left', 'turn_right'):
        assert library[name].duty_factor == pytest.approx(TROT_DUTY_FACTOR, abs=0.06)
        assert library[name].stride_length == pytest.approx(TROT_STRIDE_LENGTH, rel=0.1)
        assert library[name].n_frames == 20
        # stance feet rest on the capture floor: a few mm of residual height
        stance = library[name].residual_heights['feet'][library[name].contacts]
        assert np.median(stance) == pytest.approx(0.003, abs=0.004)
    assert np.degrees(library['turn_left'].heading_change) > 10.0
    assert np.degrees(library['turn_right'].heading_change) < -10.0
    assert abs(np.degrees(library['forward'].heading_change)) < 3.0
    assert library['idle'].stride_length < 0.01 and library['idle'].contacts.all()


def _seam_jumps(clip):
    """(seam position jump, seam velocity jump, max interior velocity change) of joint positions, m."""
    model = iguana_body_model()
    d = model.dofs
    nxt = planar_transform(clip.theta, clip.theta[0], clip.theta[-1], d)
    assert np.allclose(nxt[0], clip.theta[-1], atol=1e-9)  # the seam pose is shared
    two = np.concatenate([clip.theta, nxt[1:]])
    pos = model.state(two).positions
    vel = np.diff(pos, axis=0)
    dv = np.linalg.norm(np.diff(vel, axis=0), axis=-1).max(axis=1)  # per frame, worst joint
    n = clip.n_frames
    interior = np.concatenate([dv[:n - 3], dv[n + 2:]])
    return dv[n - 1], interior.max()


@pytest.mark.parametrize('name', ['forward', 'turn_left', 'turn_right', 'idle'])
def test_clips_loop_without_a_jump(library, name):
    seam, interior = _seam_jumps(library[name])
    assert seam <= 1.2 * interior + 1e-4  # the velocity change across the seam is like any other frame's


def test_cut_clip_is_cyclic_from_a_clean_take():
    take = generate_take(SYNTHETIC_TAKES[1])
    contacts = detect_contacts(take.markers[:, :4], take.frame_rate)
    b = stride_boundaries(contacts)
    clip = cut_clip('turn', take.theta, contacts, int(b[3]), int(b[4]))
    seam, interior = _seam_jumps(clip)
    assert seam <= 1.2 * interior + 1e-4
    assert np.degrees(clip.heading_change) == pytest.approx(15.0, abs=1.0)
    with pytest.raises(InputError, match='outside the take'):
        cut_clip('bad', take.theta, contacts, 5, 10_000)


def test_bvh_round_trip_matches_forward_kinematics(tmp_path, library):
    skeleton = iguana_skeleton()
    clip = library['turn_left']
    write_bvh(tmp_path / 'c.bvh', skeleton, clip.root_positions, clip.local_rotations, clip.frame_rate)
    names, pos = read_bvh_positions(tmp_path / 'c.bvh')
    ref, _ = forward_kinematics(skeleton, clip.root_positions, clip.local_rotations)
    idx = [int(skeleton.children(skeleton.index(n[:-4]))[0]) if n.endswith('_end') else skeleton.index(n)
           for n in names]
    assert len(names) == skeleton.n_bones
    assert np.abs(pos - ref[:, idx]).max() < 1e-5


def test_cli_inspect_and_export(tmp_path, capsys):
    assert main(['motion', 'inspect']) == 0
    out = capsys.readouterr().out
    for name in REQUIRED_CLIPS:
        assert name in out
    assert 'IK mm RMS' in out
    assert main(['motion', 'export-bvh', 'forward', '-o', str(tmp_path / 'f.bvh'), '--repeat', '2']) == 0
    names, pos = read_bvh_positions(tmp_path / 'f.bvh')
    assert pos.shape[0] == 41
    assert main(['motion', 'export-bvh', 'stand', '-o', str(tmp_path / 's.bvh')]) == 0
    assert main(['motion', 'export-bvh', 'no_such', '-o', str(tmp_path / 'x.bvh')]) == 1
    assert 'no clip or take named' in capsys.readouterr().err
