"""The edge model's design matrix, compiled: one fused pass over the pixels.

The same arithmetic as the NumPy reference ``_edge._design_numpy`` (kept for the tests, which
compare the two), without its ~40 temporary arrays: the edge model evaluates the design ~1000
times per video inside ``scipy.optimize.least_squares``, and NumPy's per-operation overhead on
~1000-pixel arrays made it 0.5-3 s per video. Written here because no library builds this
matrix; imported by ``_edge`` where the model runs (numba stays out of the package import).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

_SQRT2 = math.sqrt(2.0)
_INV_SQRT_2PI = 1.0 / math.sqrt(2.0 * math.pi)


@njit(cache=True)
def design(r, sigma, exposure, u, v, cx, cy, dir_u, dir_v, speed, frame, n_frames, weight,
           grey, bg, z0, dz, table, rim_order):
    """Weighted design matrix ``(n_pix, n_shared + 3 n_frames)`` and weighted data
    ``(grey - bg (1 - step)) weight`` at ``(r, sigma, exposure)``; ``table`` is
    ``E[sqrt(z + Z)_+]`` on the uniform grid ``z0 + dz k``."""
    n = u.size
    n_shared = 11 + 2 * max(rim_order - 2, 0)
    a = np.zeros((n, n_shared + 3 * n_frames))
    y = np.empty(n)
    base = sigma * sigma + 1.0 / 12.0
    nt = table.size
    z_hi = z0 + dz * (nt - 1)
    for i in range(n):
        du = u[i] - cx[i]
        dv = v[i] - cy[i]
        rho = math.hypot(du, dv)
        rr = max(rho, 1e-9)
        ct = du / rr
        st = dv / rr
        cos_v = ct * dir_u[i] + st * dir_v[i]
        smear2 = (exposure * speed[i]) ** 2 / 12.0
        var_r = base + smear2 * cos_v * cos_v
        var_t = base + smear2 * (1.0 - cos_v * cos_v)
        s = math.sqrt(var_r)
        uu = r - var_t / (2.0 * r) - rho
        z = uu / s
        step = 0.5 * math.erfc(-z / _SQRT2)
        dens = math.exp(-0.5 * z * z) * _INV_SQRT_2PI
        ramp = uu * step + s * dens
        square = (uu * uu + s * s) * step + uu * s * dens
        if z > z_hi:
            root = math.sqrt(max(uu, 0.0))
        elif z <= z0:
            root = math.sqrt(s) * table[0]
        else:
            x = (z - z0) / dz
            k = min(int(x), nt - 2)
            f = x - k
            root = math.sqrt(s) * (table[k] * (1.0 - f) + table[k + 1] * f)
        nz = root * math.sqrt(2.0 / r) * math.sqrt(min(max(1.0 - uu / (2.0 * r), 0.0), 1.0))
        qq = step - ramp / r
        q2 = step - 2.0 * ramp / r + square / (r * r)
        nzq = nz * min(max(1.0 - uu / r, 0.0), 1.0)
        c2 = ct * ct - st * st
        s2 = 2.0 * ct * st
        w = weight[i]
        a[i, 0] = step * w
        a[i, 1] = qq * ct * w
        a[i, 2] = qq * st * w
        a[i, 3] = nz * w
        a[i, 4] = q2 * s2 * w
        a[i, 5] = q2 * c2 * w
        a[i, 6] = nzq * ct * w
        a[i, 7] = nzq * st * w
        a[i, 8] = (step - q2) * w
        a[i, 9] = step * c2 * w
        a[i, 10] = step * s2 * w
        cm = c2
        sm = s2
        col = 11
        for _ in range(3, rim_order + 1):
            cm, sm = cm * ct - sm * st, sm * ct + cm * st
            a[i, col] = step * cm * w
            a[i, col + 1] = step * sm * w
            col += 2
        out = 1.0 - step
        j = n_shared + 3 * frame[i]
        a[i, j] = out * w
        a[i, j + 1] = out * ct * w
        a[i, j + 2] = out * st * w
        y[i] = (grey[i] - bg[i] * out) * w
    return a, y
