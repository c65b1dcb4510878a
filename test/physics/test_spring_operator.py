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

"""The matrix-free springs' pass and product against a dense reference, in the model's spring order and shuffled."""
import numpy as np
import pytest

from iguana_ros.physics.forces import spring_forces_operator, spring_operator_matvec

N_NODES, H, SCALE = 30, 1e-3, 2e-6


def _springs(order: str) -> np.ndarray:
    """Return 120 springs `(120, 2)` on 30 nodes: sorted by first node (as the model's), or shuffled."""
    rng = np.random.default_rng(11)
    pairs = {tuple(sorted(rng.choice(N_NODES, 2, replace=False).tolist())) for _ in range(400)}
    springs = np.array(sorted(pairs)[:120], dtype=np.int64)
    if order == 'shuffled':
        springs = springs[rng.permutation(len(springs))]
        springs[::3] = springs[::3, ::-1]            # and some with the larger node first
    return np.ascontiguousarray(springs)


def _dense_stiffness(springs, coef) -> np.ndarray:
    """Return Σ_s K_s on (i, i), (j, j) and −K_s on (i, j), (j, i) as a dense `(3 n, 3 n)` matrix."""
    k = np.zeros((3 * N_NODES, 3 * N_NODES))
    for s, (i, j) in enumerate(springs):
        u, c, g = coef[:3, s], coef[3, s], coef[4, s]
        ks = c * np.outer(u, u) + g * np.eye(3)
        for a, b, sign in ((i, i, 1), (j, j, 1), (i, j, -1), (j, i, -1)):
            k[3 * a:3 * a + 3, 3 * b:3 * b + 3] += sign * ks
    return k


@pytest.mark.parametrize('order', ['sorted', 'shuffled'])
def test_operator_pass_and_product_equal_the_dense_stiffness(order):
    rng = np.random.default_rng(12)
    springs = _springs(order)
    n_s = len(springs)
    x, v, dv = (rng.normal(size=(N_NODES, 3)) * scale for scale in (0.05, 0.3, 0.01))
    stiffness, desired = rng.uniform(1e3, 1e5, n_s), rng.uniform(0.0, 0.08, n_s)
    coef, work = np.zeros((5, n_s)), np.zeros((9, n_s))
    rhs, kdv = np.full((N_NODES, 3), np.nan), np.full((N_NODES, 3), np.nan)    # stale contents must not leak in
    spring_forces_operator(x, v, dv, springs, stiffness, desired, coef, np.zeros((N_NODES, 9)), work, H, rhs, kdv,
                           SCALE)
    k = _dense_stiffness(springs, coef)
    pull = np.zeros((N_NODES, 3))                    # the springs' forces: tension pulls i toward j
    for s, (i, j) in enumerate(springs):
        d = x[j] - x[i]
        length = np.linalg.norm(d)
        f = stiffness[s] * (length - desired[s]) * d / length
        pull[i] += f
        pull[j] -= f
        a = SCALE * stiffness[s]
        g = a * max(0.0, 1.0 - desired[s] / length)
        np.testing.assert_allclose(coef[:, s], [*(d / length), a - g, g], rtol=1e-12)
    np.testing.assert_allclose(rhs.ravel(), H * pull.ravel() - k @ v.ravel(), rtol=1e-10, atol=1e-9)
    np.testing.assert_allclose(kdv.ravel(), k @ dv.ravel(), rtol=1e-10, atol=1e-12)
    node_matrix = rng.normal(size=(N_NODES, 3, 3))
    out = np.full((N_NODES, 3), np.nan)
    spring_operator_matvec(springs, coef, node_matrix, v, out)
    expected = k @ v.ravel() + np.einsum('nij,nj->ni', node_matrix, v).ravel()
    np.testing.assert_allclose(out.ravel(), expected, rtol=1e-10, atol=1e-12)
