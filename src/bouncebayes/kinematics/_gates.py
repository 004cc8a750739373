"""The quality gates every fitted bounce must pass before it becomes a trial (thresholds in
:class:`FitConfig`). Each failing gate raises a :class:`TrajectoryError` with its reason."""

from __future__ import annotations

import math

import numpy as np
from scipy import special

from ._config import FitConfig
from . import _drag
from ._flight import Flight, trend_test
from ._observe import Observation
from ._read import Trajectory
from ._result import TrajectoryError

_EXACT = 1e-9  # m: residuals below this are round-off (exact data): nothing to test
_WHY_MISFIT = ("the flight is not free (contact samples, a second bounce, spin or drag the "
               "model lacks, or a tracking fault)")


def apply_gates(name: str, traj: Trajectory, pre: Flight, post: Flight, obs: Observation,
                t_ref: float, cfg: FitConfig, allowance: float) -> dict[str, float]:
    """Run every gate; return the statistics they tested.

    Raises:
        TrajectoryError: the first gate that fails, with its reason and threshold.
    """
    _directions(name, obs, t_ref)
    out = _residuals(name, pre, post, cfg)
    _standard_errors(name, obs, cfg)
    out["drag_bias_z"] = _drag_neglect(name, pre, post, obs, cfg)
    out["gap_z"] = _gap(name, traj, pre, post, obs, t_ref, cfg)
    out["energy_z"] = _energy(name, obs, cfg, allowance)
    return out


def _directions(name: str, obs: Observation, t_ref: float) -> None:
    vy_in, vy_out = obs.v_in[1], obs.v_out[1]
    if not (np.isfinite(obs.values).all() and vy_in < 0 < vy_out):
        raise TrajectoryError(name, f"at the fitted impact (t = {t_ref + obs.tau:.6g} s) the "
                                    f"normal velocity is {vy_in:.4g} m/s before and "
                                    f"{vy_out:.4g} m/s after; a bounce needs v_y < 0 before "
                                    "and > 0 after", reason="bad fit")


def _residuals(name: str, pre: Flight, post: Flight, cfg: FitConfig) -> dict[str, float]:
    """Residuals consistent with the noise: no smooth pattern in either flight, and equal
    levels in both (unknown noise: F test) or each consistent with the stated noise."""
    out: dict[str, float] = {}
    if cfg.position_noise is not None:
        _stated_noise(name, pre, post, cfg, out)
    for side, flight in (("before", pre), ("after", post)):
        p = trend_test(flight, cfg.position_noise)
        out[f"p_trend_{side}"] = p
        hint = (f" [{flight.note}]" if flight.note else "") + (
            "" if cfg.fit_drag else "; for a light ball try `drag = \"quadratic\"`")
        if p < cfg.p_min:
            raise TrajectoryError(name, f"the residuals {side} the impact hold a cubic trend "
                                        f"(score test p = {p:.2g} < {cfg.p_min:g}): "
                                        f"{_WHY_MISFIT}{hint}", reason="misfit")
        ratio, p = misfit_ratio(flight.residuals)
        out[f"misfit_{side}"] = ratio
        # residuals within the tracker's stated (correlated) error: their smooth pattern is
        # expected, and the trend test above, against that error's covariance, bounds it
        stated = flight.errors is not None and flight.s2 <= 2.0 * flight.errors.sd**2
        if ratio > cfg.max_misfit and p < cfg.p_min and not stated:
            raise TrajectoryError(name, f"the residuals {side} the impact follow a smooth "
                                        f"pattern: their variance is {ratio:.3g} times what "
                                        "their successive differences imply (white noise: 1; "
                                        f"limit {cfg.max_misfit:g}, p = {p:.2g}): {_WHY_MISFIT}"
                                        f"{hint}", reason="misfit")
    if cfg.position_noise is None and max(pre.s2, post.s2) > _EXACT**2:
        # the noise levels, each at least the tracker's stated SD where it is in the model
        s2_pre, s2_post = (fl.s2 if fl.errors is None else max(fl.s2, fl.errors.variance)
                           for fl in (pre, post))
        f = s2_pre / s2_post if s2_post > 0 else math.inf
        p = float(2 * min(special.fdtrc(pre.dof, post.dof, f),
                          special.fdtr(pre.dof, post.dof, f)))
        out["p_equal_noise"] = p
        if p < cfg.p_min and max(f, 1 / f) > cfg.max_noise_ratio**2:
            worse, other = ("before", "after") if f > 1 else ("after", "before")
            raise TrajectoryError(name, f"the residuals {worse} the impact are "
                                        f"{math.sqrt(max(f, 1 / f)):.3g} times (in SD) those "
                                        f"{other} (limit {cfg.max_noise_ratio:g}; F test of "
                                        f"equal noise, p = {p:.2g}): {_WHY_MISFIT}",
                                  reason="misfit")
    return out


