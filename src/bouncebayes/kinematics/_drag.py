"""Free flight with quadratic air drag, ``r'' = a - k |v| v``: RK4 solution, least-squares fit
and the model of the observables for the delta method."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from scipy.optimize import least_squares

from ._result import TrajectoryError, _observables, _Segment

_RK4_MAX_STEP = 2e-3  # s; RK4 error (h/T)^4 with T = 1/(k|v|) >~ 0.1 s is below 1e-10 relative


def _drag_accel(v: np.ndarray, a: np.ndarray, k: float) -> np.ndarray:
    return a - k * np.linalg.norm(v) * v


def _rk4(p: np.ndarray, d: int, tau_end: float, n_steps: int
         ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Nodes, positions and velocities of r'' = a - k|v|v from tau = 0 (state r0, v0) to tau_end.

    ``p`` = (r0, v0, a, k). Fixed steps make the result a smooth function of ``p``, as the
    finite-difference Jacobians need."""
    r, v, a, k = p[:d].copy(), p[d:2 * d].copy(), p[2 * d:3 * d], p[3 * d]
    h = tau_end / n_steps
    rs, vs = [r], [v]
    for _ in range(n_steps):
        k1 = _drag_accel(v, a, k)
        k2 = _drag_accel(v + 0.5 * h * k1, a, k)
        k3 = _drag_accel(v + 0.5 * h * k2, a, k)
        k4 = _drag_accel(v + h * k3, a, k)
        r = r + h * v + h * h / 6.0 * (k1 + k2 + k3)
        v = v + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
        rs.append(r)
        vs.append(v)
    return np.linspace(0.0, tau_end, n_steps + 1), np.array(rs), np.array(vs)


def _drag_positions(p: np.ndarray, d: int, tau: np.ndarray) -> np.ndarray:
    """Positions at ``tau`` (all one sign): RK4 on a grid + cubic Hermite interpolation."""
    tau_end = float(tau[np.argmax(np.abs(tau))])
    n_steps = max(1, math.ceil(abs(tau_end) / _RK4_MAX_STEP))
    nodes, R, V = _rk4(p, d, tau_end, n_steps)
    h = tau_end / n_steps
    j = np.clip(np.floor(tau / h).astype(int), 0, n_steps - 1)
    s = ((tau - nodes[j]) / h)[:, None]
    h00, h10 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s
    h01, h11 = -2 * s**3 + 3 * s**2, s**3 - s**2
    return h00 * R[j] + h10 * h * V[j] + h01 * R[j + 1] + h11 * h * V[j + 1]


def _fit_drag(source: str, tau: np.ndarray, pos: np.ndarray, start: _Segment) -> _Segment:
    """Least squares fit of (r0, v0, a, k) at tau = 0, from the constant-acceleration fit."""
    d = pos.shape[1]
    quad = start.params.reshape(d, 3)
    p0 = np.concatenate([quad[:, 0], quad[:, 1], 2 * quad[:, 2], [0.0]])
    res = least_squares(lambda p: (_drag_positions(p, d, tau) - pos).ravel(), p0, method="lm",
                        x_scale="jac", xtol=1e-12, ftol=1e-12, gtol=1e-12)
    dof = pos.size - p0.size
    scale = np.linalg.norm(res.jac, axis=0)  # column scaling: r0, v0, a, k differ in units
    jtj = (res.jac / scale).T @ (res.jac / scale) if np.all(scale > 0) else None
    if not res.success or dof < 1 or jtj is None or np.linalg.cond(jtj) > 1e14:
        raise TrajectoryError(source, f"the quadratic-drag fit failed ({res.message}); fit "
                                      "without drag or give longer free-flight segments",
                              reason="bad fit")
    rss = float(2 * res.cost)
    cov = rss / dof * np.linalg.inv(jtj) / np.outer(scale, scale)
    return _Segment(index=start.index, params=res.x, cov=cov,
                    rss=rss, n_resid=pos.size,
                    acceleration=tuple(float(a) for a in res.x[2 * d:3 * d]),
                    drag_k=float(res.x[3 * d]))


def _drag_model(d: int, n_params: int, tau_guess: float) -> Callable[[np.ndarray], np.ndarray]:
    """theta (both segments' r0, v0, a, k) -> observables + [tau_i, vy_in, vy_out]."""
    def state(p: np.ndarray, tau: float) -> tuple[np.ndarray, np.ndarray]:
        _, R, V = _rk4(p, d, tau, 8)
        return R[-1], V[-1]

    def model(theta: np.ndarray) -> np.ndarray:
        pre, post = theta[:n_params], theta[n_params:]
        tau = tau_guess
        for _ in range(30):  # Newton on y_pre(tau) - y_post(tau)
            (r1, v1), (r2, v2) = state(pre, tau), state(post, tau)
            step = (r1[1] - r2[1]) / (v1[1] - v2[1])
            tau -= step
            if abs(step) < 1e-15:
                break
        (_, v_in), (_, v_out) = state(pre, tau), state(post, tau)
        return np.array([*_observables(v_in, v_out), tau, v_in[1], v_out[1]])
    return model
