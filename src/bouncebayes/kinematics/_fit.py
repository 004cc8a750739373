"""Fitting the bounces of a trajectory: impact detection, free flights bounded by the
neighbouring impacts, crossing, delta-method errors, quality gates."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from scipy.signal import find_peaks

from ._config import FitConfig
from ._flight import Flight, correlated_errors, fit_drag, fit_quadratic, sample_outlier_p
from ._gates import apply_gates
from ._gravity import bounce_fall
from ._observe import Observation, observe
from ._read import Trajectory
from ._result import Kinematics, TrajectoryError

# A bounce is a local minimum of y that rises on both sides by more than this many noise
# standard deviations (noise estimated from second differences): a robust form of "dy/dt changes
# sign from - to +" that ignores the sign flips noise causes where |dy| per frame ~ noise.
PROMINENCE_IN_NOISE_SD = 12.0
_SPLIT_ITERATIONS = 5
MAX_EXTRA_GUARD = 2  # samples next to an impact that may be left out beyond `contact_guard`
SPLIT_POINTS = 10  # samples on each side whose parabolas place the impact for the split


@dataclass(frozen=True)
class _Split:
    """One bounce's two free flights (sample indices) and the crossing of their parabolas."""

    low: int  # lowest sample: the reference time of both flights
    before: np.ndarray
    after: np.ndarray
    tau: float  # crossing time from t[low]


def fit_kinematics(trajectory: Trajectory, *, config: FitConfig | None = None,
                   **options) -> Kinematics:
    """Incidence and rebound kinematics of the single bounce in ``trajectory``.

    As :func:`fit_bounces` for a trajectory holding exactly one bounce; ``options``
    (``min_points``, ``contact_guard``, ``drag``, ...) replace fields of ``config``
    (:class:`FitConfig`).

    Raises:
        TrajectoryError: "several bounces" (use :func:`fit_bounces`), or why the bounce failed.
        ValueError, TypeError: a bad option.
    """
    cfg = FitConfig.from_options(config, **options)
    lows = find_bounces(trajectory)
    if lows.size > 1:
        times = ", ".join(f"{trajectory.t[i]:.6g}" for i in lows)
        raise TrajectoryError(trajectory.source, f"found {lows.size} bounces (lowest points at "
                                                 f"t = {times} s); fit_bounces gives one trial "
                                                 "per bounce", reason="several bounces")
    (result,) = _fit_all(trajectory, lows, cfg, [0.0])
    if isinstance(result, TrajectoryError):
        raise result
    return result


