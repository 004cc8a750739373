"""Free flight with quadratic air drag and Magnus lift, ``r'' = a - k |v| v + |v| (c x v)``:
its solution with sensitivities (compiled).

``k = rho C_d A / (2 m)`` and ``c = rho C_L A / (2 m)`` times the spin axis: the aerodynamic
force on a spinning sphere, drag against the velocity and lift across it, both quadratic in
the speed (coefficients taken constant over a flight).

The fit (``_flight.fit_drag``) is SciPy's ``least_squares`` with bounds and an exact Jacobian:
the flight is integrated together with its variational equations, so one call gives positions
and their derivatives with respect to every parameter. That integration is a fixed-step RK4
written here and compiled by numba because it runs inside the optimiser's loop on a few dozen
samples, where ``scipy.integrate.solve_ivp`` costs a millisecond per call in overhead alone,
and fixed steps keep the positions a smooth function of the parameters.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

# RK4 steps of at most 5 ms: against scipy's DOP853 (rtol 1e-13) on a 1.5 s flight at 10 m/s
# with k = 0.3 /m and a lift vector of 0.3 /m (twice a table-tennis ball's), positions agree
# to 1.5e-8 m at 6.7 ms steps and 1e-10 m at 2 ms, far below any tracking noise; gravity
# (constant acceleration) is integrated exactly.
RK4_MAX_STEP = 5e-3


@njit(cache=True)
def _cross(c, w, d, i):
    """Component ``i`` of ``c x w``; in 2-D ``c`` holds the one component normal to the plane."""
    if d == 2:
        return -c[0] * w[1] if i == 0 else c[0] * w[0]
    if i == 0:
        return c[1] * w[2] - c[2] * w[1]
    if i == 1:
        return c[2] * w[0] - c[0] * w[2]
    return c[0] * w[1] - c[1] * w[0]


@njit(cache=True)
def _rates(v, sv, a, k, c, d, n_par, n_lift, dv, dsv, lift, col, e):
    """Accelerations ``a - k|v| v + |v| (c x v)`` and the variational rates
    ``d(Sv)/dt = J_v Sv + df/dp`` (``Sv = dv/dp``); ``lift``, ``col``, ``e``: scratch."""
    speed = 0.0
    for i in range(d):
        speed += v[i] * v[i]
    speed = math.sqrt(speed)
    for i in range(d):
        lift[i] = _cross(c, v, d, i) if n_lift > 0 else 0.0
        dv[i] = a[i] - k * speed * v[i] + speed * lift[i]
    for j in range(n_par):
        vs = 0.0  # v_hat . Sv[:, j]
        for i in range(d):
            col[i] = sv[i, j]
            vs += v[i] * sv[i, j]
        vs = vs / speed if speed > 0.0 else 0.0
        for i in range(d):
            # J_v = -k (|v| I + v v_hat^T) + (c x v) v_hat^T + |v| [c]_x
            dsv[i, j] = -k * (speed * col[i] + v[i] * vs) + lift[i] * vs
            if n_lift > 0:
                dsv[i, j] += speed * _cross(c, col, d, i)
    for i in range(d):
        dsv[i, 2 * d + i] += 1.0  # df/da = I
        dsv[i, 3 * d] += -speed * v[i]  # df/dk = -|v| v
    for m in range(n_lift):  # df/dc_m = |v| (e_m x v)
        e[:] = 0.0
        e[m] = 1.0
        for i in range(d):
            dsv[i, 3 * d + 1 + m] += speed * _cross(e, v, d, i)


@njit(cache=True)
def _rk4_step(r, v, sr, sv, a, k, c, h, d, n_par, n_lift, dv, dsv, vk, svk, scratch):
    """One RK4 step of positions, velocities and their sensitivities (updated in place;
    ``dv``, ``dsv``, ``vk``, ``svk``: arrays of 4 stages; ``scratch``: 3 rows for ``_rates``)."""
    vk[0] = v
    svk[0] = sv
    _rates(v, sv, a, k, c, d, n_par, n_lift, dv[0], dsv[0], scratch[0], scratch[1],
           scratch[2])
    for stage in range(1, 4):
        frac = h if stage == 3 else 0.5 * h
        for i in range(d):
            vk[stage, i] = v[i] + frac * dv[stage - 1, i]
            for j in range(n_par):
                svk[stage, i, j] = sv[i, j] + frac * dsv[stage - 1, i, j]
        _rates(vk[stage], svk[stage], a, k, c, d, n_par, n_lift, dv[stage], dsv[stage],
               scratch[0], scratch[1], scratch[2])
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
def drag_solution(p, d, taus, max_step, sensitivities=True):
    """Positions, velocities and their parameter sensitivities at ``taus`` (each of one sign,
    ordered away from 0) for ``p = (r0, v0, a, k[, c])``, the state at ``tau = 0`` (``c``: the
    lift vector, 1 component in 2-D, 3 in 3-D, or none).

    Returns arrays ``R (m, d)``, ``V (m, d)``, ``SR (m, d, P)``, ``SV (m, d, P)``; without
    ``sensitivities`` the variational equations (most of the work) are not integrated and the
    last two mean nothing.
    """
    n_par = p.size
    n_sens = n_par if sensitivities else 0
    n_lift = n_par - 3 * d - 1
    m = taus.size
    R = np.empty((m, d))
    V = np.empty((m, d))
    SR = np.empty((m, d, n_par))
    SV = np.empty((m, d, n_par))
    r = p[:d].copy()
    v = p[d:2 * d].copy()
    a = p[2 * d:3 * d].copy()
    k = p[3 * d]
    c = p[3 * d + 1:].copy()
    sr = np.zeros((d, n_par))
    sv = np.zeros((d, n_par))
    for i in range(d):
        sr[i, i] = 1.0
        sv[i, d + i] = 1.0
    dv = np.empty((4, d))
    dsv = np.empty((4, d, n_par))
    vk = np.empty((4, d))
    svk = np.empty((4, d, n_par))
    scratch = np.zeros((3, max(d, n_lift, 1)))
    now = 0.0
    for j in range(m):
        span = taus[j] - now
        n_steps = max(1, int(math.ceil(abs(span) / max_step))) if span != 0.0 else 0
        for _ in range(n_steps):
            _rk4_step(r, v, sr, sv, a, k, c, span / n_steps, d, n_sens, n_lift, dv, dsv, vk,
                      svk, scratch)
        now = taus[j]
        R[j] = r
        V[j] = v
        SR[j] = sr
        SV[j] = sv
    return R, V, SR, SV


def solve(p: np.ndarray, d: int, taus: np.ndarray, sensitivities: bool = True
          ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`drag_solution` at any ``taus`` (either sign, any order), in their order."""
    taus = np.asarray(taus, dtype=float)
    p = np.asarray(p, dtype=float)
    if taus.size > 1 and np.all(taus[1:] >= taus[:-1]):  # sorted in time: the usual case
        i = int(np.searchsorted(taus, 0.0))
        parts = [drag_solution(p, d, taus[:i][::-1], RK4_MAX_STEP, sensitivities)] if i else []
        if i < taus.size:
            parts.append(drag_solution(p, d, taus[i:], RK4_MAX_STEP, sensitivities))
        if i:
            parts[0] = tuple(a[::-1] for a in parts[0])
        return tuple(np.concatenate(arrays) if len(parts) > 1 else arrays[0]
                     for arrays in zip(*parts, strict=True))  # type: ignore[return-value]
    out = (np.empty((taus.size, d)), np.empty((taus.size, d)),
           np.empty((taus.size, d, p.size)), np.empty((taus.size, d, p.size)))
    for side in (taus < 0, taus >= 0):
        idx = np.flatnonzero(side)
        if idx.size:
            idx = idx[np.argsort(np.abs(taus[idx]), kind="stable")]
            solution = drag_solution(p, d, taus[idx], RK4_MAX_STEP, sensitivities)
            for arr, part in zip(out, solution, strict=True):
                arr[idx] = part
    return out
