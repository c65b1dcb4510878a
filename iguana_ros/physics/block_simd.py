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
SIMD kernels of the 3×3-block Cholesky factor (`iguana_ros.physics.cholesky`), as numba intrinsics in LLVM IR.

A 3×3 block is 9 contiguous float64 (row-major): one 8-lane vector plus a scalar lane. numba's compiler does not
vectorise the blocks' scalar code (measured: the factor's block update ~6 ns, a solve's block ~2.5 ns, the scalar
rate); these intrinsics state the vector operations, which LLVM lowers to the host's SIMD (AVX-512 here, split
into narrower registers elsewhere): on the fine body the factorisation runs 2.2x and the triangular solves 1.3x
faster. The multiply-adds are explicit `llvm.fma` calls, so a kernel rounds the same whether freshly compiled or
loaded from numba's cache (fused multiply-adds chosen by the compiler did not, `iguana_ros.jit.FASTMATH`).

The kernels index raw data: their arrays must be C-contiguous (float64 blocks `(n, 3, 3)`, vectors `(n, 3)`,
int64 indices), which their typing checks.
"""
from __future__ import annotations

from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.core.errors import TypingError
from numba.extending import intrinsic

_F64 = ir.DoubleType()
_V8 = ir.VectorType(_F64, 8)
_I32 = ir.IntType(32)
_I64 = ir.IntType(64)

# lanes of a block's first 8 entries (row-major, lane 3 r + c); lane index 8 in a shuffle is the second operand's
# lane 0, where the block's 9th entry goes
_COLUMN_OF = ([0, 0, 0, 3, 3, 3, 6, 6], [1, 1, 1, 4, 4, 4, 7, 7], [2, 2, 2, 5, 5, 5, 8, 8])   # P[r, k] at lane 3r+c
_TRANSPOSED_COLUMN_OF = ([0, 3, 6, 0, 3, 6, 0, 3], [1, 4, 7, 1, 4, 7, 1, 4], [2, 5, 8, 2, 5, 8, 2, 5])  # B[c, k]
_ROW_PRODUCT_LANES = ([0, 1, 2, 0, 1, 2, 0, 1], ((0, 1, 2), (3, 4, 5), (6, 7, 8)))     # Σ_c B[r, c] w_c
_COLUMN_PRODUCT_LANES = ([0, 0, 0, 1, 1, 1, 2, 2], ((0, 3, 6), (1, 4, 7), (2, 5, 8)))  # Σ_r B[r, c] w_r


def _check_arrays(**arrays) -> None:
    """Raise TypingError unless every array is C-contiguous with the dtype and dimensions the kernels index."""
    wanted = {'blocks': (types.float64, 3), 'vectors': (types.float64, 2), 'indices': (types.int64, 1)}
    for kind, ty in arrays.items():
        dtype, ndim = wanted[kind.rstrip('0123456789')]
        if not (isinstance(ty, types.Array) and ty.layout == 'C' and ty.dtype == dtype and ty.ndim == ndim):
            raise TypingError(f'block_simd: {kind} must be a C-contiguous {ndim}-d {dtype} array, not {ty}')


def _mask(lanes: list) -> ir.Constant:
    """Return the shuffle mask `<8 x i32>` of `lanes`."""
    return ir.Constant(ir.VectorType(_I32, 8), [ir.Constant(_I32, k) for k in lanes])


def _fma(builder: ir.IRBuilder, a, b, c):
    """Return the fused a b + c (`<8 x double>` or double)."""
    ty = a.type
    name = 'llvm.fma.v8f64' if ty == _V8 else 'llvm.fma.f64'
    fn = cgutils.get_or_insert_function(builder.module, ir.FunctionType(ty, [ty, ty, ty]), name)
    return builder.call(fn, [a, b, c])


def _data(context, builder, ty, value):
    """Return the data pointer of array `value` of numba type `ty`."""
    return context.make_array(ty)(context, builder, value).data


def _block(builder: ir.IRBuilder, data, index):
    """Return a pointer to block `index` of a `(n, 3, 3)` float64 array's data."""
    return builder.gep(data, [builder.mul(index, ir.Constant(_I64, 9))])