def fit_bounces(trajectory: Trajectory, *, config: FitConfig | None = None,
                energy_allowance: float | Sequence[float] = 0.0,
                **options) -> tuple[Kinematics | TrajectoryError, ...]:
    """Incidence and rebound kinematics of every bounce in ``trajectory``, in time order.

    1. Impacts: every local minimum of ``y`` where ``dy/dt`` changes sign from - to + and ``y``
       rises by more than 12 noise standard deviations on both sides (noise from second
       differences, robustly). None: ``"no bounce"``.
    2. Free flights: the samples between the neighbouring impacts (the file's ends for the
       first and last), leaving out ``contact_guard`` samples next to each impact. Fewer than
       ``min_points`` on a side: ``"too few points"``. The splits are re-made at the fitted
       impact times until they no longer change.
    3. Each flight is fitted with constant acceleration, ``r(t) = r0 + v0 t + a t^2 / 2``, by
       ordinary least squares per coordinate (acceleration free: the camera may be tilted), or
       with ``drag = "quadratic"``, ``r'' = a - k |v| v`` (bounded least squares from the
       drag-free fit, ``0 <= k <= drag_k_max``; a flight that cannot tell ``k`` falls back to
       constant acceleration, said in ``notes``). Drag matters for light, large balls: ``k =
       rho C_d A / (2 m)`` is ~0.14 /m for a table-tennis ball (``k v^2`` ~ 3.5 m/s^2 at 5 m/s).
       What biases the constant-acceleration fit is the *change* of the drag along a flight,
       so it grows with its duration: for a table-tennis ball at 5 m/s filmed at 1 kHz with
       0.2 mm noise, the rebound speed is biased by ~0.7 standard errors with 0.05 s flights,
       ~4 with 0.1 s and ~30 with 0.2 s; the drag fit removes the bias at the price of ~2.5x
       larger errors (tests/test_kinematics.py, ``test_quadratic_drag_*``).
    4. Impact time ``t_i``: the crossing of the two fitted ``y(t)`` nearest the lowest sample.
       Incidence = velocity of the flight before at ``t_i``, rebound = flight after at ``t_i``;
       speed ``|v|``, angle ``atan2(v_x, |v_y|)``. If the incident ``v_x`` comes out negative
       (near head-on) both angles are mirrored and ``flipped_x`` toggled.
    5. Standard errors: the flights' parameter covariances (residual variance, or the stated
       ``position_noise``), plus the tracker's surface-angle uncertainty, propagated by the
       delta method (exact derivatives) to ``t_i``, the velocities, speeds and angles.
    6. Gates (thresholds in :class:`FitConfig`): residual levels consistent between the two
       flights (or with the stated noise) and free of smooth patterns; finite standard errors
       below 25 % of a speed and 10 deg; no energy gain beyond 3 standard errors (plus
       ``energy_allowance``, m^2/s^2, what spin could add to ``v_out^2``; one value or one
       per bounce); the impact between the flights.

    3-D (a ``z`` column): (x, z) span the plane; incidence and rebound are projected onto the
    plane of incidence, and ``lateral_angle`` reports the rebound's out-of-plane part.

    Returns one :class:`Kinematics` or :class:`TrajectoryError` per bounce; a bounce's error
    names ``<file>#<k>`` when the file holds several.

    Raises:
        TrajectoryError: "no bounce".
        ValueError, TypeError: a bad option.
    """
    cfg = FitConfig.from_options(config, **options)
    lows = find_bounces(trajectory)
    allowance = np.broadcast_to(np.asarray(energy_allowance, dtype=float), lows.shape)
    return _fit_all(trajectory, lows, cfg, list(allowance))


def _fit_all(traj: Trajectory, lows: np.ndarray, cfg: FitConfig,
             allowance: list[float]) -> tuple[Kinematics | TrajectoryError, ...]:
    splits = _split(traj, lows, cfg)
    out: list[Kinematics | TrajectoryError] = []
    for k, split in enumerate(splits):
        try:
            if isinstance(split, TrajectoryError):
                raise split
            out.append(_fit_bounce(traj, split, cfg, allowance[k], k, lows.size))
        except TrajectoryError as exc:
            out.append(exc)
    return tuple(out)


def bounce_name(traj: Trajectory, k: int, n: int) -> str:
    """``<source>`` for a single bounce, ``<source>#<k+1>`` for bounce ``k`` of several."""
    return traj.source if n == 1 else f"{traj.source}#{k + 1}"


def _noise_sd(y: np.ndarray) -> float:
    """Robust noise SD from second differences (white noise: var(d2) = 6 sigma^2)."""
    d2 = np.diff(y, 2)
    return float(1.4826 * np.median(np.abs(d2 - np.median(d2))) / math.sqrt(6.0))


def find_bounces(traj: Trajectory) -> np.ndarray:
    """Indices of the lowest samples of the clear bounces, in time order.

    Raises:
        TrajectoryError: "no bounce".
    """
    y, t = traj.y, traj.t
    threshold = max(PROMINENCE_IN_NOISE_SD * _noise_sd(y), 1e-6 * float(np.ptp(y)), 1e-12)
    peaks, _ = find_peaks(-y, prominence=threshold)
    if peaks.size == 0:
        low = int(np.argmin(y))
        where = ("the first sample" if low == 0 else "the last sample (does the file end at the "
                 "impact?)" if low == traj.n - 1 else f"at t = {t[low]:.6g} s, but it does not "
                 f"rise by more than {threshold * 1e3:.3g} mm on both sides")
        raise TrajectoryError(traj.source, "the normal position y has no clear minimum where "
                                           f"dy/dt changes sign from - to +; its lowest point is "
                                           f"{where}. Check that y points away from the plane "
                                           "(up) and that the file holds a whole bounce",
                              reason="no bounce")
    return peaks