def _stated_noise(name: str, pre: Flight, post: Flight, cfg: FitConfig,
                  out: dict[str, float]) -> None:
    """Each flight's chi-square against the stated position noise."""
    noise = float(cfg.position_noise or 0.0)
    for side, flight in (("before", pre), ("after", post)):
        chi2 = flight.rss / noise**2
        p = float(special.chdtrc(flight.dof, chi2))
        out[f"p_noise_{side}"] = p
        if p < cfg.p_min:
            raise TrajectoryError(name, f"the residuals {side} the impact are "
                                        f"{math.sqrt(chi2 / flight.dof):.3g} times the stated "
                                        f"noise {noise * 1e3:.3g} mm (chi-square p = {p:.2g} < "
                                        f"{cfg.p_min:g}): {_WHY_MISFIT}", reason="misfit")


def misfit_ratio(residuals: np.ndarray) -> tuple[float, float]:
    """Residual variance over half the variance of successive differences (von Neumann's
    ratio inverted: ~1 for white noise, larger for a smooth misfit) and the one-sided p-value
    of a ratio so large under white noise (normal approximation, var(eta) = 4 (n - 2) /
    ((n + 1)(n - 1)) per coordinate for eta = sum of squared differences / sum of squares)."""
    n, d = residuals.shape
    den = float(np.sum(residuals**2))
    if den <= n * d * _EXACT**2 or n < 3:
        return 1.0, 1.0
    eta = float(np.sum(np.diff(residuals, axis=0) ** 2)) / den
    sd = math.sqrt(4.0 * (n - 2) / ((n + 1) * (n - 1)) / d)
    return (2.0 / eta if eta > 0 else math.inf), float(special.ndtr(-(2.0 - eta) / sd))


def _standard_errors(name: str, obs: Observation, cfg: FitConfig) -> None:
    se = obs.se
    labels = ["incidence speed", "incidence angle", "rebound speed", "rebound angle",
              "lateral angle"]
    for i, value in enumerate(obs.values):
        is_speed = i in (0, 2)
        limit = cfg.max_speed_rel_se * value if is_speed else cfg.max_angle_se_deg
        if not (math.isfinite(se[i]) and se[i] <= limit):
            unit = "m/s" if is_speed else "deg"
            allowed = (f"{cfg.max_speed_rel_se:.0%} of the speed" if is_speed
                       else f"{cfg.max_angle_se_deg:g} deg")
            raise TrajectoryError(name, f"the {labels[i]} is {value:.4g} +- {se[i]:.3g} {unit}; "
                                        f"a standard error must be finite and at most "
                                        f"{allowed}: the flights do not determine it (too few "
                                        "or too noisy samples)", reason="implausible errors")


