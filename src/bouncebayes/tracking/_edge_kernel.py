"""The edge model, compiled: its residual and analytic Jacobian in one fused pass over the
pixels, and the least-squares fit of one frame that calls it.

The same arithmetic as the NumPy reference ``_edge._design_numpy`` (kept for the tests, which
compare the two), without its ~40 temporary arrays and NumPy's per-call overhead: the edge
model is evaluated ~300 times per video. Each call builds the design matrix, solves the
linear coefficients (variable projection) and differentiates the projected residual with
respect to the nonlinear parameters (the design's derivatives by forward-mode
differentiation of each pixel's row, by hand): with finite differences instead the model was
evaluated ~1000 times per video. :func:`fit_frame` is the bounded Levenberg-Marquardt over
those parameters (it replaced ``scipy.optimize.least_squares``, whose Python cost was most of
the tracker's time on the paper's camera). Written here because no library builds this model;
imported by ``_edge`` where the model runs (numba stays out of the package import).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

_SQRT2 = math.sqrt(2.0)
_INV_SQRT_2PI = 1.0 / math.sqrt(2.0 * math.pi)
_HALF_PI = 0.5 * math.pi
_CUT = 4.0  # the shadow columns' Gaussian is integrated over +-_CUT SDs (mass left: 6e-5)


@njit(cache=True)
def _shadow(uu, s, r, ct, st, az_c, az_s, el, nodes, cp):
    """The two shadow columns of a pixel at depth ``uu`` inside the rim, radial blur ``s``
    and polar angle ``t`` (``ct, st``), lit from the distant direction of azimuth ``az``
    (image plane, ``az_c, az_s`` its cosine and sine) and elevation ``el`` towards the camera,
    into ``cp[j] = (C_j, dC_j/duu, dC_j/ds, dC_j/dr, dC_j/dt, dC_j/daz, dC_j/del)``.

    Lambert shading ``max(0, n . L) = n . L - min(0, n . L)``: the linear part is in the
    spherical harmonics; the shadowed part ``m = min(0, n . L)`` is not (the harmonics up to
    order 2 smooth it over, which biased the radius of a ball lit from the side by +1.6 %
    under a 1.5 px blur, docs/tracking.md §3). At depth ``w`` inside the rim ``n . L =
    A (1 - w/r) + L_z n_z(w)``, ``A = cos(el) cos(t - az)``, ``n_z = sqrt(w (2r - w)) / r``;
    for ``L_z >= 0`` it is negative only on the side away from the light (``A < 0``) and
    down to the terminator ``w* = r (1 - L_z / sqrt(A^2 + L_z^2))``. The columns are ``m``
    and ``n_z m`` (linear limb darkening times Lambert), blurred along the radius as the
    others: ``C = int_0^w* N(w; uu, s^2) m(w) dw``, by Gauss-Legendre quadrature in
    ``tau = sqrt(w)`` (which takes away the ``sqrt`` of ``n_z`` at the rim) over the
    Gaussian's +-4 s (``_CUT``). ``m(w*) = 0`` so the limit's motion adds nothing to the
    derivatives."""
    for j in range(2):
        for k in range(7):
            cp[j, k] = 0.0
    cd = ct * az_c + st * az_s            # cos(t - az)
    lxy = math.cos(el)
    lz = math.sin(el)
    a = lxy * cd
    if not a < 0.0:
        return
    w_star = r * (1.0 - lz / math.sqrt(a * a + lz * lz))
    lo = max(0.0, uu - _CUT * s)
    hi = min(w_star, uu + _CUT * s)
    if not hi > lo:
        return
    t0 = math.sqrt(lo)
    t1 = math.sqrt(hi)
    mid = 0.5 * (t0 + t1)
    half = 0.5 * (t1 - t0)
    a_t = lxy * (ct * az_s - st * az_c)   # dA/dt = cos(el) sin(az - t) = -dA/daz
    a_el = -lz * cd
    inv_s = 1.0 / s
    for k in range(nodes.shape[1]):
        tau = mid + half * nodes[0, k]
        w = tau * tau
        jac = 2.0 * tau * half * nodes[1, k]
        x = (w - uu) * inv_s
        g = jac * math.exp(-0.5 * x * x) * _INV_SQRT_2PI * inv_s
        rest = max(2.0 * r - w, 0.0)
        root = math.sqrt(rest)
        nzw = tau * root / r
        nz_r = tau * (w - r) / (r * r * root) if root > 0.0 else 0.0
        rho = 1.0 - w / r
        m = a * rho + lz * nzw
        m_r = a * w / (r * r) + lz * nz_r
        m_t = a_t * rho
        m_el = a_el * rho + lxy * nzw
        g_uu = g * x * inv_s
        g_s = g * (x * x - 1.0) * inv_s
        for j in range(2):
            f = m if j == 0 else m * nzw
            f_r = m_r if j == 0 else m_r * nzw + m * nz_r
            f_t = m_t if j == 0 else m_t * nzw
            f_el = m_el if j == 0 else m_el * nzw
            cp[j, 0] += g * f
            cp[j, 1] += g_uu * f
            cp[j, 2] += g_s * f
            cp[j, 3] += g * f_r
            cp[j, 4] += g * f_t
            cp[j, 6] += g * f_el
    for j in range(2):  # A depends on t - az only
        cp[j, 5] = -cp[j, 4]
    # the Gaussian's cut at uu -+ CUT s moves with uu and s: the ends' terms (the derivatives
    # are then those of the integral computed, which the fits' Jacobian must be)
    for end in range(2):
        w = lo if end == 0 else hi
        if (w == uu - _CUT * s) if end == 0 else (w == uu + _CUT * s):
            sign = -1.0 if end == 0 else 1.0
            nzw = math.sqrt(max(w * (2.0 * r - w), 0.0)) / r
            f = math.exp(-0.5 * _CUT * _CUT) * _INV_SQRT_2PI * inv_s * (a * (1.0 - w / r)
                                                                       + lz * nzw)
            for j in range(2):
                fj = f if j == 0 else f * nzw
                cp[j, 1] += sign * fj
                cp[j, 2] += _CUT * fj


_HANKEL_CUT = 5.0  # the exact columns' Gaussian is integrated over +-5 SDs (mass left: 6e-7)


@njit(cache=True)
def _ive(a, etab, da, ev):
    """``ev[0, m] = I_m(a) exp(-a)``, ``m = 0 .. ev.shape[1] - 1`` (``I_m`` the modified
    Bessel function), and ``ev[1, m]`` its derivative: linearly interpolated in ``etab[m]``
    (spacing ``da`` from 0) within it (the derivative the interpolant's, so that the model's
    Jacobian is the derivative of what it computes); beyond, ``m = 0, 1`` from the
    large-argument series ``(2 pi a)^(-1/2) sum_k (-1)^k prod_(j<=k) (4 m^2 - (2j - 1)^2) /
    (k! (8 a)^k)`` (DLMF 10.40.1; from ``a = 40`` its fifth term is below 1e-7), the rest by
    the recurrence ``I_(m+1) = I_(m-1) - (2m / a) I_m`` (DLMF 10.29.1, stable upwards for ``m
    < a``) and ``I_m' = (I_(m-1) + I_(m+1)) / 2``."""
    nt = etab.shape[1]
    n_m = ev.shape[1]
    x = a / da
    if x < nt - 1:
        j = int(x)
        f = x - j
        for m in range(n_m):
            ev[0, m] = etab[m, j] * (1.0 - f) + etab[m, j + 1] * f
            ev[1, m] = (etab[m, j + 1] - etab[m, j]) / da
        return
    pre = 1.0 / math.sqrt(2.0 * math.pi * a)
    inv = 1.0 / (8.0 * a)
    # the series' coefficients (-1)^k prod_(j<=k) (4 m^2 - (2j - 1)^2) / k!, m = 0 and 1
    t0 = 1.0 + inv * (1.0 + inv * (4.5 + inv * (37.5 + inv * 459.375)))
    t1 = 1.0 - inv * (3.0 + inv * (7.5 + inv * (52.5 + inv * 590.625)))
    e_prev = pre * t0
    e_cur = pre * t1
    ev[0, 0] = e_prev
    ev[0, 1] = e_cur
    for m in range(1, n_m):
        e_next = e_prev - 2.0 * m / a * e_cur
        if m + 1 < n_m:
            ev[0, m + 1] = e_next
        # d/da (I_m e^-a) = (I_(m-1) + I_(m+1)) / 2 e^-a - I_m e^-a
        ev[1, m] = 0.5 * (e_prev + e_next) - e_cur
        e_prev, e_cur = e_cur, e_next
    ev[1, 0] = ev[0, 1] - ev[0, 0]


