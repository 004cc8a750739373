"""The quadratic-drag kinematics as bouncebayes 0.1.0 computed it: the baseline that
benchmarks/kinematics.py measures the current code against, in the same run.

A condensed copy of that release's ``kinematics/_drag.py`` and the drag branch of
``kinematics/_fit.py``: each flight fitted by ``scipy.optimize.least_squares`` (Levenberg-
Marquardt, finite-difference Jacobian) of a fixed-step RK4 solution written in plain NumPy,
then the delta method by central differences through the whole map (both flights integrated to
the crossing, found by Newton). Only the arithmetic that costs time is kept; the splits come
from the current code's drag-free fits (the same for both).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.linalg import block_diag
from scipy.optimize import least_squares

_RK4_MAX_STEP = 2e-3


def _accel(v, a, k):
    return a - k * np.linalg.norm(v) * v


def _rk4(p, d, tau_end, n_steps):
    r, v, a, k = p[:d].copy(), p[d:2 * d].copy(), p[2 * d:3 * d], p[3 * d]
    h = tau_end / n_steps
    rs, vs = [r], [v]
    for _ in range(n_steps):
        k1 = _accel(v, a, k)
        k2 = _accel(v + 0.5 * h * k1, a, k)
        k3 = _accel(v + 0.5 * h * k2, a, k)
        k4 = _accel(v + h * k3, a, k)
        r = r + h * v + h * h / 6.0 * (k1 + k2 + k3)
        v = v + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
        rs.append(r)
        vs.append(v)
    return np.linspace(0.0, tau_end, n_steps + 1), np.array(rs), np.array(vs)


def _positions(p, d, tau):
    tau_end = float(tau[np.argmax(np.abs(tau))])
    n_steps = max(1, math.ceil(abs(tau_end) / _RK4_MAX_STEP))
    nodes, R, V = _rk4(p, d, tau_end, n_steps)
    h = tau_end / n_steps
    j = np.clip(np.floor(tau / h).astype(int), 0, n_steps - 1)
    s = ((tau - nodes[j]) / h)[:, None]
    h00, h10 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s
    h01, h11 = -2 * s**3 + 3 * s**2, s**3 - s**2
    return h00 * R[j] + h10 * h * V[j] + h01 * R[j + 1] + h11 * h * V[j + 1]


def fit_flight(tau, pos):
    """(params, covariance) of the drag fit of one flight, from its constant-acceleration
    fit."""
    d = pos.shape[1]
    X = np.column_stack([np.ones_like(tau), tau, tau * tau])
    coef, *_ = np.linalg.lstsq(X, pos, rcond=None)
    p0 = np.concatenate([coef[0], coef[1], 2 * coef[2], [0.0]])
    res = least_squares(lambda p: (_positions(p, d, tau) - pos).ravel(), p0, method="lm",
                        x_scale="jac", xtol=1e-12, ftol=1e-12, gtol=1e-12)
    scale = np.linalg.norm(res.jac, axis=0)
    jtj = (res.jac / scale).T @ (res.jac / scale)
    cov = 2 * res.cost / (pos.size - p0.size) * np.linalg.inv(jtj) / np.outer(scale, scale)
    return res.x, cov


def _observables(v_in, v_out):
    return [math.hypot(*v_in), math.degrees(math.atan2(v_in[0], abs(v_in[1]))),
            math.hypot(*v_out), math.degrees(math.atan2(v_out[0], abs(v_out[1])))]


def _model(d, n, tau_guess):
    def state(p, tau):
        _, R, V = _rk4(p, d, tau, 8)
        return R[-1], V[-1]

    def model(theta):
        pre, post = theta[:n], theta[n:]
        tau = tau_guess
        for _ in range(30):
            (r1, v1), (r2, v2) = state(pre, tau), state(post, tau)
            step = (r1[1] - r2[1]) / (v1[1] - v2[1])
            tau -= step
            if abs(step) < 1e-15:
                break
        (_, v_in), (_, v_out) = state(pre, tau), state(post, tau)
        return np.array([*_observables(v_in, v_out), tau])
    return model


def kinematics(tau_pre, pos_pre, tau_post, pos_post, tau_guess=0.0):
    """Incidence and rebound speed and angle with standard errors, as 0.1.0 computed them."""
    (p1, c1), (p2, c2) = fit_flight(tau_pre, pos_pre), fit_flight(tau_post, pos_post)
    theta, cov = np.concatenate([p1, p2]), block_diag(c1, c2)
    f = _model(pos_pre.shape[1], p1.size, tau_guess)
    f0 = f(theta)
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    jac = np.zeros((f0.size, theta.size))
    for j in np.flatnonzero(sd > 0):
        step = np.zeros_like(theta)
        step[j] = 1e-4 * sd[j]
        jac[:, j] = (f(theta + step) - f(theta - step)) / (2 * step[j])
    return f0, np.sqrt(np.clip(np.einsum("ij,jk,ik->i", jac, cov, jac), 0.0, None))
