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
Statics diagnostics (iguana_lab.diagnostics, `iguana bench statics`).

Support margins follow the geometry of the COM and the support line, springs' bending capacity is linear in their
stiffness, a stiffer body sags less, the CLI reports every part as valid JSON and rejects bad arguments.
"""
import dataclasses
import json
import math
from types import SimpleNamespace

import numpy as np
import pytest

from iguana_lab.diagnostics import (inside_triangle, line_margin, mid_diagonal_frame, model_variant,
                                    spring_capacity, static_sag, stiffness_summary, support_margins)
from iguana_ros.body.model import build_model
from iguana_ros.cli import main
from iguana_ros.constants import GRAVITY
from iguana_ros.motion.clips import load_clip_library


@pytest.fixture(scope='module')
def coarse():
    return build_model('coarse')


@pytest.fixture(scope='module')
def forward():
    return load_clip_library()['forward']


def _normal(row: dict) -> np.ndarray:
    """Return unit normal of a row's support line toward the swinging hind foot (behind the line: -x; hl is +y)."""
    s, c = abs(math.sin(row['line_angle_rad'])), abs(math.cos(row['line_angle_rad']))
    return np.array([-s, c if row['stance'] == 'fl+hr' else -c])


def test_line_margin_and_triangle_geometry():
    margin = line_margin((0.0, 1.0), (0.0, 0.0), (2.0, 0.0), (5.0, 3.0))
    assert margin['distance'] == pytest.approx(1.0) and margin['angle'] == pytest.approx(0.0)
    assert line_margin((0.0, 1.0), (0.0, 0.0), (2.0, 0.0), (5.0, -3.0))['distance'] == pytest.approx(-1.0)
    assert line_margin((1.0, 0.0), (0.0, 0.0), (-1.0, -1.0), (0.0, 1.0))['angle'] == pytest.approx(math.pi / 4)
    assert (inside_triangle((0.2, 0.2), (0, 0), (1, 0), (0, 1))
            and not inside_triangle((0.8, 0.8), (0, 0), (1, 0), (0, 1)))


def test_support_margins_of_the_shipped_forward_clip(coarse, forward):
    result = support_margins(coarse, forward)
    flags = np.asarray(forward.contacts, bool)
    diagonal = [i for i, f in enumerate(flags) if tuple(f) in ((True, False, False, True), (False, True, True, False))]
    assert result['diagonal_frames'] == len(diagonal) > 0 and [r['frame'] for r in result['rows']] == diagonal
    assert result['distance_mean_m'] > 0                   # the COM lies behind the diagonal support line
    assert result['distance_min_m'] <= result['distance_mean_m'] <= result['distance_max_m']
    assert 0.0 <= result['inside_tail_triangle_fraction'] <= 1.0
    assert result['weight_n'] == pytest.approx(coarse.node_mass.sum() * GRAVITY)
    assert mid_diagonal_frame(forward) in diagonal


def test_moving_the_mass_forward_moves_the_com_toward_the_line(coarse, forward):
    """
    Mass re-weighted along x moves the COM ~1 cm forward.

    Each frame's distance changes by -Δx |sin(angle)| plus the lateral part n_y Δy (the posed tail swings sideways, so
    Δy is a few mm).
    """
    x = coarse.rest_positions[:, 0]
    x_mean = coarse.node_mass @ x / coarse.node_mass.sum()
    shifted = dataclasses.replace(coarse, node_mass=coarse.node_mass * (1.0 + 0.8 * (x - x_mean)))
    before, after = support_margins(coarse, forward)['rows'], support_margins(shifted, forward)['rows']
    shifts = np.array([np.subtract(b['com_m'], a['com_m']) for a, b in zip(before, after)])
    assert shifts[:, 0].min() > 0.005 and np.ptp(shifts[:, 0]) < 0.1 * shifts[:, 0].mean()
    for a, b, shift in zip(before, after, shifts):
        expected = -shift[0] * abs(math.sin(a['line_angle_rad'])) + _normal(a)[1] * shift[1]
        assert b['distance_m'] - a['distance_m'] == pytest.approx(expected, abs=1e-9)
        assert b['distance_m'] < a['distance_m']


def _made_up_body(skeleton, half_length=0.1, half_width=0.06, tail_x=-0.3, head_shift=0.0):
    """
    Return a point-symmetric body of the real skeleton (every node skinned rigidly to the pelvis).

    Four feet of 3 sole nodes at (±a, ±b), a tail node at (tail_x, 0) and a head node at (-tail_x + head_shift, 0), all
    1 kg.
    """
    feet = {}
    nodes = []
    for name, sx, sy in (('foot_fl', 1, 1), ('foot_fr', 1, -1), ('foot_hl', -1, 1), ('foot_hr', -1, -1)):
        centre = np.array([sx * half_length, sy * half_width, 0.0])
        feet[name] = range(len(nodes), len(nodes) + 3)
        nodes += [centre + d for d in ((0.01, 0, 0), (-0.005, 0.008, 0), (-0.005, -0.008, 0))]
    nodes += [np.array([tail_x, 0.0, 0.01]), np.array([-tail_x + head_shift, 0.0, 0.01])]
    n = len(nodes)
    tags = {name: np.isin(np.arange(n), list(idx)) for name, idx in feet.items()}
    tags['tail'] = np.arange(n) == n - 2
    model = SimpleNamespace(rest_positions=np.array(nodes), node_mass=np.ones(n), node_tags=tags,
                            skin_bones=np.zeros((n, 1), np.int64), skin_weights=np.ones((n, 1)),
                            springs=np.zeros((0, 2), np.int64), skeleton=skeleton)
    root, local = skeleton.rest_pose()
    clip = SimpleNamespace(name='made_up', root_positions=np.array([root, root]),
                           local_rotations=np.array([local, local]),
                           contacts=np.array([[1, 0, 0, 1], [0, 1, 1, 0]], bool))
    return model, clip


