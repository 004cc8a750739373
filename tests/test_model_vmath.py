"""The model's vectorisable elementary functions (src/bouncebayes/model/_vmath.py).

Expected values: NumPy's C library in extended precision (x86's 80-bit long double, 11 more
bits than a double), an implementation independent of the hand-written code; and the C
library's own special values (zero, infinities, NaN)."""

import re

import numpy as np
import pytest
from numba import njit

from bouncebayes.model import _fast, _vmath
from bouncebayes.model._outputs import N_OUT

LONG = np.finfo(np.longdouble).eps < 1e-18
needs_long = pytest.mark.skipif(not LONG, reason="needs an extended-precision long double")


@njit
def _map(f, a):
    """f (a compiled scalar function) of each element of a, in a compiled loop."""
    out = np.empty_like(a)
    for i in range(a.size):
        out[i] = f(a[i])
    return out


def _map_cbrt(a):
    return _map(_vmath.cbrt, a)


def _map_root5(a):
    return _map(_vmath.root5, a)


@njit
def _map_atan2(y, x):
    out = np.empty_like(y)
    for i in range(y.size):
        out[i] = _vmath.atan2(y[i], x[i])
    return out


def ulps(value, exact):
    """Error in units of the last place of the exactly rounded value."""
    rounded = exact.astype(np.float64)
    return np.abs(value - rounded) / np.spacing(np.abs(rounded))


def arguments(n=400_000, seed=0):
    """Positive doubles over the whole range: 1e-307..1e308 log-uniform, subnormals, the
    extremes."""
    rng = np.random.default_rng(seed)
    return np.concatenate([10.0 ** rng.uniform(-307, 308, n),
                           rng.uniform(0, 1, 2000) * 2.0**-1022,
                           [5e-324, 2.0**-1022, np.finfo(float).max, 1.0, 8.0, 27.0, 32.0]])


@needs_long
def test_cube_root_within_one_ulp():
    a = arguments()
    exact = np.cbrt(a.astype(np.longdouble))
    assert ulps(_map_cbrt(a), exact).max() <= 1.0
    assert ulps(_map_cbrt(-a), -exact).max() <= 1.0  # odd function


@needs_long
def test_fifth_root_within_one_ulp():
    a = arguments(seed=1)
    exact = np.power(a.astype(np.longdouble), 1 / np.longdouble(5))
    assert ulps(_map_root5(a), exact).max() <= 1.0


@needs_long
def test_atan2_within_two_ulps_in_every_quadrant():
    rng = np.random.default_rng(2)
    n = 400_000
    y = rng.normal(size=n) * 10.0 ** rng.uniform(-8, 8, n)
    x = rng.normal(size=n) * 10.0 ** rng.uniform(-8, 8, n)
    exact = np.arctan2(y.astype(np.longdouble), x.astype(np.longdouble))
    assert ulps(_map_atan2(y, x), exact).max() <= 2.0
    # the model's use: a rebound angle, x = outward normal speed > 0, angles near 0 and 90 deg
    x = 10.0 ** rng.uniform(-6, 1, n)
    y = x * np.tan(rng.uniform(-np.pi / 2, np.pi / 2, n))
    exact = np.arctan2(y.astype(np.longdouble), x.astype(np.longdouble))
    assert ulps(_map_atan2(y, x), exact).max() <= 2.0


def test_special_values_as_the_c_library():
    special = np.array([0.0, -0.0, np.inf, -np.inf, np.nan, 1.0, 8.0, -27.0])
    # perfect cubes exactly (NumPy's own cbrt gives -3.0000000000000004 for -27 here)
    np.testing.assert_array_equal(_map_cbrt(special), [0.0, -0.0, np.inf, -np.inf, np.nan, 1.0,
                                                       2.0, -3.0])
    assert np.signbit(_map_cbrt(np.array([-0.0])))[0]
    positive = np.array([0.0, np.inf, np.nan, 1.0, 32.0])
    np.testing.assert_array_equal(_map_root5(positive), [0.0, np.inf, np.nan, 1.0, 2.0])
    assert np.isnan(_map_root5(np.array([-1.0, -np.inf]))).all()
    values = [0.0, -0.0, 1.0, -1.0, np.inf, -np.inf, np.nan]
    y, x = (a.ravel() for a in np.meshgrid(values, values))
    np.testing.assert_array_equal(_map_atan2(y, x), np.arctan2(y, x))


def _host_has_avx2() -> bool:
    import llvmlite.binding as llvm

    return "+avx2" in llvm.get_host_cpu_features().flatten()


@pytest.mark.skipif(not _host_has_avx2(), reason="vector code is checked on AVX2 processors")
@pytest.mark.parametrize("kernel", ["_block_scales", "_block_speed_angle", "_early_series",
                                    "_early_start", "_early_newton"])
def test_block_passes_compile_to_vector_code(kernel):
    """The reason for _vmath and for the passes: the block passes of the closed-form kernel
    divide four elements at a time (ymm registers; eight, zmm, on AVX-512). Compiled afresh (no cache, whose code
    cannot be inspected) from the kernel's own source, after the functions of _vmath were
    compiled for a caller with Python's error model (which, were it inherited, would keep the
    loops scalar)."""
    njit(lambda a: _vmath.root5(a) + _vmath.cbrt(a) + _vmath.atan2(a, a)
         + _vmath.sincos_deg(a)[0])(2.0)
    fn = getattr(_fast, kernel)
    fresh = njit(error_model="numpy")(fn.py_func)
    soa, res = np.full(_fast.N_ROWS_EARLY * _fast.ROW, 0.5), np.zeros(3 * _fast.ROW)
    if kernel == "_block_scales":
        fresh(1.0, 0, 256, np.full((_fast.N_SCALES, 256), 0.5))
    elif kernel == "_block_speed_angle":
        fresh(np.full((N_OUT, 512), 0.5), 0, 256)
    elif kernel == "_early_series":
        fresh(soa, 256)
    else:
        fresh(soa, 256, res)
    asm = fresh.inspect_asm(fresh.signatures[0])
    # ymm (four doubles) on AVX2; on an AVX-512 processor LLVM takes zmm (eight)
    assert re.search(r"vdivpd[^\n]*[yz]mm", asm), f"{kernel}: no vector division"
