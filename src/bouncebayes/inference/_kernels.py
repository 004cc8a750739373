"""Compiled inner loops of the samplers: the gaussian likelihood's terms (one pass over
(rows, trials), no temporaries; with inferred noise or model discrepancy, normal or Student-t
residuals and the shared scale factor marginalised), the prior's box, and Metropolis–Hastings
proposal and accept.

Samplers evaluate the posterior thousands of times on a few rows (one per chain) of 55 trials
each. There a chain of NumPy expressions costs far more in per-call overhead (about a
microsecond per operation) than in arithmetic, so each of these does in one call what would
take several NumPy operations.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

LOG_2PI = math.log(2.0 * math.pi)


@njit(cache=True, inline="always")
def _term(speed, angle, obs_speed, obs_angle, i00, i01, i11, log_norm):
    ds = speed - obs_speed
    da = angle - obs_angle
    return -0.5 * (i00 * ds * ds + 2.0 * i01 * ds * da + i11 * da * da) - log_norm


@njit(cache=True, inline="always")
def _inverse(c00, c01, c11):
    """Inverse of the symmetric 2 x 2 covariance and ``0.5 log det + log 2 pi``."""
    det = c00 * c11 - c01 * c01
    return c11 / det, -c01 / det, c00 / det, 0.5 * math.log(det) + LOG_2PI


@njit(cache=True, error_model="numpy")
def given_noise_sum(speed, angle, ok, obs_speed, obs_angle, i00, i01, i11, log_norm, out):
    """``out[r]`` = sum over trials k of the log-density of row r's residual (covariances
    fixed: inverse ``(i00, i01, i11)`` and ``log_norm`` per trial); ``-inf`` if any trial
    failed or the sum is not a number."""
    for r in range(speed.shape[0]):
        total = 0.0
        for k in range(speed.shape[1]):
            if not ok[r, k]:
                total = -math.inf
                break
            total += _term(speed[r, k], angle[r, k], obs_speed[k], obs_angle[k], i00[k],
                           i01[k], i11[k], log_norm[k])
        out[r] = total if total == total else -math.inf


@njit(cache=True, error_model="numpy")
def given_noise_terms(speed, angle, ok, obs_speed, obs_angle, i00, i01, i11, log_norm, out):
    """Per-trial log-densities ``out[r, k]`` (``-inf`` where the bounce failed)."""
    for r in range(speed.shape[0]):
        for k in range(speed.shape[1]):
            t = _term(speed[r, k], angle[r, k], obs_speed[k], obs_angle[k], i00[k], i01[k],
                      i11[k], log_norm[k])
            out[r, k] = t if ok[r, k] and t == t else -math.inf


@njit(cache=True, inline="always")
def _log_density(q, log_norm, nu):
    """Log-density of a bivariate residual with squared Mahalanobis length ``q`` and
    ``log_norm = 0.5 log det + log 2 pi``: normal where ``nu`` is infinite, else Student-t
    with ``nu`` degrees of freedom (whose bivariate normalisation, Gamma((nu + 2) / 2) /
    (Gamma(nu / 2) nu pi), is the normal's 1 / (2 pi))."""
    if nu == math.inf:
        return -0.5 * q - log_norm
    return -log_norm - 0.5 * (nu + 2.0) * math.log1p(q / nu)


@njit(cache=True, error_model="numpy")
def measurement_terms(speed, angle, ok, obs_speed, obs_angle, c00, c01, c11, g_speed,
                      g_angle, extra_speed, extra_angle, nu, out):
    """Per-trial log-densities ``out[r, k]`` of each trial on its own: covariance
    ``C_k + diag(extra_speed[r]^2, extra_angle[r]^2) + g_k g_k^T`` (``C_k``: the trial's fixed
    part; ``extra``: inferred noise or model discrepancy of row r; ``g_k``: the trial's
    sensitivity to the shared scale factor), normal or Student-t (``nu``)."""
    for r in range(speed.shape[0]):
        vs, va = extra_speed[r] ** 2, extra_angle[r] ** 2
        for k in range(speed.shape[1]):
            i00, i01, i11, log_norm = _inverse(c00[k] + vs + g_speed[k] * g_speed[k],
                                               c01[k] + g_speed[k] * g_angle[k],
                                               c11[k] + va + g_angle[k] * g_angle[k])
            ds = speed[r, k] - obs_speed[k]
            da = angle[r, k] - obs_angle[k]
            t = _log_density(i00 * ds * ds + 2.0 * i01 * ds * da + i11 * da * da, log_norm, nu)
            out[r, k] = t if ok[r, k] and t == t else -math.inf


@njit(cache=True, error_model="numpy")
def measurement_sum(speed, angle, ok, obs_speed, obs_angle, c00, c01, c11, g_speed, g_angle,
                    extra_speed, extra_angle, nu, nodes, log_weights, out):
    """``out[r]``: the joint log-likelihood of every trial of row r, the shared scale factor
    ``eps ~ N(0, 1)`` (observation k moves by ``eps g_k``) marginalised. Normal residuals: in
    closed form (the matrix determinant lemma and Sherman-Morrison formula for the rank-one
    covariance ``g g^T`` shared by all trials); Student-t: by Gauss-Hermite quadrature over
    eps at ``nodes`` with normalised ``log_weights``. ``-inf`` if any trial failed."""
    acc = np.empty(nodes.size)
    for r in range(speed.shape[0]):
        vs, va = extra_speed[r] ** 2, extra_angle[r] ** 2
        total, a, b = 0.0, 0.0, 0.0
        acc[:] = log_weights
        for k in range(speed.shape[1]):
            if not ok[r, k]:
                total = -math.inf
                break
            i00, i01, i11, log_norm = _inverse(c00[k] + vs, c01[k], c11[k] + va)
            ds = speed[r, k] - obs_speed[k]
            da = angle[r, k] - obs_angle[k]
            if nu == math.inf:
                total += -0.5 * (i00 * ds * ds + 2.0 * i01 * ds * da + i11 * da * da) - log_norm
                ws = i00 * g_speed[k] + i01 * g_angle[k]
                wa = i01 * g_speed[k] + i11 * g_angle[k]
                a += g_speed[k] * ws + g_angle[k] * wa
                b += ds * ws + da * wa
            else:
                for j in range(nodes.size):
                    es = ds + nodes[j] * g_speed[k]
                    ea = da + nodes[j] * g_angle[k]
                    acc[j] += _log_density(i00 * es * es + 2.0 * i01 * es * ea + i11 * ea * ea,
                                           log_norm, nu)
        if total > -math.inf and nu == math.inf:
            total += 0.5 * b * b / (1.0 + a) - 0.5 * math.log1p(a)
        elif total > -math.inf:
            top = acc.max()
            total = top + math.log(np.sum(np.exp(acc - top))) if top > -math.inf else top
        out[r] = total if total == total else -math.inf


@njit(cache=True)
def box_log_prior(theta, lower, upper, constant, out):
    """``out[r]`` = ``constant`` where row r of ``theta`` lies in the box, else ``-inf``;
    returns the number of rows inside."""
    inside = 0
    for r in range(theta.shape[0]):
        value = constant
        for j in range(theta.shape[1]):
            x = theta[r, j]
            if not (lower[j] <= x <= upper[j]):
                value = -math.inf
                break
        out[r] = value
        inside += value > -math.inf
    return inside


@njit(cache=True)
def add_log_densities(a, b, out):
    """``out = a + b`` with anything that is not a number (``-inf + inf``) set to ``-inf``."""
    for r in range(a.shape[0]):
        s = a[r] + b[r]
        out[r] = s if s == s else -math.inf


@njit(cache=True)
def mh_propose(position, increment, log_scale):
    """Random-walk proposals ``position + exp(log_scale) * increment``, row by row."""
    out = np.empty_like(position)
    for c in range(position.shape[0]):
        scale = math.exp(log_scale[c])
        for j in range(position.shape[1]):
            out[c, j] = position[c, j] + scale * increment[c, j]
    return out


@njit(cache=True)
def mh_accept(position, logdensity, proposal, lp, log_u):
    """Metropolis acceptance of every chain: new positions and log densities, which chains
    accepted (``log_u < lp - logdensity``) and the log ratios."""
    new_position = position.copy()
    new_logdensity = logdensity.copy()
    accepted = np.zeros(position.shape[0], dtype=np.bool_)
    log_ratio = np.empty(position.shape[0])
    for c in range(position.shape[0]):
        log_ratio[c] = lp[c] - logdensity[c]
        if log_u[c] < log_ratio[c]:
            accepted[c] = True
            new_logdensity[c] = lp[c]
            for j in range(position.shape[1]):
                new_position[c, j] = proposal[c, j]
    return new_position, new_logdensity, accepted, log_ratio
