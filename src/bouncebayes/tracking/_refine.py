"""The ball's centres, refined per frame by a blurred, shaded disk fitted to the frame.

For a ball of a few pixels' radius the coverage centroid (:mod:`._measure`) is pulled towards
the lit side by up to ~0.4 px: the coverage's two outermost rings lie inside the blurred edge,
so the rim's grey level extrapolated from them falls to about the background and the coverage
becomes a thresholded mask (docs/tracking.md, the paper's camera). A larger ball's centroid
follows the wall's texture under its blurred rim (the wall it hides, which the background
model does not show) and its highlight: errors of 0.05-0.3 px that change smoothly along the
track, so that they bias the velocities at the impact (the rebound angle by up to 3.6 standard
errors on rendered footage). Here every frame's centre is fitted instead, with the ball's blur
and exposure from the edge model (:mod:`._edge`) held (a ball larger than ``SMALL_RADIUS``
on the pixels near its rim only, :func:`rim_only`)::

    I_i = B_i (1 - S_i) + S_i (b_0 + b_1 X_i + b_2 Y_i + b_4 X_i Y_i + b_5 (X_i^2 - Y_i^2))
          + b_3 N_i + (1 - S_i) (o_0 + o_1 cos t_i + o_2 sin t_i) + c_1 M_i + c_2 M'_i

``S`` the blurred step of the rim (as :mod:`._edge`: a Gaussian lens blur, the pixel's width
and the exposure's smear along the direction of motion, with the curvature shift of a blurred
circle), ``X, Y`` the pixel's offset from the centre over the radius, ``N`` the blurred normal
towards the camera ``n_z = sqrt(u (2r - u)) / r`` (``u`` the depth inside the rim; blurred
through the edge model's table of ``E[sqrt(u + e)_+]``), ``t`` the polar angle and ``o`` the
local background level on each side: the edge model's shading (:mod:`._edge`, the spherical
harmonics of the normal to order 2) cut to the terms that matter at this size, so that side
light and limb darkening do not pull the centre. ``M, M'``: where the light is not frontal,
the edge model's two shadow columns (:func:`._edge_kernel._shadow`: the blurred ``min(0, n .
L)`` and ``n_z min(0, n . L)``, the kink of Lambert shading at the terminator, which runs near
the rim on the side away from the light; without them a ball lit from the side had its centres
pulled away from the light by up to 0.2 px). The linear coefficients and the centre by
Gauss-Newton on the ~150 pixels within about two blurs of the rim that are in the frame:
``N_ITER`` step from the centre predicted from the two frames before, one more from the
coverage centroid (or the frame-edge disk fit) where there is no prediction or it is off by
more than ``PREDICT_PX`` (the impact). The radius first (free, with the centre, on
``RADIUS_FRAMES`` frames spread over the video, without the shadow: their median is the
ball's radius, which gives a small ball's scale); on ``LIGHT_FRAMES`` of them the light's
direction (:func:`find_light`), and where it casts a shadow those frames again with it, whose
median radius the fits of every frame then hold. A frame whose fit misfits one side of the rim
by a large part of the ball's contrast (a logo near it takes a bite out of the rim, which the
fit follows) is fitted again without that side (:func:`_fit_clean`, ``MISFIT_SECTOR``). The
exposure's smear takes the ball's velocity from the frames either side (:func:`_velocities`:
the slower side where the ball jumps).

Measured over the 32 clips of ``benchmarks/paper_camera.py`` (radius 5 px; RMS error of the
centres, mean over clips): the coverage centroid with the edge fits' offset 0.224 px; this
fit without the shadow columns 0.092 px (0.088 with two steps from the centroid in every
frame, ~10 % more time), 0.100 px with the blur from the compiled edge fit (docs/tracking.md
section 4), 26 of the 32 within 0.15 px; with them 0.070 px, 31 of 32 (the side-lit clips
0.15-0.25 -> 0.04-0.10 px; docs/tracking.md section 3). Two more shading
terms, ``N X`` and ``N Y`` (the limb of a side-lit ball), were tried with the one step per
frame: 0.161 px. Its
radius is its own: the edge model's is off by up to 18 % at this size under MPEG-4
(docs/tracking.md section 3), and even the true radius held gives 0.124 px (the true blur
0.099): the fitted ones are this model's effective values. With ``n_z`` unblurred (an earlier
version) its radius came out ~0.3 px small at a blur of 0.6 px, pulling the centres towards
the lit side by up to 0.18 px.

Why not the edge model itself on every frame: ~2 ms a frame even compiled (four fits of 5-11
model evaluations, each solving ~20 linear coefficients; 10x the 224 x 64 speed target's
budget, and ~7 ms through ``scipy.optimize.least_squares`` before); this fit, compiled, ~20 us
a frame. Written by hand
because no library fits a blurred disk per frame at this cost.
"""

from __future__ import annotations

import functools
import math
from typing import NamedTuple

import numpy as np
from numba import njit

from ._edge import median_and_se, spread
from ._edge_kernel import (BAND_BLURS, BAND_PX, MISFIT_ROUNDS, MISFIT_SECTOR, SECTORS, _cho_solve,
                           _cholesky, _shadow, foreign_sectors, grow_run, sector_misfit,
                           sector_of)

