"""From two fitted flights to the observables at the impact, with the delta method.

The impact time ``tau`` is where the two fitted ``y(t)`` cross; its derivatives follow from
the implicit-function theorem, ``dtau/dtheta = -(dy_pre/dtheta - dy_post/dtheta) /
(vy_pre - vy_post)``, and the velocities at ``tau`` carry ``a dtau/dtheta``. A tilt of the
surface by ``eps`` (the tracker's stated surface-angle uncertainty) turns both velocities by
``-eps`` in the (x, y) plane: it is one more parameter of the propagation, so incidence and
rebound angles move together (by ``-eps`` and ``+eps``) as they should.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from ._flight import Flight, block_diagonal
from ._result import observables

_NEWTON_ITERATIONS = 30


@dataclass(frozen=True)
class Observation:
    """Observables ``values`` = [incidence speed, angle, rebound speed, angle(, lateral)],
    their covariance, and the impact time and velocities behind them."""

    values: np.ndarray
    cov: np.ndarray
    tau: float
    tau_se: float
    v_in: np.ndarray
    v_out: np.ndarray
    a_in: np.ndarray  #: acceleration of the flight before at the impact
    a_out: np.ndarray
    jac_velocity: np.ndarray  #: d(values)/d(v_in, v_out)

    @property
    def se(self) -> np.ndarray:
        """Standard errors of ``values`` (NaN where the variance is not a finite number)."""
        var = np.diag(self.cov)
        return np.where(np.isfinite(var) & (var >= 0), np.sqrt(np.abs(var)), np.nan)


def crossing(pre: Flight, post: Flight, tau0: float) -> float | None:
    """Where the flights' normal positions cross, by Newton from ``tau0``; None if it fails."""
    tau = tau0
    for _ in range(_NEWTON_ITERATIONS):
        (r1, v1, *_), (r2, v2, *_) = pre.state(tau), post.state(tau)
        slope = v1[1] - v2[1]
        if not (math.isfinite(slope) and slope != 0.0):
            return None
        step = (r1[1] - r2[1]) / slope
        tau -= step
        if not math.isfinite(tau):
            return None
        if abs(step) <= 1e-13 * max(1.0, abs(tau)):
            return tau
    return None


def observe(pre: Flight, post: Flight, tau0: float,
            tilt_sd_deg: float | None) -> Observation | None:
    """The observables at the crossing nearest ``tau0`` with their covariance; None if the
    flights do not cross there."""
    tau = crossing(pre, post, tau0)
    if tau is None:
        return None
    _, v1, a1, dr1, dv1 = pre.state(tau)
    _, v2, a2, dr2, dv2 = post.state(tau)
    n1, n2 = pre.params.size, post.params.size
    dtau = np.concatenate([-dr1[1], dr2[1]]) / (v1[1] - v2[1])
    jv_in = np.hstack([dv1, np.zeros((v1.size, n2))]) + np.outer(a1, dtau)
    jv_out = np.hstack([np.zeros((v2.size, n1)), dv2]) + np.outer(a2, dtau)
    jv = np.vstack([jv_in, jv_out])
    tilt = np.concatenate([_turn(v1), _turn(v2)])  # d(v_in, v_out)/d(eps)
    jv = np.hstack([jv, tilt[:, None]])
    dtau = np.r_[dtau, 0.0]
    sd = math.radians(tilt_sd_deg or 0.0)
    cov_theta = block_diagonal(pre.cov, post.cov, np.array([[sd * sd]]))
    values, jobs = _observables_jacobian(v1, v2)
    jac = jobs @ jv
    cov = jac @ cov_theta @ jac.T
    tau_var = float(dtau @ cov_theta @ dtau)
    return Observation(values, cov, float(tau), math.sqrt(max(tau_var, 0.0)), v1, v2, a1, a2,
                       jobs)


def _turn(v: np.ndarray) -> np.ndarray:
    """d/d(eps) of the velocity's coordinates in a frame turned by eps: (v_y, -v_x, 0)."""
    out = np.zeros_like(v)
    out[0], out[1] = v[1], -v[0]
    return out


def _observables_jacobian(v_in: np.ndarray, v_out: np.ndarray
                          ) -> tuple[np.ndarray, np.ndarray]:
    """Observables and their derivatives with respect to (v_in, v_out), central differences
    (the map is smooth and cheap; steps of 1e-6 of the speed)."""
    x = np.concatenate([v_in, v_out])
    d = v_in.size
    f0 = np.array(observables(v_in, v_out))
    jac = np.empty((f0.size, x.size))
    h = 1e-6 * max(float(np.linalg.norm(v_in)), float(np.linalg.norm(v_out)), 1e-12)
    for j in range(x.size):
        up, down = x.copy(), x.copy()
        up[j] += h
        down[j] -= h
        jac[:, j] = (np.array(observables(up[:d], up[d:]))
                     - np.array(observables(down[:d], down[d:]))) / (2 * h)
    return f0, jac
