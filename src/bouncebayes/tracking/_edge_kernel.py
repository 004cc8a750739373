"""The edge model, compiled: its residual and analytic Jacobian in one fused pass over the
pixels.

The same arithmetic as the NumPy reference ``_edge._design_numpy`` (kept for the tests, which
compare the two), without its ~40 temporary arrays and NumPy's per-call overhead: the edge
model is evaluated ~300 times per video inside ``scipy.optimize.least_squares``. Each call
builds the design matrix, solves the linear coefficients (variable projection) and, for
``least_squares``'s ``jac=``, differentiates the projected residual with respect to the
nonlinear parameters (the design's derivatives by forward-mode differentiation of each
pixel's row, by hand): with finite differences instead the model was evaluated ~1000 times
per video. Written here because no library builds this model; imported by ``_edge`` where
the model runs (numba stays out of the package import).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

_SQRT2 = math.sqrt(2.0)
_INV_SQRT_2PI = 1.0 / math.sqrt(2.0 * math.pi)


@njit(cache=True)
def _row(du, dv, dir_u, dir_v, speed, r, sigma, exposure, z0, dz, table, rim_order, k, row,
         drow):
    """One pixel's design row (unweighted: the shared columns, then the pixel's frame's three
    local ones) at offset ``(du, dv)`` from the centre, into ``row``; with ``0 <= k < 5`` also
    its derivative with respect to parameter ``k`` of ``(cx, cy, r, sigma, exposure)`` into
    ``drow`` (forward-mode, by hand: the arithmetic of ``_edge._design_numpy``, each line followed
    by its tangent). Returns the step and its derivative."""
    e_cx = 1.0 if k == 0 else 0.0
    e_cy = 1.0 if k == 1 else 0.0
    e_r = 1.0 if k == 2 else 0.0
    e_sg = 1.0 if k == 3 else 0.0
    e_ex = 1.0 if k == 4 else 0.0
    d_du, d_dv = -e_cx, -e_cy
    rho = math.hypot(du, dv)
    rr = max(rho, 1e-9)
    ct = du / rr
    st = dv / rr
    if rho > 1e-9:
        d_rho = ct * d_du + st * d_dv
        d_ct = (d_du - ct * d_rho) / rr
        d_st = (d_dv - st * d_rho) / rr
    else:  # a pixel on the centre (never fitted: INNER)
        d_rho = d_ct = d_st = 0.0
    cos_v = ct * dir_u + st * dir_v
    d_cv = d_ct * dir_u + d_st * dir_v
    smear2 = (exposure * speed) ** 2 / 12.0
    d_sm = exposure * speed * speed / 6.0 * e_ex
    base = sigma * sigma + 1.0 / 12.0
    d_base = 2.0 * sigma * e_sg
    cv2 = cos_v * cos_v
    d_cv2 = 2.0 * cos_v * d_cv
    var_r = base + smear2 * cv2
    d_vr = d_base + d_sm * cv2 + smear2 * d_cv2
    var_t = base + smear2 * (1.0 - cv2)
    d_vt = d_base + d_sm * (1.0 - cv2) - smear2 * d_cv2
    s = math.sqrt(var_r)
    d_s = d_vr / (2.0 * s)
    uu = r - var_t / (2.0 * r) - rho
    d_uu = e_r - d_vt / (2.0 * r) + var_t / (2.0 * r * r) * e_r - d_rho
    z = uu / s
    d_z = (d_uu - z * d_s) / s
    step = 0.5 * math.erfc(-z / _SQRT2)
    dens = math.exp(-0.5 * z * z) * _INV_SQRT_2PI
    d_step = dens * d_z
    d_dens = -z * dens * d_z
    ramp = uu * step + s * dens
    d_ramp = d_uu * step + uu * d_step + d_s * dens + s * d_dens
    square = (uu * uu + s * s) * step + uu * s * dens
    d_square = (2.0 * (uu * d_uu + s * d_s) * step + (uu * uu + s * s) * d_step
                + (d_uu * s + uu * d_s) * dens + uu * s * d_dens)
    nt = table.size
    if z > z0 + dz * (nt - 1):
        root = math.sqrt(max(uu, 0.0))
        d_root = d_uu / (2.0 * root) if root > 0.0 else 0.0
    elif z <= z0:
        root = math.sqrt(s) * table[0]
        d_root = table[0] * d_s / (2.0 * math.sqrt(s))
    else:
        x = (z - z0) / dz
        j = min(int(x), nt - 2)
        f = x - j
        g = table[j] * (1.0 - f) + table[j + 1] * f
        root = math.sqrt(s) * g
        d_root = (d_s / (2.0 * math.sqrt(s)) * g
                  + math.sqrt(s) * (table[j + 1] - table[j]) / dz * d_z)
    sq2r = math.sqrt(2.0 / r)
    d_sq2r = -0.5 * sq2r / r * e_r
    a1 = 1.0 - uu / (2.0 * r)
    cl1 = min(max(a1, 0.0), 1.0)
    d_cl1 = -d_uu / (2.0 * r) + uu / (2.0 * r * r) * e_r if 0.0 < a1 < 1.0 else 0.0
    sc1 = math.sqrt(cl1)
    d_sc1 = d_cl1 / (2.0 * sc1) if sc1 > 0.0 else 0.0
    nz = root * sq2r * sc1
    d_nz = d_root * sq2r * sc1 + root * d_sq2r * sc1 + root * sq2r * d_sc1
    qq = step - ramp / r
    d_qq = d_step - d_ramp / r + ramp / (r * r) * e_r
    q2 = step - 2.0 * ramp / r + square / (r * r)
    d_q2 = (d_step - 2.0 * d_ramp / r + 2.0 * ramp / (r * r) * e_r + d_square / (r * r)
            - 2.0 * square / (r * r * r) * e_r)
    a2 = 1.0 - uu / r
    cl2 = min(max(a2, 0.0), 1.0)
    d_cl2 = -d_uu / r + uu / (r * r) * e_r if 0.0 < a2 < 1.0 else 0.0
    nzq = nz * cl2
    d_nzq = d_nz * cl2 + nz * d_cl2
    c2 = ct * ct - st * st
    d_c2 = 2.0 * (ct * d_ct - st * d_st)
    s2 = 2.0 * ct * st
    d_s2 = 2.0 * (d_ct * st + ct * d_st)
    row[0] = step
    drow[0] = d_step
    row[1] = qq * ct
    drow[1] = d_qq * ct + qq * d_ct
    row[2] = qq * st
    drow[2] = d_qq * st + qq * d_st
    row[3] = nz
    drow[3] = d_nz
    row[4] = q2 * s2
    drow[4] = d_q2 * s2 + q2 * d_s2
    row[5] = q2 * c2
    drow[5] = d_q2 * c2 + q2 * d_c2
    row[6] = nzq * ct
    drow[6] = d_nzq * ct + nzq * d_ct
    row[7] = nzq * st
    drow[7] = d_nzq * st + nzq * d_st
    row[8] = step - q2
    drow[8] = d_step - d_q2
    row[9] = step * c2
    drow[9] = d_step * c2 + step * d_c2
    row[10] = step * s2
    drow[10] = d_step * s2 + step * d_s2
    cm, sm, d_cm, d_sm2 = c2, s2, d_c2, d_s2
    col = 11
    for _ in range(3, rim_order + 1):
        cm, sm, d_cm, d_sm2 = (cm * ct - sm * st, sm * ct + cm * st,
                               d_cm * ct + cm * d_ct - d_sm2 * st - sm * d_st,
                               d_sm2 * ct + sm * d_ct + d_cm * st + cm * d_st)
        row[col] = step * cm
        drow[col] = d_step * cm + step * d_cm
        row[col + 1] = step * sm
        drow[col + 1] = d_step * sm + step * d_sm2
        col += 2
    out = 1.0 - step
    row[col] = out
    drow[col] = -d_step
    row[col + 1] = out * ct
    drow[col + 1] = -d_step * ct + out * d_ct
    row[col + 2] = out * st
    drow[col + 2] = -d_step * st + out * d_st
    return step, d_step


@njit(cache=True)
def _cholesky(m):
    """Lower Cholesky factor of the symmetric positive definite ``m`` (in place: the lower
    triangle); False where a pivot is not positive. By hand: numba's ``np.linalg`` took ~25 s
    more to compile for a 15-20 column matrix."""
    n = m.shape[0]
    for j in range(n):
        d = m[j, j]
        for p in range(j):
            d -= m[j, p] * m[j, p]
        if not d > 0.0:
            return False
        d = math.sqrt(d)
        m[j, j] = d
        for i in range(j + 1, n):
            t = m[i, j]
            for p in range(j):
                t -= m[i, p] * m[j, p]
            m[i, j] = t / d
    return True


@njit(cache=True)
def _cho_solve(low, b):
    """``x`` with ``low low^T x = b`` (``low`` from :func:`_cholesky`), in place in ``b``."""
    n = b.size
    for i in range(n):
        t = b[i]
        for p in range(i):
            t -= low[i, p] * b[p]
        b[i] = t / low[i, i]
    for i in range(n - 1, -1, -1):
        t = b[i]
        for p in range(i + 1, n):
            t -= low[p, i] * b[p]
        b[i] = t / low[i, i]


@njit(cache=True)
def varpro(cx, cy, r, sigma, exposure, free, u, v, cu, cv, dir_u, dir_v, speed, frame,
           n_frames, weight, grey, bg, z0, dz, table, rim_order, want_jac):
    """The edge model's weighted residual at ``(cx, cy, r, sigma, exposure)``, the linear
    coefficients solved (variable projection), and its Jacobian with respect to the
    parameters flagged in ``free`` (``(n_pix, n_free)``; empty unless ``want_jac``), in one
    call. Each pixel's centre is ``(cu + cx, cv + cy)``: ``cu, cv`` the frames' offsets (zero
    for one frame), ``cx, cy`` a shift shared by all. The coefficients are the normal
    equations' with a small ridge (the columns are O(1) functions of the pixels: a
    near-degenerate column gets a coefficient ~0). The Jacobian is the exact derivative of
    ``res = y - A beta``, ``beta = M^-1 A^T y``, ``M = A^T A + ridge`` (Golub & Pereyra 1973;
    the ridge held): ``d res = g - A M^-1 (A^T g + dA^T res)``, ``g = dy - dA beta``; ``dA``
    and ``dy`` from :func:`_row`. ``ok`` is False where the normal equations are singular.
    """
    n = u.size
    n_shared = 11 + 2 * max(rim_order - 2, 0)
    m = n_shared + 3 * n_frames
    a = np.zeros((n, m))
    y = np.empty(n)
    row = np.empty(n_shared + 3)
    drow = np.empty(n_shared + 3)
    for i in range(n):
        step, _ = _row(u[i] - cu[i] - cx, v[i] - cv[i] - cy, dir_u[i], dir_v[i], speed[i],
                       r, sigma, exposure, z0, dz, table, rim_order, -1, row, drow)
        w = weight[i]
        for c in range(n_shared):
            a[i, c] = row[c] * w
        j = n_shared + 3 * frame[i]
        for c in range(3):
            a[i, j + c] = row[n_shared + c] * w
        y[i] = (grey[i] - bg[i] * (1.0 - step)) * w
    # normal equations (lower triangle), with the ridge of the NumPy path
    low = np.zeros((m, m))
    aty = np.zeros(m)
    for i in range(n):
        for c in range(m):
            ac = a[i, c]
            if ac != 0.0:
                aty[c] += ac * y[i]
                for p in range(c + 1):
                    low[c, p] += ac * a[i, p]
    trace = 0.0
    for c in range(m):
        trace += low[c, c]
    ridge = 1e-9 * (trace / m + 1.0)
    for c in range(m):
        low[c, c] += ridge
    n_free = 0
    for k in range(5):
        n_free += 1 if free[k] else 0
    res = np.empty(n)
    jac = np.empty((n, n_free if want_jac else 0))
    if not _cholesky(low):
        return res, jac, False
    beta = aty
    _cho_solve(low, beta)
    for i in range(n):
        t = y[i]
        for c in range(m):
            t -= a[i, c] * beta[c]
        res[i] = t
    if not want_jac:
        return res, jac, True
    g = np.empty((n, n_free))
    h = np.zeros((m, n_free))
    col = 0
    for k in range(5):
        if not free[k]:
            continue
        for i in range(n):
            _, d_step = _row(u[i] - cu[i] - cx, v[i] - cv[i] - cy, dir_u[i], dir_v[i],
                             speed[i], r, sigma, exposure, z0, dz, table, rim_order, k, row,
                             drow)
            w = weight[i]
            j = n_shared + 3 * frame[i]
            t = bg[i] * d_step
            for c in range(n_shared):
                t -= drow[c] * beta[c]
                h[c, col] += drow[c] * w * res[i]
            for c in range(3):
                t -= drow[n_shared + c] * beta[j + c]
                h[j + c, col] += drow[n_shared + c] * w * res[i]
            g[i, col] = t * w
        col += 1
    rhs = np.empty(m)
    for col in range(n_free):
        for c in range(m):
            t = h[c, col]
            for i in range(n):
                t += a[i, c] * g[i, col]
            rhs[c] = t
        _cho_solve(low, rhs)
        for i in range(n):
            t = g[i, col]
            for c in range(m):
                t -= a[i, c] * rhs[c]
            jac[i, col] = t
    return res, jac, True