# the radial profiles of the exact columns: each column is ``g(rho / r) cos(m t)`` (or sin)
# on the disk, ``g`` one of 1, x, sqrt(1 - x^2), x^2, x sqrt(1 - x^2), 1 - x^2 and 1 again
# for the rim's harmonics m = 2 .. RIM_ORDER; their orders m
_PROFILE_M = (0, 1, 0, 2, 1, 0)
_HANKEL_SPLIT = 3.0  # the last 3 s of the disk integrated in sqrt(r - rho'), the rest in rho'
_NODES_IN = 14       # Gauss-Legendre nodes in rho' (to within 3e-6 with _NODES_RIM = 10) ...
_NODES_RIM = 10      # ... and in sqrt(r - rho')


def hankel_nodes() -> np.ndarray:
    """The nodes and weights on [-1, 1] of :func:`_hankel`'s two pieces, ``(2, _NODES_IN +
    _NODES_RIM)``."""
    return np.hstack([np.stack(np.polynomial.legendre.leggauss(_NODES_IN)),
                      np.stack(np.polynomial.legendre.leggauss(_NODES_RIM))])


@njit(cache=True)
def _hankel(rho, s, r, hnodes, etab, da, ev, gg, want, rad):
    """The exact Gaussian blur (covariance ``s^2 I``) of each of the columns' radial profiles
    (``_PROFILE_M``, then profile 1 of the rim's ``m = 2, 3, ..``) on the disk of radius
    ``r``, at distance ``rho`` from its centre, into ``rad[j] = (H_j, dH_j/drho, dH_j/ds,
    dH_j/dr)`` (the derivatives only with ``want``; ``ev``, ``gg`` (6 rows) scratch).

    The blur of ``g(rho') cos(m t)`` is ``H(rho) cos(m t)``, ``H(rho) = int_0^r K_m(rho,
    rho') g(rho') drho'``, ``K_m = (rho' / s^2) exp(-(rho - rho')^2 / (2 s^2)) I_m(rho rho' /
    s^2) exp(-rho rho' / s^2)`` (the Gaussian's angular integral, DLMF 10.32.3), over ``rho
    -+ 5 s`` within the disk, by Gauss-Legendre: in ``rho'`` (14 nodes), and over the last
    ``3 s`` of the disk in ``w = sqrt(r - rho')`` (10 nodes; it takes away the square root of
    ``n_z`` at the rim, where in ``w`` alone over the whole range the quadrature was off by
    1e-3 deeper in); against adaptive quadrature within 3e-6 for radii 3-20 px and blurs
    0.29-2 px. The derivatives are
    the exact integral's (under the integral, and the ends that move: the Gaussian's cut with
    ``rho`` and ``s``, the rim with ``r``). The columns it replaces (a blur along the radius
    only, and products of blurred factors for the products of the normal's components) were
    off by up to 13 % of ``n_x n_z``'s and 40 % of the rim's fourth harmonic's largest value
    under a 1.5 px blur of a 10 px ball (docs/tracking.md §1)."""
    n_prof = rad.shape[0]
    for j in range(n_prof):
        for k in range(4):
            rad[j, k] = 0.0
    cut = _HANKEL_CUT * s
    lo = max(rho - cut, 0.0)
    hi = min(rho + cut, r)
    if not hi > lo:
        return
    inv_s2 = 1.0 / (s * s)
    g = gg[0]
    g_r = gg[1]
    km = gg[2:6, :ev.shape[1]]
    mid = hi if hi < r else max(lo, r - _HANKEL_SPLIT * s)
    for node in range(_NODES_IN + _NODES_RIM):
        if node < _NODES_IN:  # in rho' over [lo, mid]
            if not mid > lo:
                continue
            half = 0.5 * (mid - lo)
            rp = lo + half * (1.0 + hnodes[0, node])
            jw = half * hnodes[1, node]
            p = 1.0 - rp / r
            root = math.sqrt(max(p * (2.0 - p), 0.0))
            jwr = jw / root if root > 0.0 else 0.0  # the weight over sqrt(1 - x^2)
        else:  # in w = sqrt(r - rho') over [0, sqrt(r - mid)]
            if not (hi >= r and mid < r):
                break
            half = 0.5 * math.sqrt(r - mid)
            w = half * (1.0 + hnodes[0, node])
            rp = r - w * w
            jw = 2.0 * w * half * hnodes[1, node]
            p = w * w / r
            root = math.sqrt(max(p * (2.0 - p), 0.0))
            jwr = 2.0 * half * hnodes[1, node] * math.sqrt(r / max(2.0 - p, 1e-300))
        d = rho - rp
        a = rho * rp * inv_s2
        _ive(a, etab, da, ev)
        gauss = inv_s2 * math.exp(-0.5 * d * d * inv_s2) * rp  # K_m / E_m
        _profiles(1.0 - p, root, r, g, g_r)
        # each order's kernel times the weight (and its derivatives in rho and s, and the
        # weight over sqrt(1 - x^2)), then the profiles'
        for m in range(ev.shape[1]):
            kk = gauss * ev[0, m]
            km[0, m] = kk * jw
            if want:
                kp = gauss * ev[1, m]
                km[1, m] = (-kk * d + kp * rp) * inv_s2 * jw
                km[2, m] = (kk * (d * d * inv_s2 - 2.0) - kp * 2.0 * a) / s * jw
                km[3, m] = kk * jwr
        for j in range(n_prof):
            m = _PROFILE_M[j] if j < 6 else j - 4
            rad[j, 0] += km[0, m] * g[j]
            if want:
                rad[j, 1] += km[1, m] * g[j]
                rad[j, 2] += km[2, m] * g[j]
                # d g / dr at rho' held: regular, or (2, 4) a multiple of 1 / sqrt(1 - x^2)
                rad[j, 3] += km[3 if j == 2 or j == 4 else 0, m] * g_r[j]
    if not want:
        return
    # the ends that move: the Gaussian's cuts with rho and s, the rim with r
    for end in range(2):
        rp = hi if end == 0 else lo
        if end == 1 and not rp > 0.0:
            continue  # K = 0 at rho' = 0
        d = rho - rp
        _ive(rho * rp * inv_s2, etab, da, ev)
        p = 1.0 - rp / r
        _profiles(1.0 - p, math.sqrt(max(p * (2.0 - p), 0.0)), r, g, g_r)
        sign = 1.0 if end == 0 else -1.0
        at_rim = end == 0 and not rp < r
        for j in range(n_prof):
            m = _PROFILE_M[j] if j < 6 else j - 4
            f = rp * inv_s2 * math.exp(-0.5 * d * d * inv_s2) * ev[0, m] * g[j]
            if at_rim:
                rad[j, 3] += f
            else:
                rad[j, 1] += sign * f
                rad[j, 2] += _HANKEL_CUT * f


