"""One free flight: constant acceleration (closed form) or quadratic drag (bounded least
squares started from it), with the parameter covariance and the state at any time.

Parameters, both at the flight's reference time ``tau = 0`` (the bounce's lowest sample):

- ``"quadratic"``: per coordinate ``(r0, v0, a/2)``, coordinate after coordinate;
- ``"drag"``: ``(r0 (d), v0 (d), a (d), k)`` for ``r'' = a - k |v| v``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg import block_diag
from scipy.optimize import least_squares

from . import _drag

# The drag fit needs this many samples: 3d + 1 parameters and enough residual degrees of
# freedom to estimate the noise and tell k from the constant acceleration.
DRAG_MIN_POINTS = 8
_BOUND_FRACTION = 1e-3  # k within this fraction of k_max from a bound: "at the bound"


@dataclass(frozen=True)
class Flight:
    """A fitted free flight: samples used, parameters, covariance, residuals (``(n, d)``)."""

    index: np.ndarray
    model: str  #: "quadratic" or "drag"
    params: np.ndarray
    cov: np.ndarray
    residuals: np.ndarray
    dof: int
    drag_k: float | None = None
    drag_k_se: float | None = None
    note: str | None = None  #: why a requested drag fit fell back to constant acceleration

    @property
    def d(self) -> int:
        """Number of coordinates."""
        return int(self.residuals.shape[1])

    @property
    def rss(self) -> float:
        """Residual sum of squares over all coordinates (m^2)."""
        return float(np.sum(self.residuals**2))

    @property
    def s2(self) -> float:
        """Residual variance per coordinate, ``rss / dof`` (m^2)."""
        return self.rss / self.dof

    @property
    def acceleration(self) -> tuple[float, ...]:
        """The constant acceleration (with drag: its constant part ``a``), m/s^2."""
        d = self.d
        a = 2 * self.params.reshape(d, 3)[:, 2] if self.model == "quadratic" else \
            self.params[2 * d:3 * d]
        return tuple(float(x) for x in a)

    def state(self, tau: float) -> tuple[np.ndarray, ...]:
        """Position, velocity, acceleration at ``tau`` and d(position)/d(params),
        d(velocity)/d(params) (``(d, n_params)`` each)."""
        d = self.d
        if self.model == "quadratic":
            c = self.params.reshape(d, 3)
            r = c[:, 0] + c[:, 1] * tau + c[:, 2] * tau * tau
            v = c[:, 1] + 2 * c[:, 2] * tau
            dr = block_diag(*[np.array([[1.0, tau, tau * tau]])] * d)
            dv = block_diag(*[np.array([[0.0, 1.0, 2 * tau]])] * d)
            return r, v, 2 * c[:, 2], dr, dv
        R, V, SR, SV = _drag.solve(self.params, d, np.array([tau]))
        a, k = self.params[2 * d:3 * d], self.params[3 * d]
        return R[0], V[0], a - k * np.linalg.norm(V[0]) * V[0], SR[0], SV[0]


def fit_quadratic(tau: np.ndarray, pos: np.ndarray, index: np.ndarray,
                  noise: float | None) -> Flight:
    """OLS of each coordinate on ``(1, tau, tau^2)``; covariance ``s_c^2 (X^T X)^-1`` per
    coordinate with its own residual variance, or ``noise^2 (X^T X)^-1`` when known."""
    X = np.column_stack([np.ones_like(tau), tau, tau * tau])
    coef, *_ = np.linalg.lstsq(X, pos, rcond=None)
    resid = pos - X @ coef
    dof = tau.size - 3
    s2 = np.sum(resid * resid, axis=0) / dof if noise is None else np.full(pos.shape[1],
                                                                             noise**2)
    xtx_inv = np.linalg.inv(X.T @ X)
    return Flight(index=index, model="quadratic", params=coef.T.ravel(),
                  cov=block_diag(*(s * xtx_inv for s in s2)), residuals=resid,
                  dof=pos.size - coef.size)


def fit_drag(tau: np.ndarray, pos: np.ndarray, start: Flight, k_max: float,
             noise: float | None) -> Flight:
    """Quadratic-drag fit of one flight, or ``start`` (the drag-free fit) with the reason.

    Starts from the drag-free fit linearised in ``k`` (one Gauss-Newton step from ``k = 0``,
    a linear least-squares problem), keeps ``0 <= k <= k_max`` (SciPy's trust-region
    reflective ``least_squares``, exact Jacobian), and falls back when the flight has fewer
    than 8 samples, the fit fails, ``k`` ends on a bound, or the flight cannot tell ``k``
    (its standard error exceeds ``k_max``).
    """
    d = pos.shape[1]
    if tau.size < DRAG_MIN_POINTS:
        return _fallback(start, f"too short for the drag fit ({tau.size} samples, need "
                                f"{DRAG_MIN_POINTS})")
    p0 = _linearised_start(tau, pos, start, k_max)
    order = np.argsort(tau)  # any order works; keep residuals in time order

    def residuals(p: np.ndarray) -> np.ndarray:
        return (_drag.solve(p, d, tau[order])[0] - pos[order]).ravel()

    def jacobian(p: np.ndarray) -> np.ndarray:
        return _drag.solve(p, d, tau[order])[2].reshape(-1, p.size)

    low = np.r_[np.full(3 * d, -np.inf), 0.0]
    high = np.r_[np.full(3 * d, np.inf), k_max]
    with np.errstate(all="ignore"):
        res = least_squares(residuals, p0, jac=jacobian, bounds=(low, high), method="trf",
                            x_scale="jac", xtol=1e-10, ftol=1e-10, gtol=1e-10, max_nfev=50)
    return _accept_drag(start, res, order, pos.size - p0.size, k_max, noise)


def _linearised_start(tau: np.ndarray, pos: np.ndarray, start: Flight,
                      k_max: float) -> np.ndarray:
    """(r0, v0, a, k) of one Gauss-Newton step from the drag-free fit with k = 0: the model is
    linear in r0, v0, a and, to first order, in k (sensitivity -integral of |v| v)."""
    d = pos.shape[1]
    quad = start.params.reshape(d, 3)
    p = np.concatenate([quad[:, 0], quad[:, 1], 2 * quad[:, 2], [0.0]])
    with np.errstate(all="ignore"):
        R, _, SR, _ = _drag.solve(p, d, tau)
        J = SR.reshape(-1, p.size)
        step, *_ = np.linalg.lstsq(J, (pos - R).ravel(), rcond=None)
    p = p + np.where(np.isfinite(step), step, 0.0)
    p[-1] = min(max(p[-1], 0.05 * k_max), 0.95 * k_max)  # strictly inside the bounds
    return p


def _accept_drag(start: Flight, res, order: np.ndarray, dof: int, k_max: float,
                 noise: float | None) -> Flight:
    d = start.d
    k = float(res.x[-1]) if np.all(np.isfinite(res.x)) else math.nan
    if res.status <= 0 or not math.isfinite(k) or not np.all(np.isfinite(res.fun)):
        return _fallback(start, f"the drag fit did not converge ({res.message})")
    if k >= (1 - _BOUND_FRACTION) * k_max:
        return _fallback(start, f"the drag fit ran to the upper bound k = {k_max:g} /m (the "
                                "flight slows more than air drag can; a tracking fault?)")
    if k <= _BOUND_FRACTION * k_max:
        return _fallback(start, "the drag fit found no drag (k = 0)")
    resid = res.fun.reshape(-1, d)
    s2 = float(np.sum(resid**2)) / dof if noise is None else noise**2
    cov = _covariance(res.jac, s2)
    if cov is None:
        return _fallback(start, "the drag fit's parameters are not determined (singular "
                                "Jacobian)")
    k_se = math.sqrt(cov[-1, -1])
    if k_se > k_max:
        return _fallback(start, f"the flight is too short to tell the drag (k = {k:.2g} +- "
                                f"{k_se:.2g} /m, range 0-{k_max:g})")
    back = np.empty_like(resid)
    back[order] = resid
    return Flight(index=start.index, model="drag", params=res.x.copy(), cov=cov,
                  residuals=back, dof=dof, drag_k=k, drag_k_se=k_se)


def _covariance(jac: np.ndarray, s2: float) -> np.ndarray | None:
    """``s2 (J^T J)^-1`` with column scaling (r0, v0, a and k differ in units); None if
    singular."""
    scale = np.linalg.norm(jac, axis=0)
    if not np.all(np.isfinite(scale)) or np.any(scale == 0):
        return None
    js = jac / scale
    jtj = js.T @ js
    if not np.isfinite(jtj).all() or np.linalg.cond(jtj) > 1e14:
        return None
    return s2 * np.linalg.inv(jtj) / np.outer(scale, scale)


def _fallback(start: Flight, reason: str) -> Flight:
    return Flight(index=start.index, model=start.model, params=start.params, cov=start.cov,
                  residuals=start.residuals, dof=start.dof, note=f"{reason}: fitted without "
                                                                  "drag")
