"""Fitting one bounce: impact detection, free-flight segments, crossing, delta-method errors."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Literal, get_args

import numpy as np
from scipy.linalg import block_diag
from scipy.signal import find_peaks

from .._validate import check_choice
from ._drag import _drag_model, _fit_drag
from ._read import Trajectory
from ._result import Kinematics, TrajectoryError, _observables, _Segment

Drag = Literal["none", "quadratic"]  # "none" (or None): constant acceleration
DRAG_MODELS: tuple[str, ...] = get_args(Drag)
# A bounce is a local minimum of y that rises on both sides by more than this many noise
# standard deviations (noise estimated from second differences): a robust form of "dy/dt changes
# sign from - to +" that ignores the sign flips noise causes where |dy| per frame ~ noise.
PROMINENCE_IN_NOISE_SD = 12.0


def fit_kinematics(trajectory: Trajectory, *, min_points: int = 5, contact_guard: int = 1,
                   drag: Drag | None = None) -> Kinematics:
    """Incidence and rebound kinematics of the single bounce in ``trajectory``.

    1. Impact detection: the bounce is the one local minimum of ``y`` where ``dy/dt`` changes sign
       from - to + and ``y`` rises by more than 12 noise standard deviations on both sides (noise
       from second differences, robustly); none -> ``"no bounce"``, more -> ``"several bounces"``.
    2. Free flight: the samples before and after the impact, leaving out the ``contact_guard``
       samples nearest the impact on each side (the ball may touch the plane for one or two
       frames at 1 kHz; use ``contact_guard >= ceil(contact time x rate / 2)``). Fewer than
       ``min_points`` on a side -> ``"too few points"``. The split is re-made at the fitted
       impact time until it no longer changes.
    3. Each segment is fitted with constant acceleration, ``r(t) = r0 + v0 t + a t^2 / 2``, by
       ordinary least squares per coordinate (acceleration free: the camera may be tilted).
       ``drag="quadratic"`` (default ``None`` or ``"none"``: no drag) fits
       ``r'' = a - k |v| v`` instead (``scipy.optimize.least_squares`` on an RK4 solution; one
       ``k`` and one noise level per segment). Drag matters for light, large balls:
       ``k = rho C_d A / (2 m)`` is ~0.14 /m for a table-tennis ball (``k v^2`` ~ 3.5 m/s^2 at
       5 m/s), ~0.01 /m for a tennis ball, ~1e-3 /m for a steel ball. What biases the
       constant-acceleration fit is the *change* of the drag along a segment, so it grows with
       the segment's duration: for a table-tennis ball at 5 m/s filmed at 1 kHz with 0.2 mm
       noise, the constant-acceleration rebound speed is biased by ~0.7 standard errors with
       0.05 s segments, ~4 with 0.1 s and ~30 with 0.2 s; the drag fit removes the bias at the
       price of ~2.5x larger errors (tests/test_kinematics.py, ``test_quadratic_drag_*``).
    4. Impact time ``t_i``: the crossing of the two fitted ``y(t)`` nearest the lowest sample.
       Incidence = velocity of the pre-impact fit at ``t_i``, rebound = post-impact fit at
       ``t_i``; speed ``|v|``, angle ``atan2(v_x, |v_y|)`` (incident ``v_y < 0``, rebound
       ``v_y > 0``). If the incident ``v_x`` comes out negative (near head-on, where the file's
       direction was ambiguous) both angles are mirrored and ``flipped_x`` toggled.
    5. Standard errors: coefficient covariance ``s^2 (X^T X)^-1`` per coordinate and segment
       (``s^2`` = residual variance, ``n - 3`` degrees of freedom; with drag ``s^2 (J^T J)^-1``),
       propagated by the delta method through the whole map coefficients -> (``t_i``, velocities,
       speed, angle), so the uncertainty of ``t_i`` is included. With few points the z-scores
       follow Student's t with ``n - 3`` degrees of freedom rather than a normal.

    3-D (a ``z`` column): (x, z) span the plane. The plane of incidence contains the normal and the
    fitted incident in-plane velocity; incidence and rebound are its projections onto that plane
    (the incident velocity lies in it), and ``lateral_angle`` reports the rebound's out-of-plane
    part.

    Raises:
        TrajectoryError: with ``reason`` "no bounce", "several bounces", "too few points",
            "no crossing" (the fitted parabolas do not cross near the impact) or "bad fit".
        ValueError, TypeError: bad ``min_points`` (an integer >= 4), ``contact_guard`` (>= 0) or
            ``drag``.
    """
    min_points, contact_guard, drag = _check_fit_options(min_points, contact_guard, drag)
    t, pos, src = trajectory.t, trajectory.positions(), trajectory.source
    low = _find_bounce(trajectory)
    t_ref = float(t[low])
    pre, post, tau_i = _split_and_fit(trajectory, low, t_ref, min_points, contact_guard)
    model: Callable[[np.ndarray], np.ndarray]
    if drag == "quadratic":
        pre = _fit_drag(src, t[pre.index] - t_ref, pos[pre.index], pre)
        post = _fit_drag(src, t[post.index] - t_ref, pos[post.index], post)
        model = _drag_model(pos.shape[1], pre.params.size, tau_i)
    else:
        model = _quadratic_model(pos.shape[1])
    theta = np.concatenate([pre.params, post.params])
    values, se = _delta_method(model, theta, block_diag(pre.cov, post.cov))
    _check_directions(src, values, t_ref)
    return _kinematics(trajectory, values, se, pre, post, t_ref, drag)


def _check_fit_options(min_points, contact_guard, drag) -> tuple[int, int, str | None]:
    _check_int("min_points", min_points, 4, "a quadratic fit needs >= 4 points for a residual "
                                            "variance")
    _check_int("contact_guard", contact_guard, 0, "samples left out on each side of the impact")
    if drag is not None:
        check_choice("drag", drag, DRAG_MODELS)
    return int(min_points), int(contact_guard), None if drag == "none" else drag


def _check_int(name: str, value, low: int, why: str) -> None:
    message = f"`{name}` must be an integer >= {low} ({why}); got {value!r}"
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise TypeError(message)
    if value < low:
        raise ValueError(message)


def _noise_sd(y: np.ndarray) -> float:
    """Robust noise SD from second differences (white noise: var(d2) = 6 sigma^2)."""
    d2 = np.diff(y, 2)
    return float(1.4826 * np.median(np.abs(d2 - np.median(d2))) / math.sqrt(6.0))


def _find_bounce(traj: Trajectory) -> int:
    """Index of the lowest sample of the single clear bounce."""
    y, t = traj.y, traj.t
    threshold = max(PROMINENCE_IN_NOISE_SD * _noise_sd(y), 1e-6 * float(np.ptp(y)), 1e-12)
    peaks, _ = find_peaks(-y, prominence=threshold)
    if peaks.size > 1:
        times = ", ".join(f"{t[i]:.6g}" for i in peaks)
        raise TrajectoryError(traj.source, f"found {peaks.size} bounces (lowest points at t = "
                                           f"{times} s); keep one bounce per file",
                              reason="several bounces")
    if peaks.size == 0:
        low = int(np.argmin(y))
        where = ("the first sample" if low == 0 else "the last sample (does the file end at the "
                 "impact?)" if low == traj.n - 1 else f"at t = {t[low]:.6g} s, but it does not "
                 f"rise by more than {threshold * 1e3:.3g} mm on both sides")
        raise TrajectoryError(traj.source, "the normal position y has no clear minimum where "
                                           f"dy/dt changes sign from - to +; its lowest point is "
                                           f"{where}. Check that y points away from the plane "
                                           "(up) and that the file holds one whole bounce",
                              reason="no bounce")
    return int(peaks[0])


def _split_and_fit(traj: Trajectory, low: int, t_ref: float, min_points: int, guard: int
                   ) -> tuple[_Segment, _Segment, float]:
    """Split into free-flight segments around the impact, refit until the split is stable."""
    t, pos = traj.t, traj.positions()
    t_split, last = t_ref, None
    for _ in range(5):
        before = np.flatnonzero(t < t_split)[: max(0, np.sum(t < t_split) - guard)]
        after = np.flatnonzero(t > t_split)[guard:]
        if last is not None and np.array_equal(before, last[0]) and np.array_equal(after,
                                                                                   last[1]):
            break
        for side, idx in (("before", before), ("after", after)):
            if idx.size < min_points:
                raise TrajectoryError(traj.source, f"too few points {side} the impact (got "
                                                   f"{idx.size}, need {min_points}) after leaving "
                                                   f"out {guard} sample(s) next to it "
                                                   "(`contact_guard`); record more of the flight "
                                                   "or lower `min_points`",
                                      reason="too few points")
        pre, post = (_fit_quadratic(t[i] - t_ref, pos[i], i) for i in (before, after))
        tau_i = _crossing(pre.params.reshape(-1, 3)[1], post.params.reshape(-1, 3)[1])
        if tau_i is None or not t[0] <= t_ref + tau_i <= t[-1]:
            raise TrajectoryError(traj.source, "the fitted y(t) before and after the impact do "
                                               "not cross within the record; is the bounce "
                                               "tracked on both sides?", reason="no crossing")
        t_split, last = t_ref + tau_i, (before, after)
    return pre, post, tau_i


def _fit_quadratic(tau: np.ndarray, pos: np.ndarray, index: np.ndarray) -> _Segment:
    """OLS of each coordinate on (1, tau, tau^2); params per coordinate: r0, v0, a/2."""
    X = np.column_stack([np.ones_like(tau), tau, tau * tau])
    coef, *_ = np.linalg.lstsq(X, pos, rcond=None)
    resid = pos - X @ coef
    rss = np.sum(resid * resid, axis=0)
    s2 = rss / (tau.size - 3)
    xtx_inv = np.linalg.inv(X.T @ X)
    cov = block_diag(*(s * xtx_inv for s in s2))
    return _Segment(index=index, params=coef.T.ravel(), cov=cov, rss=float(rss.sum()),
                    n_resid=resid.size, acceleration=tuple(float(a) for a in 2 * coef[2]))


def _crossing(p: np.ndarray, q: np.ndarray) -> float | None:
    """Root nearest 0 of (p - q)(tau) for coefficients (c0, c1, c2); None if they never cross."""
    c0, c1, c2 = p - q
    disc = c1 * c1 - 4.0 * c2 * c0
    if disc < 0:
        return None
    qq = -0.5 * (c1 + math.copysign(math.sqrt(disc), c1))
    if qq == 0.0:
        return None
    roots = [c0 / qq] + ([qq / c2] if c2 != 0.0 else [])
    return min(roots, key=abs)


def _quadratic_model(d: int) -> Callable[[np.ndarray], np.ndarray]:
    """theta (both segments' r0, v0, a/2 per coordinate) -> observables + [tau_i, vy_in, vy_out]."""
    def model(theta: np.ndarray) -> np.ndarray:
        pre, post = theta[: 3 * d].reshape(d, 3), theta[3 * d:].reshape(d, 3)
        tau = _crossing(pre[1], post[1])
        tau = math.nan if tau is None else tau
        v_in, v_out = pre[:, 1] + 2 * pre[:, 2] * tau, post[:, 1] + 2 * post[:, 2] * tau
        return np.array([*_observables(v_in, v_out), tau, v_in[1], v_out[1]])
    return model


def _delta_method(f: Callable[[np.ndarray], np.ndarray], theta: np.ndarray, cov: np.ndarray,
                  rel_step: float = 1e-4) -> tuple[np.ndarray, np.ndarray]:
    """f(theta) and its standard errors sqrt(diag(J cov J^T)), J by central differences with
    steps of ``rel_step`` standard deviations of each parameter."""
    f0 = f(theta)
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    jac = np.zeros((f0.size, theta.size))
    for j in np.flatnonzero(sd > 0):
        step = np.zeros_like(theta)
        step[j] = rel_step * sd[j]
        jac[:, j] = (f(theta + step) - f(theta - step)) / (2 * step[j])
    var = np.einsum("ij,jk,ik->i", jac, cov, jac)
    return f0, np.sqrt(np.clip(var, 0.0, None))


def _check_directions(source: str, values: np.ndarray, t_ref: float) -> None:
    tau, vy_in, vy_out = values[-3:]
    if not (np.isfinite(values).all() and vy_in < 0 < vy_out):
        raise TrajectoryError(source, f"at the fitted impact (t = {t_ref + tau:.6g} s) the normal "
                                      f"velocity is {vy_in:.4g} m/s before and {vy_out:.4g} m/s "
                                      "after; a bounce needs v_y < 0 before and > 0 after",
                              reason="bad fit")


def _kinematics(traj: Trajectory, values: np.ndarray, se: np.ndarray, pre: _Segment,
                post: _Segment, t_ref: float, drag: str | None) -> Kinematics:
    three_d = traj.z is not None
    mirror = -1.0 if (not three_d and values[1] < 0) else 1.0  # near head-on, see step 4

    def mirrored(a: tuple[float, ...]) -> tuple[float, ...]:
        return (mirror * a[0], *a[1:])

    rms = math.sqrt((pre.rss + post.rss) / (pre.n_resid + post.n_resid))
    return Kinematics(
        incidence_speed=float(values[0]), incidence_speed_se=float(se[0]),
        incidence_angle=float(mirror * values[1]), incidence_angle_se=float(se[1]),
        rebound_speed=float(values[2]), rebound_speed_se=float(se[2]),
        rebound_angle=float(mirror * values[3]), rebound_angle_se=float(se[3]),
        impact_time=t_ref + float(values[-3]), impact_time_se=float(se[-3]),
        n_before=int(pre.index.size), n_after=int(post.index.size), residual_rms=rms,
        acceleration_before=mirrored(pre.acceleration),
        acceleration_after=mirrored(post.acceleration),
        sample_rate_hz=traj.sample_rate_hz, source=traj.source,
        lateral_angle=float(values[4]) if three_d else None,
        lateral_angle_se=float(se[4]) if three_d else None,
        flipped_x=traj.flipped_x != (mirror < 0), drag=drag,
        drag_coefficient=(pre.drag_k, post.drag_k) if drag else None)