@njit(cache=True)
def _profiles(x, root, r, g, g_r):
    """The radial profiles of :func:`_hankel` at ``x = rho' / r`` (``root = sqrt(1 - x^2)``),
    and their derivatives with respect to ``r`` at ``rho'`` held (those of the profiles with
    ``root``, 2 and 4, times ``root``: they diverge at the rim)."""
    g[0], g_r[0] = 1.0, 0.0
    g[1], g_r[1] = x, -x / r
    g[2], g_r[2] = root, x * x / r
    g[3], g_r[3] = x * x, -2.0 * x * x / r
    g[4], g_r[4] = x * root, -x * (1.0 - 2.0 * x * x) / r
    g[5], g_r[5] = 1.0 - x * x, 2.0 * x * x / r
    for j in range(6, g.size):
        g[j], g_r[j] = 1.0, 0.0


@njit(cache=True)
def _analytic(uu, s, z, r, step, dens, z0, dz, table, want, part):
    """The radial factors of :func:`_row` blurred along the radius only, in closed form, into
    ``part[j, 0]`` and (with ``want``) their derivatives ``part[j, 1:] = (d/duu, d/ds, d/dr)``:
    ``step, qq, nz, q2, nzq`` (``n_z`` times ``rho / r``: the product of the blurred factors),
    ``step - q2`` (``n_z^2``) and ``step`` for each of the rim's harmonics; from the blurred
    step and its density at ``z = uu / s``, the ramp's and square's closed forms (``d ramp/duu
    = step``, ``d ramp/ds = dens``, ``d square/duu = 2 ramp``, ``d square/ds = 2 s step``) and
    ``E[sqrt(uu + e)_+]`` from ``table`` (``G(z)`` from ``z0``, spacing ``dz``)."""
    ramp = uu * step + s * dens
    square = (uu * uu + s * s) * step + uu * s * dens
    nt = table.size
    if z > z0 + dz * (nt - 1):
        root = math.sqrt(max(uu, 0.0))
        root_uu = 0.5 / root if root > 0.0 else 0.0
        root_s = 0.0
    elif z <= z0:
        root = math.sqrt(s) * table[0]
        root_uu = 0.0
        root_s = 0.5 * table[0] / math.sqrt(s)
    else:
        x = (z - z0) / dz
        j = min(int(x), nt - 2)
        f = x - j
        g = table[j] * (1.0 - f) + table[j + 1] * f
        g_z = (table[j + 1] - table[j]) / dz  # d G / dz, of the interpolant
        root = math.sqrt(s) * g
        root_uu = g_z / math.sqrt(s)
        root_s = 0.5 * g / math.sqrt(s) - g_z * z / math.sqrt(s)
    sq2r = math.sqrt(2.0 / r)
    a1 = 1.0 - uu / (2.0 * r)
    b = math.sqrt(min(max(a1, 0.0), 1.0))
    nz = root * sq2r * b
    qq = step - ramp / r
    q2 = step - 2.0 * ramp / r + square / (r * r)
    a2 = 1.0 - uu / r
    cl2 = min(max(a2, 0.0), 1.0)
    part[0, 0] = step
    part[1, 0] = qq
    part[2, 0] = nz
    part[3, 0] = q2
    part[4, 0] = nz * cl2
    part[5, 0] = step - q2
    for j in range(6, part.shape[0]):
        part[j, 0] = step
    if not want:
        return
    step_uu = dens / s
    step_s = -dens * z / s
    b_uu = b_r = 0.0
    if 0.0 < a1 < 1.0:
        b_uu = -0.25 / (r * b)
        b_r = 0.25 * uu / (r * r * b)
    c_uu = c_r = 0.0
    if 0.0 < a2 < 1.0:
        c_uu = -1.0 / r
        c_r = uu / (r * r)
    nz_uu = (root_uu * b + root * b_uu) * sq2r
    nz_s = root_s * sq2r * b
    nz_r = -0.5 * nz / r + root * sq2r * b_r
    part[0, 1], part[0, 2], part[0, 3] = step_uu, step_s, 0.0
    part[1, 1] = step_uu - step / r
    part[1, 2] = step_s - dens / r
    part[1, 3] = ramp / (r * r)
    part[2, 1], part[2, 2], part[2, 3] = nz_uu, nz_s, nz_r
    part[3, 1] = step_uu - 2.0 * step / r + 2.0 * ramp / (r * r)
    part[3, 2] = step_s - 2.0 * dens / r + 2.0 * s * step / (r * r)
    part[3, 3] = 2.0 * ramp / (r * r) - 2.0 * square / (r * r * r)
    part[4, 1] = nz_uu * cl2 + nz * c_uu
    part[4, 2] = nz_s * cl2
    part[4, 3] = nz_r * cl2 + nz * c_r
    for k in range(1, 4):
        part[5, k] = part[0, k] - part[3, k]
        for j in range(6, part.shape[0]):
            part[j, k] = part[0, k]


