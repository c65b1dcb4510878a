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

"""Bitwise determinism across numba compilation: a freshly compiled run equals a cache-loaded run."""
import json
import os
import subprocess
import sys

SCRIPT = """
import hashlib, json
from iguana_ros.physics import integrator
from iguana_ros.bench.sim import make_scene
from iguana_ros.bench.workload import run_gait
sim, gait, _, _ = make_scene('coarse')
start = hashlib.sha256(sim.positions.tobytes() + sim.velocities.tobytes()).hexdigest()
run_gait(sim, gait, 0.2)
stats = integrator.run_steps_cg.stats
print(json.dumps({'start': start, 'end': hashlib.sha256(sim.positions.tobytes() + sim.velocities.tobytes()).hexdigest(),
                  'compiled': sum(stats.cache_misses.values()), 'loaded': sum(stats.cache_hits.values())}))
"""


def _gait_run(cache_dir) -> dict:
    """
    Return a 0.2 s coarse gait run in a fresh interpreter using `cache_dir` for numba.

    SHA-256 of its start and end state, and how many signatures of the step loop (`run_steps_cg`) it compiled and loaded
    from the cache.
    """
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache_dir))
    done = subprocess.run([sys.executable, '-c', SCRIPT], env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_fresh_compile_and_cached_kernels_give_the_same_state(tmp_path):
    cold = _gait_run(tmp_path)                      # empty cache: every kernel JIT-compiled in this run
    warm = _gait_run(tmp_path)                      # the same kernels loaded from the cache
    assert (cold['compiled'], cold['loaded']) == (1, 0), cold
    assert (warm['compiled'], warm['loaded']) == (0, 1), warm   # really the cached code, not a second compile
    assert cold['end'] != cold['start']                          # the gait moved the body
    assert cold['end'] == warm['end']


PIPELINE_SCRIPT = """
import dataclasses, hashlib
from iguana_ros.pipeline import run
from iguana_ros.scene import load_scene
scene = load_scene('hills')
scene = dataclasses.replace(scene, duration=0.5, model=dataclasses.replace(scene.model, resolution='coarse'))
result = run(scene)
print(hashlib.sha256(result.node_positions.tobytes() + result.reference_joints.tobytes()).hexdigest())
"""


def test_first_run_after_install_equals_later_runs(tmp_path):
    """
    The whole frame loop over hills (terrain adaptation's compiled IK and height-field kernels included).

    first with empty numba and model caches -- as after `make install` -- then warm, bitwise. Issue 12 reported a
    2.5e-14 m difference from frame 1 between such runs; it did not reproduce at the commit it was filed against
    (bea95f5) nor since, with the package's own cache or NUMBA_CACHE_DIR, for 1 s or the whole 25 s `hills` run; this
    test keeps it so.
    """
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / 'numba'), IGUANA_CACHE_DIR=str(tmp_path / 'models'))

    def digest():
        done = subprocess.run([sys.executable, '-c', PIPELINE_SCRIPT], env=env, capture_output=True, text=True,
                              timeout=600)
        assert done.returncode == 0, done.stderr[-2000:]
        return done.stdout.strip().splitlines()[-1]
    cold = digest()
    assert any((tmp_path / 'models').glob('model-coarse-*.npz')), 'the cold run should have built the model'
    assert digest() == cold