SMALL_RADIUS = 8.0   # px: balls up to this radius are fitted over their whole disk, and the
#                      fit's radius is the ball's; larger ones over their rim only (INNER_BLURS),
#                      their radius the edge model's
# ... a larger ball's pixels deeper than REACH_PX + INNER_BLURS blurs inside the rim are left
# out: its interior holds nothing of the centre that the rim does not, and the shading there
# (a highlight's lobe, a mark on the ball) is what the cut-down model follows worst. Measured
# on 48 bounces of benchmarks/tracking_centres.py (radius 10-20 px, blur 0-1.5 px, exposure
# 0-80 %, side-lit, glossy and dark balls, textured and plain walls, MJPEG or none): the
# centres' RMS error about their mean, median over the bounces, 0.083 px as coverage
# centroids, 0.028 px fitted on the rim (largest 0.34 -> 0.08); the rebound angle's z-scores
# RMS 1.72 -> 0.57 (largest 3.60 -> 1.18). The whole disk fitted: 0.065 px against 0.029 on
# the rim on a 10 px side-lit ball over texture, and a ball with a dark stripe painted on it
# 0.59 px against 0.27 (centroids 0.30)
INNER_BLURS = 2.5
N_ITER = 1           # Gauss-Newton steps per frame from the centre predicted from the two
#                      frames before (from the centroid: one more; 2 and 3 steps from it give the
#                      same accuracy, 1 less; benchmarks/paper_camera.py)
PREDICT_PX = 0.5     # the prediction is used where within this of the centroid (not at impact)
BACKWARD_PX = 1.0    # a fit this far from the prediction from the two frames after is tried again
#                      from there (_backward) ...
BACKWARD_REACH = 0.5  # ... where that lies within this many radii of the frame's centroid
# a frame whose per-frame centre fit leaves an RMS residual over REFIT_FACTOR times the
# video's median (and _quality.REFIT_EXCESS of the ball's contrast beyond it) is flagged:
# part of the ball hidden by something in front of it that the background holds as well (a
# frame counter burned in across its path, tests/render_pbr.py: the frames 0.7-3.6 px off
# 2.0-10 times the median, the coverage's misfit only 1.0-2.3 times its own, high on every
# frame of that low-contrast ball; clean frames of ten rendered scenes, contact shadow, lit
# band, glossy, dark, marked and motion-blurred balls of 6-15 px, MJPEG, at most 1.65 times)
REFIT_FACTOR = 2.0   # (flagged: _quality.refit_misfit; nor do they predict: _backward)
RADIUS_FRAMES = 15   # frames of the first pass (radius free): its median radius is held after
REACH_PX, REACH_BLURS = 1.0, 2.5  # pixels fitted: within r + REACH_PX + REACH_BLURS blurs
N_LIN = 9            # linear coefficients: b_0..b_5, o_0..o_2
N_SHADOW = 2         # shadow columns (those of the edge model) where the light is not frontal
SHADOW_NODES = 4     # their quadrature nodes (the crescent is < 1.5 px deep at this size: 4
#                      nodes give the columns to 4e-6 of their largest value; the edge model: 12)
LIGHT_FRAMES = 5     # frames the light's direction is chosen on (of the RADIUS_FRAMES)
LIGHT_GAIN = 15.0    # the shadow kept where it lowers their cost by at least this many residual
#   variances a frame (32 clips of benchmarks/paper_camera.py: lit from the camera 3-33, from
#   73 degrees 5-59, from 48-50 degrees 130-215)
# the light's azimuth: the shading's gradient's, and within +-30 degrees of it (10 apart); its
# elevation: the best of these (radians; 49, 57, 69 degrees). The cost is nearly flat in the
# elevation and under a blur prefers ones lower than the light's (20-30 degrees for a light at
# 48, blur 0.6 px: the blurred crescent trades against the blur and the shading), where the
# centres are pulled the other way (a clip lit from the left: RMS 0.056 px at 48 degrees,
# 0.103 at 34, 0.158 at 20; docs/tracking.md section 3)
LIGHT_OFFSETS = np.radians(np.arange(-30.0, 31.0, 10.0))
LIGHT_ELEVATIONS = (0.85, 1.0, 1.2)
SE_FACTOR = 2.0      # the stated per-frame SD of refined centres: this times their formal SE
#   (independent pixels; MJPEG/MPEG-4 errors are correlated between pixels, which it misses).
#   Over the 32 clips of benchmarks/paper_camera.py the centres' scatter about their mean error
#   is 0.46-1.60x the formal SE, and they drift along a flight by up to ~0.1 px with the ball's
#   speed or height (the same in every lighting; the rebound angle's error, ~0.4 degrees in the
#   worst clips, did not shrink with the shadow columns while the formal SE did): with 1.5 the
#   rebound angle's z-scores had a mean square of 1.32 (largest 2.94), with 2.0 0.75 (2.21)
VELOCITY_JUMP = 4.0  # _velocities: one one-sided difference this many times the other
_INV_SQRT_2PI = 1.0 / math.sqrt(2.0 * math.pi)
_INV_SQRT2 = 1.0 / math.sqrt(2.0)


@njit(cache=True)
def _phi(z, gauss):
    """The standard normal CDF at ``z``, given ``gauss = exp(-z^2 / 2)``: Abramowitz & Stegun
    7.1.26 (``erfc`` to 1.5e-7, so ``S`` to 7.5e-8: 1e-5 grey levels at a contrast of 150),
    which reuses the exponential the density needs (with ``math.erfc`` a pass over 150 pixels
    took 10 us instead of 6)."""
    t = 1.0 / (1.0 + 0.3275911 * _INV_SQRT2 * abs(z))
    tail = 0.5 * t * (0.254829592 + t * (-0.284496736 + t * (1.421413741 + t * (
        -1.453152027 + t * 1.061405429)))) * gauss
    return 1.0 - tail if z >= 0.0 else tail