@njit(cache=True)
def _row(du, dv, dir_u, dir_v, speed, r, sigma, exposure, az_c, az_s, el, z0, dz, table,
         nodes, rim_order, want, row, part, chain, ang, cp, gbu, gbv, docc, exact, hnodes,
         etab, da, ev, gg, rad):
    """One pixel's design row (unweighted: the shared columns, then the pixel's frame's three
    local ones) at offset ``(du, dv)`` from the centre, into ``row`` (the arithmetic of
    ``_edge._design_numpy``); returns the step. With ``want``, also what :func:`_drow` needs
    for the row's derivatives: every column is a radial factor (a function of the depth
    ``uu``, the blur ``s`` and ``r``) times an angular one (of the polar angle ``t``), so
    ``part[j] = (R_j, dR_j/duu, dR_j/ds, dR_j/dr)`` for ``R = step, qq, nz, q2, nzq, n_z^2``
    and the rim's harmonics' ``m = 2 .. rim_order``, ``chain[k] = (duu, ds, dr, dt)`` with
    respect to parameter ``k`` of ``(cx, cy, r, sigma, exposure)`` and ``ang[m] = (cos m t,
    sin m t)``. The radial factors are blurred along the radius in closed form
    (:func:`_analytic`), or with ``exact`` in two dimensions by quadrature (:func:`_hankel`;
    ``hnodes`` its nodes, ``etab`` the Bessel functions' table of spacing ``da``, ``ev, gg,
    rad`` scratch).

    Also returns the wall's occlusion term ``occ`` (grey levels; ``gbu, gbv`` the background's
    gradient at the pixel), and with ``want`` its derivatives ``docc[k]``. The ball hides the
    wall before the lens blurs it: the image is ``K * (W (1 - D))``, not the model's ``B (1 -
    S)`` (``B = K * W`` the background, ``S = K * D`` the blurred step). For a kernel ``K`` of
    covariance ``k I``, ``K * (W D) = W S + k grad W . grad S`` to first order in the wall's
    gradient (``(y - x) K(x - y) = k grad_x K(x - y)`` for a Gaussian), so the image is
    ``B (1 - S) - k grad B . grad S``: ``occ = k (dB/drho) dens / s``, ``k = sigma^2 + 1/12``
    (the lens and the pixel; the exposure smears the ball, not the wall). A textured wall
    without it: a dark 10 px ball blurred by 1.5 px, noise-free, -0.8 to -1.4 % in the radius
    (docs/tracking.md §1)."""
    rho = math.hypot(du, dv)
    rr = max(rho, 1e-9)
    ct = du / rr
    st = dv / rr
    cos_v = ct * dir_u + st * dir_v
    smear2 = (exposure * speed) ** 2 / 12.0
    base = sigma * sigma + 1.0 / 12.0
    cv2 = cos_v * cos_v
    var_r = base + smear2 * cv2
    var_t = base + smear2 * (1.0 - cv2)
    s = math.sqrt(var_r)
    uu = r - var_t / (2.0 * r) - rho
    z = uu / s
    step = 0.5 * math.erfc(-z / _SQRT2)
    dens = math.exp(-0.5 * z * z) * _INV_SQRT_2PI
    kap = sigma * sigma + 1.0 / 12.0
    g_rho = gbu * ct + gbv * st
    occ = kap * g_rho * dens / s
    if exact:  # the radial profiles blurred in two dimensions (at rho with the curvature's
        # shift of the tangential blur beyond the radial one: uu's r - var_t / 2r is the
        # isotropic blur's r - var_r / 2r there), by quadrature
        _hankel(r - uu - var_r / (2.0 * r), s, r, hnodes, etab, da, ev, gg, want, rad)
        shift_r = 1.0 + var_r / (2.0 * r * r)
        for j in range(part.shape[0]):
            h_rho = rad[j, 1]
            part[j, 0] = rad[j, 0]
            part[j, 1] = -h_rho
            part[j, 2] = rad[j, 2] - h_rho * s / r
            part[j, 3] = rad[j, 3] + h_rho * shift_r
        step = part[0, 0]
    else:
        _analytic(uu, s, z, r, step, dens, z0, dz, table, want, part)
    qq, nz, q2, nzq, nz2 = part[1, 0], part[2, 0], part[3, 0], part[4, 0], part[5, 0]
    c2 = ct * ct - st * st
    s2 = 2.0 * ct * st
    row[0] = step
    row[1] = qq * ct
    row[2] = qq * st
    row[3] = nz
    row[4] = q2 * s2
    row[5] = q2 * c2
    row[6] = nzq * ct
    row[7] = nzq * st
    row[8] = nz2
    row[9] = part[6, 0] * c2
    row[10] = part[6, 0] * s2
    cm = c2
    sm = s2
    col = 11
    for m in range(3, rim_order + 1):
        cm, sm = cm * ct - sm * st, sm * ct + cm * st
        row[col] = part[m + 4, 0] * cm
        row[col + 1] = part[m + 4, 0] * sm
        col += 2
    if el < _HALF_PI:  # else lit from the camera: no shadow, no columns
        _shadow(uu, s, r, ct, st, az_c, az_s, el, nodes, cp)
        row[col] = cp[0, 0]
        row[col + 1] = cp[1, 0]
        col += 2
    out = 1.0 - step
    row[col] = out
    row[col + 1] = out * ct
    row[col + 2] = out * st
    if not want:
        return step, occ
    ang[1, 0], ang[1, 1], ang[2, 0], ang[2, 1] = ct, st, c2, s2
    for m in range(3, rim_order + 1):
        ang[m, 0] = ang[m - 1, 0] * ct - ang[m - 1, 1] * st
        ang[m, 1] = ang[m - 1, 1] * ct + ang[m - 1, 0] * st
    # (uu, s, r, t) with respect to (cx, cy, r, sigma, exposure): the centre moves rho and t
    # (d rho/dcx = -cos t, dt/dcx = sin t / rho), the blur and exposure the variances
    inv = 1.0 / rr if rho > 1e-9 else 0.0
    sin_v = st * dir_u - ct * dir_v  # sin(t - t_v)
    for k in range(5, 7):  # the light's direction moves only the shadow columns (cp)
        for j in range(4):
            chain[k, j] = 0.0
    for k in range(5):
        d_rho = -ct if k == 0 else (-st if k == 1 else 0.0)
        d_t = st * inv if k == 0 else (-ct * inv if k == 1 else 0.0)
        d_cv2 = -2.0 * cos_v * sin_v * d_t
        d_base = 2.0 * sigma if k == 3 else 0.0
        d_sm = exposure * speed * speed / 6.0 if k == 4 else 0.0
        d_vr = d_base + d_sm * cv2 + smear2 * d_cv2
        d_vt = d_base + d_sm * (1.0 - cv2) - smear2 * d_cv2
        e_r = 1.0 if k == 2 else 0.0
        chain[k, 0] = e_r - d_vt / (2.0 * r) + var_t / (2.0 * r * r) * e_r - d_rho
        chain[k, 1] = d_vr / (2.0 * s)
        chain[k, 2] = e_r
        chain[k, 3] = d_t
        # the occlusion term: its density's derivatives in (uu, s), the gradient's turn with
        # t, the kernel's variance with sigma
        d_dens = dens / (s * s) * (-z * chain[k, 0] + (z * z - 1.0) * chain[k, 1])
        docc[k] = kap * (g_rho * d_dens + (gbv * ct - gbu * st) * d_t * dens / s)
        if k == 3:
            docc[k] += 2.0 * sigma * g_rho * dens / s
    docc[5] = docc[6] = 0.0
    return step, occ


