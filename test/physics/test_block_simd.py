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

"""The SIMD block kernels of the Cholesky factor against numpy's 3×3 products, and the row structure they read."""
import numba
from numba.core.errors import TypingError
import numpy as np
import pytest

from iguana_ros.physics.block_simd import column_products, row_products, scale_column, update_column
from iguana_ros.physics.cholesky import _row_structure


@numba.njit
def _update(values, start, dest, lo, hi):
    update_column(values, start, dest, lo, hi)


@numba.njit
def _scale(values, lo, hi, factors, j):
    scale_column(values, lo, hi, factors, j)


@numba.njit
def _rows(values, positions, columns, y, lo, hi):
    return row_products(values, positions, columns, y, lo, hi)


@numba.njit
def _columns(values, rows, y, lo, hi):
    return column_products(values, rows, y, lo, hi)


@pytest.fixture
def blocks():
    """Return 40 random 3×3 blocks with entries of mixed sign and magnitude."""
    rng = np.random.default_rng(7)
    return rng.normal(size=(40, 3, 3)) * rng.choice([1e-3, 1.0, 1e4], size=(40, 1, 1))


def test_update_column_subtracts_each_block_times_the_first_transposed(blocks):
    values = blocks.copy()
    dest = np.array([0, 0, 30, 31, 33, 35, 37, 39], dtype=np.int64)    # values[10 + q] land at dest[2 + q]
    _update(values, 10, dest, 2, 8)
    expected = blocks.copy()
    for q in range(6):
        expected[dest[2 + q]] -= blocks[10 + q] @ blocks[10].T
    np.testing.assert_allclose(values, expected, rtol=1e-13, atol=1e-9)
    untouched = np.setdiff1d(np.arange(40), dest[2:])
    assert np.array_equal(values[untouched], blocks[untouched])     # the 9th entry and no neighbour overwritten


def test_update_column_of_no_blocks_changes_nothing(blocks):
    values = blocks.copy()
    _update(values, 5, np.array([1, 2], dtype=np.int64), 1, 1)
    assert np.array_equal(values, blocks)


def test_scale_column_multiplies_by_the_transposed_factor(blocks):
    values = blocks.copy()
    factors = np.tril(blocks[:4])
    _scale(values, 3, 9, factors, 2)
    expected = blocks.copy()
    expected[3:9] = blocks[3:9] @ factors[2].T
    np.testing.assert_allclose(values, expected, rtol=1e-13, atol=1e-9)
    assert np.array_equal(values[9:], blocks[9:]) and np.array_equal(values[:3], blocks[:3])


def test_row_and_column_products_sum_blocks_times_gathered_vectors(blocks):
    y = np.random.default_rng(3).normal(size=(12, 3))
    positions = np.array([4, 17, 2, 33, 8], dtype=np.int64)
    others = np.array([11, 0, 5, 5, 9], dtype=np.int64)
    expected_rows = sum(blocks[p] @ y[o] for p, o in zip(positions[1:4], others[1:4]))
    np.testing.assert_allclose(_rows(blocks, positions, others, y, 1, 4), expected_rows, rtol=1e-13)
    rows = np.arange(40, dtype=np.int64) % 12
    expected_columns = sum(blocks[p].T @ y[rows[p]] for p in range(6, 29))
    np.testing.assert_allclose(_columns(blocks, rows, y, 6, 29), expected_columns, rtol=1e-13)
    assert _columns(blocks, rows, y, 3, 3) == (0.0, 0.0, 0.0)


def test_kernels_refuse_arrays_they_cannot_index_raw(blocks):
    with pytest.raises(TypingError, match='C-contiguous'):
        _update(blocks[::2], 0, np.zeros(4, dtype=np.int64), 0, 1)       # strided blocks
    with pytest.raises(TypingError, match='int64'):
        _columns(blocks, np.zeros(40, dtype=np.int32), np.zeros((12, 3)), 0, 1)


def test_row_structure_lists_every_block_below_the_diagonal_once_by_row_then_column():
    l_ptr = np.array([0, 3, 5, 7, 8], dtype=np.int64)                 # columns 0..3 of a 4-node factor
    l_rows = np.array([0, 1, 3, 1, 2, 2, 3, 3], dtype=np.int64)
    rows = _row_structure(l_ptr, l_rows)
    assert rows['r_ptr'].tolist() == [0, 0, 1, 2, 4]
    assert rows['r_pos'].tolist() == [1, 4, 2, 6]                     # (1, 0); (2, 1); (3, 0), (3, 2)
    assert rows['r_col'].tolist() == [0, 1, 0, 2]