@njit(cache=True)
def _pixel(du, dv, r, inv_r, base, inv_s0, smear2, dir_u, dir_v, r_free, out, k, z0,
           inv_dzt, gt, dgt):
    """One pixel at offset ``(du, dv)`` from the centre, into row ``k`` of ``out``: ``S``,
    ``cos t``, ``sin t``, ``X``, ``Y``, ``N``, then the derivatives of ``S``, ``X``, ``Y``,
    ``N``, ``cos t``, ``sin t`` with respect to ``cx``, then ``cy``, then ``r`` (where
    ``r_free``), then (columns 24-27, for the shadow columns) ``rho``, the depth inside the
    rim, the radial blur and the tangential variance. ``inv_r = 1 / r``, ``inv_s0 = base^-1/2`` (the blur without smear); ``z0,
    inv_dzt, gt, dgt``: the table of ``G(z) = E[sqrt(z + Z)_+]`` (grid start, 1 / step, values,
    derivative)."""
    rho = max(math.sqrt(du * du + dv * dv), 1e-9)
    inv_rho = 1.0 / rho
    ct, st = du * inv_rho, dv * inv_rho
    if smear2 > 0.0:
        cv = ct * dir_u + st * dir_v
        var_t = base + smear2 * (1.0 - cv * cv)
        inv_s = 1.0 / math.sqrt(base + smear2 * cv * cv)
    else:
        var_t, inv_s = base, inv_s0
    u = r - 0.5 * var_t * inv_r - rho  # the depth inside the (blurred) rim
    z = u * inv_s
    out[k, 24], out[k, 25], out[k, 26], out[k, 27] = rho, u, 1.0 / inv_s, var_t
    gauss = math.exp(-0.5 * z * z)
    dens = gauss * _INV_SQRT_2PI * inv_s
    x, y = du * inv_r, dv * inv_r
    # the blurred n_z = sqrt(u (2r - u)) / r: E[sqrt(u + e)_+] (the edge model's table) times
    # sqrt(2 / r) sqrt(1 - u / (2 r)), and its derivative with respect to the depth u
    depth = z / inv_s
    pos = (z - z0) * inv_dzt
    if pos >= len(gt) - 1:
        root, droot = math.sqrt(max(depth, 0.0)), 0.5 / math.sqrt(max(depth, 1e-9))
    else:
        i0 = max(int(pos), 0)
        f = min(max(pos - i0, 0.0), 1.0)
        s_half = 1.0 / math.sqrt(inv_s)
        root = s_half * (gt[i0] * (1.0 - f) + gt[i0 + 1] * f)
        droot = (dgt[i0] * (1.0 - f) + dgt[i0 + 1] * f) / s_half
    fac = math.sqrt(max(inv_r + rho * inv_r * inv_r, 1e-12))  # sqrt(2/r) sqrt(1 - (r-rho)/2r)
    nz = root * fac
    dnz_du = droot * fac - root * 0.5 * inv_r * inv_r / fac  # u = r - rho: d rho = -d u
    out[k, 0] = _phi(z, gauss)
    out[k, 1], out[k, 2], out[k, 3], out[k, 4], out[k, 5] = ct, st, x, y, nz
    # the centre moves: du, dv fall by one
    out[k, 6], out[k, 7], out[k, 8], out[k, 9] = dens * ct, -inv_r, 0.0, dnz_du * ct
    out[k, 10], out[k, 11] = -st * st * inv_rho, ct * st * inv_rho
    out[k, 12], out[k, 13], out[k, 14], out[k, 15] = dens * st, 0.0, -inv_r, dnz_du * st
    out[k, 16], out[k, 17] = ct * st * inv_rho, -ct * ct * inv_rho
    if r_free:
        out[k, 18] = dens * (1.0 + 0.5 * var_t * inv_r * inv_r)
        dfac_dr = -(inv_r * inv_r + 2.0 * rho * inv_r * inv_r * inv_r) / (2.0 * fac)
        out[k, 19], out[k, 20] = -x * inv_r, -y * inv_r
        out[k, 21] = droot * fac * (1.0 + 0.5 * var_t * inv_r * inv_r) + root * dfac_dr
        out[k, 22] = out[k, 23] = 0.0


_N_AUX = 28


@njit(cache=True)
def _result(cx, cy, r, se_x, se_y, rss, n, b_1, b_2):
    """A fit's outcome as one array: centre, radius, the centre's formal standard errors, the
    residual sum of squares and pixel count, and the shading's gradient ``b_1, b_2``."""
    out = np.empty(9)
    out[0], out[1], out[2], out[3], out[4] = cx, cy, r, se_x, se_y
    out[5], out[6], out[7], out[8] = rss, n, b_1, b_2
    return out