def test_symmetric_body_has_its_com_on_both_diagonals(coarse):
    model, clip = _made_up_body(coarse.skeleton)
    result = support_margins(model, clip)
    assert result['diagonal_frames'] == 2
    assert [r['distance_m'] for r in result['rows']] == pytest.approx([0.0, 0.0], abs=1e-9)


@pytest.mark.parametrize('head_shift', [0.05, -0.05])
def test_com_shift_changes_the_margin_by_dx_sin_angle_and_sets_the_tail_load(coarse, head_shift):
    """
    Moving the head by h moves the COM by h / 14 along x.

    Margin -Δx sin θ; the tail triangle needs W Δx / c on the tail (moment about the diagonal, lever c sin θ), and holds
    the COM only when it moved backward.
    """
    model, clip = _made_up_body(coarse.skeleton, half_length=0.1, half_width=0.06, tail_x=-0.3,
                                head_shift=head_shift)
    result = support_margins(model, clip)
    dx = head_shift / 14.0
    theta = math.atan2(0.06, 0.1)
    weight = 14 * GRAVITY
    for row in result['rows']:
        assert row['distance_m'] == pytest.approx(-dx * math.sin(theta), abs=1e-9)
        assert abs(row['line_angle_rad']) == pytest.approx(theta, abs=1e-9)
        assert row['tail_lever_m'] == pytest.approx(0.3 * math.sin(theta), abs=1e-9)
        assert row['tail_load_n'] == pytest.approx(-weight * dx / 0.3, rel=1e-9)
        assert row['inside_tail_triangle'] == (dx < 0)


def test_model_variant_rebuilds_the_spring_stiffness(coarse):
    assert model_variant(coarse) is coarse
    old = stiffness_summary(model_variant(coarse, 0.1, 10.0))
    now = stiffness_summary(coarse)
    assert old['spring_a_n_per_m'] == pytest.approx(0.1 * now['spring_a_n_per_m'])
    assert old['leg_factor'] == pytest.approx(10.0) and now['leg_factor'] == pytest.approx(3.0)


def test_spring_capacity_is_linear_in_the_stiffness(coarse):
    base, doubled = spring_capacity(coarse), spring_capacity(model_variant(coarse, 2.0))
    legs = spring_capacity(model_variant(coarse, leg_factor=30.0))
    assert [r['plane'] for r in base] == ['pelvis', 'mid_trunk', 'tail_base']
    for b, d, g in zip(base, doubled, legs):
        assert b['springs'] > 0 and b['gravity_moment_nm'] > 0 and d['gravity_moment_nm'] == b['gravity_moment_nm']
        assert d['spring_moment_nm'] == pytest.approx(2 * b['spring_moment_nm'], rel=1e-12)
        assert d['required_strain_percent'] == pytest.approx(b['required_strain_percent'] / 2, rel=1e-12)
        assert d['main_body_spring_moment_nm'] == pytest.approx(2 * b['main_body_spring_moment_nm'], rel=1e-12)
        # the leg factor leaves the main-body springs alone
        assert g['main_body_spring_moment_nm'] == pytest.approx(b['main_body_spring_moment_nm'], rel=1e-12)
    assert spring_capacity(coarse, [0.0])[0]['spring_moment_nm'] == pytest.approx(base[0]['spring_moment_nm'])


def test_a_stiffer_body_sags_less(coarse):
    soft = static_sag(model_variant(coarse, 0.1), seconds=1.0)
    stiff = static_sag(model_variant(coarse, 10.0), seconds=1.0)
    assert soft['offset_m']['pelvis'] < 0 and soft['offset_m']['pelvis'] < stiff['offset_m']['pelvis']
    for run in (soft, stiff):
        assert run['ground_load_n']['total'] == pytest.approx(run['weight_n'], rel=0.05)
        assert set(run['offset_m']) >= {'pelvis', 'mid_trunk', 'shoulders', 'head', 'tail_base', 'tail_tip',
                                        'foot_hl', 'foot_hr'}


def _no_nan(text: str):
    raise AssertionError(f'{text} in the JSON output')


def test_cli_json_has_every_part(capsys):
    assert main(['bench', 'statics', '--mesh', 'coarse', '--seconds', '0.5', '--json']) == 0
    report = json.loads(capsys.readouterr().out, parse_constant=_no_nan)
    assert {'model', 'support', 'sag', 'sag_diagonal', 'springs', 'planted', 'wall_s'} <= set(report)
    assert report['model']['resolution'] == 'coarse' and report['support']['distance_mean_m'] > 0
    assert report['planted']['frames'] > 0 and set(report['planted']['feet']) == {
        'foot_fl', 'foot_fr', 'foot_hl', 'foot_hr'}
    assert report['sag']['seconds'] == pytest.approx(0.25, abs=1 / 30) and len(report['springs']) == 3


@pytest.mark.parametrize('argv, message', [(['--spring-scale', '-1'], 'spring scale'),
                                           (['--leg-factor', 'stiff'], 'leg factor'),
                                           (['--seconds', '0'], 'seconds'),
                                           (['--mesh', 'huge'], 'invalid choice')])
def test_cli_rejects_bad_arguments(capsys, argv, message):
    with pytest.raises(SystemExit) as exc:
        main(['bench', 'statics'] + argv)
    assert exc.value.code == 2 and message in capsys.readouterr().err
