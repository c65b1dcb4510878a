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
`iguana warm` caches what a run asks for.

A fresh process that runs the frame loop of a scene and renders a real bag uses no kernel signature that the warm-up did
not compile (so `make install` leaves nothing to compile).
"""
import json
import os
from pathlib import Path
import subprocess
import sys

import pytest

from iguana_ros.cli import main

REPO = Path(__file__).resolve().parent.parent
RENDER_HELPERS = REPO / 'test' / 'render'

pytestmark = [pytest.mark.slow, pytest.mark.timeout(600)]

_SIGNATURES = 'import json; from iguana_ros.warmup import kernel_signatures; print(json.dumps(kernel_signatures()))'


def _signatures_after(code: str) -> dict:
    """kernel_signatures() of a fresh interpreter after it ran `code`."""
    out = subprocess.run([sys.executable, '-c', f'{code}\n{_SIGNATURES}'], cwd=REPO, capture_output=True, text=True,
                         timeout=500, check=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def test_a_run_and_a_render_need_no_kernel_beyond_the_warm_up(tmp_path):
    warm = _signatures_after('from iguana_ros.warmup import warm_up; warm_up()')
    bag = tmp_path / 'bag'
    used = _signatures_after(
        f'import sys; sys.path.insert(0, {str(RENDER_HELPERS)!r})\n'
        'from render_synthetic import write_synthetic_bag\n'
        f'write_synthetic_bag({str(bag)!r}, duration=0.5)\n'
        'from iguana_ros.pipeline import run\nfrom iguana_ros.scene import parse_scene\n'
        "run(parse_scene({'terrain': {'kind': 'noise', 'seed': 3}, 'goals': [{'x': 1.0, 'y': 1.0}], 'pushes': "
        "[{'at': 0.0, 'force': [0.0, -40.0, 0.0], 'duration': 0.1, 'region': 'trunk_left'}]}), n_frames=4)\n"
        'import numpy as np\nfrom iguana_ros.body.model import build_model\n'
        'from iguana_ros.physics.simulator import SoftBodySimulator\n'
        'from iguana_ros.terrain.heightfield import HeightField\n'
        'import dataclasses\nmodel = build_model("coarse")\n'   # writable copies of its read-only arrays
        'model = dataclasses.replace(model, **{f.name: np.array(getattr(model, f.name))'
        ' for f in dataclasses.fields(model) if isinstance(getattr(model, f.name), np.ndarray)})\n'
        'lengths = np.array(model.spring_rest_lengths)\nlengths.setflags(write=False)\n'   # as decoded from a message
        'push = np.zeros((model.n_nodes, 3))\npush.setflags(write=False)\n'
        "for terrain, friction in ((HeightField.flat(), 0.5), (None, {'default': 0.8})):\n"
        "    sim = SoftBodySimulator(model, terrain, 'balanced', friction=friction)\n"
        '    sim.advance_frame(lengths, push)\n    sim.advance_frame(None)\n'
        "SoftBodySimulator(model, HeightField.flat(), 'balanced', solver='direct').advance_frame(lengths)\n"
        'from iguana_ros.cli import main\n'
        f"assert main(['render', {str(bag)!r}, '-o', {str(tmp_path / 'f.png')!r}, '-q']) == 0\n")
    assert 'iguana_ros.physics.integrator.run_steps_cg' in used and used, used   # the probe saw the simulator
    assert any(k.startswith('iguana_ros.render.') for k in used), used          # ... and the renderer
    missing = {k: sorted(set(v) - set(warm.get(k, []))) for k, v in used.items() if set(v) - set(warm.get(k, []))}
    assert not missing, f'kernels a run compiles that `iguana warm` did not: {missing}'


def test_after_the_warm_up_the_doctor_finds_the_kernel_cache_warm_where_numba_keeps_it(tmp_path):
    """`iguana warm` (as `make install` runs it) into a fresh NUMBA_CACHE_DIR: the doctor, looking there, says warm."""
    numba_dir = tmp_path / 'numba'
    report = ('from iguana_ros.doctor.checks import check_kernel_cache\nfrom iguana_ros.jit import kernel_cache\n'
              'print(repr(kernel_cache().state), check_kernel_cache().lines()[0])')
    env = {**os.environ, 'NUMBA_CACHE_DIR': str(numba_dir)}
    warm = subprocess.run([sys.executable, '-m', 'iguana_ros.cli', 'warm'], cwd=REPO, capture_output=True, text=True,
                          timeout=500, env=env)
    assert warm.returncode == 0, warm.stdout + warm.stderr
    assert any(numba_dir.rglob('*.nbi')), 'numba wrote nothing to NUMBA_CACHE_DIR'
    done = subprocess.run([sys.executable, '-c', report], cwd=REPO, capture_output=True, text=True, timeout=100,
                          env=env, check=True)
    assert done.stdout.startswith("'warm' ✓ kernel cache: warm (13 modules compiled and cached in NUMBA_CACHE_DIR ("), \
        done.stdout


def test_warm_prints_its_figures(capsys):
    assert main(['warm', '--json']) == 0
    report = json.loads(capsys.readouterr().out)
    assert report['kernels'] >= 5 and report['signatures'] >= report['kernels'] and report['loop_s'] > 0