@njit(cache=True)
def _drow(part, chain, ang, cp, k, rim_order, lit, drow):
    """The derivative of the row of :func:`_row` with respect to parameter ``k``, into
    ``drow``: each column's radial factor's total derivative times its angular factor, plus
    the radial factor times the angular factor's derivative (``d cos(m t) = -m sin(m t) dt``)."""
    d_uu, d_s, d_r, d_t = chain[k, 0], chain[k, 1], chain[k, 2], chain[k, 3]
    step, qq, q2, nzq = part[0, 0], part[1, 0], part[3, 0], part[4, 0]
    d_step = part[0, 1] * d_uu + part[0, 2] * d_s + part[0, 3] * d_r
    d_qq = part[1, 1] * d_uu + part[1, 2] * d_s + part[1, 3] * d_r
    d_nz = part[2, 1] * d_uu + part[2, 2] * d_s + part[2, 3] * d_r
    d_q2 = part[3, 1] * d_uu + part[3, 2] * d_s + part[3, 3] * d_r
    d_nzq = part[4, 1] * d_uu + part[4, 2] * d_s + part[4, 3] * d_r
    d_nz2 = part[5, 1] * d_uu + part[5, 2] * d_s + part[5, 3] * d_r
    out = 1.0 - step
    ct, st, c2, s2 = ang[1, 0], ang[1, 1], ang[2, 0], ang[2, 1]
    drow[0] = d_step
    drow[1] = d_qq * ct - qq * st * d_t
    drow[2] = d_qq * st + qq * ct * d_t
    drow[3] = d_nz
    drow[4] = d_q2 * s2 + 2.0 * q2 * c2 * d_t
    drow[5] = d_q2 * c2 - 2.0 * q2 * s2 * d_t
    drow[6] = d_nzq * ct - nzq * st * d_t
    drow[7] = d_nzq * st + nzq * ct * d_t
    drow[8] = d_nz2
    col = 9
    for m in range(2, rim_order + 1):
        p = part[m + 4, 0]
        d_p = part[m + 4, 1] * d_uu + part[m + 4, 2] * d_s + part[m + 4, 3] * d_r
        drow[col] = d_p * ang[m, 0] - m * p * ang[m, 1] * d_t
        drow[col + 1] = d_p * ang[m, 1] + m * p * ang[m, 0] * d_t
        col += 2
    if lit:  # the shadow columns: through (uu, s, r, t), and the light's direction
        for j in range(2):
            drow[col + j] = (cp[j, 1] * d_uu + cp[j, 2] * d_s + cp[j, 3] * d_r + cp[j, 4] * d_t
                             + (cp[j, 5] if k == 5 else (cp[j, 6] if k == 6 else 0.0)))
        col += 2
    drow[col] = -d_step
    drow[col + 1] = -d_step * ct - out * st * d_t
    drow[col + 2] = -d_step * st + out * ct * d_t


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
def varpro(cx, cy, r, sigma, exposure, az, el, free, u, v, cu, cv, dir_u, dir_v, speed, frame,
           n_frames, weight, kappa, grey, bg, gbu, gbv, z0, dz, table, nodes, rim_order,
           want_jac, exact, hnodes, etab, da):
    """The edge model's weighted residual at ``(cx, cy, r, sigma, exposure, az, el)`` (the
    light's direction; elevation pi/2 or more: no shadow columns), the linear
    coefficients solved (variable projection), and its Jacobian with respect to the
    parameters flagged in ``free`` (``(n_pix, n_free)``; empty unless ``want_jac``), in one
    call; with the centre free (``free[0]`` and ``free[1]``) its columns are each frame's
    centre's, ``(cx, cy)`` of frame 0, of frame 1, ..., then the others (one frame: the usual
    seven). ``gbu, gbv``: the background's gradient (grey levels per px; the wall's occlusion
    term of :func:`_row`). Each pixel's centre is ``(cu + cx, cv + cy)``: ``cu, cv`` the
    frames' offsets (zero for one frame), ``cx, cy`` a shift shared by all. The coefficients
    are the normal equations' with a small ridge (the columns are O(1) functions of the pixels: a
    near-degenerate column gets a coefficient ~0). The Jacobian is the exact derivative of
    ``res = y - A beta``, ``beta = M^-1 A^T y``, ``M = A^T A + ridge`` (Golub & Pereyra 1973;
    the ridge held): ``d res = g - A M^-1 (A^T g + dA^T res)``, ``g = dy - dA beta``; ``dA``
    and ``dy`` from :func:`_row` and :func:`_drow`. ``ok`` is False where the normal
    equations are singular.

    ``kappa``: the background model's variance at each pixel in units of the frame's noise
    variance there. Each residual is divided by its SD, ``sqrt(1 + kappa (1 - S)^2)`` (``S`` the
    blurred step: the background shows through ``1 - S`` of the pixel), ``weight`` times that:
    the cost profiled over the background's errors with their Gaussian prior. Its expectation
    is the same at every radius (``E[res^2] / (1 + kappa (1 - S)^2)`` is the noise variance plus
    the model's error), where the plain sum of squares falls by ``kappa (1 - S)^2`` noise
    variances for each pixel the ball covers more and so pulls the radius out. The weights'
    derivatives are in the Jacobian.

    ``exact``: the columns blurred in two dimensions (:func:`_hankel`, nodes ``hnodes``, the
    Bessel functions' table ``etab`` of spacing ``da``), else along the radius in closed form."""
    n = u.size
    lit = el < _HALF_PI  # a shadow on the rim: its two columns
    n_shared = 11 + 2 * max(rim_order - 2, 0) + (2 if lit else 0)
    m = n_shared + 3 * n_frames
    a = np.zeros((n, m))
    y = np.empty(n)
    row = np.empty(n_shared + 3)
    drow = np.empty(n_shared + 3)
    n_prof = 6 + max(rim_order, 2) - 1  # radial factors: 6, then the rim's m = 2 .. rim_order
    part = np.empty((n_prof, 4))
    rad = np.empty((n_prof, 4))
    gg = np.empty((6, n_prof))
    ev = np.empty((2, max(rim_order, 2) + 1))
    chain = np.empty((7, 4))
    ang = np.empty((max(rim_order, 2) + 1, 2))
    cp = np.empty((2, 7))
    docc = np.empty(7)
    az_c = math.cos(az)
    az_s = math.sin(az)
    # with the Jacobian, what each pixel's row derivatives need, kept from the first pass
    nk = n if want_jac else 0
    k_step = np.empty(nk)
    k_part = np.empty((nk, n_prof, 4))
    k_chain = np.empty((nk, 7, 4))
    k_ang = np.empty((nk, ang.shape[0], 2))
    k_cp = np.empty((nk, 2, 7))
    k_docc = np.empty((nk, 7))
    for i in range(n):
        step, occ = _row(u[i] - cu[i] - cx, v[i] - cv[i] - cy, dir_u[i], dir_v[i], speed[i],
                         r, sigma, exposure, az_c, az_s, el, z0, dz, table, nodes, rim_order,
                         want_jac, row, part, chain, ang, cp, gbu[i], gbv[i], docc, exact,
                         hnodes, etab, da, ev, gg, rad)
        if want_jac:
            k_step[i] = step
            k_part[i] = part
            k_chain[i] = chain
            k_ang[i] = ang
            k_cp[i] = cp
            k_docc[i] = docc
        out = 1.0 - step
        w = weight[i] / math.sqrt(1.0 + kappa[i] * out * out)
        for c in range(n_shared):
            a[i, c] = row[c] * w
        j = n_shared + 3 * frame[i]
        for c in range(3):
            a[i, j + c] = row[n_shared + c] * w
        y[i] = (grey[i] - bg[i] * (1.0 - step) - occ) * w
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
    # the centre's columns: one pair per frame
    n_centre = 2 * n_frames if free[0] else 0
    n_free = n_centre
    for k in range(2, 7):
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
    g = np.zeros((n, n_free))
    h = np.zeros((m, n_free))
    for i in range(n):
        step = k_step[i]
        part, chain, ang, cp, docc = k_part[i], k_chain[i], k_ang[i], k_cp[i], k_docc[i]
        out = 1.0 - step
        spread = 1.0 + kappa[i] * out * out
        w = weight[i] / math.sqrt(spread)
        wr = w * res[i]
        j = n_shared + 3 * frame[i]
        col = n_centre
        for k in range(7):
            if not free[k]:
                continue
            if k < 2:  # the pixel's own frame's centre
                at = 2 * frame[i] + k
            else:
                at = col
                col += 1
            _drow(part, chain, ang, cp, k, rim_order, lit, drow)
            # the weight's own derivative, relative: dw / w = kappa (1 - S) dS / spread; with it
            # dA = w dA0 + (dw / w) A and dy = w dy0 + (dw / w) y, so g gains (dw / w) res
            dw = kappa[i] * out * drow[0] / spread
            t = bg[i] * drow[0] - docc[k]  # dy: y = (grey - bg (1 - step) - occ) w
            for c in range(n_shared):
                t -= drow[c] * beta[c]
                h[c, at] += drow[c] * wr + dw * a[i, c] * res[i]
            for c in range(3):
                t -= drow[n_shared + c] * beta[j + c]
                h[j + c, at] += drow[n_shared + c] * wr + dw * a[i, j + c] * res[i]
            t = t * w + dw * res[i]
            g[i, at] = t
            for c in range(n_shared):  # h += A^T g (the row's nonzero columns)
                h[c, at] += a[i, c] * t
            for c in range(j, j + 3):
                h[c, at] += a[i, c] * t
    sol = np.empty((m, n_free))
    for col in range(n_free):
        rhs = h[:, col].copy()
        _cho_solve(low, rhs)
        sol[:, col] = rhs
    for i in range(n):
        j = n_shared + 3 * frame[i]
        for col in range(n_free):
            t = g[i, col]
            for c in range(n_shared):
                t -= a[i, c] * sol[c, col]
            for c in range(j, j + 3):
                t -= a[i, c] * sol[c, col]
            jac[i, col] = t
    return res, jac, True