@njit(cache=True)
def _fit_frame(frame, bg, gain, cx, cy, vx, vy, r, sigma, exposure, r_free, n_iter, z0, dzt,
               gt, dgt, az, el, nodes, inner, occlusion, cast, drop, score):
    """One frame's fit from the centre ``(cx, cy)``, ``n_iter`` Gauss-Newton steps, with the
    shadow columns of a light from ``(az, el)`` (radians; none where ``el >= pi/2``): ok, and
    :func:`_result` (the centre's formal standard errors: the residual's variance times the
    inverse normal matrix, px). With ``n_iter = 0`` only the linear coefficients at the
    starting centre: the residual sum of squares there and the shading's gradient. Pixels
    nearer the centre than ``inner`` (px) are left out (:func:`rim_only`); with ``occlusion``
    the model has the wall the ball hides, ``+ k grad B . (-grad S)`` (``k = sigma^2 + 1/12``,
    the background's gradient from central differences; the edge model's term, held, not
    differentiated: a few per cent of the step's own derivative). ``cast``: the ball's shadow
    on the wall ``(du, dv, radius, penumbra, depth)`` (px; depth 0: none, :mod:`._cast`),
    painted into the background at each step's centre (held, not differentiated). Pixels in
    the polar sectors ``drop`` (about the starting centre; :data:`SECTORS` booleans) are left
    out; ``score`` (as many floats) is written with each sector's misfit after the last step
    (:func:`._edge_kernel.sector_misfit`; not written with ``n_iter = 0`` or where the fit
    fails)."""
    h, w = frame.shape
    speed = math.hypot(vx, vy)
    dir_u, dir_v = (vx / speed, vy / speed) if speed > 0 else (1.0, 0.0)
    smear2 = (exposure * speed) ** 2 / 12.0
    base = sigma * sigma + 1.0 / 12.0
    reach = _reach(r, base + smear2)
    # the wall beyond the blurred rim, read to check it against the background (not fitted)
    band_from = r + BAND_BLURS * math.sqrt(base + smear2)
    gather = max(reach, band_from + BAND_PX)
    # the pixels in the frame (a ball near its edge: the ring outside it is cut)
    u0, v0 = max(int(math.floor(cx - gather)), 0), max(int(math.floor(cy - gather)), 0)
    u1, v1 = min(int(math.ceil(cx + gather)) + 1, w), min(int(math.ceil(cy + gather)) + 1, h)
    if u1 - u0 < 3 or v1 - v0 < 3:
        return False, _result(cx, cy, r, 0.0, 0.0, 0.0, 0, 0.0, 0.0)
    n_max = (u1 - u0) * (v1 - v0)
    pu = np.empty(n_max)
    pv = np.empty(n_max)
    grey = np.empty(n_max)
    back = np.empty(n_max)
    gbu = np.zeros(n_max)
    gbv = np.zeros(n_max)
    n = 0
    for i in range(v0, v1):
        for j in range(u0, u1):
            d2 = (j - cx) ** 2 + (i - cy) ** 2
            if d2 <= gather * gather and d2 >= inner * inner:
                pu[n], pv[n] = j, i
                grey[n], back[n] = frame[i, j], gain * bg[i, j]
                if occlusion:  # the background's gradient: central differences
                    ja, jb = max(j - 1, 0), min(j + 1, w - 1)
                    ia, ib = max(i - 1, 0), min(i + 1, h - 1)
                    gbu[n] = gain * (bg[i, jb] - bg[i, ja]) / (jb - ja)
                    gbv[n] = gain * (bg[ib, j] - bg[ia, j]) / (ib - ia)
                n += 1
    # the wall beside the ball as the background model has it (a lamp's shadow of the ball:
    # _edge_kernel.foreign_sectors)
    du, dv = pu[:n] - cx, pv[:n] - cy
    rho = np.sqrt(du * du + dv * dv)
    wall = np.empty(n)
    _shaded(pu[:n], pv[:n], back[:n], cx, cy, cast, wall)
    mask = ~foreign_sectors(grey[:n] - wall, du, dv, rho, band_from) & (rho <= reach)
    if drop.any():  # the sectors left out (_fit_clean)
        for k in range(n):
            mask[k] &= not drop[sector_of(du[k], dv[k])]
    keep = np.flatnonzero(mask)
    pu, pv, grey, back = pu[keep], pv[keep], grey[keep], back[keep]
    gbu, gbv = gbu[keep], gbv[keep]
    n = keep.size
    n_nl = 3 if r_free else 2
    n_sh = N_SHADOW if el < 0.5 * math.pi else 0  # lit from the camera: no shadow column
    n_lin = N_LIN + n_sh
    m = n_nl + n_lin
    az_c, az_s = math.cos(az), math.sin(az)
    cp = np.zeros((2, 7))
    dsh = np.zeros((n, max(n_sh, 1), 3))  # the shadow columns' derivatives (cx, cy, r)
    inv_s0, inv_dzt = 1.0 / math.sqrt(base), 1.0 / dzt
    if n < 4 * m:
        return False, _result(cx, cy, r, 0.0, 0.0, 0.0, 0, 0.0, 0.0)
    aux = np.empty((n, _N_AUX))
    jt = np.empty((m, n))  # the Jacobian, transposed: its rows' dot products vectorise
    res = np.empty(n)
    beta = np.zeros(n_lin)
    r0, x0, y0 = r, cx, cy
    wall = np.empty(n)  # (written by _shaded at each step)
    for it in range(max(n_iter, 1)):
        _shaded(pu, pv, back, cx, cy, cast, wall)
        for k in range(n):
            _pixel(pu[k] - cx, pv[k] - cy, r, 1.0 / r, base, inv_s0, smear2, dir_u, dir_v, r_free,
                   aux, k, z0, inv_dzt, gt, dgt)
            step, ct, st = aux[k, 0], aux[k, 1], aux[k, 2]
            out = 1.0 - step
            jt[n_nl, k], jt[n_nl + 1, k] = step, step * aux[k, 3]
            jt[n_nl + 2, k], jt[n_nl + 3, k] = step * aux[k, 4], aux[k, 5]
            jt[n_nl + 4, k] = step * aux[k, 3] * aux[k, 4]
            jt[n_nl + 5, k] = step * (aux[k, 3] * aux[k, 3] - aux[k, 4] * aux[k, 4])
            jt[n_nl + 6, k] = out
            jt[n_nl + 7, k], jt[n_nl + 8, k] = out * ct, out * st
            if n_sh > 0:
                rho, var_t = aux[k, 24], aux[k, 27]
                _shadow(aux[k, 25], aux[k, 26], r, ct, st, az_c, az_s, el, nodes, cp)
                for j in range(n_sh):
                    jt[n_nl + N_LIN + j, k] = cp[j, 0]
                    # the depth grows by cos t, the angle by sin t / rho as cx grows
                    dsh[k, j, 0] = cp[j, 1] * ct + cp[j, 4] * st / rho
                    dsh[k, j, 1] = cp[j, 1] * st - cp[j, 4] * ct / rho
                    dsh[k, j, 2] = cp[j, 1] * (1.0 + 0.5 * var_t / (r * r)) + cp[j, 3]
            res[k] = grey[k] - wall[k] * out
            if occlusion:  # the wall the ball hides: + k grad B . (-grad S), k = sigma^2 + 1/12
                res[k] -= base * (gbu[k] * aux[k, 6] + gbv[k] * aux[k, 12])
        if it == 0:  # the linear coefficients at the starting centre
            ok, beta = _solve(*_normal(jt, res, n_nl))
            if not ok:
                return False, _result(cx, cy, r, 0.0, 0.0, 0.0, 0, 0.0, 0.0)
            if n_iter == 0:  # only the cost there
                rss = 0.0
                for k in range(n):
                    e = res[k]
                    for q in range(n_lin):
                        e -= beta[q] * jt[n_nl + q, k]
                    rss += e * e
                return True, _result(cx, cy, r, 0.0, 0.0, rss, n, beta[1], beta[2])
        for k in range(n):
            step, ct, st = aux[k, 0], aux[k, 1], aux[k, 2]
            e = res[k]
            for q in range(n_lin):
                e -= beta[q] * jt[n_nl + q, k]
            res[k] = e
            x, y = aux[k, 3], aux[k, 4]
            d_step = (beta[0] + beta[1] * x + beta[2] * y
                      + beta[4] * x * y + beta[5] * (x * x - y * y) - wall[k]
                      - beta[6] - beta[7] * ct - beta[8] * st)  # d model / d S
            for p in range(n_nl):
                o = 6 + 6 * p
                dx, dy, dnz = aux[k, o + 1], aux[k, o + 2], aux[k, o + 3]
                jt[p, k] = (d_step * aux[k, o]
                            + beta[3] * dnz + step * (beta[1] * dx + beta[2] * dy
                                      + beta[4] * (dx * y + x * dy)
                                      + beta[5] * 2.0 * (x * dx - y * dy))
                            + (1.0 - step) * (beta[7] * aux[k, o + 4] + beta[8] * aux[k, o + 5]))
                for j in range(n_sh):
                    jt[p, k] += beta[N_LIN + j] * dsh[k, j, p]
        mat, rhs = _normal(jt, res, 0)
        ok, delta = _solve(mat, rhs)  # mat: its Cholesky factor
        if not ok or abs(delta[0]) > 3.0 or abs(delta[1]) > 3.0:
            return False, _result(cx, cy, r, 0.0, 0.0, 0.0, 0, 0.0, 0.0)
        cx += delta[0]
        cy += delta[1]
        if r_free:
            r = min(max(r + delta[2], 0.7 * r0), 1.3 * r0)
        for q in range(n_lin):
            beta[q] += delta[n_nl + q]
        if math.hypot(cx - x0, cy - y0) > 0.5 * r0:  # diverged: not this ball
            return False, _result(cx, cy, r, 0.0, 0.0, 0.0, 0, 0.0, 0.0)
    sector_misfit(res, grey, wall, aux[:, 0], pu - cx, pv - cy, r, score)
    # the centre's formal standard errors, from the last step's residual and normal equations
    var = 0.0
    for k in range(n):
        var += res[k] * res[k]
    var /= max(n - m, 1)
    se = np.zeros(2)
    for p in range(2):
        e = np.zeros(m)
        e[p] = 1.0
        _cho_solve(mat, e)
        se[p] = math.sqrt(max(e[p], 0.0) * var)
    return True, _result(cx, cy, r, se[0], se[1], var * max(n - m, 1), n, beta[1], beta[2])


