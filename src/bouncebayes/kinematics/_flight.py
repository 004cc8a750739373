"""One free flight: constant acceleration (closed form) or quadratic drag (bounded least
squares started from it), with the parameter covariance and the state at any time.

Parameters, both at the flight's reference time ``tau = 0`` (the bounce's lowest sample):

- ``"quadratic"``: per coordinate ``(r0, v0, a/2)``, coordinate after coordinate;
- ``"drag"``: ``(r0 (d), v0 (d), a (d), k[, c])`` for ``r'' = a - k |v| v + |v| (c x v)``
  (``c``, the lift: 1 component in 2-D, 3 in 3-D, or none).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy import special
from scipy.optimize import least_squares

from . import _drag

# The drag fit needs this many samples: 3d + 1 parameters and enough residual degrees of
# freedom to estimate the noise and tell k from the constant acceleration.
DRAG_MIN_POINTS = 8
_BOUND_FRACTION = 1e-3  # k within this fraction of k_max from a bound: "at the bound"


@dataclass(frozen=True)
class ErrorModel:
    """Correlated position errors: per coordinate, the stated SD ``sd`` (m) correlated as
    ``phi^|frames apart|`` between the samples (``frames``: their frame numbers), plus white
    noise of variance ``white`` (``(d,)``, m^2). Coordinates are independent."""

    frames: np.ndarray
    phi: float
    sd: float
    white: np.ndarray

    @property
    def variance(self) -> float:
        """Mean marginal variance per coordinate (m^2)."""
        return self.sd**2 + float(np.mean(self.white))

    def apply(self, v: np.ndarray) -> np.ndarray:
        """``S @ v`` for ``v`` ``(n d, m)`` raveled sample by sample (``S`` the errors'
        covariance), in O(n): the AR(1) correlation as a forward and a backward recursion
        (``phi^|f_i - f_j|`` is the product of the steps between them), so that a long flight
        from a fast camera never builds the ``(n d)^2`` matrix."""
        n, d = self.frames.size, self.white.size
        x = v.reshape(n, d, -1)
        step = self.phi ** np.diff(self.frames)
        fwd, bwd = x.copy(), x.copy()
        for i in range(1, n):
            fwd[i] += step[i - 1] * fwd[i - 1]
        for i in range(n - 2, -1, -1):
            bwd[i] += step[i] * bwd[i + 1]
        out = self.sd**2 * (fwd + bwd - x) + self.white[None, :, None] * x
        return out.reshape(v.shape)


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
    lift: np.ndarray | None = None  #: the lift vector c (1/m; 2-D: its normal component)
    tau: np.ndarray | None = None  #: sample times from the reference time
    design: np.ndarray | None = None  #: d(residuals, raveled)/d(parameters); None: quadratic
    note: str | None = None  #: why a requested drag fit fell back to constant acceleration
    #: the position errors' model where the tracker stated a correlated centre error
    #: (:func:`correlated_errors`); None: white noise
    errors: ErrorModel | None = None

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

    def jacobian(self) -> np.ndarray | None:
        """d(residuals, raveled sample by sample)/d(fitted parameters)."""
        if self.design is not None or self.tau is None:
            return self.design
        n, d = self.residuals.shape
        X = np.column_stack([np.ones(n), self.tau, self.tau * self.tau])
        out = np.zeros((n, d, 3 * d))
        for c in range(d):
            out[:, c, 3 * c:3 * c + 3] = X
        return out.reshape(n * d, 3 * d)

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
            dr, dv = np.zeros((d, 3 * d)), np.zeros((d, 3 * d))
            for i in range(d):
                dr[i, 3 * i:3 * i + 3] = (1.0, tau, tau * tau)
                dv[i, 3 * i + 1:3 * i + 3] = (1.0, 2 * tau)
            return r, v, 2 * c[:, 2], dr, dv
        R, V, SR, SV = _drag.solve(self.params, d, np.array([tau]))
        a, k, c = self.params[2 * d:3 * d], self.params[3 * d], self.params[3 * d + 1:]
        speed = float(np.linalg.norm(V[0]))
        lift = np.zeros(d) if c.size == 0 else (np.cross(c, V[0]) if d == 3 else
                                               c[0] * np.array([-V[0][1], V[0][0]]))
        return R[0], V[0], a - k * speed * V[0] + speed * lift, SR[0], SV[0]


def fit_quadratic(tau: np.ndarray, pos: np.ndarray, index: np.ndarray,
                  noise: float | None) -> Flight:
    """OLS of each coordinate on ``(1, tau, tau^2)``; covariance ``s_c^2 (X^T X)^-1`` per
    coordinate with its own residual variance, or ``noise^2 (X^T X)^-1`` when known."""
    X = np.column_stack([np.ones_like(tau), tau, tau * tau])
    coef, *_ = np.linalg.lstsq(X, pos, rcond=None)
    xtx_inv = np.linalg.inv(X.T @ X)
    resid = pos - X @ coef
    dof = tau.size - 3
    s2 = np.sum(resid * resid, axis=0) / dof if noise is None else np.full(pos.shape[1],
                                                                             noise**2)
    return Flight(index=index, model="quadratic", params=coef.T.ravel(),
                  cov=block_diagonal(*(s * xtx_inv for s in s2)), residuals=resid,
                  dof=pos.size - coef.size, tau=tau)


@dataclass(frozen=True)
class Aero:
    """What is known of the aerodynamic coefficients before a flight is fitted (1/m).

    ``k_max`` bounds the drag coefficient ``k`` (``0 <= k <= k_max``) and each lift component
    (``|c_i| <= k_max``). ``k_mean``/``k_sd``: a normal prior on ``k`` (the ball's expected
    drag); None: none, the bounds only. ``lift_sd``: the normal prior's SD of each lift
    component (mean 0: the spin is not known)."""

    k_max: float
    k_mean: float | None = None
    k_sd: float | None = None
    lift_sd: float | None = None
    lift: bool = True

    def prior_sd(self, d: int, n_lift: int) -> np.ndarray:
        """Prior SD of (k, lift...) (inf: no prior)."""
        k_sd = self.k_sd if self.k_sd is not None else math.inf
        lift_sd = self.lift_sd if self.lift_sd is not None else 0.5 * self.k_max
        return np.r_[k_sd, np.full(n_lift, lift_sd)]

    def prior_mean(self, n_lift: int) -> np.ndarray:
        """Prior mean of (k, lift...)."""
        return np.r_[self.k_mean if self.k_mean is not None else 0.0, np.zeros(n_lift)]


def fit_drag(tau: np.ndarray, pos: np.ndarray, start: Flight, aero: Aero,
             noise: float | None) -> Flight:
    """Aerodynamic fit of one flight, or ``start`` (the drag-free fit) with the reason.

    Tries drag and lift, ``r'' = a - k |v| v + |v| (c x v)`` (``c`` normal to the plane in 2-D;
    in 3-D normal to the velocity at the impact, since a lift component along the velocity has
    no effect there and is not determined), then drag alone, then gives up. ``k`` and ``c`` are
    bounded (``aero.k_max``) and carry normal priors (``aero``: the lift's mean 0, since the
    spin is not known; the drag's the ball's expected value, where known), so that a short
    flight gets the uncertainty of what it cannot determine instead of a wild estimate. Each
    fit starts from the drag-free fit linearised in ``k`` and ``c`` (one Gauss-Newton step from
    ``k = c = 0``, a linear least-squares problem) and runs SciPy's trust-region reflective
    ``least_squares`` with the exact Jacobian; it is refused when the flight has fewer than 8
    samples, the fit fails, a coefficient ends on a bound, or (without a prior) the flight
    cannot tell the drag (its standard error exceeds ``k_max``).
    """
    if tau.size < DRAG_MIN_POINTS:
        return _fallback(start, f"too short for the drag fit ({tau.size} samples, need "
                                f"{DRAG_MIN_POINTS})")
    reasons: list[str] = []
    for with_lift in ((True, False) if aero.lift else (False,)):
        flight, reason = _fit_aero(tau, pos, start, aero, noise, with_lift)
        if flight is not None:
            return flight if not reasons else replace(
                flight, note=f"{reasons[0]}: fitted with drag only")
        reasons.append(reason)
    return _fallback(start, "; ".join(dict.fromkeys(reasons)))


def _lift_basis(start: Flight, with_lift: bool) -> np.ndarray:
    """Columns spanning the fitted lift vectors: none; (1) in 2-D; two unit vectors normal to
    the drag-free fit's velocity at ``tau = 0`` in 3-D."""
    d = start.d
    if not with_lift:
        return np.zeros((0 if d == 2 else 3, 0))
    if d == 2:
        return np.ones((1, 1))
    v = start.params.reshape(d, 3)[:, 1]
    e1 = np.cross(v, [0.0, 1.0, 0.0] if abs(v[1]) < 0.9 * np.linalg.norm(v) else [1.0, 0, 0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(v, e1)
    return np.column_stack([e1, e2 / np.linalg.norm(e2)])


@dataclass(frozen=True)
class _Problem:
    """One aerodynamic least-squares problem: parameters ``q`` (r0, v0, a, k, lift) map to
    the kernel's ``p = T q``; prior rows are scaled by ``scale`` (the noise SD)."""

    tau: np.ndarray
    pos: np.ndarray
    T: np.ndarray
    mean: np.ndarray
    sd: np.ndarray
    scale: float
    noise: float | None = None  # stated position noise, if any

    @property
    def d(self) -> int:
        return int(self.pos.shape[1])

    def prior_rows(self) -> np.ndarray:
        """The Jacobian of the prior residuals (rows for the parameters with a prior)."""
        n = self.T.shape[1]
        rows = np.zeros((self.sd.size, n))
        rows[:, 3 * self.d:] = np.diag(self.scale / self.sd)
        return rows[np.isfinite(self.sd)]

    def residuals(self, q: np.ndarray) -> np.ndarray:
        model = (_drag.solve(self.T @ q, self.d, self.tau)[0] - self.pos).ravel()
        prior = self.scale * (q[3 * self.d:] - self.mean) / self.sd
        return np.r_[model, prior[np.isfinite(self.sd)]]

    def jacobian(self, q: np.ndarray) -> np.ndarray:
        model = _drag.solve(self.T @ q, self.d, self.tau)[2].reshape(-1, self.T.shape[0])
        return np.vstack([model @ self.T, self.prior_rows()])


def _fit_aero(tau: np.ndarray, pos: np.ndarray, start: Flight, aero: Aero,
              noise: float | None, with_lift: bool) -> tuple[Flight | None, str]:
    """One aerodynamic model fitted, or None and why not."""
    d = pos.shape[1]
    basis = _lift_basis(start, with_lift)
    T = block_diagonal(np.eye(3 * d + 1), basis)
    n_lift = basis.shape[1]
    scale = noise if noise is not None else math.sqrt(max(start.s2, 1e-30))
    problem = _Problem(tau, pos, T, aero.prior_mean(n_lift), aero.prior_sd(d, n_lift), scale,
                       noise)
    low = np.r_[np.full(3 * d, -np.inf), 0.0, np.full(n_lift, -aero.k_max)]
    high = np.r_[np.full(3 * d, np.inf), aero.k_max, np.full(n_lift, aero.k_max)]
    q0, k_lin, k_se = _linearised_start(problem, start, aero.k_max)
    # decided before any iteration: a flight that slows far more than air drag can (the fit
    # would run to the bound), or one too short to tell (the common case)
    if k_lin - 3 * k_se > aero.k_max:
        return None, (f"the flight slows more than air drag can (k = {k_lin:.2g} +- "
                      f"{k_se:.2g} /m from a linearised fit; range 0-{aero.k_max:.2g} /m): the "
                      "drag fit would diverge; a tracking fault?")
    if k_se > aero.k_max and aero.k_sd is None:
        return None, (f"the flight is too short to tell the drag (k +- {k_se:.2g} /m from a "
                      f"linearised fit; range 0-{aero.k_max:.2g} /m)")
    res = None
    with np.errstate(all="ignore"):
        if not np.all(np.isfinite(problem.residuals(q0))):  # the linearised step overshot
            q0 = _linearised_start(problem, start, aero.k_max, step=False)[0]
        for _ in range(2):  # a second pass if the fit's own noise rescales the prior much
            try:
                res = least_squares(problem.residuals, q0, jac=problem.jacobian,
                                    bounds=(low, high), method="trf", x_scale="jac",
                                    max_nfev=50)
            except ValueError as exc:  # residuals not finite at the start: nothing to fit
                return None, f"the drag fit cannot start ({exc})"
            s = math.sqrt(float(np.sum(res.fun[:pos.size] ** 2)) / (pos.size - q0.size))
            if noise is not None or res.status <= 0 or abs(s / problem.scale - 1) < 0.3:
                break
            problem, q0 = replace(problem, scale=max(s, 1e-15)), np.clip(res.x, low, high)
    return _accept(start, problem, res, aero)


def _linearised_start(problem: _Problem, start: Flight, k_max: float,
                      step: bool = True) -> tuple[np.ndarray, float, float]:
    """(r0, v0, a, k, lift) of one Gauss-Newton step from the drag-free fit with no drag and
    no lift (the model is linear in r0, v0, a and, to first order, in k and the lift), kept
    strictly inside the bounds, and the estimate and standard error of k that linearisation
    gives from the data alone, without the prior (``step=False``: the drag-free fit itself,
    with a small k)."""
    d = start.d
    quad = start.params.reshape(d, 3)
    q = np.concatenate([quad[:, 0], quad[:, 1], 2 * quad[:, 2],
                        np.zeros(problem.T.shape[1] - 3 * d)])
    q[3 * d] = 0.05 * k_max
    if not step:
        return q, q[3 * d], 0.0
    with np.errstate(all="ignore"):
        jac = problem.jacobian(q)
        delta, *_ = np.linalg.lstsq(jac, -problem.residuals(q), rcond=None)
        # what the data alone say of k, to first order (no prior): the divergence check
        n = problem.pos.size
        alone, *_ = np.linalg.lstsq(jac[:n], -problem.residuals(q)[:n], rcond=None)
        cov = _covariance(jac[:n], problem.scale**2, np.full(problem.sd.size, np.inf))
    k_se = math.sqrt(cov[3 * d, 3 * d]) if cov is not None else math.inf
    k_alone = float(q[3 * d] + alone[3 * d]) if np.isfinite(alone[3 * d]) else math.nan
    q = q + np.where(np.isfinite(delta), delta, 0.0)
    q[3 * d] = min(max(q[3 * d], 0.05 * k_max), 0.95 * k_max)  # strictly inside the bounds
    q[3 * d + 1:] = np.clip(q[3 * d + 1:], -0.95 * k_max, 0.95 * k_max)
    return q, k_alone, k_se


def _accept(start: Flight, problem: _Problem, res, aero: Aero) -> tuple[Flight | None, str]:
    d, k_max = start.d, aero.k_max
    n_model = problem.pos.size
    what = "the drag and lift fit" if problem.T.shape[1] > 3 * d + 1 else "the drag fit"
    if res.status <= 0 or not (np.all(np.isfinite(res.x)) and np.all(np.isfinite(res.fun))):
        return None, f"{what} did not converge ({res.message})"
    k, c = float(res.x[3 * d]), res.x[3 * d + 1:]
    dof = n_model - res.x.size
    s2 = float(np.sum(res.fun[:n_model] ** 2)) / dof if problem.noise is None else \
        problem.noise**2
    cov = _covariance(res.jac[:n_model], s2, problem.sd)
    if cov is None:
        return None, f"{what}: the parameters are not determined (singular Jacobian)"
    se = np.sqrt(np.diag(cov)[3 * d:])
    if se[0] > k_max:
        return None, (f"the flight is too short to tell the drag (k = {k:.2g} +- "
                      f"{se[0]:.2g} /m; range 0-{k_max:.2g} /m)")
    if k >= (1 - _BOUND_FRACTION) * k_max:
        return None, (f"{what} ran to the upper bound k = {k_max:.2g} /m (the flight slows more "
                      "than air drag can; a tracking fault?)")
    if np.any(np.abs(c) >= (1 - _BOUND_FRACTION) * k_max):
        return None, f"{what} ran to the bound of the lift, {k_max:.2g} /m"
    if k <= _BOUND_FRACTION * k_max:
        return None, f"{what} found no drag (k = 0)"
    p = problem.T @ res.x
    return Flight(index=start.index, model="drag", params=p,
                  cov=problem.T @ cov @ problem.T.T, residuals=res.fun[:n_model].reshape(-1, d),
                  dof=dof, tau=problem.tau, design=res.jac[:n_model], drag_k=k,
                  drag_k_se=float(se[0]), lift=p[3 * d + 1:].copy() if c.size else None), ""


def _covariance(jac: np.ndarray, s2: float, prior_sd: np.ndarray) -> np.ndarray | None:
    """Laplace covariance ``(J^T J / s2 + prior precision)^-1`` with column scaling (r0, v0,
    a, k differ in units); None if singular."""
    n = jac.shape[1]
    precision = np.zeros(n)
    precision[n - prior_sd.size:] = np.where(np.isfinite(prior_sd), 1 / prior_sd**2, 0.0)
    info = jac.T @ jac / s2 + np.diag(precision)
    scale = np.sqrt(np.diag(info))
    if not np.all(np.isfinite(scale)) or np.any(scale == 0):
        return None
    scaled = info / np.outer(scale, scale)
    if not np.isfinite(scaled).all() or np.linalg.cond(scaled) > 1e14:
        return None
    return np.linalg.inv(scaled) / np.outer(scale, scale)


# Largest lag-one correlation of the position errors used: the tracked centres' residuals on
# the independent renderer's campaign (benchmarks/tracking_campaign.py) have 0.07-0.55; a
# misfit (a jump, samples in contact) raises it, and a larger value would hide the misfit.
PHI_MAX = 0.55


def correlated_errors(flight: Flight, sd: float, rate: float) -> Flight:
    """The flight's covariance where the positions carry a tracker's correlated error of
    stated SD ``sd`` (m per coordinate; sample rate ``rate``, Hz): that error correlated as
    ``phi^|frames apart|`` (``phi`` the residuals' lag-one autocorrelation, 0 to
    ``PHI_MAX``) plus white noise of what residual variance ``s_c^2`` it leaves,
    ``max(s_c^2 - sd^2, 0)`` per coordinate; and the least-squares estimate's
    covariance ``A S A^T`` (``A`` the least-squares map, ``S`` that error covariance; a
    "sandwich"). A tracker's centre errors follow the texture under the ball and the codec's
    blocks: a smooth bias over several frames, which white-noise standard errors understate
    (docs/tracking.md). Constant-acceleration flights only (a drag fit's priors are not a
    plain least-squares map): others are returned as they are."""
    J = flight.jacobian()
    e = flight.residuals
    n, d = e.shape
    den = float(np.sum(e * e))
    if flight.model != "quadratic" or J is None or flight.tau is None or n < 6 or den <= 0:
        return flight
    phi = min(max(float(np.sum(e[1:] * e[:-1])) / den, 0.0), PHI_MAX)
    # the residual variance beyond the stated SD is white noise: a misfit larger than the
    # tracker's error then still shows as a trend against it
    white = np.maximum(np.sum(e * e, axis=0) / (n - 3) - sd * sd, 0.0)
    errors = ErrorModel(np.rint(flight.tau * rate), phi, sd, white)
    a = np.linalg.pinv(J.T @ J) @ J.T
    return replace(flight, cov=a @ errors.apply(a.T), errors=errors)


def trend_test(flight: Flight, noise: float | None) -> float:
    """p-value of a cubic trend the flight's model lacks: a score test of one more term
    ``tau^3`` per coordinate, orthogonal to the model's own derivatives (an F test with the
    residual variance, a chi-square test with a stated noise). A smooth change of the
    acceleration along the flight (drag or lift the model lacks, or has wrong) shows first as
    such a term, and it is what biases the velocities at the impact."""
    J = flight.jacobian()
    if flight.tau is None or J is None:
        return 1.0
    n, d = flight.residuals.shape
    scale = float(np.max(np.abs(flight.tau))) or 1.0
    cube = np.zeros((n, d, d))
    for c in range(d):
        cube[:, c, c] = (flight.tau / scale) ** 3
    Z = cube.reshape(n * d, d)
    with np.errstate(all="ignore"):
        Zp = Z - J @ np.linalg.lstsq(J, Z, rcond=None)[0]
        e = flight.residuals.ravel()
        b, *_ = np.linalg.lstsq(Zp, e, rcond=None)
        explained = float(e @ (Zp @ b))
    rss = float(e @ e)
    dof = flight.dof - d
    if not (math.isfinite(explained) and dof > 0) or rss <= n * d * 1e-18:
        return 1.0
    if flight.errors is not None and noise is None:
        return _stated_error_trend_p(flight, J, Z)
    if noise is not None:
        return float(special.chdtrc(d, explained / noise**2))
    f = (explained / d) / (max(rss - explained, 1e-300) / dof)
    return float(special.fdtrc(d, dof, f))


END_SAMPLES = 3  # samples nearest the impact in the end term of the stated-error test


def _stated_error_trend_p(flight: Flight, J: np.ndarray, Z: np.ndarray) -> float:
    """:func:`trend_test` against the tracker's stated correlated error (``errors``): the
    score of the cubic term and of an offset of the ``END_SAMPLES`` samples nearest the impact
    (samples in contact, or blurred by it: a run of them is no outlier, and a correlated error
    would hide it from the cubic term alone), each orthogonal to the model, chi-square with
    their covariance under that error (``Zp^T S Zp``: ``Zp`` is orthogonal to the model, so the
    residuals' projection does not change it)."""
    assert flight.tau is not None and flight.errors is not None
    n, d = flight.residuals.shape
    end = np.zeros((n, d, d))
    near = np.argsort(np.abs(flight.tau))[:END_SAMPLES]
    for c in range(d):
        end[near, c, c] = 1.0
    Z = np.hstack([Z, end.reshape(n * d, d)])
    e = flight.residuals.ravel()
    with np.errstate(all="ignore"):
        Zp = Z - J @ np.linalg.lstsq(J, Z, rcond=None)[0]
        score = Zp.T @ e
        stat = float(score @ np.linalg.pinv(Zp.T @ flight.errors.apply(Zp)) @ score)
    return float(special.chdtrc(2 * d, stat)) if math.isfinite(stat) else 1.0


def sample_outlier_p(flight: Flight, i: int) -> float:
    """p-value of sample ``i`` (position in the flight) being this far off the fit of the
    others: its externally studentized residual, ``e_i^T (I - H_ii)^-1 e_i / d`` over the
    leave-one-out residual variance, F with ``(d, dof - d)`` degrees of freedom (``H``: the
    hat matrix of the model's derivatives)."""
    J = flight.jacobian()
    if J is None:
        return 1.0
    n, d = flight.residuals.shape
    e = flight.residuals[i]
    with np.errstate(all="ignore"):
        Ji = J[i * d:(i + 1) * d]
        h = Ji @ np.linalg.pinv(J.T @ J) @ Ji.T
        q = float(e @ np.linalg.solve(np.eye(d) - h, e))
    dof = flight.dof - d
    rest = flight.rss - q
    if not (math.isfinite(q) and dof > 0) or rest <= n * d * 1e-18:
        return 1.0
    return float(special.fdtrc(d, dof, (q / d) / (rest / dof)))


def block_diagonal(*blocks: np.ndarray) -> np.ndarray:
    """The block-diagonal matrix of 2-D ``blocks`` (SciPy's ``block_diag`` costs 0.5 ms a
    call, which the fit of one trajectory would pay dozens of times)."""
    rows = sum(b.shape[0] for b in blocks)
    cols = sum(b.shape[1] for b in blocks)
    out = np.zeros((rows, cols))
    r = c = 0
    for b in blocks:
        out[r:r + b.shape[0], c:c + b.shape[1]] = b
        r, c = r + b.shape[0], c + b.shape[1]
    return out


def _fallback(start: Flight, reason: str) -> Flight:
    return replace(start, note=f"{reason}: fitted without drag")