@njit(cache=True)
def _evaluate_frame(q, free, u, v, dir_u, dir_v, speed, frame, n_frames, weight, kappa, grey,
                    bg, gbu, gbv, z0, dz, table, nodes, rim_order, exact, hnodes, etab, da):
    """:func:`varpro` at ``q = (cx, cy, r, sigma, exposure, az, el)`` of one frame's pixels,
    with the Jacobian; ``ok`` False where the normal equations are singular or a residual is not
    finite."""
    zero = np.zeros(u.size)
    res, jac, ok = varpro(q[0], q[1], q[2], q[3], q[4], q[5], q[6], free, u, v, zero, zero,
                          dir_u, dir_v, speed, frame, n_frames, weight, kappa, grey, bg, gbu,
                          gbv, z0, dz, table, nodes, rim_order, True, exact, hnodes, etab,
                          da)
    if ok:
        for i in range(res.size):
            if not math.isfinite(res[i]):
                return res, jac, False
    return res, jac, ok


@njit(cache=True)
def fit_frame(q0, free, lo, hi, x_scale, xtol, ftol, max_nfev, u, v, dir_u, dir_v, speed,
              frame, n_frames, weight, kappa, grey, bg, gbu, gbv, z0, dz, table, nodes,
              rim_order, exact, hnodes, etab, da):
    """Least squares of the edge model of one frame over the parameters of ``q0 = (cx, cy, r,
    sigma, exposure, az, el)`` flagged in ``free``, within ``lo <= x <= hi`` (the free ones):
    Levenberg-Marquardt on the analytic Jacobian of :func:`varpro`, in the variables
    ``x / x_scale``, the damping updated from the gain ratio (Nielsen 1999: ``lambda`` times
    ``max(1/3, 1 - (2 rho - 1)^3)`` on success, doubling factors on failure) from 1e-6 of the
    largest curvature (nearly Gauss-Newton), a parameter at a bound that the gradient pushes
    outwards held there for the step, the step clipped to the bounds, and SciPy
    ``least_squares``' stopping rules (gradient below 1e-8 in the scaled variables; ``ftol``:
    the cost fell by less than ``ftol`` of itself with a gain ratio above 0.25; ``xtol``: a
    step shorter than ``xtol (xtol + |x|)``; at most ``max_nfev`` evaluations of the model).
    ``exact, hnodes, etab, da`` as :func:`varpro`'s.
    Returns ``(q, residuals at q, status)``; ``status`` -1 where the start cannot be evaluated,
    else the number of the rule that stopped it (0: evaluations, 1: gradient, 2: ``ftol``, 3:
    ``xtol``).

    Written here rather than calling ``scipy.optimize.least_squares``: that one's Python costs
    ~1.5 ms a fit against ~0.15 ms for the model itself, and the tracker fits ~60 times a
    video; on the paper's camera (224 x 64 px, 1200 frames) SciPy's share was as much as all
    the per-frame work (~90 ms a video; docs/tracking.md §4)."""
    q = q0.copy()
    nf = 0
    for k in range(7):
        nf += 1 if free[k] else 0
    idx = np.empty(nf, np.int64)
    j = 0
    for k in range(7):
        if free[k]:
            idx[j] = k
            j += 1
    res, jac, ok = _evaluate_frame(q, free, u, v, dir_u, dir_v, speed, frame, n_frames, weight,
                                   kappa, grey, bg, gbu, gbv, z0, dz, table, nodes, rim_order,
                                   exact, hnodes, etab, da)
    if not ok:
        return q, res, -1
    nfev = 1
    cost = 0.5 * np.dot(res, res)
    lam = -1.0
    nu = 2.0
    jtj = np.empty((nf, nf))
    grad = np.empty(nf)
    mat = np.empty((nf, nf))
    step = np.empty(nf)
    held = np.zeros(nf, np.bool_)
    trial = np.empty(7)
    status = 0
    fresh = True  # jtj and grad are those of the current point
    while nfev < max_nfev:
        if fresh:
            for a in range(nf):
                t = 0.0
                for i in range(res.size):
                    t += jac[i, a] * res[i]
                grad[a] = t * x_scale
                for b in range(a + 1):
                    t = 0.0
                    for i in range(res.size):
                        t += jac[i, a] * jac[i, b]
                    jtj[a, b] = jtj[b, a] = t * x_scale * x_scale
            gmax = 0.0
            for a in range(nf):
                gmax = max(gmax, abs(grad[a]))
            if gmax < 1e-8:
                status = 1
                break
            if lam < 0.0:
                dmax = 0.0
                for a in range(nf):
                    dmax = max(dmax, jtj[a, a])
                lam = 1e-6 * dmax + 1e-300
            fresh = False
        # a parameter at a bound that the gradient pushes outwards stays there (its column
        # left out of the step): a step clipped afterwards would point elsewhere
        for a in range(nf):
            k = idx[a]
            span = 1e-9 * (hi[a] - lo[a])
            held[a] = ((q[k] <= lo[a] + span and grad[a] > 0.0)
                       or (q[k] >= hi[a] - span and grad[a] < 0.0))
        for a in range(nf):
            for b in range(nf):
                mat[a, b] = 0.0 if held[a] or held[b] else jtj[a, b]
            mat[a, a] += 1.0 if held[a] else lam
            step[a] = 0.0 if held[a] else -grad[a]
        if not _cholesky(mat):  # a Jacobian with a NaN: no step can be found
            lam *= nu
            nu *= 2.0
            if not lam < 1e300:
                status = 1
                break
            continue
        _cho_solve(mat, step)
        # the step clipped to the bounds, back in the scaled variables
        xnorm = 0.0
        snorm = 0.0
        for k in range(7):
            trial[k] = q[k]
        for a in range(nf):
            k = idx[a]
            x = min(max(q[k] + x_scale * step[a], lo[a]), hi[a])
            trial[k] = x
            step[a] = (x - q[k]) / x_scale
            xnorm += q[k] * q[k]
            snorm += (x - q[k]) * (x - q[k])
        predicted = 0.0
        for a in range(nf):
            t = 0.0
            for b in range(nf):
                t += jtj[a, b] * step[b]
            predicted -= grad[a] * step[a] + 0.5 * step[a] * t
        small = math.sqrt(snorm) < xtol * (xtol + math.sqrt(xnorm))
        res_t, jac_t, ok = _evaluate_frame(trial, free, u, v, dir_u, dir_v, speed, frame,
                                           n_frames, weight, kappa, grey, bg, gbu, gbv, z0,
                                           dz, table, nodes, rim_order, exact, hnodes,
                                           etab, da)
        nfev += 1
        actual = cost - 0.5 * np.dot(res_t, res_t) if ok else -math.inf
        if predicted > 0.0 and actual > 1e-4 * predicted:
            rho = actual / predicted
            for k in range(7):
                q[k] = trial[k]
            res, jac = res_t, jac_t
            lam *= max(1.0 / 3.0, 1.0 - (2.0 * rho - 1.0) ** 3)
            nu = 2.0
            fresh = True
            before, cost = cost, cost - actual
            if actual < ftol * before and rho > 0.25:
                status = 2
                break
            if small:
                status = 3
                break
        else:
            if small:
                status = 3
                break
            lam *= nu
            nu *= 2.0
    return q, res, status