@njit(cache=True)
def _fit_clean(frame, bg, gain, cx, cy, vx, vy, r, sigma, exposure, r_free, n_iter, z0, dzt,
               gt, dgt, az, el, nodes, inner, occlusion, cast):
    """:func:`_fit_frame` (its arguments), and where a polar sector of the ball's rim misfits by
    more than ``MISFIT_SECTOR`` of its contrast, again from that fit's centre without the run
    of sectors about the worst (:func:`._edge_kernel.grow_run`; ``n_iter + 1`` steps, up to
    ``MISFIT_ROUNDS`` times and ``MISFIT_SECTORS`` sectors in all; kept where it succeeds).
    Not where the fit reads beyond the frame (:func:`_in_frame`)."""
    score = np.zeros(SECTORS)
    drop = np.zeros(SECTORS, np.bool_)
    ok, fit = _fit_frame(frame, bg, gain, cx, cy, vx, vy, r, sigma, exposure, r_free, n_iter,
                         z0, dzt, gt, dgt, az, el, nodes, inner, occlusion, cast, drop, score)
    if not ok or n_iter == 0 or not _in_frame(frame.shape, fit[0], fit[1], r, sigma):
        return ok, fit
    first = fit
    for _ in range(MISFIT_ROUNDS):
        worst = int(np.argmax(np.abs(score)))
        if abs(score[worst]) <= MISFIT_SECTOR or not grow_run(score, worst, drop):
            break
        ok2, fit2 = _fit_frame(frame, bg, gain, fit[0], fit[1], vx, vy, fit[2], sigma, exposure,
                               r_free, n_iter + 1, z0, dzt, gt, dgt, az, el, nodes, inner,
                               occlusion, cast, drop, score)
        if not ok2:
            break
        # the refit's formal SEs the whole rim's where larger: what that fit left unexplained
        # stays stated
        fit2[3:5] = np.maximum(fit2[3:5], first[3:5])
        fit = fit2
    return ok, fit


@njit(cache=True)
def _in_frame(shape, cx, cy, r, sigma):
    """Whether the pixels a fit of a ball at ``(cx, cy)`` reads (:func:`_fit_frame`, without
    the exposure's smear) all lie in a frame of ``shape``."""
    reach = _reach(r, sigma * sigma + 1.0 / 12.0)
    return (cx - reach >= 0.0 and cy - reach >= 0.0 and cx + reach <= shape[1] - 1.0
            and cy + reach <= shape[0] - 1.0)


@njit(cache=True)
def _reach(r, blur2):
    """How far (px) from a ball's centre a fit reads (:func:`_fit_frame`): ``REACH_PX`` and
    ``REACH_BLURS`` blurs beyond its radius ``r``, ``blur2`` the blur's variance (px^2: the
    lens's, the pixel's and the exposure's smear)."""
    return r + REACH_PX + REACH_BLURS * math.sqrt(blur2)


@njit(cache=True)
def _shaded(pu, pv, back, cx, cy, cast, wall):
    """``wall``: the background ``back`` at pixels ``(pu, pv)`` with the ball's shadow
    ``cast`` (:func:`_fit_frame`) painted in, the ball at ``(cx, cy)``; ``back`` where none."""
    if cast[4] <= 0.0:
        wall[:] = back
        return
    for k in range(pu.size):
        z = (cast[2] - math.hypot(pu[k] - cx - cast[0], pv[k] - cy - cast[1])) / cast[3]
        wall[k] = back[k] * (1.0 - cast[4] * _phi(z, math.exp(-0.5 * z * z)))


@njit(cache=True, fastmath=True)
def _normal(jt, res, first):
    """The normal equations of the rows ``first:`` of the transposed Jacobian ``jt``
    (parameters x pixels): ``J^T J`` and ``J^T res``, as dot products of contiguous rows,
    ``fastmath`` so that the sums are vectorised (reassociated: the last bits differ from a
    sum in order). 5x faster than NumPy's ``J.T @ J`` through BLAS on a matrix this small
    (~150 x 9), 25x than the sums in order."""
    m, n = jt.shape
    size = m - first
    mat = np.empty((size, size))
    rhs = np.empty(size)
    for a in range(size):
        s = 0.0
        for k in range(n):
            s += jt[first + a, k] * res[k]
        rhs[a] = s
        for b in range(a + 1):
            s = 0.0
            for k in range(n):
                s += jt[first + a, k] * jt[first + b, k]
            mat[a, b] = s
            mat[b, a] = s
    return mat, rhs


