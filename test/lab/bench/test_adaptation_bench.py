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

"""`iguana bench adaptation`: the trot over the hills scene and a tilted plane, through the CLI."""
import json

from iguana_ros.cli import main


def test_synthetic_trot_on_hills_and_bench_command(capsys):
    """The motion room's trot over the hills scene: stance feet on target, nothing below ground (via the CLI)."""
    assert main(['bench', 'adaptation', '--frames', '20', '--resolution', 'coarse', '--json']) == 0
    figures = json.loads(capsys.readouterr().out)
    assert figures['frames'] == 20
    for terrain in ('hills', 'tilted_12deg'):
        fig = figures[terrain]
        assert fig['stance_foot_error_max_mm'] < 2.0
        assert fig['min_joint_clearance_mm'] > -0.1
        assert 0 < fig['plane_fit_ms'] and 0 < fig['residual_fit_ms'] and 0 < fig['dqs_spring_lengths_ms']
    assert main(['bench', 'adaptation', '--frames', '1']) == 1
    assert 'at least 2' in capsys.readouterr().err