SECTORS = 24     # polar sectors of the ring whose wall is checked against the background
BAND_PX = 2.0    # px: the band beyond the blurred rim (from three blurs out) that is checked
BAND_BLURS = 3.0
FOREIGN = 4.0    # robust SDs: a sector whose band differs more in the median is left out
SECTOR_REACH = 2  # sectors either side of one left out that go with it (a shadow's arc on
#                   the rim is wider than on the band outside it)


_TAN_15 = np.tan(np.radians(np.arange(15.0, 90.0, 15.0)))  # the sectors' edges in a quadrant


@njit(cache=True)
def sector_of(du, dv):
    """The polar sector (of ``SECTORS``, 15 degrees each) of a pixel at offset ``(du, dv)``
    from the centre: ``floor((atan2(dv, du) + pi) / 15 degrees)``, by comparisons with the
    sectors' edges in the quadrant instead of ``atan2`` (1.8 against 31 ns a pixel, compiled;
    the per-frame fits take it for many pixels of every frame)."""
    x, y = -du, -dv  # atan2(dv, du) + pi is the angle of (-du, -dv) in [0, 2 pi)
    if x > 0.0 and y >= 0.0:
        q = 0
    elif x <= 0.0 and y > 0.0:
        q, x, y = 1, y, -x
    elif x < 0.0 and y <= 0.0:
        q, x, y = 2, -x, -y
    elif x >= 0.0 and y < 0.0:
        q, x, y = 3, -y, x
    else:  # the centre itself: atan2(0, 0) = 0
        return SECTORS // 2
    k = 0
    while k < 5 and y >= x * _TAN_15[k]:
        k += 1
    return (6 * q + k) % SECTORS