@njit(cache=True)
def _solve(mat, rhs):
    """``mat^-1 rhs`` for a symmetric positive definite ``mat`` (overwritten), with a ridge of
    1e-10 of its mean diagonal; ok, solution."""
    size = len(rhs)
    ridge = 0.0
    for a in range(size):
        ridge += mat[a, a]
    ridge *= 1e-10 / size
    for a in range(size):
        mat[a, a] += ridge
    if not _cholesky(mat):
        return False, rhs
    out = rhs.copy()
    _cho_solve(mat, out)
    return True, out


@njit(cache=True)
def refine_frames(frames, bg, gains, idx, start, vel, r, sigma, exposure, r_free, n_iter,
                  z0, dzt, gt, dgt, az, el, nodes, inner, occlusion, cast):
    """:func:`_fit_frame` on frames ``idx`` (in time order) with velocities ``vel`` (px per
    frame): ``(len(idx), 6)`` centre, radius, the centre's formal standard errors and the RMS
    residual (grey levels), NaN where the fit failed. Each fit starts from the centre
    predicted from the two frames before, where both were fitted and it is within
    ``PREDICT_PX`` of ``start`` (the centroid), and then takes ``n_iter`` Gauss-Newton steps;
    from ``start`` and ``n_iter + 1`` steps otherwise. Then :func:`_backward`."""
    out = np.full((len(idx), 6), np.nan)
    cost = np.full(len(idx), np.inf)  # the fits' mean squared residuals
    for n in range(len(idx)):
        k = idx[n]
        x0, y0, steps = start[n, 0], start[n, 1], n_iter + 1
        if (n >= 2 and idx[n - 1] == k - 1 and idx[n - 2] == k - 2
                and not math.isnan(out[n - 1, 0]) and not math.isnan(out[n - 2, 0])):
            px = 2.0 * out[n - 1, 0] - out[n - 2, 0]
            py = 2.0 * out[n - 1, 1] - out[n - 2, 1]
            if math.hypot(px - x0, py - y0) <= PREDICT_PX:
                x0, y0, steps = px, py, n_iter
        ok, fit = _fit_clean(frames[k], bg, gains[k], x0, y0, vel[n, 0], vel[n, 1], r, sigma,
                             exposure, r_free, steps, z0, dzt, gt, dgt, az, el, nodes, inner,
                             occlusion, cast)
        if ok:
            _store(out, cost, n, fit)
    fitted = cost[np.isfinite(cost)]
    if fitted.size:
        _backward(frames, bg, gains, idx, start, vel, r, sigma, exposure, r_free, n_iter, z0,
                  dzt, gt, dgt, az, el, nodes, inner, occlusion, cast, out, cost,
                  REFIT_FACTOR ** 2 * np.median(fitted))
    return out


@njit(cache=True)
def _backward(frames, bg, gains, idx, start, vel, r, sigma, exposure, r_free, n_iter, z0, dzt,
              gt, dgt, az, el, nodes, inner, occlusion, cast, out, cost, trusted):
    """From the last frame back, each fit that failed or lies more than ``BACKWARD_PX`` from
    the centre predicted from the two frames after it is fitted again from that prediction
    (``n_iter + 1`` steps), and the new fit kept where its mean squared residual is lower;
    only from frames whose fits' mean squared residual is at most ``trusted`` (a ball partly
    hidden behind a frame counter: a prediction from two such frames found a fit 1.7 px off
    whose pixels, fewer, misfit less).
    The starts the forward pass has can all be wrong together: a ball entering the frame
    whose shadow on the wall merges with it (a dark 15 px ball: its frame-edge disk fits 5.5 px
    towards the shadow, and the fits from there 3.6-4.2 px off, nothing said; from the frames
    after, 0.1 px). Not where the prediction lies more than ``BACKWARD_REACH`` radii from the
    frame's centroid ``start``: across the bounce the two frames after predict the ball on
    the rebound's line (a 240 fps clip, the ball 8.6 px a frame: the last frame before the
    impact predicted 13 px off; its fit from there misfit less per pixel and was kept 9 px
    off, and the frames before it followed, up to 27 px off, nothing said). ``out`` and
    ``cost`` (:func:`refine_frames`) are written in place."""
    for n in range(len(idx) - 3, -1, -1):
        k = idx[n]
        if (idx[n + 1] != k + 1 or idx[n + 2] != k + 2 or math.isnan(out[n + 1, 0])
                or math.isnan(out[n + 2, 0]) or cost[n + 1] > trusted or cost[n + 2] > trusted):
            continue
        px = 2.0 * out[n + 1, 0] - out[n + 2, 0]
        py = 2.0 * out[n + 1, 1] - out[n + 2, 1]
        if not math.isnan(out[n, 0]) and math.hypot(px - out[n, 0], py - out[n, 1]) <= BACKWARD_PX:
            continue
        if math.hypot(px - start[n, 0], py - start[n, 1]) > BACKWARD_REACH * r:
            continue
        ok, fit = _fit_clean(frames[k], bg, gains[k], px, py, vel[n, 0], vel[n, 1], r, sigma,
                             exposure, r_free, n_iter + 1, z0, dzt, gt, dgt, az, el, nodes,
                             inner, occlusion, cast)
        if ok and fit[5] / fit[6] < cost[n]:
            _store(out, cost, n, fit)


@njit(cache=True)
def _store(out, cost, n, fit):
    """Fit ``fit`` (:func:`_result`) as row ``n`` of :func:`refine_frames`' ``out`` (centre,
    radius, formal SEs, RMS residual) and ``cost`` (its mean squared residual)."""
    out[n, :5] = fit[:5]
    cost[n] = fit[5] / fit[6]
    out[n, 5] = math.sqrt(cost[n])


