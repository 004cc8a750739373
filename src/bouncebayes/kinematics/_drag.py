"""Free flight with quadratic air drag, ``r'' = a - k |v| v``: its solution with sensitivities
(compiled), and the bounded least-squares fit that starts from the drag-free fit.

The fit is SciPy's ``least_squares`` (trust-region reflective, bounds ``0 <= k <= k_max``) with
an exact Jacobian: the flight is integrated together with its variational equations, so one
call gives positions and their derivatives with respect to every parameter. That integration
is a fixed-step RK4 written here and compiled by numba because it runs inside the optimiser's
loop on a few dozen samples, where ``scipy.integrate.solve_ivp`` costs a millisecond per call in
overhead alone, and fixed steps keep the positions a smooth function of the parameters.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

# RK4 steps of at most 2 ms: the local error scales as (h k |v|)^4 with k |v| < 10 /s for any
# ball in air (k < 1 /m, |v| < 10 m/s), below 1e-9 of the drag displacement per step; gravity
# (constant acceleration) is integrated exactly.
RK4_MAX_STEP = 2e-3


@njit(cache=True)
def _rates(v, sv, a, k, d, n_par, dv, dsv):
    """Accelerations and the variational rates d(Sv)/dt = J_v Sv + df/dp for r'' = a - k|v|v."""
    speed = 0.0
    for i in range(d):
        speed += v[i] * v[i]
    speed = math.sqrt(speed)
    for i in range(d):
        dv[i] = a[i] - k * speed * v[i]
    for j in range(n_par):
        vs = 0.0
        for i in range(d):
            vs += v[i] * sv[i, j]
        for i in range(d):
            # J_v = -k (|v| I + v v^T / |v|)
            dsv[i, j] = -k * (speed * sv[i, j] + (v[i] * vs / speed if speed > 0.0 else 0.0))
    for i in range(d):
        dsv[i, 2 * d + i] += 1.0  # df/da = I
        dsv[i, 3 * d] += -speed * v[i]  # df/dk = -|v| v


@njit(cache=True)
def _rk4_step(r, v, sr, sv, a, k, h, d, n_par, dv, dsv, vk, svk):
    """One RK4 step of positions, velocities and their sensitivities (updated in place;
    ``dv``, ``dsv``, ``vk``, ``svk``: scratch arrays of 4 stages)."""
    vk[0] = v
    svk[0] = sv
    _rates(v, sv, a, k, d, n_par, dv[0], dsv[0])
    for stage in range(1, 4):
        frac = h if stage == 3 else 0.5 * h
        for i in range(d):
            vk[stage, i] = v[i] + frac * dv[stage - 1, i]
            for j in range(n_par):
                svk[stage, i, j] = sv[i, j] + frac * dsv[stage - 1, i, j]
        _rates(vk[stage], svk[stage], a, k, d, n_par, dv[stage], dsv[stage])
    w = h / 6.0
    for i in range(d):
        r[i] += w * (vk[0, i] + 2.0 * vk[1, i] + 2.0 * vk[2, i] + vk[3, i])
        v[i] += w * (dv[0, i] + 2.0 * dv[1, i] + 2.0 * dv[2, i] + dv[3, i])
        for j in range(n_par):
            sr[i, j] += w * (svk[0, i, j] + 2.0 * svk[1, i, j] + 2.0 * svk[2, i, j]
                             + svk[3, i, j])
            sv[i, j] += w * (dsv[0, i, j] + 2.0 * dsv[1, i, j] + 2.0 * dsv[2, i, j]
                             + dsv[3, i, j])


@njit(cache=True)
def drag_solution(p, d, taus, max_step):
    """Positions, velocities and their parameter sensitivities at ``taus`` (each of one sign,
    ordered away from 0) for ``p = (r0, v0, a, k)``, the state at ``tau = 0``.

    Returns arrays ``R (m, d)``, ``V (m, d)``, ``SR (m, d, 3d+1)``, ``SV (m, d, 3d+1)``.
    """
    n_par = 3 * d + 1
    m = taus.size
    R = np.empty((m, d))
    V = np.empty((m, d))
    SR = np.empty((m, d, n_par))
    SV = np.empty((m, d, n_par))
    r = p[:d].copy()
    v = p[d:2 * d].copy()
    a = p[2 * d:3 * d].copy()
    k = p[3 * d]
    sr = np.zeros((d, n_par))
    sv = np.zeros((d, n_par))
    for i in range(d):
        sr[i, i] = 1.0
        sv[i, d + i] = 1.0
    dv = np.empty((4, d))
    dsv = np.empty((4, d, n_par))
    vk = np.empty((4, d))
    svk = np.empty((4, d, n_par))
    now = 0.0
    for j in range(m):
        span = taus[j] - now
        n_steps = max(1, int(math.ceil(abs(span) / max_step))) if span != 0.0 else 0
        for _ in range(n_steps):
            _rk4_step(r, v, sr, sv, a, k, span / n_steps, d, n_par, dv, dsv, vk, svk)
        now = taus[j]
        R[j] = r
        V[j] = v
        SR[j] = sr
        SV[j] = sv
    return R, V, SR, SV


def solve(p: np.ndarray, d: int, taus: np.ndarray
          ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`drag_solution` at any ``taus`` (either sign, any order), in their order."""
    taus = np.asarray(taus, dtype=float)
    n_par = 3 * d + 1
    out = (np.empty((taus.size, d)), np.empty((taus.size, d)),
           np.empty((taus.size, d, n_par)), np.empty((taus.size, d, n_par)))
    for side in (taus < 0, taus >= 0):
        idx = np.flatnonzero(side)
        if idx.size:
            idx = idx[np.argsort(np.abs(taus[idx]), kind="stable")]
            for arr, part in zip(out, drag_solution(np.asarray(p, dtype=float), d, taus[idx],
                                                    RK4_MAX_STEP), strict=True):
                arr[idx] = part
    return out
