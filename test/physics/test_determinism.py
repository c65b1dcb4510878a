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
Bitwise determinism across numba compilation: a freshly compiled run equals a cache-loaded run.

One test compiles every kernel once (the frame loop over hills: the simulator's step loop, terrain adaptation's
IK and height-field kernels, skinning) and compares it with the cached run; a second cold compile of the
simulator alone would add ~50 s and check a subset of it.
"""
import json
import os
import subprocess
import sys

import pytest

PIPELINE_SCRIPT = """
import dataclasses, hashlib, json
from iguana_ros.physics import integrator
from iguana_ros.pipeline import run
from iguana_ros.scene import load_scene
scene = load_scene('hills')
scene = dataclasses.replace(scene, duration=0.5, model=dataclasses.replace(scene.model, resolution='coarse'))
result = run(scene)
stats = integrator.run_steps_cg.stats
from iguana_lab.bench.sim import make_scene
sim, gait, _, _ = make_scene('medium', 'balanced', factor_thread='on')   # the factor thread's kernel too
for _ in range(6):
    sim.advance_frame(gait.desired_lengths(sim.time))
implicit, gait, _, _ = make_scene('coarse', 'fast')    # the implicit FEM path (coarse at dt 1/200)
assert implicit.elastic_implicit
for _ in range(30):
    implicit.advance_frame(gait.desired_lengths(implicit.time))
digest = hashlib.sha256(result.node_positions.tobytes() + result.reference_joints.tobytes()
                        + sim.positions.tobytes() + implicit.positions.tobytes()).hexdigest()
print(json.dumps({'end': digest,
                  'moved': bool(abs(result.node_positions[-1] - result.node_positions[0]).max() > 1e-3),
                  'compiled': sum(stats.cache_misses.values()), 'loaded': sum(stats.cache_hits.values())}))
"""


@pytest.mark.long
def test_first_run_after_install_equals_later_runs(tmp_path):
    """
    The whole frame loop over hills runs bitwise the same first with empty numba and model caches, then warm.

    Terrain adaptation's compiled IK and height-field kernels are included, and the coarse body's split FEM
    (`elastic_rates`), the Cholesky factor thread on a medium body and the implicit FEM (coarse, `fast`: a second call
    site of the FEM kernel made its cold and cached runs differ by 4 mm after 2 s); empty caches are as after `make
    install`.
    Issue 12 reported a 2.5e-14 m difference from frame 1 between such runs; it did not reproduce at the commit it was
    filed against (bea95f5) nor since, with the package's own cache or NUMBA_CACHE_DIR, for 1 s or the whole 25 s
    `hills` run; this test keeps it so.
    """
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / 'numba'), IGUANA_CACHE_DIR=str(tmp_path / 'models'))

    def digest():
        done = subprocess.run([sys.executable, '-c', PIPELINE_SCRIPT], env=env, capture_output=True, text=True,
                              timeout=600)
        assert done.returncode == 0, done.stderr[-2000:]
        return json.loads(done.stdout.strip().splitlines()[-1])
    cold = digest()                                 # empty caches: every kernel JIT-compiled in this run
    assert any((tmp_path / 'models').glob('model-coarse-*.npz')), 'the cold run should have built the model'
    warm = digest()                                 # the same kernels loaded from the cache
    assert (cold['compiled'], cold['loaded']) == (1, 0), cold
    assert (warm['compiled'], warm['loaded']) == (0, 1), warm   # really the cached step loop, not a second compile
    assert cold['moved']                                         # the walk moved the body
    assert warm['end'] == cold['end']
