"""Template: ``inverse_root(x, inverse_m)`` = x ** (-inverse_m) for x > 0, in arithmetic that vectorizes.

numba has no vector ``pow`` here (no SVML), so a ``**`` in a lane loop is a scalar call per
lane (measured: 56 cycles each) and keeps the whole loop scalar. This one is a handful of
multiplications on the float's bits: x = 2^e m with m in [sqrt(1/2), sqrt(2)),
ln m = 2 atanh((m - 1) / (m + 1)) by its series (|z| <= 0.172, six terms: error < 1e-11),
then exp(-inverse_m ln x) = 2^n exp(r), |r| <= ln(2) / 2, by Taylor to degree 12 (error
< 1e-14). Relative error under 1e-10: meant for step-size rules, where it is far inside the
safety factor. A subnormal x is scaled first; 0 gives 2^(1074 inverse_m) (large, finite),
inf and NaN give finite nonsense (callers guard them).
"""
# ruff: noqa: F821  (njit and JIT come from the generated header)

from llvmlite import ir
from numba.core import types
from numba.extending import intrinsic

LN2 = 0.6931471805599453
SQRT2 = 1.4142135623730951
MANTISSA = 0x000FFFFFFFFFFFFF
ONE_BITS = 0x3FF0000000000000
TINY = 2.2250738585072014e-308  # the smallest normal float
SCALE = 18014398509481984.0  # 2^54
EXP_TAYLOR = (1.0, 1.0, 0.5, 0.16666666666666666, 0.041666666666666664, 0.008333333333333333, 0.001388888888888889, 0.0001984126984126984, 2.48015873015873e-05, 2.7557319223985893e-06, 2.755731922398589e-07, 2.505210838544172e-08, 2.08767569878681e-09)  # 1 / k!


@intrinsic
def _bits(typingctx, x):
    """The bits of a float64 as an int64 (a bitcast; vectorizes)."""

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.IntType(64))

    return types.int64(types.float64), codegen


@intrinsic
def _float(typingctx, i):
    """The float64 of the bits in an int64 (a bitcast)."""

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.DoubleType())

    return types.float64(types.int64), codegen


@njit(**JIT)
def inverse_root(x, inverse_m):
    small = x < TINY
    y = x * SCALE if small else x
    b = _bits(y)
    e = (b >> 52) - 1023 - (54 if small else 0)
    m = _float((b & MANTISSA) | ONE_BITS)
    big = m > SQRT2
    m = m * 0.5 if big else m
    e = e + 1 if big else e
    z = (m - 1.0) / (m + 1.0)
    z2 = z * z
    series = 1.0 + z2 * (1.0 / 3.0 + z2 * (1.0 / 5.0 + z2 * (1.0 / 7.0 + z2 * (1.0 / 9.0 + z2 * (1.0 / 11.0)))))
    t = -inverse_m * (e * LN2 + 2.0 * z * series)  # ln of the result
    n = math.floor(t * (1.0 / LN2) + 0.5)
    r = t - n * LN2
    # exp(r) by Horner on the Taylor coefficients 1 / k!, k = 12 down to 0
    p = EXP_TAYLOR[12]
    for k in range(11, -1, -1):
        p = p * r + EXP_TAYLOR[k]
    return p * _float((int(n) + 1023) << 52)
