"""Centres of a small ball, refined per frame by a blurred, shaded disk fitted to the frame.

For a ball of a few pixels' radius the coverage centroid (:mod:`._measure`) is pulled towards
the lit side by up to ~0.4 px: the coverage's two outermost rings lie inside the blurred edge,
so the rim's grey level extrapolated from them falls to about the background and the coverage
becomes a thresholded mask (docs/tracking.md, the paper's camera). Here every frame's centre
is fitted instead, with the ball's blur and exposure from the edge model (:mod:`._edge`) held::

    I_i = B_i (1 - S_i) + S_i (b_0 + b_1 X_i + b_2 Y_i + b_3 n_z,i)
          + (1 - S_i) (o_0 + o_1 cos t_i + o_2 sin t_i)

``S`` the blurred step of the rim (as :mod:`._edge`: a Gaussian lens blur, the pixel's width
and the exposure's smear along the direction of motion, with the curvature shift of a blurred
circle), ``X, Y`` the offset from the centre over the radius, ``n_z = sqrt(1 - X^2 - Y^2)``
the sphere's normal towards the camera (Lambert shading under a light from any side, to first
order, and limb darkening), ``o`` the local background level on each side. The linear
coefficients ``b, o`` and the centre (and, in a first pass on a few frames, the radius) by
Gauss-Newton, a few steps from the coverage centroid: ``(2 + 7)`` parameters, ~200 pixels.

Why not the edge model itself on every frame: ~7 ms a frame through ``least_squares`` (35x the
224 x 64 speed target's budget); this model, compiled, costs ~10-20 us a frame. Why its radius
is fitted again: the edge model's radius of a 5 px ball is off by up to ~18 % under MPEG-4
(docs/tracking.md section 3) and a radius off by that much moves these centres (measured over
the 32 clips of ``benchmarks/paper_camera.py``: mean RMS 0.154 px with the edge model's radius
held, 0.118 with the true one, 0.144 with the median radius of this fit). Written by hand
because no library fits a blurred disk per frame at this cost.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ._edge_kernel import _cho_solve, _cholesky

SMALL_RADIUS = 8.0   # px: balls up to this radius get refined centres (larger ones: centroids)
N_ITER = 4           # Gauss-Newton steps per frame
RADIUS_FRAMES = 15   # frames of the first pass (radius free): its median radius is held after
N_LIN = 7            # linear coefficients: b_0..b_3, o_0..o_2
_INV_SQRT_2PI = 1.0 / math.sqrt(2.0 * math.pi)
_NZ_FLOOR = 0.05     # below it n_z's derivative (infinite at the rim) is taken as 0


@njit(cache=True)
def _pixel(du, dv, r, base, smear2, dir_u, dir_v, lin, dnl, r_free):
    """One pixel at offset ``(du, dv)`` from the centre: its design row ``lin`` (``N_LIN``),
    ``d S / d(cx, cy, r)`` and the angular and shading factors' derivatives into ``dnl``
    (rows: cx, cy, r; columns: S, X, Y, n_z, cos t, sin t); returns ``S``, ``cos t``,
    ``sin t``, ``X``, ``Y``, ``n_z``."""
    rho = max(math.hypot(du, dv), 1e-9)
    ct, st = du / rho, dv / rho
    cv = ct * dir_u + st * dir_v
    var_r = base + smear2 * cv * cv
    var_t = base + smear2 * (1.0 - cv * cv)
    s = math.sqrt(var_r)
    z = (r - var_t / (2.0 * r) - rho) / s
    step = 0.5 * math.erfc(-z / math.sqrt(2.0))
    dens = math.exp(-0.5 * z * z) * _INV_SQRT_2PI / s
    x, y = du / r, dv / r
    q2 = x * x + y * y
    nz = math.sqrt(max(1.0 - q2, 0.0))
    inv = 1.0 / nz if nz > _NZ_FLOOR else 0.0
    lin[0], lin[1], lin[2], lin[3] = step, step * x, step * y, step * nz
    out = 1.0 - step
    lin[4], lin[5], lin[6] = out, out * ct, out * st
    # d/dcx, d/dcy (the centre moves: du, dv fall by one)
    dnl[0, 0], dnl[1, 0] = dens * ct, dens * st
    dnl[0, 1], dnl[1, 1] = -1.0 / r, 0.0
    dnl[0, 2], dnl[1, 2] = 0.0, -1.0 / r
    dnl[0, 3], dnl[1, 3] = x * inv / r, y * inv / r
    dnl[0, 4], dnl[1, 4] = -st * st / rho, ct * st / rho
    dnl[0, 5], dnl[1, 5] = ct * st / rho, -ct * ct / rho
    if r_free:
        dnl[2, 0] = dens * (1.0 + var_t / (2.0 * r * r))
        dnl[2, 1], dnl[2, 2], dnl[2, 3] = -x / r, -y / r, q2 / r * inv
        dnl[2, 4] = dnl[2, 5] = 0.0
    return step, ct, st, x, y, nz


@njit(cache=True)
def _fit_frame(frame, bg, gain, cx, cy, vx, vy, r, sigma, exposure, r_free, n_iter):
    """One frame's fit from the centre ``(cx, cy)``: ok, centre, radius."""
    h, w = frame.shape
    speed = math.hypot(vx, vy)
    dir_u, dir_v = (vx / speed, vy / speed) if speed > 0 else (1.0, 0.0)
    smear2 = (exposure * speed) ** 2 / 12.0
    base = sigma * sigma + 1.0 / 12.0
    reach = r + 2.0 + 3.0 * math.sqrt(base + smear2)
    u0, v0 = int(math.floor(cx - reach)), int(math.floor(cy - reach))
    u1, v1 = int(math.ceil(cx + reach)) + 1, int(math.ceil(cy + reach)) + 1
    if u0 < 0 or v0 < 0 or u1 > w or v1 > h:
        return False, cx, cy, r
    n_max = (u1 - u0) * (v1 - v0)
    pu = np.empty(n_max)
    pv = np.empty(n_max)
    grey = np.empty(n_max)
    back = np.empty(n_max)
    n = 0
    for i in range(v0, v1):
        for j in range(u0, u1):
            if (j - cx) ** 2 + (i - cy) ** 2 <= reach * reach:
                pu[n], pv[n] = j, i
                grey[n], back[n] = frame[i, j], gain * bg[i, j]
                n += 1
    n_nl = 3 if r_free else 2
    m = n_nl + N_LIN
    lin = np.empty(N_LIN)
    dnl = np.zeros((3, 6))
    row = np.empty(m)
    beta = np.zeros(N_LIN)
    r0, x0, y0 = r, cx, cy
    for it in range(n_iter + 1):
        # it == 0: the linear coefficients alone; then joint Gauss-Newton steps
        jtj = np.zeros((m, m))
        jtr = np.zeros(m)
        for k in range(n):
            step, ct, st, x, y, nz = _pixel(pu[k] - cx, pv[k] - cy, r, base, smear2, dir_u,
                                            dir_v, lin, dnl, r_free)
            res = grey[k] - back[k] * (1.0 - step)
            if it == 0:
                for a in range(N_LIN):
                    row[a] = lin[a]
                size = N_LIN
            else:
                for a in range(N_LIN):
                    res -= beta[a] * lin[a]
                    row[n_nl + a] = lin[a]
                shade = beta[0] + beta[1] * x + beta[2] * y + beta[3] * nz
                other = beta[4] + beta[5] * ct + beta[6] * st
                d_step = shade - back[k] - other  # d model / d S
                for p in range(n_nl):
                    row[p] = (d_step * dnl[p, 0]
                              + step * (beta[1] * dnl[p, 1] + beta[2] * dnl[p, 2]
                                        + beta[3] * dnl[p, 3])
                              + (1.0 - step) * (beta[5] * dnl[p, 4] + beta[6] * dnl[p, 5]))
                size = m
            for a in range(size):
                jtr[a] += row[a] * res
                for b in range(a + 1):
                    jtj[a, b] += row[a] * row[b]
        size = N_LIN if it == 0 else m
        sub = np.empty((size, size))
        ridge = 0.0
        for a in range(size):
            ridge += jtj[a, a]
        ridge *= 1e-10 / size
        for a in range(size):
            for b in range(a + 1):
                sub[a, b] = jtj[a, b]
                sub[b, a] = jtj[a, b]
            sub[a, a] += ridge
        if not _cholesky(sub):
            return False, cx, cy, r
        delta = jtr[:size].copy()
        _cho_solve(sub, delta)
        if it == 0:
            beta[:] = delta
            continue
        if abs(delta[0]) > 3.0 or abs(delta[1]) > 3.0:
            return False, cx, cy, r
        cx += delta[0]
        cy += delta[1]
        if r_free:
            r = min(max(r + delta[2], 0.7 * r0), 1.3 * r0)
        for a in range(N_LIN):
            beta[a] += delta[n_nl + a]
        if math.hypot(cx - x0, cy - y0) > 0.5 * r0:  # diverged: not this ball
            return False, cx, cy, r
    return True, cx, cy, r