@njit(cache=True)
def light_costs(frames, bg, gains, idx, centres, vel, r, sigma, exposure, z0, dzt, gt, dgt,
                azs, els, nodes, inner, occlusion, cast):
    """The cost of the small-ball model with the light from each direction ``(azs[c],
    els[c])`` (radians; elevation pi/2: no shadow) on frames ``idx`` at the centres
    ``centres`` (the linear coefficients fitted, the centre and radius held): the residual sums
    of squares over the frames (inf where a frame's fit failed), the number of pixels, and the
    shading's gradient ``(b_1, b_2)`` summed over the frames (of the first direction)."""
    costs = np.zeros(len(azs))
    n_pix = 0
    grad = np.zeros(2)
    for c in range(len(azs)):
        for n in range(len(idx)):
            k = idx[n]
            ok, fit = _fit_frame(frames[k], bg, gains[k], centres[n, 0], centres[n, 1],
                                 vel[n, 0], vel[n, 1], r, sigma, exposure, False, 0, z0, dzt, gt,
                                 dgt, azs[c], els[c], nodes, inner, occlusion, cast,
                                 np.zeros(SECTORS, np.bool_), np.zeros(SECTORS))
            if not ok:
                costs[c] = np.inf
            else:
                costs[c] += fit[5]
                if c == 0:
                    n_pix += int(fit[6])
                    grad[0] += fit[7]
                    grad[1] += fit[8]
    return costs, n_pix, grad


def refine_centres(frames: np.ndarray, clean, gains: np.ndarray, centre: np.ndarray,
                   method: np.ndarray, fit) -> Refined:
    """Refine, in place, the centres of the frames where the ball was found (``method``
    ``CENTROID``, or ``EDGE_FIT`` for a ball cut by the frame edge: the fit takes the pixels in
    the frame) where the edge model's fitted blur is at most ``SMALL_FIT_BLUR`` of its radius
    ``fit.radius`` (a failed fit keeps its centroid); returns :class:`Refined`. A ball of at
    most ``SMALL_RADIUS`` is fitted over its whole disk, a larger one over its rim
    (:func:`rim_only`). First the radius and the light (:func:`_radius_and_light`), then every
    frame with that radius held.
    ``clean(centres)``: the background model with the ball left out around ``centres`` (and
    its variance map, not used here)."""
    from ._edge import SMALL_FIT_BLUR
    from ._measure import CENTROID, EDGE_FIT

    done = np.zeros(len(frames), bool)
    no_se = np.full((len(frames), 2), np.nan)
    # not where the blur is a large part of the radius (SMALL_FIT_BLUR: up to a 1.5 px blur at
    # 5 px): there the edge model's blur trades against the shading near the rim
    if fit is None or fit.sigma > SMALL_FIT_BLUR * fit.radius:
        return Refined(done, no_se)
    idx = np.flatnonzero((method == CENTROID) | (method == EDGE_FIT)).astype(np.int64)
    if len(idx) < 3:
        return Refined(done, no_se)
    args = _inputs(frames, clean, gains, centre, idx, fit, rim_only(fit.radius, fit.sigma),
                   fit.radius > SMALL_RADIUS)
    held, r, r_se, light = _radius_and_light(args, float(fit.radius))
    out = refine_frames(*args[:6], held, *args.blur, False, N_ITER, *args.table, *light,
                        args.nodes, args.inner, args.rim, args.cast)
    ok = ~np.isnan(out[:, 0])
    centre[idx[ok]] = out[ok, :2]
    done[idx[ok]] = True
    se = np.full((len(frames), 2), np.nan)
    se[idx[ok]] = out[ok, 3:5]
    rms = np.full(len(frames), np.nan)
    rms[idx[ok]] = out[ok, 5]
    return Refined(done, se, light, r, r_se, rms)


class Refined(NamedTuple):
    """What :func:`refine_centres` found: the mask of frames refined, their centres' formal
    standard errors ``(n, 2)`` (px; NaN where not refined), the light's direction ``(az,
    el)`` of the shadow columns (radians; elevation pi/2: none), and the ball's radius with its
    standard error (px; :func:`_radius_and_light`; NaN where the first pass failed). ``light``
    None where nothing was refined."""

    done: np.ndarray
    se: np.ndarray
    light: tuple[float, float] | None = None
    radius: float = math.nan
    radius_se: float = math.nan
    rms: np.ndarray | None = None  # each frame's RMS residual (grey levels; NaN: not refined)


class _Inputs(NamedTuple):
    """What the small-ball fits of a video read: the frames, the ball-free background (float),
    the frames' gains, the frames to fit (``idx``) with their starting centres and velocities
    (px per frame), the blur and exposure, the limb table, the shadow's quadrature nodes."""

    frames: np.ndarray
    bg: np.ndarray
    gains: np.ndarray
    idx: np.ndarray
    start: np.ndarray
    vel: np.ndarray
    blur: tuple[float, float]
    table: tuple[float, float, np.ndarray, np.ndarray]
    nodes: np.ndarray
    inner: float  # the radius inside which no pixel is fitted (px; :func:`rim_only`)
    rim: bool  # a larger ball's fit: its rim only, with the wall's occlusion term
    # the ball's shadow on the wall (du, dv, radius, penumbra, depth; px), zeros: none
    cast: np.ndarray


def rim_only(radius: float, sigma: float) -> float:
    """The radius (px) inside which a ball of ``radius`` blurred by ``sigma`` (px) has no
    pixel fitted: 0 up to ``SMALL_RADIUS``; larger, ``REACH_PX`` plus ``INNER_BLURS`` blurs
    inside the rim (the blur with the pixel's width)."""
    if radius <= SMALL_RADIUS:
        return 0.0
    return max(radius - REACH_PX - INNER_BLURS * math.sqrt(sigma * sigma + 1.0 / 12.0), 0.0)


def _inputs(frames, clean, gains, centre, idx, fit, inner: float = 0.0,
            rim: bool = False) -> _Inputs:
    """:class:`_Inputs` for the frames ``idx`` (the velocities from the neighbouring frames'
    centres where both were found, else 0)."""
    from ._edge import _nodes, _sqrt_table

    vel = _velocities(centre, idx)
    zt, gt = _sqrt_table()
    f64 = functools.partial(np.ascontiguousarray, dtype=np.float64)
    return _Inputs(np.ascontiguousarray(frames), f64(clean(centre[idx])[0]), f64(gains), idx,
                   f64(centre[idx]), f64(vel), (float(fit.sigma), float(fit.exposure)),
                   (float(zt[0]), float(zt[1] - zt[0]), gt, np.gradient(gt, zt)),
                   _nodes(SHADOW_NODES), float(inner), bool(rim),
                   np.zeros(5) if fit.cast is None else np.array(fit.cast, dtype=np.float64))