def _split(traj: Trajectory, lows: np.ndarray, cfg: FitConfig) -> list[_Split | TrajectoryError]:
    """Free flights of every bounce, bounded by the neighbouring impacts; re-split at the
    fitted crossings until stable."""
    impacts = traj.t[lows].astype(float)
    splits: list[_Split | TrajectoryError] = []
    for _ in range(_SPLIT_ITERATIONS):
        new = [_split_one(traj, lows, impacts, k, cfg) for k in range(lows.size)]
        stable = len(new) == len(splits) and all(
            isinstance(a, _Split) and isinstance(b, _Split) and np.array_equal(a.before, b.before)
            and np.array_equal(a.after, b.after) or (isinstance(a, TrajectoryError)
                                                     and isinstance(b, TrajectoryError))
            for a, b in zip(new, splits, strict=True))
        splits = new
        if stable:
            break
        impacts = np.array([traj.t[s.low] + s.tau if isinstance(s, _Split) else impacts[k]
                            for k, s in enumerate(splits)])
    return splits


def _split_one(traj: Trajectory, lows: np.ndarray, impacts: np.ndarray, k: int,
               cfg: FitConfig) -> _Split | TrajectoryError:
    t, guard, n = traj.t, cfg.contact_guard, lows.size
    name = bounce_name(traj, k, n)
    prev = impacts[k - 1] if k > 0 else -np.inf
    nxt = impacts[k + 1] if k < n - 1 else np.inf
    before = _between(t, prev, impacts[k], guard if k > 0 else 0, guard)
    after = _between(t, impacts[k], nxt, guard, guard if k < n - 1 else 0)
    if cfg.window is not None:
        before = before[t[before] >= impacts[k] - cfg.window]
        after = after[t[after] <= impacts[k] + cfg.window]
    for side, idx in (("before", before), ("after", after)):
        if idx.size < cfg.min_points:
            return TrajectoryError(name, f"too few points {side} the impact (got {idx.size}, "
                                         f"need {cfg.min_points}) after leaving out "
                                         f"{guard} sample(s) next to it (`contact_guard`); "
                                         "record more of the flight or lower `min_points`",
                                   reason="too few points")
    t_ref, pos = float(t[lows[k]]), traj.positions()
    # parabolas through the samples next to the impact: a long flight bends under drag and
    # lift, and its whole-flight parabola would put the impact in the wrong place
    near = (before[-SPLIT_POINTS:], after[:SPLIT_POINTS])
    pre, post = (fit_quadratic(t[i] - t_ref, pos[i], i, None) for i in near)
    tau = _crossing(pre.params.reshape(-1, 3)[1], post.params.reshape(-1, 3)[1])
    if tau is None or not t[0] <= t_ref + tau <= t[-1]:
        return TrajectoryError(name, "the fitted y(t) before and after the impact do not cross "
                                     "within the record; is the bounce tracked on both sides?",
                               reason="no crossing")
    return _Split(int(lows[k]), before, after, tau)


def _between(t: np.ndarray, low: float, high: float, guard_low: int,
             guard_high: int) -> np.ndarray:
    idx = np.flatnonzero((t > low) & (t < high))
    return idx[guard_low: max(guard_low, idx.size - guard_high)]


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


def _fit_flights(traj: Trajectory, split: _Split, cfg: FitConfig) -> tuple[Flight, Flight]:
    t_ref = float(traj.t[split.low])
    return (_fit_side(traj, split.before, t_ref, cfg, True),
            _fit_side(traj, split.after, t_ref, cfg, False))


def _fit_side(traj: Trajectory, idx: np.ndarray, t_ref: float, cfg: FitConfig,
              before: bool) -> Flight:
    """One flight fitted with the configured model. A sample next to the impact that is off
    the flight (p below ``cfg.p_min``: in contact, or blurred by the impact) is left out and
    the flight refitted, up to ``MAX_EXTRA_GUARD`` samples, said in the flight's note."""
    dropped = 0
    while True:
        tau, pos = traj.t[idx] - t_ref, traj.positions()[idx]
        flight = fit_quadratic(tau, pos, idx, cfg.position_noise)
        if cfg.fit_drag:
            flight = fit_drag(tau, pos, flight, cfg.aero(), cfg.position_noise)
        end = -1 if before else 0
        if (dropped == MAX_EXTRA_GUARD or idx.size <= cfg.min_points
                or sample_outlier_p(flight, end % idx.size) >= cfg.p_min):
            break
        idx = idx[:-1] if before else idx[1:]
        dropped += 1
    if dropped:
        note = (f"{dropped} more sample(s) next to the impact left out (off the flight beyond "
                f"p = {cfg.p_min:g}: in contact?)")
        flight = replace(flight, note=note if flight.note is None else f"{flight.note}; {note}")
    if cfg.position_noise is None and traj.position_sd:
        flight = correlated_errors(flight, traj.position_sd, traj.sample_rate_hz)
    return flight


