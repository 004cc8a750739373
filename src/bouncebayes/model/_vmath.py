"""Elementary functions the compiler can vectorise: cube and fifth roots, ``atan2``, and the
sine and cosine of an angle in degrees.

Why hand-written: numba calls the C library for ``np.cbrt``, ``x ** 0.4``, ``math.sin``/``cos``
and ``math.atan2``, one element at a time (20-30 ns each on the development machine, a quarter
of a closed-form bounce), and no vector maths library is available to it (the pip build of
llvmlite has no SVML). These are written in plain arithmetic and bit operations with no calls
and no branches (only selects), so that a loop over a block of elements compiles to 4-wide
AVX2 code (``bounce_range`` runs them so, :mod:`._fast`), while the same function called on
one element gives the same bits. Every kernel of the model uses them, so the samplers' and
the full results' numbers stay identical. They are compiled once each and left to LLVM to
inline where they are used: numba's own inlining of them into every kernel tripled the
compile time for no speed. Each declares ``error_model="numpy"``: a numba function without
one is compiled with its first caller's, and with Python's (a test for a zero divisor before
every division, which no argument reaches here) the loops that call it stay scalar, in every
kernel compiled after it in the process.

Accuracy (tests/test_model_vmath.py, against NumPy's extended precision over 1e-307..1e308,
the subnormals and the special values): cube and fifth roots within 1 unit in the last place,
``atan2`` and the degree sine and cosine within 2; zero, infinities and NaN as the C library
gives them.

The roots start from the exponent and leading mantissa bits scaled like a logarithm (the
start of fdlibm's ``cbrt``: the high word of the bits divided by the root's order, plus a
bias; worst start ~3 % off), then take three Halley steps (cubic convergence: 3e-2 -> 2e-5 ->
1e-14 -> rounding), each written as a correction so that its rounding is relative to the
correction. ``atan2`` is Cephes' ``atan`` (S. L. Moshier, Cephes Math Library, netlib): the
ratio reduced to [0, 1] and further to |t| <= 0.66 by t -> (t - 1) / (t + 1), then a 4/5
rational function (relative error ~1e-17 on that interval).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.extending import intrinsic

_MAGIC = np.int64(0x4330000000000000)  # the bits of 2^52
_TWO52 = 4503599627370496.0
_LOW32 = np.int64(0xFFFFFFFF)
_ONE_HI = 1072693248.0  # the high word of 1.0
# bias of the start, in units of the high word's last bit: centres the start's relative error
# (fdlibm's cbrt uses 715094163 = (682 - 0.03306235651) * 2^20 for the cube root)
_CBRT_B = 715094163.0
_ROOT5_B = 0.8 * _ONE_HI - 0.02 * 2.0**20
# arguments below _TINY (subnormals included) are scaled up by 2^600 first, those above _HUGE
# down (the Halley steps' products, ~t^(4/3), would underflow or overflow), and the root
# scaled back
_TINY, _HUGE = 2.0**-600, 2.0**600
_UP, _DOWN = 2.0**600, 2.0**-600
_UP3, _DOWN3 = 2.0**200, 2.0**-200
_UP5, _DOWN5 = 2.0**120, 2.0**-120

# Cephes atan.c
_P0, _P1, _P2, _P3, _P4 = (-8.750608600031904122785e-1, -1.615753718733365076637e1,
                           -7.500855792314704667340e1, -1.228866684490136173410e2,
                           -6.485021904942025371773e1)
_Q0, _Q1, _Q2, _Q3, _Q4 = (2.485846490142306297962e1, 1.650270098316988542046e2,
                           4.328810604912902668951e2, 4.853903996359136964868e2,
                           1.945506571482613964425e2)
_MOREBITS = 6.123233995736765886130e-17  # pi/2 - float(pi/2)
_PIO4 = 0.78539816339744830962


def _bits_typer(typingctx, x):
    """The bits of a float64 as an int64 (a bit cast: no conversion)."""
    if not isinstance(x, types.Float):
        return None
    sig = types.int64(types.float64)

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.IntType(64))

    return sig, codegen


def _float_typer(typingctx, i):
    """The float64 whose bits are the int64 ``i``."""
    if not isinstance(i, types.Integer):
        return None
    sig = types.float64(types.int64)

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.DoubleType())

    return sig, codegen


_bits: Any = intrinsic(_bits_typer)
_float: Any = intrinsic(_float_typer)


@njit(cache=True, error_model="numpy")
def _start(t, order, bias):
    """About t ** (1 / order) for t > 0 (normal): the high word of t's bits divided by
    ``order`` plus ``bias`` as the high word of the result (integer <-> float conversions
    through 2^52, which the processor does in vector registers)."""
    hf = _float((_bits(t) >> 32) | _MAGIC) - _TWO52
    yh = hf * (1.0 / order) + bias
    return _float((_bits(yh + _TWO52) & _LOW32) << 32)


@njit(cache=True, error_model="numpy")
def _halley3(y, t):
    """One Halley step towards t ** (1/3) (y > 0), y (y^3 + 2t) / (2y^3 + t) written as a
    correction, whose rounding is relative to the correction, not to y."""
    y3 = y * y * y
    return y - y * (y3 - t) / (2.0 * y3 + t)


@njit(cache=True, error_model="numpy")
def _halley5(z, t):
    """One Halley step towards t ** (1/5) (z > 0), z (4z^5 + 6t) / (6z^5 + 4t) written as a
    correction."""
    z5 = z * z
    z5 = z5 * z5 * z
    return z - z * (z5 - t) / (3.0 * z5 + 2.0 * t)


@njit(cache=True, error_model="numpy")
def cbrt(a):
    """The cube root of ``a`` (any sign; 0, +-inf and NaN as given)."""
    t = abs(a)
    normal = (t > 0.0) & (t < math.inf)
    t = t if normal else 1.0  # (no division by zero in the steps, whatever the error model)
    tiny, huge = t < _TINY, t > _HUGE
    t = t * _UP if tiny else (t * _DOWN if huge else t)
    y = _start(t, 3.0, _CBRT_B)
    y = _halley3(_halley3(_halley3(y, t), t), t)
    y = y * _DOWN3 if tiny else (y * _UP3 if huge else y)
    return math.copysign(y, a) if normal else a


@njit(cache=True, error_model="numpy")
def root5(a):
    """The fifth root of ``a`` >= 0 (0, inf and NaN as given; NaN for a < 0)."""
    normal = (a > 0.0) & (a < math.inf)
    t = a if normal else 1.0
    tiny, huge = t < _TINY, t > _HUGE
    t = t * _UP if tiny else (t * _DOWN if huge else t)
    z = _start(t, 5.0, _ROOT5_B)
    z = _halley5(_halley5(_halley5(z, t), t), t)
    z = z * _DOWN5 if tiny else (z * _UP5 if huge else z)
    z = z if normal else a
    return z if a >= 0.0 else math.nan


@njit(cache=True, error_model="numpy")
def atan2(y, x):
    """The angle of (x, y) in (-pi, pi], as ``math.atan2`` (signed zeros and infinities
    aside: +-0 and inf arguments give the C library's values up to the sign of zero)."""
    ax, ay = abs(x), abs(y)
    swap = ay > ax
    big = ay if swap else ax
    small = ax if swap else ay
    t = small / (big if big != 0.0 else 1.0)  # both zero: t = 0
    t = 1.0 if (ax == math.inf) & (ay == math.inf) else t
    mid = t > 0.66
    t = (t - 1.0) / (t + 1.0) if mid else t
    z = t * t
    p = ((((_P0 * z + _P1) * z + _P2) * z + _P3) * z + _P4)
    q = (((((z + _Q0) * z + _Q1) * z + _Q2) * z + _Q3) * z + _Q4)
    r = t + t * (z * p / q)
    r = r + (_PIO4 + 0.5 * _MOREBITS) if mid else r  # atan(t) of [0, 1]
    r = (math.pi / 2 - r) + _MOREBITS if swap else r  # of the ratio ay / ax
    r = math.pi - r if math.copysign(1.0, x) < 0.0 else r
    return math.copysign(r, y)


# fdlibm's __kernel_sin and __kernel_cos (Sun Microsystems, 1993; netlib): minimax polynomials
# good to < 1 unit in the last place on [-pi/4, pi/4]
_S1, _S2, _S3, _S4, _S5, _S6 = (-1.66666666666666324348e-01, 8.33333333332248946124e-03,
                                -1.98412698298579493134e-04, 2.75573137070700676789e-06,
                                -2.50507602534068634195e-08, 1.58969099521155010221e-10)
_C1, _C2, _C3, _C4, _C5, _C6 = (4.16666666666666019037e-02, -1.38888888888741095749e-03,
                                2.48015872894767294178e-05, -2.75573143513906633035e-07,
                                2.08757232129817482790e-09, -1.13596475577881948265e-11)
_DEG = math.pi / 180.0


@njit(cache=True, error_model="numpy")
def sincos_deg(angle):
    """(sin, cos) of ``angle`` in degrees. The angle is reduced exactly in degrees, to
    d = angle - 90 q in [-45, 45] (exact: Sterbenz's lemma), so that no multiple of pi is
    rounded; then d in radians and fdlibm's kernels, and the quadrant q by selects. Within
    2 units in the last place for |angle| < 2^40 degrees (NaN for infinities and NaN)."""
    q = math.floor(angle * (1.0 / 90.0) + 0.5)
    d = angle - 90.0 * q
    x = d * _DEG
    z = x * x
    s = x + z * x * (_S1 + z * (_S2 + z * (_S3 + z * (_S4 + z * (_S5 + z * _S6)))))
    r = z * z * (_C1 + z * (_C2 + z * (_C3 + z * (_C4 + z * (_C5 + z * _C6)))))
    hz = 0.5 * z
    w = 1.0 - hz
    c = w + (((1.0 - w) - hz) + r)
    quadrant = q - 4.0 * math.floor(q * 0.25)  # 0, 1, 2, 3
    odd = (quadrant == 1.0) | (quadrant == 3.0)
    sin = c if odd else s
    cos = s if odd else c
    sin = -sin if quadrant >= 2.0 else sin
    cos = -cos if (quadrant == 1.0) | (quadrant == 2.0) else cos
    finite = abs(angle) < math.inf
    return (sin if finite else math.nan), (cos if finite else math.nan)