def _load_block(builder: ir.IRBuilder, ptr) -> tuple:
    """Return (its first 8 entries `<8 x double>`, a vector with its 9th in lane 0) of the block at `ptr`."""
    first = builder.load(builder.bitcast(ptr, _V8.as_pointer()), align=8)
    ninth = builder.load(builder.gep(ptr, [ir.Constant(_I64, 8)]))
    return first, builder.insert_element(ir.Constant(_V8, ir.Undefined), ninth, ir.Constant(_I32, 0)), ninth


def _transposed_columns(builder: ir.IRBuilder, b_ptr) -> tuple:
    """Return the vectors B[c, k] at lane 3 r + c (k = 0, 1, 2) and the scalars B[2, k] of the block at `b_ptr`."""
    bv, b9, _ = _load_block(builder, b_ptr)
    bk = [builder.shuffle_vector(bv, b9, _mask(m)) for m in _TRANSPOSED_COLUMN_OF]
    return bk, [builder.extract_element(bk[k], ir.Constant(_I32, 2)) for k in range(3)]


def _add_times_transposed(builder: ir.IRBuilder, p_ptr, b_columns: tuple, dv, d8, sign: float) -> tuple:
    """Return (dv, d8) + sign P Bᵀ, lanes 3 r + c and the 9th entry, for the block P at `p_ptr` (B: `b_columns`)."""
    bk, b_last = b_columns
    pv, p9, _ = _load_block(builder, p_ptr)
    for k in range(3):
        pk = builder.shuffle_vector(pv, p9, _mask(_COLUMN_OF[k]))
        p2k = builder.load(builder.gep(p_ptr, [ir.Constant(_I64, 6 + k)]))
        if sign < 0:
            pk, p2k = builder.fneg(pk), builder.fneg(p2k)
        dv = _fma(builder, pk, bk[k], dv)
        d8 = _fma(builder, p2k, b_last[k], d8)
    return dv, d8


def _store_block(builder: ir.IRBuilder, ptr, dv, d8) -> None:
    """Store the 8 lanes `dv` and the 9th entry `d8` into the block at `ptr`."""
    builder.store(dv, builder.bitcast(ptr, _V8.as_pointer()), align=8)
    builder.store(d8, builder.gep(ptr, [ir.Constant(_I64, 8)]))


@intrinsic
def update_column(typingctx, values, start, u_dest, lo, hi):
    """values[u_dest[lo + q]] −= values[start + q] values[start]ᵀ for q < hi − lo: a column k into column j."""
    _check_arrays(blocks=values, indices=u_dest)

    def codegen(context, builder, signature, args):
        data = _data(context, builder, signature.args[0], args[0])
        dest = _data(context, builder, signature.args[2], args[2])
        start_, lo_, hi_ = args[1], args[3], args[4]
        b_columns = _transposed_columns(builder, _block(builder, data, start_))
        with cgutils.for_range(builder, builder.sub(hi_, lo_)) as loop:
            d = _block(builder, data, builder.load(builder.gep(dest, [builder.add(lo_, loop.index)])))
            dv, d8 = _load_block(builder, d)[::2]
            dv, d8 = _add_times_transposed(builder, _block(builder, data, builder.add(start_, loop.index)), b_columns,
                                           dv, d8, -1.0)
            _store_block(builder, d, dv, d8)
        return context.get_dummy_value()
    return types.void(values, start, u_dest, lo, hi), codegen