@njit(cache=True)
def foreign_sectors(res, du, dv, rho, band_from):
    """Where the wall beside the ball is not the background model's, for the edge model's and
    the per-frame fits' pixels (offsets ``du, dv`` from the centre, ``rho`` their distance,
    ``res`` the frame less the background; 1-D): the pixels of the polar sectors (``SECTORS``
    of them, and ``SECTOR_REACH`` either side) whose pixels from ``band_from`` out (three blurs
    beyond the rim: the wall alone) differ from the background by more than ``FOREIGN`` robust
    SDs in the median (sectors with fewer than 3 such pixels are not judged). A lamp's shadow of the ball on the wall (rendered: a bright 12 px ball, its
    shadow half as bright as the wall and overlapping it, in every frame alike so that no
    frame was flagged: the radius +6.7 % and the centres 1.0 px off), a contact shadow, a
    reflection. None where more than half the sectors would go (the background itself is off
    there, or the band holds the rim's light)."""
    n = res.size
    out = np.zeros(n, np.bool_)
    sector = np.empty(n, np.int64)
    nb = 0
    for i in range(n):
        sector[i] = sector_of(du[i], dv[i])
        if rho[i] >= band_from:
            nb += 1
    if nb < 4 * SECTORS:
        return out
    band = np.empty(nb)
    which = np.empty(nb, np.int64)
    k = 0
    for i in range(n):
        if rho[i] >= band_from:
            band[k], which[k] = res[i], sector[i]
            k += 1
    sd = 1.4826 * np.median(np.abs(band - np.median(band))) + 0.5
    bad = np.zeros(SECTORS, np.bool_)
    count = 0
    for j in range(SECTORS):
        vals = band[which == j]
        if vals.size >= 3 and abs(np.median(vals)) > FOREIGN * sd:
            bad[j] = True
            count += 1
    if count == 0 or 2 * count > SECTORS:
        return out
    grown = bad.copy()
    for j in range(SECTORS):
        if bad[j]:
            for o in range(-SECTOR_REACH, SECTOR_REACH + 1):
                grown[(j + o) % SECTORS] = True
    if 2 * grown.sum() > SECTORS:  # half the rim at least is kept
        grown = bad
    for i in range(n):
        out[i] = grown[sector[i]]
    return out


# a frame's fit whose pixels inside the blurred rim misfit, in one of the rim's polar sectors
# (_edge_kernel.SECTORS, 15 degrees each), by more than MISFIT_SECTOR of the ball's contrast
# in the mean is fitted again without the run of sectors about the worst (grow_run), up to
# MISFIT_ROUNDS times and MISFIT_SECTORS sectors in all (._refine._fit_clean; the edge
# model's fits likewise at ._edge.EDGE_MISFIT): a logo near the rim takes a bite out of it
# that the fit follows. benchmarks/tracking_centres.py's 8 bounces of
# a side-lit 10-15 px ball with a dark spot of 0.3-0.5 rad turning near its rim: centres
# 0.24-0.72 -> 0.09-0.23 px (median 0.44 -> 0.14), 8 of 8 accepted (7), rebound angle |z|
# at most 3.24 -> 2.65, speed 2.53 -> 2.00; 0.15 and 0.3 gave medians of 0.15 and 0.17 px
# (largest 0.32 and 0.25). A clear ball's worst sector misfits by 0.02-0.03 of its contrast
# in the median frame (at most 0.42 in a frame, six of the benchmark's bounces probed): its 48
# clear bounces came out alike (0.035 -> 0.029 px in one, the rest within 0.001 px); the
# striped balls 0.21 -> 0.23 px (median), rebound angle |z| at most 0.39 -> 1.39. Not where
# the fit's pixels reach beyond the frame (._refine._in_frame): a dark ball entering it whose
# shadow merges with it moved 2-3.7 px further towards the shadow with the true rim's sectors left
# out (test_a_dark_balls_shadow_merged_with_it_is_not_taken_for_the_ball)
MISFIT_SECTOR = 0.2
MISFIT_SECTORS = 10
MISFIT_ROUNDS = 3


@njit(cache=True)
def sector_misfit(res, grey, wall, step, du, dv, r, score):
    """``score[j]``: the mean residual ``res`` of polar sector ``j``'s pixels inside the
    blurred rim (``step`` over a half) and beyond half the radius ``r`` from the centre
    (offsets ``du, dv``), over the ball's contrast there (the mean of ``|grey - wall|``); 0
    where a sector has fewer than 3 such pixels."""
    total = np.zeros(SECTORS)
    count = np.zeros(SECTORS)
    contrast, m = 0.0, 0
    for k in range(res.size):
        if step[k] > 0.5 and du[k] * du[k] + dv[k] * dv[k] > 0.25 * r * r:
            j = sector_of(du[k], dv[k])
            total[j] += res[k]
            count[j] += 1.0
            contrast += abs(grey[k] - wall[k])
            m += 1
    score[:] = 0.0
    if m == 0 or contrast <= 0.0:
        return
    contrast /= m
    for j in range(SECTORS):
        if count[j] >= 3.0:
            score[j] = total[j] / count[j] / contrast


@njit(cache=True)
def grow_run(score, worst, drop):
    """Add to ``drop`` the run of sectors about ``worst`` whose ``score`` is at least half of
    ``MISFIT_SECTOR`` either way, and one more each side; False (``drop`` unchanged) where
    that would leave out more than ``MISFIT_SECTORS`` in all."""
    new = drop.copy()
    for step in (-1, 1):
        j = worst
        for _ in range(SECTORS):
            new[j % SECTORS] = True
            if abs(score[j % SECTORS]) < 0.5 * MISFIT_SECTOR:
                break
            j += step
    if new.sum() > MISFIT_SECTORS:
        return False
    drop[:] = new
    return True


@njit(cache=True)
def in_sectors(du, dv, drop):
    """Whether each pixel at offset ``(du, dv)`` from the ball's centre lies in one of the
    polar sectors flagged in ``drop`` (``SECTORS`` of them, :func:`sector_of`)."""
    out = np.zeros(du.size, np.bool_)
    for k in range(du.size):
        out[k] = drop[sector_of(du[k], dv[k])]
    return out
