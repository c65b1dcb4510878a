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

"""`iguana bench sim` reports the promised JSON keys with sane values; bad arguments fail clearly."""
import json

import pytest

from iguana_ros.cli import main


def test_bench_sim_json_keys(capsys):
    assert main(['bench', 'sim', '--mesh', 'coarse', '--seconds', '0.2', '--dt', '1/1200', '--json']) == 0
    result = json.loads(capsys.readouterr().out)
    for key in ('realtime_factor', 'ms_per_step', 'nodes', 'tets', 'springs', 'peak_rss_mb', 'compile_s'):
        assert key in result
    assert result['steps'] == 240 and result['dt'] == pytest.approx(1 / 1200)
    assert result['realtime_factor'] > 0 and result['ms_per_step'] > 0 and 0 < result['peak_rss_mb'] < 2000
    assert result['nodes'] > 50 and result['tets'] > result['nodes'] / 2 and result['springs'] > result['nodes']


def test_bench_sim_rejects_bad_time_step(capsys):
    with pytest.raises(SystemExit) as exc:
        main(['bench', 'sim', '--dt', '1/0'])
    assert exc.value.code == 2 and 'time step' in capsys.readouterr().err


def test_bench_sim_solver_knobs_reach_the_simulator(capsys):
    """--factor-every / --polar-iters are applied and reported; factorisations follow the reuse interval."""
    argv = ['bench', 'sim', '--mesh', 'coarse', '--seconds', '0.1', '--json']
    assert main(argv + ['--factor-every', '1', '--polar-iters', '3']) == 0
    fresh = json.loads(capsys.readouterr().out)
    assert main(argv + ['--factor-every', '8']) == 0
    reused = json.loads(capsys.readouterr().out)
    assert (fresh['factor_every'], fresh['polar_iters'], reused['factor_every']) == (1, 3, 8)
    assert fresh['factorisations_per_step'] == pytest.approx(1.0)
    assert reused['factorisations_per_step'] < 0.6
    assert fresh['cg_iterations_per_step'] < reused['cg_iterations_per_step'] <= 3.0


def test_bench_sim_profile_splits_a_step_into_its_parts():
    """`iguana bench sim --profile`: every part timed; the parts a step runs account for most of a whole step's time."""
    from iguana_lab.bench.sim import bench_sim

    result = bench_sim('coarse', seconds=0.2, profile=True)
    parts = result['profile_us']
    per_step = {name: us for name, us in parts.items() if name.startswith('per_step_')}
    assert {'per_step_elastic', 'per_step_springs', 'per_step_cg', 'per_step_cholesky_factor',
            'per_step_factor_rotation', 'per_step_other'} <= set(per_step)
    assert result['factor_rotation_every'] == 4 and 0 < parts['per_step_factor_rotation'] < parts['factor_rotation']
    assert result['elastic_fast_tets'] > 0 and parts['per_step_matvec_pair'] == 0.0   # coarse: split, matrix-free
    assert parts['per_step_elastic'] < 0.6 * parts['elastic_forces']                # 164 of 411 tets per step
    assert all(us > 0 for name, us in parts.items() if name not in ('per_step_other', 'per_step_matvec_pair'))
    named = sum(us for name, us in per_step.items() if name != 'per_step_other')
    assert 0.5 * parts['step'] < named < 1.5 * parts['step']       # a part left out or timed wrongly shows here
