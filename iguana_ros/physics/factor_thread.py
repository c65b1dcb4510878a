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
The Cholesky preconditioner's factorisation on a second thread, beside the step loop (a large body's largest cost).

The step loop (`integrator.run_steps_cg` with `IP_FACTOR_THREAD`) copies the matrix of a step whose factor is due by
age or the amortised budget into `CholeskyFactor.snapshot` and returns; `FactorThread.start` factorises it into spare
storage on a worker thread (`block_cholesky` releases the GIL) while the loop goes on with the current factor;
`factor_lag` steps after the snapshot the loop returns again and `FactorThread.swap` waits for the worker and puts the
new factor in place. The schedule is the step and iteration counts' alone, so a run is bit for bit the same however
the threads are timed.
"""
from __future__ import annotations

from concurrent.futures import Future, ThreadPoolExecutor

import numpy as np

from iguana_ros.physics import integrator as itg
from iguana_ros.physics.cholesky import block_cholesky, CholeskyFactor, CholeskyPattern
from iguana_ros.physics.factor_rotation import anchor_factor


FACTOR_LAG_FRACTION = 0.5
"""Steps from a snapshot to its factor's use, as a fraction of `factor_every` (see `factor_lag`)."""


def factor_lag(factor_every: int) -> int:
    """Return the steps the worker has for a factorisation: a factor is then `lag` to `factor_every + lag - 1` old."""
    return max(1, int(round(FACTOR_LAG_FRACTION * factor_every)))


class FactorThread:
    """Worker that factorises a CholeskyFactor's snapshot into spare storage and swaps it in when due."""

    def __init__(self, pattern: CholeskyPattern) -> None:
        self._spare_values = np.zeros((pattern.n_factor_blocks, 3, 3))
        self._spare_diag_inv = np.zeros((pattern.n_nodes, 3, 3))
        self._executor: ThreadPoolExecutor | None = None
        self._job: Future | None = None

    def start(self, chol: CholeskyFactor) -> None:
        """Begin factorising `chol.snapshot` (the loop returned STATUS_FACTOR_REQUEST)."""
        if self._executor is None:
            self._executor = ThreadPoolExecutor(max_workers=1, thread_name_prefix='iguana-factor')
        self._job = self._executor.submit(block_cholesky, chol.pattern, chol.snapshot, self._spare_values,
                                          self._spare_diag_inv)

    def swap(self, chol: CholeskyFactor, counters: np.ndarray) -> CholeskyFactor:
        """
        Return `chol` with the worker's factor in place (the loop returned STATUS_FACTOR_SWAP); waits for it.

        A failed factorisation (a pivot not positive definite) keeps the current factor and counts the failure; a
        factor refactorised in the loop since the snapshot (after a slow or failed solve) is newer and stays.
        """
        valid = bool(self._job.result()) if self._job is not None else False
        self._job = None
        state = chol.state
        pending_step = int(state[itg.F_PENDING_STEP])
        state[itg.F_PENDING] = 0
        counters[itg.C_FACTORS] += 1
        if not valid:
            counters[itg.C_FACTOR_FAILS] += 1
            return chol
        if state[itg.F_VALID] > 0 and state[itg.F_STEP] >= pending_step:
            return chol
        values, diag_inv = self._spare_values, self._spare_diag_inv
        self._spare_values, self._spare_diag_inv = chol.values, chol.diag_inv
        state[itg.F_VALID] = 1
        state[itg.F_STEP] = pending_step
        state[itg.F_LAST_ITERS] = 0
        state[itg.F_EXTRA_ITERS] = 0
        if chol.cluster_quats.shape[0]:
            anchor_factor(chol.snapshot_anchor, chol)       # the new factor's rotations start from its snapshot
        return chol._replace(values=values, diag_inv=diag_inv)

    def cancel(self, chol: CholeskyFactor) -> None:
        """Wait for any factorisation under way and forget it (the body was reset)."""
        if self._job is not None:
            self._job.result()
            self._job = None
        chol.state[itg.F_PENDING] = 0

    def close(self) -> None:
        """Stop the worker thread (after any factorisation under way)."""
        if self._executor is not None:
            self._executor.shutdown(wait=True)
            self._executor = None
        self._job = None