def _velocities(centre: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """The ball's velocity (px per frame) at the frames ``idx`` from its ``centre`` in the
    frames before and after (one-sided at the video's ends; 0 where either is not found):
    their central difference, or where one of the two one-sided differences is more than
    ``VELOCITY_JUMP`` times the other, the smaller. An impact does that only where the ball
    keeps less than a quarter of its speed; a ball that jumps does (`benchmarks/tracking.py`
    repeats a clip: the last frame's velocity came out the length of the whole flight, and
    the exposure's smear spread its fit over ~30 000 pixels: the last frame of each repeat
    2.6 px off, the RMS error over 4000 frames 0.05 -> 0.21 px, and each such fit ~5 ms). Taking the smaller at the impact as well (where the two differ by more than
    half the larger) made the impact frame worse under a long exposure: a sharp side-lit 10
    px ball of `benchmarks/tracking_accuracy.py` at 80 %, centres 0.030 -> 0.063 px."""
    found = ~np.isnan(centre[:, 0])
    last = len(centre) - 1
    prev, nxt = np.maximum(idx - 1, 0), np.minimum(idx + 1, last)
    both = found[prev] & found[nxt] & (nxt > prev)
    vel = np.where(both[:, None], (centre[nxt] - centre[prev]) / np.maximum(nxt - prev, 1)[:, None],
                   0.0)
    inner = both & (idx > 0) & (idx < last)
    back, ahead = centre[idx] - centre[prev], centre[nxt] - centre[idx]
    size_b, size_a = np.hypot(*back.T), np.hypot(*ahead.T)
    jump = inner & (np.maximum(size_b, size_a) > VELOCITY_JUMP * np.minimum(size_b, size_a))
    vel[jump] = np.where((size_b <= size_a)[jump, None], back[jump], ahead[jump])
    return vel


def _radius_and_light(a: _Inputs, r0: float
                      ) -> tuple[float, float, float, tuple[float, float]]:
    """The radius the fits hold, the ball's radius and its standard error (px), and the light's
    direction: the median radius of ``RADIUS_FRAMES`` frames' fits with it free (from ``r0``)
    and no shadow is the ball's; on ``LIGHT_FRAMES`` of them the light (:func:`find_light`), and
    where it casts a shadow the radius the fits hold is those frames' median again with it.
    ``r0`` (standard error NaN) where fewer than 3 of the fits succeed.

    The ball's radius is the one without the shadow: with it the columns trade against the
    radius where the shading is far from Lambert's (at 5 px, blur 0.7 px, a glossy ball with a
    clipped highlight and strong limb darkening: -4.7 to -5.4 % with, -0.3 to -1.2 % without);
    over the 49 rendered cases of docs/tracking.md §3 within 2 % in 45 without, 42 with."""
    sub = spread(len(a.idx), RADIUS_FRAMES)

    def first_pass(light: tuple[float, float]):  # the frames' fits, and those that succeeded
        first = refine_frames(a.frames, a.bg, a.gains, a.idx[sub], a.start[sub], a.vel[sub], r0,
                              *a.blur, True, N_ITER, *a.table, *light, a.nodes, a.inner,
                              a.rim, a.cast)
        return first, np.flatnonzero(~np.isnan(first[:, 0]))

    light = (0.0, 0.5 * math.pi)  # first without a shadow
    first, good = first_pass(light)
    if len(good) < 3:
        return r0, r0, math.nan, light
    r, r_se = median_and_se(first[good, 2])
    pick = good[spread(len(good), LIGHT_FRAMES)]
    light = find_light(a.frames, a.bg, a.gains, a.idx[sub][pick], first[pick, :2],
                       a.vel[sub][pick], r, a.blur, a.table, a.nodes, a.inner, a.rim, a.cast)
    held = r
    if light[1] < 0.5 * math.pi:  # the radius the fits hold, with the shadow
        again, ok = first_pass(light)
        held = float(np.median(again[ok, 2])) if len(ok) >= 3 else r
    return held, r, r_se, light


def find_light(frames, bg, gains, idx, centres, vel, r: float, blur: tuple[float, float],
               table: tuple[float, float, np.ndarray, np.ndarray], nodes, inner: float = 0.0,
               rim: bool = False, cast: np.ndarray | None = None) -> tuple[float, float]:
    """The light's direction ``(az, el)`` (radians) for the small-ball fit's shadow columns,
    from the frames ``idx`` at their centres ``centres`` (``vel``: px per frame; ``blur``:
    sigma, exposure): the azimuth of the shading's gradient without a shadow, then the best
    of ``LIGHT_OFFSETS`` about it at the middle elevation, then the best of
    ``LIGHT_ELEVATIONS`` there. ``(0, pi/2)`` (no shadow) where the best does not lower the
    cost by ``LIGHT_GAIN`` residual variances a frame."""
    args = (frames, bg, gains, idx.astype(np.int64), np.ascontiguousarray(centres),
            np.ascontiguousarray(vel), r, *blur, *table)
    cast = np.zeros(5) if cast is None else cast
    none, n_pix, grad = light_costs(*args, np.zeros(1), np.full(1, 0.5 * math.pi), nodes, inner,
                                    rim, cast)
    azs = math.atan2(grad[1], grad[0]) + LIGHT_OFFSETS  # the lit side's direction
    costs, _, _ = light_costs(*args, azs, np.full(azs.size, LIGHT_ELEVATIONS[1]), nodes, inner,
                              rim, cast)
    az = float(azs[int(np.argmin(costs))])
    els = np.array(LIGHT_ELEVATIONS)
    costs, _, _ = light_costs(*args, np.full(els.size, az), els, nodes, inner, rim, cast)
    best = int(np.argmin(costs))
    if not none[0] - costs[best] >= LIGHT_GAIN * len(idx) * costs[best] / max(n_pix, 1):
        return 0.0, 0.5 * math.pi
    return az, float(els[best])


def stated_centre_sd(se: np.ndarray) -> float:
    """The refined centres' per-frame SD (px, per coordinate) from their formal standard errors
    ``se`` ``(n, 2)``: ``SE_FACTOR`` times their RMS. It leaves out a constant error (the
    lighting's bias, which moves no velocity)."""
    return SE_FACTOR * float(np.sqrt(np.mean(se**2)))
