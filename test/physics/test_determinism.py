"""Bitwise determinism across numba compilation: a freshly compiled run equals a cache-loaded run."""
import hashlib
import os
import subprocess
import sys

SCRIPT = '''
import hashlib
from iguana_ros.physics.benchmarks import make_scene
from iguana_ros.physics.scenes import run_gait
sim, gait, _, _ = make_scene('coarse')
run_gait(sim, gait, 0.2)
print(hashlib.sha256(sim.positions.tobytes() + sim.velocities.tobytes()).hexdigest())
'''


def _state_digest(cache_dir) -> str:
    """SHA-256 of the final state of a 0.2 s coarse gait run in a fresh interpreter using `cache_dir` for numba."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache_dir))
    done = subprocess.run([sys.executable, '-c', SCRIPT], env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    return done.stdout.strip().splitlines()[-1]


def test_fresh_compile_and_cached_kernels_give_the_same_state(tmp_path):
    cold = _state_digest(tmp_path)                  # empty cache: every kernel JIT-compiled in this run
    assert any(tmp_path.rglob('*.nbc')), 'the cold run should have filled the numba cache'
    warm = _state_digest(tmp_path)                  # the same kernels loaded from the cache
    assert cold == warm
    assert len(cold) == len(hashlib.sha256().hexdigest())
