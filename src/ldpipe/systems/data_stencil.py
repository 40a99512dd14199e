"""The 4 x 4 x 4 tensor-product sum of the velocity-data kernel, as vector instructions.

The kernel of gridded velocity data (``kernels/gridded_velocity.py``) weighs the (u, v) of 4 x 4
nodes at 4 time levels by separable weights wx[a] wy[b] wt[c]. Its buffer holds a node's (u, v)
at consecutive time levels side by side, so the 8 values a node gives are contiguous:
``stencil_velocity`` loads each as one vector of 8 doubles and contracts x, then y, then t,
then the pairs (u, v) apart:

    R_b = sum_a wx[a] D[b, a]      (16 vector products, the rows)
    S   = sum_b wy[b] R_b          (4 more)
    (u, v) = sum_c wt[c] S[c]      (one product and two pairwise sums)

numba does not vectorize straight-line code (its SLP vectorizer is off by default) and its loop
vectorizer does not reorder floating-point sums (no fastmath), so the vectors are written here as
LLVM IR. The additions are separate IEEE multiplications and additions (no contraction to fused
multiply-adds), the same in every function the kernel is inlined into. Against the scalar sum
over (c, b) of wt[c] wy[b] sum_a wx[a] D the order of the additions differs: the values agree
to rounding.

This module's text is part of every data kernel's cache key (``SOURCE_DIGEST``), as
:mod:`ldpipe.systems.data_pointer`'s is.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

from llvmlite import ir
from numba import types
from numba.extending import intrinsic

#: Doubles a node gives: (u, v) at 4 time levels.
NODE_VALUES = 8
SOURCE_DIGEST = hashlib.sha256(Path(__file__).read_bytes()).hexdigest()[:20]


@intrinsic
def stencil_velocity(typingctx, pointer, first, x_step, y_step, wx, wy, wt):
    """(u, v): the sum over a, b, c < 4 of wx[a] wy[b] wt[c] (u, v)[first + b y_step + a x_step + 2 c]
    of the doubles at ``pointer`` (offsets in doubles; wx, wy, wt tuples of 4 floats)."""
    if not (isinstance(pointer, types.CPointer) and pointer.dtype == types.float64):
        return None
    for weights in (wx, wy, wt):
        if not (isinstance(weights, types.UniTuple) and weights.count == 4 and weights.dtype == types.float64):
            return None
    signature = types.UniTuple(types.float64, 2)(pointer, types.int64, types.int64, types.int64, wx, wy, wt)

    def codegen(context, builder, signature, args):
        base, first, x_step, y_step, wx, wy, wt = args
        i32, i64 = ir.IntType(32), ir.IntType(64)
        vector = ir.VectorType(ir.DoubleType(), NODE_VALUES)
        undefined = ir.Constant(vector, ir.Undefined)

        def splat(value):
            single = builder.insert_element(undefined, value, ir.Constant(i32, 0))
            return builder.shuffle_vector(single, undefined, ir.Constant(ir.VectorType(i32, NODE_VALUES), [0] * 8))

        def halves(value, count):
            """The first and second ``count`` lanes of ``value``, summed."""
            low = ir.Constant(ir.VectorType(i32, count), list(range(count)))
            high = ir.Constant(ir.VectorType(i32, count), list(range(count, 2 * count)))
            spare = ir.Constant(value.type, ir.Undefined)
            return builder.fadd(builder.shuffle_vector(value, spare, low), builder.shuffle_vector(value, spare, high))

        wx_at = [splat(builder.extract_value(wx, a)) for a in range(4)]
        total = None
        for b in range(4):
            row = builder.add(first, builder.mul(y_step, ir.Constant(i64, b)))
            along_x = None
            for a in range(4):
                at = builder.add(row, builder.mul(x_step, ir.Constant(i64, a)))
                node = builder.load(builder.bitcast(builder.gep(base, [at]), vector.as_pointer()), align=8)
                term = builder.fmul(wx_at[a], node)
                along_x = term if along_x is None else builder.fadd(along_x, term)
            term = builder.fmul(splat(builder.extract_value(wy, b)), along_x)
            total = term if total is None else builder.fadd(total, term)
        time_weights = undefined
        for lane in range(NODE_VALUES):  # (u, v) of level c: lanes 2c, 2c + 1
            time_weights = builder.insert_element(time_weights, builder.extract_value(wt, lane // 2),
                                                  ir.Constant(i32, lane))
        pair = halves(halves(builder.fmul(total, time_weights), 4), 2)  # levels (0 + 2) + (1 + 3), for u and v
        u = builder.extract_element(pair, ir.Constant(i32, 0))
        v = builder.extract_element(pair, ir.Constant(i32, 1))
        return context.make_tuple(builder, signature.return_type, [u, v])

    return signature, codegen