@njit(cache=True)
def refine_frames(frames, bg, gains, idx, start, vel, r, sigma, exposure, r_free, n_iter):
    """:func:`_fit_frame` on frames ``idx`` from centres ``start`` ``(len(idx), 2)`` with
    velocities ``vel`` (px per frame): ``(len(idx), 3)`` centre and radius, NaN where the fit
    failed."""
    out = np.full((len(idx), 3), np.nan)
    for n in range(len(idx)):
        k = idx[n]
        ok, cx, cy, rr = _fit_frame(frames[k], bg, gains[k], start[n, 0], start[n, 1],
                                    vel[n, 0], vel[n, 1], r, sigma, exposure, r_free, n_iter)
        if ok:
            out[n, 0], out[n, 1], out[n, 2] = cx, cy, rr
    return out


def refine_centres(frames: np.ndarray, bg: np.ndarray, gains: np.ndarray, centre: np.ndarray,
                   method: np.ndarray, fit) -> np.ndarray:
    """Refine, in place, the centres of the frames with the ball wholly in view (``method``
    ``CENTROID``) where the ball is small (the edge model's radius ``fit.radius`` at most
    ``SMALL_RADIUS``); returns the mask of the frames refined (a failed fit keeps its
    centroid). First ``RADIUS_FRAMES`` frames spread over the video with the radius free, then
    every frame with it held at their median."""
    from ._measure import CENTROID

    done = np.zeros(len(frames), bool)
    if fit is None or not fit.radius <= SMALL_RADIUS:
        return done
    idx = np.flatnonzero(method == CENTROID)
    if len(idx) < 3:
        return done
    found = ~np.isnan(centre[:, 0])
    prev, nxt = np.maximum(idx - 1, 0), np.minimum(idx + 1, len(frames) - 1)
    both = found[prev] & found[nxt] & (nxt > prev)
    vel = np.where(both[:, None], (centre[nxt] - centre[prev]) / np.maximum(nxt - prev, 1)[:, None],
                   0.0)
    frames = np.ascontiguousarray(frames)
    bg64 = np.ascontiguousarray(bg, np.float64)
    gains = np.ascontiguousarray(gains, np.float64)
    start = np.ascontiguousarray(centre[idx], np.float64)
    vel = np.ascontiguousarray(vel, np.float64)
    sub = np.unique(np.linspace(0, len(idx) - 1, min(RADIUS_FRAMES, len(idx))).round()
                    .astype(np.int64))
    first = refine_frames(frames, bg64, gains, idx[sub].astype(np.int64), start[sub], vel[sub],
                          float(fit.radius), float(fit.sigma), float(fit.exposure), True, N_ITER)
    radii = first[:, 2][~np.isnan(first[:, 2])]
    r = float(np.median(radii)) if len(radii) >= 3 else float(fit.radius)
    out = refine_frames(frames, bg64, gains, idx.astype(np.int64), start, vel, r,
                        float(fit.sigma), float(fit.exposure), False, N_ITER)
    ok = ~np.isnan(out[:, 0])
    centre[idx[ok]] = out[ok, :2]
    done[idx[ok]] = True
    return done
