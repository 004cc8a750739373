"""Where results are written: the output layouts of both paths, and the one conversion of a
rebound velocity into speed and angle.

Full results (``Bounces``) are rows of one float block ``(N_OUT, n)`` plus status, rolling,
Hertz-validity and closed-form flags; rebound-only results (``Rebounds``, for samplers) are rows
of a ``(N_REBOUND, n)`` block plus status, rolling and ok. The closed-form kernels write these
directly; :func:`store_ode` and :func:`store_ode_rebound` copy ODE results into them.
"""

from __future__ import annotations

import math

from numba import njit

from . import _kernel as K
from ._domain import HERTZ_OVERLAP_LIMIT
from ._vmath import atan2

(O_SPEED, O_ANGLE, O_SPIN, O_U, O_VN, O_TC, O_FN, O_FT, O_DMAX, O_DSEP, O_TPK,
 O_STEPS) = range(12)
N_OUT = 12
RB_SPEED, RB_ANGLE, RB_SPIN, RB_TC = range(4)
N_REBOUND = 4

RAD = 180.0 / math.pi


@njit(cache=True, inline="always")
def speed_angle(u, vn):
    """Rebound speed and angle from the normal in degrees (positive: moving forward), from the
    tangential and outward normal velocities: the only place this conversion is made (with the
    vectorisable ``atan2`` of :mod:`._vmath`, so that a loop of these compiles to vector code)."""
    return math.sqrt(u * u + vn * vn), atan2(u, vn) * RAD  # no overflow in the domain


@njit(cache=True)
def fill_failed(out, i, status, code, rolling, flags):
    """Mark element ``i`` of a full block failed: NaN results, ``code``, flags False."""
    for q in range(N_OUT):
        out[q, i] = math.nan
    out[O_STEPS, i] = 0.0
    status[i] = code
    rolling[i] = False
    for f in range(flags.shape[0]):
        flags[f, i] = False


@njit(cache=True)
def store_ode(res, res_status, rows, radius, out, status, rolling, flags):
    """Copy ODE results (``R_*`` rows) into the full block at element indices ``rows``;
    ``flags[0]`` is the Hertz validity, ``flags[1]`` the closed form (False here)."""
    for j in range(rows.shape[0]):
        i = rows[j]
        if res_status[j] != K.ST_OK:
            fill_failed(out, i, status, res_status[j], rolling, flags)
            continue
        r = res[j]
        out[O_SPEED, i], out[O_ANGLE, i] = speed_angle(r[K.R_U], r[K.R_V])
        out[O_SPIN, i] = r[K.R_W]
        out[O_U, i] = r[K.R_U]
        out[O_VN, i] = r[K.R_V]
        out[O_TC, i] = r[K.R_TC]
        out[O_FN, i] = r[K.R_FN_PEAK]
        out[O_FT, i] = r[K.R_FT_PEAK]
        out[O_DMAX, i] = r[K.R_D_MAX]
        out[O_DSEP, i] = r[K.R_D]
        out[O_TPK, i] = r[K.R_T_FN_PEAK]
        out[O_STEPS, i] = r[K.R_STEPS]
        status[i] = K.ST_OK
        rolling[i] = r[K.R_PHASE] == 0.0
        flags[0, i] = r[K.R_D_MAX] <= HERTZ_OVERLAP_LIMIT * radius
        flags[1, i] = False


@njit(cache=True)
def store_ode_rebound(res, res_status, rows, out, status, rolling, ok):
    """Copy ODE results into the rebound-only block at flat element indices ``rows``."""
    for j in range(rows.shape[0]):
        i = rows[j]
        good = res_status[j] == K.ST_OK
        status[i] = res_status[j]
        ok[i] = good
        rolling[i] = good and res[j, K.R_PHASE] == 0.0
        if good:
            out[RB_SPEED, i], out[RB_ANGLE, i] = speed_angle(res[j, K.R_U], res[j, K.R_V])
            out[RB_SPIN, i] = res[j, K.R_W]
            out[RB_TC, i] = res[j, K.R_TC]
        else:
            for q in range(N_REBOUND):
                out[q, i] = math.nan