@intrinsic
def scale_column(typingctx, values, lo, hi, factors, j):
    """values[p] ← values[p] factors[j]ᵀ `(3, 3)` for p in [lo, hi): a column of L times its pivot's L_jj⁻ᵀ."""
    _check_arrays(blocks=values, blocks2=factors)

    def codegen(context, builder, signature, args):
        data = _data(context, builder, signature.args[0], args[0])
        b_columns = _transposed_columns(builder, _block(builder, _data(context, builder, signature.args[3], args[3]),
                                                        args[4]))
        zero = ir.Constant(_F64, 0.0)
        with cgutils.for_range(builder, builder.sub(args[2], args[1])) as loop:
            p = _block(builder, data, builder.add(args[1], loop.index))
            dv, d8 = _add_times_transposed(builder, p, b_columns, ir.Constant(_V8, [zero] * 8), zero, 1.0)
            _store_block(builder, p, dv, d8)
        return context.get_dummy_value()
    return types.void(values, lo, hi, factors, j), codegen


def _products(context, builder, data, y_data, count, position_of, other_of, lanes):
    """IR of Σ_q (block position_of(q)) or its transpose times y[other_of(q)] over q < count: three doubles."""
    w_lanes, sums = lanes
    zero = ir.Constant(_F64, 0.0)
    undef = ir.Constant(_V8, ir.Undefined)
    acc_ptr = cgutils.alloca_once_value(builder, ir.Constant(_V8, [zero] * 8))
    acc8_ptr = cgutils.alloca_once_value(builder, zero)
    with cgutils.for_range(builder, count) as loop:
        bv, _, b8 = _load_block(builder, _block(builder, data, position_of(loop.index)))
        w = builder.gep(y_data, [builder.mul(other_of(loop.index), ir.Constant(_I64, 3))])
        wv = undef
        for k in range(3):
            wv = builder.insert_element(wv, builder.load(builder.gep(w, [ir.Constant(_I64, k)])), ir.Constant(_I32, k))
        w2 = builder.extract_element(wv, ir.Constant(_I32, 2))
        wv = builder.shuffle_vector(wv, undef, _mask(w_lanes))
        builder.store(_fma(builder, bv, wv, builder.load(acc_ptr)), acc_ptr)
        builder.store(_fma(builder, b8, w2, builder.load(acc8_ptr)), acc8_ptr)
    acc = builder.load(acc_ptr)
    lane = [builder.extract_element(acc, ir.Constant(_I32, k)) for k in range(8)] + [builder.load(acc8_ptr)]
    return [builder.fadd(builder.fadd(lane[a], lane[b]), lane[c]) for a, b, c in sums]


@intrinsic
def row_products(typingctx, values, positions, columns, y, lo, hi):
    """Return Σ_q values[positions[q]] y[columns[q]] over q in [lo, hi) `(3 floats)`: a row of L times y."""
    _check_arrays(blocks=values, indices=positions, indices2=columns, vectors=y)
    ret = types.UniTuple(types.float64, 3)

    def codegen(context, builder, signature, args):
        data, pos, cols, y_data = (_data(context, builder, signature.args[k], args[k]) for k in range(4))
        lo_ = args[4]

        def at(array):
            return lambda q: builder.load(builder.gep(array, [builder.add(lo_, q)]))
        out = _products(context, builder, data, y_data, builder.sub(args[5], lo_), at(pos), at(cols),
                        _ROW_PRODUCT_LANES)
        return context.make_tuple(builder, ret, out)
    return ret(values, positions, columns, y, lo, hi), codegen


@intrinsic
def column_products(typingctx, values, rows, y, lo, hi):
    """Return Σ_p values[p]ᵀ y[rows[p]] over p in [lo, hi) `(3 floats)`: a column of L, transposed, times y."""
    _check_arrays(blocks=values, indices=rows, vectors=y)
    ret = types.UniTuple(types.float64, 3)

    def codegen(context, builder, signature, args):
        data, row_data, y_data = (_data(context, builder, signature.args[k], args[k]) for k in range(3))
        lo_ = args[3]

        def position(q):
            return builder.add(lo_, q)
        out = _products(context, builder, data, y_data, builder.sub(args[4], lo_), position,
                        lambda q: builder.load(builder.gep(row_data, [position(q)])), _COLUMN_PRODUCT_LANES)
        return context.make_tuple(builder, ret, out)
    return ret(values, rows, y, lo, hi), codegen