def _fit_bounce(traj: Trajectory, split: _Split, cfg: FitConfig, allowance: float, k: int,
                n: int) -> Kinematics:
    name = bounce_name(traj, k, n)
    pre, post = _fit_flights(traj, split, cfg)
    with np.errstate(all="ignore"):
        obs = observe(pre, post, split.tau, traj.surface_angle_sd_deg)
    if obs is None:
        raise TrajectoryError(name, "the fitted flights before and after the impact do not "
                                    "cross near the lowest sample", reason="no crossing")
    t_ref = float(traj.t[split.low])
    gates = apply_gates(name, traj, pre, post, obs, t_ref, cfg, allowance)
    notes = [*traj.notes, *(f"{side}: {f.note}" for side, f in (("flight before", pre),
                                                                ("flight after", post))
                            if f.note)]
    if traj.position_sd and pre.errors is not None and post.errors is not None:
        notes.append(f"positions: the tracker's stated centre SD ({traj.position_sd * 1e3:.3g} "
                     "mm per coordinate, correlated along the track) is in the standard errors "
                     "and the residual tests")
    return _kinematics(traj, obs, pre, post, t_ref, cfg, name, k, n, tuple(notes), gates)


def _kinematics(traj: Trajectory, obs: Observation, pre: Flight, post: Flight, t_ref: float,
                cfg: FitConfig, name: str, k: int, n: int, notes: tuple[str, ...],
                gates: dict[str, float]) -> Kinematics:
    three_d = traj.z is not None
    values, se = obs.values, obs.se
    mirror = -1.0 if (not three_d and values[1] < 0) else 1.0  # near head-on, see step 4

    def mirrored(a: tuple[float, ...]) -> tuple[float, ...]:
        return (mirror * a[0], *a[1:])

    rms = math.sqrt((pre.rss + post.rss) / (pre.residuals.size + post.residuals.size))
    return Kinematics(
        incidence_speed=float(values[0]), incidence_speed_se=float(se[0]),
        incidence_angle=float(mirror * values[1]), incidence_angle_se=float(se[1]),
        rebound_speed=float(values[2]), rebound_speed_se=float(se[2]),
        rebound_angle=float(mirror * values[3]), rebound_angle_se=float(se[3]),
        impact_time=t_ref + obs.tau, impact_time_se=obs.tau_se,
        n_before=int(pre.index.size), n_after=int(post.index.size), residual_rms=rms,
        acceleration_before=mirrored(pre.acceleration),
        acceleration_after=mirrored(post.acceleration),
        sample_rate_hz=traj.sample_rate_hz, source=traj.source,
        lateral_angle=float(values[4]) if three_d else None,
        lateral_angle_se=float(se[4]) if three_d else None,
        flipped_x=traj.flipped_x != (mirror < 0), drag="quadratic" if cfg.fit_drag else None,
        drag_coefficient=(_k(pre), _k(post)) if cfg.fit_drag else None,
        label=Path(name).name, bounce=k + 1, n_bounces=n, notes=notes, gates=gates,
        scale_rel_sd=traj.scale_rel_sd,
        impact_acceleration_before=_in_plane(obs.a_in, obs.v_in, mirror),
        impact_acceleration_after=_in_plane(obs.a_out, obs.v_in, mirror),
        fall=bounce_fall(pre, post, cfg.drag_k), calibration_source=traj.calibration_source)


def _in_plane(a: np.ndarray, v_in: np.ndarray, mirror: float) -> tuple[float, float]:
    """(along the incident direction in the plane, normal) components of ``a``."""
    if a.size == 2:
        return float(mirror * a[0]), float(a[1])
    h = math.hypot(v_in[0], v_in[2])
    ex, ez = (v_in[0] / h, v_in[2] / h) if h > 0 else (1.0, 0.0)
    return float(a[0] * ex + a[2] * ez), float(a[1])


def _k(flight: Flight) -> float:
    return flight.drag_k if flight.drag_k is not None else math.nan
