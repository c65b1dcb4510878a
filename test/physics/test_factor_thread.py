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

"""The Cholesky factorisation on a second thread (`Fidelity.factor_thread`): deterministic, bounded age, stoppable."""
import threading
import time

import numpy as np
import pytest

from iguana_lab.bench.workload import gait_for, walk_on_hills
from iguana_ros.body.model import build_model
from iguana_ros.errors import InputError
from iguana_ros.physics import integrator as itg
from iguana_ros.physics.cholesky import block_cholesky
from iguana_ros.physics.factor_thread import factor_lag, FactorThread
from iguana_ros.physics.fidelity import get_fidelity
from iguana_ros.physics.simulator import SoftBodySimulator

FRAMES = 12


@pytest.fixture(scope='module')
def medium():
    return build_model('medium', 'normal')


def _walk(model, frames: int = FRAMES, **overrides) -> SoftBodySimulator:
    """Return a simulator of `model` after `frames` frames of the bench gait on hills (overrides of 'balanced')."""
    return walk_on_hills(model, frames, **overrides)


def _factor_threads() -> list:
    return [t for t in threading.enumerate() if t.name.startswith('iguana-factor')]


def test_a_run_is_the_same_however_the_worker_is_timed(medium, monkeypatch):
    """A worker that factorises at once, normally or 20 ms late: the same positions bit for bit (steps set the plan)."""
    threaded = _walk(medium, factor_thread='on')
    assert threaded._ip[itg.IP_FACTOR_THREAD] and threaded.stats['factorisations'] > FRAMES
    threaded.close()
    off = _walk(medium, factor_thread='off')
    assert not np.array_equal(threaded.positions, off.positions)    # the thread's factors are other (older) ones
    assert np.abs(threaded.positions - off.positions).max() < 2e-3

    def late(job):
        def run(*args):
            time.sleep(0.02)
            return job(*args)
        return run

    original = FactorThread.start
    monkeypatch.setattr('iguana_ros.physics.factor_thread.block_cholesky', late(block_cholesky))
    slow = _walk(medium, factor_thread='on')
    slow.close()
    monkeypatch.undo()

    def inline(self, chol):
        original(self, chol)
        self._job.result()                   # done before the loop goes on
    monkeypatch.setattr(FactorThread, 'start', inline)
    at_once = _walk(medium, factor_thread='on')
    at_once.close()
    np.testing.assert_array_equal(slow.positions, threaded.positions)
    np.testing.assert_array_equal(at_once.positions, threaded.positions)


def test_the_factor_in_use_is_never_older_than_its_window(medium):
    """Step by step: the factor's matrix is at most factor_every + lag − 1 steps old; the worker stops on close."""
    sim = _walk(medium, frames=1, factor_thread='on')
    every, lag = sim.fidelity.factor_every, factor_lag(sim.fidelity.factor_every)
    assert 1 <= lag <= every and sim._ip[itg.IP_FACTOR_LAG] == lag
    gait = gait_for(medium)
    ages = []
    for _ in range(200):
        sim.advance_frame(gait.desired_lengths(sim.time), n_steps=1)
        state = sim._chol.state
        assert state[itg.F_VALID] == 1
        ages.append(int(sim._counters[itg.C_STEP] - 1 - state[itg.F_STEP]))   # the last step's factor
    assert max(ages) <= every + lag - 1 and min(ages) <= lag
    assert _factor_threads()
    sim.close()
    assert not _factor_threads()


def test_a_reset_with_a_factorisation_under_way_starts_afresh(medium):
    """Reset while the worker holds a snapshot: the next frames equal a fresh simulator's, bit for bit."""
    sim = _walk(medium, frames=3, factor_thread='on')
    sim.advance_frame(n_steps=9)                       # a snapshot is out at some step of these
    sim.reset(sim.rest_positions + [0.0, 0.0, 0.03])
    assert sim._chol.state[itg.F_PENDING] == 0
    gait = gait_for(medium)
    for _ in range(3):
        sim.advance_frame(gait.desired_lengths(sim.time))
    fresh = _walk(medium, frames=3, factor_thread='on')
    np.testing.assert_array_equal(sim.positions, fresh.positions)
    sim.close()
    fresh.close()


def test_the_thread_is_opt_in_and_only_for_the_cg_solver(medium):
    """Off by default (no worker, no snapshot storage); 'on' has both; the direct solver has no factor to thread."""
    sim = SoftBodySimulator(medium, None, 'balanced')
    assert not sim._ip[itg.IP_FACTOR_THREAD] and sim._factor_thread is None
    assert sim._chol.snapshot.shape == (0, 3, 3) and not sim.stats['factor_thread']
    on = SoftBodySimulator(medium, None, 'balanced', factor_thread='on')
    assert on._ip[itg.IP_FACTOR_THREAD] and on._factor_thread is not None and on.stats['factor_thread']
    assert on._chol.snapshot.shape == (on.pattern.n_blocks, 3, 3)
    assert not SoftBodySimulator(medium, None, 'balanced', solver='direct', factor_thread='on')._ip[
        itg.IP_FACTOR_THREAD]


def test_a_bad_factor_thread_is_one_clear_error():
    with pytest.raises(InputError, match='factor_thread'):
        get_fidelity('balanced', factor_thread='sometimes')