def _drag_neglect(name: str, pre: Flight, post: Flight, obs: Observation,
                  cfg: FitConfig) -> float:
    """Without a drag fit but with the ball's expected drag ``cfg.drag_k``: how far (in
    standard errors) ignoring that drag moves the observables. Each flight is recomputed as air
    drag would make it, from its fitted state and acceleration at the impact, and refitted
    with constant acceleration; the change of the velocities at the impact is the bias."""
    if cfg.fit_drag or cfg.drag_k is None:
        return 0.0
    bias = np.concatenate([_velocity_bias(f, obs.tau, cfg.drag_k) for f in (pre, post)])
    with np.errstate(all="ignore"):
        z = np.abs(obs.jac_velocity @ bias) / obs.se
    z = np.where(np.isfinite(z), z, 0.0)
    worst = int(np.argmax(z))
    if z[worst] > cfg.max_drag_bias:
        labels = ["incidence speed", "incidence angle", "rebound speed", "rebound angle",
                  "lateral angle"]
        raise TrajectoryError(name, f"air drag on this ball (k = {cfg.drag_k:.2g} /m expected) "
                                    f"moves the {labels[worst]} by {z[worst]:.3g} standard "
                                    f"errors over these flights (limit {cfg.max_drag_bias:g}) "
                                    "and the fit leaves it out: set `drag = \"quadratic\"` in "
                                    "[trajectories]", reason="misfit")
    return float(z[worst])


def _velocity_bias(flight: Flight, tau_i: float, k: float) -> np.ndarray:
    """Velocity at the impact that a constant-acceleration fit makes of this flight under air
    drag ``k``, minus the true one."""
    if flight.tau is None:
        return np.zeros(flight.d)
    r, v, a, *_ = flight.state(tau_i)
    taus = flight.tau - tau_i
    with np.errstate(all="ignore"):
        R = _drag.solve(np.r_[r, v, a, k], flight.d, taus, sensitivities=False)[0]
        X = np.column_stack([np.ones_like(taus), taus, taus * taus])
        coef, *_ = np.linalg.lstsq(X, R, rcond=None)
    bias = coef[1] - v
    return np.where(np.isfinite(bias), bias, 0.0)


def _gap(name: str, traj: Trajectory, pre: Flight, post: Flight, obs: Observation,
         t_ref: float, cfg: FitConfig) -> float:
    """The fitted impact between the last sample before and the first after (z beyond)."""
    low, high = float(traj.t[pre.index[-1]]), float(traj.t[post.index[0]])
    t_i = t_ref + obs.tau
    outside = max(low - t_i, t_i - high, 0.0)
    z = outside / obs.tau_se if obs.tau_se > 0 else (math.inf if outside > 0 else 0.0)
    if z > cfg.gap_sd:
        raise TrajectoryError(name, f"the fitted impact (t = {t_i:.6g} +- {obs.tau_se:.2g} s) "
                                    f"is not between the flights ({low:.6g}-{high:.6g} s, "
                                    f"tolerance {cfg.gap_sd:g} standard errors): the flights "
                                    "do not meet where the ball turned", reason="impact outside "
                                                                                "the gap")
    return z


def _energy(name: str, obs: Observation, cfg: FitConfig, allowance: float) -> float:
    """The z-score of ``v_out^2 - v_in^2 - allowance`` (its variance from the observables' covariance)."""
    v_in, v_out = obs.values[0], obs.values[2]
    excess = v_out**2 - v_in**2 - allowance
    g = np.zeros(obs.values.size)
    g[0], g[2] = -2 * v_in, 2 * v_out
    sd = math.sqrt(max(float(g @ obs.cov @ g), 0.0))
    z = excess / sd if sd > 0 else (math.inf if excess > 0 else -math.inf)
    if z > cfg.energy_gain_sd:
        spin = (f" plus the {math.sqrt(allowance):.3g} m/s the spin could add"
                if allowance > 0 else "")
        raise TrajectoryError(name, f"the rebound ({v_out:.4g} m/s) is faster than the "
                                    f"incidence ({v_in:.4g} m/s){spin} by {z:.3g} standard "
                                    f"errors (limit {cfg.energy_gain_sd:g}): a bounce does not "
                                    "gain energy; check the tracking of both flights",
                              reason="energy gain")
    return z
