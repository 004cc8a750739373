"""Standardised residuals of the measured rebounds per trial, and their figure.

:class:`Residuals` is the figure's whole input (arrays of residuals per trial with the trials'
labels and incidence), so that any computation of residuals can be drawn.
:func:`posterior_residuals` computes them from a run: for a deterministic subset of posterior
draws, each trial's rebound is simulated at the trial's own incidence and the residual
``(observed - model) / sd`` is formed with the standard deviation of the measurement model
(the table's standard errors, or the inferred noise levels, plus the incidence uncertainty
pushed through the model by central differences); each trial's residual is the posterior median
over the draws. Without standard errors or noise levels the residuals are scaled by their own
robust spread and say so.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ._figure import new_figure, styled
from ._layout import place_panels
from ._limits import clip_points_y, robust_limits

if TYPE_CHECKING:
    from matplotlib.figure import Figure

N_DRAWS = 200  # posterior draws the residuals are computed at
NOISE = {"rebound_speed": "sigma_speed", "rebound_angle": "sigma_angle"}
INCIDENCE = ("incidence_speed", "incidence_angle", "incidence_spin")
STEPS = (1e-4, 1e-3, 1e-2)  # central-difference steps: relative speed, deg, rad/s
MAD_TO_SD = 0.6745
N_NAMED = 3  # trials named on the per-trial panel (the largest beyond 2)


@dataclass(frozen=True, eq=False)
class Residuals:
    """Standardised residuals ``(observed - model) / sd`` of one campaign, per trial.

    Arguments:
        speed: residuals of the rebound speed (dimensionless), one per trial.
        angle: residuals of the rebound angle (dimensionless).
        labels: the trials' names.
        incidence_speed: each trial's incidence speed, m/s.
        incidence_angle: each trial's incidence angle from the normal, deg.
        scale: what the residuals were divided by, in words (shown on the figure).
        incidence_measured: whether the incidence columns were measured per trial (otherwise
            they hold the nominal value and the panels against them say so).
    """

    speed: np.ndarray
    angle: np.ndarray
    labels: tuple[str, ...]
    incidence_speed: np.ndarray
    incidence_angle: np.ndarray
    scale: str = "their standard deviations"
    incidence_measured: bool = True

    def __post_init__(self) -> None:
        n = len(self.labels)
        for name in ("speed", "angle", "incidence_speed", "incidence_angle"):
            arr = np.asarray(getattr(self, name), dtype=float)
            if arr.shape != (n,):
                raise ValueError(f"Residuals.{name} must hold one value per trial ({n} "
                                 f"labels); got shape {arr.shape}")
            object.__setattr__(self, name, arr)


def posterior_residuals(result, *, n_draws: int = N_DRAWS) -> Residuals:
    """Per-trial standardised residuals of a run at its posterior (see the module's text)."""
    t = result.trials
    flat = result.draws.samples.reshape(-1, result.draws.samples.shape[-1])
    pick = np.unique(np.linspace(0, flat.shape[0] - 1, min(n_draws, flat.shape[0])).astype(int))
    draws = {name: flat[pick, i] for i, name in enumerate(result.names)}
    model = _simulate_trials(result, draws)
    sd = _measurement_sd(result, draws)
    observed = (np.asarray(t.rebound_speed), np.asarray(t.rebound_angle))
    if sd is None:
        scale = "their own robust spread (the table has no standard errors)"
        raw = [_median(obs - m, axis=0) for obs, m in zip(observed, model, strict=True)]
        res = [r / (_median(np.abs(r - _median(r))) / MAD_TO_SD or 1.0) for r in raw]
    else:
        scale = "the standard deviation of the measurement model"
        prop = _propagated_var(result, {k: np.median(v) for k, v in draws.items()})
        res = [_median((obs - m) / np.sqrt(s**2 + p), axis=0)
               for obs, m, s, p in zip(observed, model, sd, prop, strict=True)]
    return Residuals(res[0], res[1], tuple(t.labels), np.asarray(t.incidence_speed),
                     np.asarray(t.incidence_angle), scale,
                     {"incidence_speed", "incidence_angle"} <= set(t.measured))


def _median(x: np.ndarray, axis: int | None = None) -> np.ndarray:
    """Median over the finite values; NaN (no warning) where a trial's every draw failed."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # "All-NaN slice": NaN is the answer
        return np.nanmedian(x, axis=axis)


def _model_values(result, draws: dict) -> dict:
    """Model parameters at the draws: inferred ones from the draws, the others fixed."""
    e = result.experiment
    n = next(iter(draws.values())).size
    return {name: draws[name] if name in draws else np.full(n, e.fixed_value(name))
            for name in e.model_parameters}


def _simulate(result, theta: dict, speed, angle, spin):
    from ..model import SimulationWarning, simulate

    e = result.experiment
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SimulationWarning)  # failed bounces are NaN here
        values = {k: v for k, v in theta.items() if k != "spin"}
        b = simulate(e.ball, speed=speed, angle=angle, spin=spin, errors="flag", **values,
                     **e.model_options)
    ok = b.ok
    return np.where(ok, b.rebound_speed, np.nan), np.where(ok, b.rebound_angle, np.nan)


def _simulate_trials(result, draws: dict) -> tuple[np.ndarray, np.ndarray]:
    """Rebound speed and angle (draws, trials) at each trial's own incidence."""
    t = result.trials
    theta = {k: v[:, None] for k, v in _model_values(result, draws).items()}
    spin = theta["spin"] if "spin" in result.names else np.asarray(t.incidence_spin)[None, :]
    return _simulate(result, theta, np.asarray(t.incidence_speed)[None, :],
                     np.asarray(t.incidence_angle)[None, :], spin)


def _measurement_sd(result, draws: dict) -> tuple[np.ndarray, np.ndarray] | None:
    """The sd of the rebound measurement, (draws, trials) or (trials,): the inferred noise levels,
    else the table's standard errors; None when neither is available."""
    if all(name in draws for name in NOISE.values()):
        return draws[NOISE['rebound_speed']][:, None], draws[NOISE['rebound_angle']][:, None]
    se = [np.asarray(result.trials.se[c], dtype=float) for c in NOISE]
    if all(np.all(np.isfinite(s) & (s > 0)) for s in se):
        return se[0], se[1]
    return None


def _propagated_var(result, at: dict) -> tuple[np.ndarray, np.ndarray]:
    """Variance of the modelled rebound speed and angle per trial from the incidence's own
    uncertainty (the table's standard errors where measured, the experiment's bounce-to-bounce
    spread where not), linearised by central differences at the parameters ``at``."""
    t, inc = result.trials, result.experiment.incidence
    spread = dict(zip(INCIDENCE, (inc.speed_sd, inc.angle_sd, inc.spin_sd), strict=True))
    base = [np.asarray(t.column(c), dtype=float) for c in INCIDENCE]
    if "spin" in result.names:  # the inferred spin replaces the table's
        base[2] = np.full(t.n, float(at["spin"]))
    theta = _model_values(result, {k: np.atleast_1d(v) for k, v in at.items()})
    out = [np.zeros(t.n), np.zeros(t.n)]
    for k, column in enumerate(INCIDENCE):
        sd = (np.nan_to_num(np.asarray(t.se[column], dtype=float)) if column in t.measured
              else np.full(t.n, spread[column]))
        if (k == 2 and "spin" in result.names) or not np.any(sd > 0):
            continue
        step = STEPS[k] * (base[0] if k == 0 else 1.0)
        sides = []
        for sign in (1.0, -1.0):
            cond = [b.copy() for b in base]
            cond[k] = cond[k] + sign * step
            sides.append(_simulate(result, theta, *cond))
        for j in range(2):
            out[j] += (sd * (sides[0][j] - sides[1][j]) / (2 * step)) ** 2
    return np.nan_to_num(out[0]), np.nan_to_num(out[1])


ROWS = (("speed", "rebound speed"), ("angle", "rebound angle"))


@styled
def plot_residuals(res: Residuals) -> Figure:
    """Standardised residuals of rebound speed and angle per trial, and against the incidence
    angle and speed, with the ±2 and ±3 bands of a well-specified model."""
    fig = new_figure(13, 6.6)
    axes = fig.subplots(2, 3, sharey="row")
    n = len(res.labels)
    index = np.arange(1, n + 1)
    nominal = "" if res.incidence_measured else " (not measured: nominal value)"
    columns = ((index, "trial (order in the table)"),
               (res.incidence_angle, f"incidence angle (deg){nominal}"),
               (res.incidence_speed, f"incidence speed (m/s){nominal}"))
    for row, (attr, name) in zip(axes, ROWS, strict=True):
        r = getattr(res, attr)
        limits = robust_limits(r, include=(-3.6, 3.6), pad=0.04)
        for ax, (x, xlabel) in zip(row, columns, strict=True):
            _residual_panel(ax, x, r, limits)
            ax.set_xlabel(xlabel)
        row[0].set_ylabel(f"{name}: standardised\nresidual (dimensionless)")
        row[0].set_title(_row_summary(name, r), loc="left", fontsize=10)
        _name_worst(row[0], index, r, res.labels, limits)
    handles, labels = _legend_entries(axes)
    fig.legend(handles, labels, loc="lower center", ncols=len(labels), fontsize=9)
    fig.suptitle(f"Residuals (observed − model) / sd per trial, at the posterior (median over "
                 f"draws); divided by {res.scale}")
    place_panels(fig, axes, legend_rows=1)
    return fig


BANDS = ((3.0, "0.93", "within ±3 (99.7 % expected)"), (2.0, "0.82", "within ±2 (95 % expected)"))


def _residual_panel(ax, x, r, limits) -> None:
    from matplotlib.patches import Rectangle

    for k, color, label in BANDS:
        # a band across the panel, added as an artist: axhspan would also update the data
        # limits, through a path interpolated in 100 steps, which these fixed limits do not need
        ax.add_artist(Rectangle((0.0, -k), 1.0, 2.0 * k, transform=ax.get_yaxis_transform(),
                                color=color, zorder=0, label=label, lw=0))
    ax.axhline(0, color="k", lw=0.8)
    inside = (r >= limits[0]) & (r <= limits[1])
    ax.plot(x[inside], r[inside], "o", ms=4, color="C0", label="trials")
    clip_points_y(ax, x, r, limits, what="trials", unit="")
    ax.set_ylim(limits)


def _row_summary(name: str, r: np.ndarray) -> str:
    r = r[np.isfinite(r)]
    n = r.size
    rms = float(np.sqrt(np.mean(r**2))) if n else float("nan")
    over2, over3 = int(np.sum(np.abs(r) > 2)), int(np.sum(np.abs(r) > 3))
    return (f"{name}: rms {rms:.2f} (about 1 expected); {over2} of {n} beyond ±2 "
            f"({0.0455 * n:.1f} expected), {over3} beyond ±3 ({0.0027 * n:.1f} expected)")


def _name_worst(ax, index, r, labels, limits) -> None:
    """Label the trials with the largest residuals beyond ±2 (at most ``N_NAMED``), each label
    beside its point (on the side towards the middle), moved down a line while it would sit on
    the previous one."""
    order = np.argsort(-np.nan_to_num(np.abs(r), nan=-1.0))[:N_NAMED]
    placed: list[tuple[float, float]] = []  # (index, height in points) of earlier labels
    per_point = 72.0 * 2.2 / max(np.ptp(limits), 1e-12)  # points per unit (panel ~2.2 in)
    for i in sorted(int(k) for k in order if np.abs(r[k]) > 2):
        y = float(np.clip(r[i], *limits))
        dy = -4.0
        while any(abs(index[i] - px) < 0.15 * len(labels)
                  and abs(y * per_point + dy - py) < 9.0 for px, py in placed):
            dy -= 9.0
        placed.append((index[i], y * per_point + dy))
        right = index[i] > 0.6 * len(labels)  # near the right edge: label on the left
        ax.annotate(labels[i], (index[i], y), xytext=(-5 if right else 5, dy),
                    textcoords="offset points", fontsize=7, color="0.25", va="top",
                    ha="right" if right else "left")


def _legend_entries(axes):
    """The legend entries of every panel (the bands first), each label once."""
    from matplotlib.patches import Patch

    seen: dict = {label: Patch(color=color, lw=0) for _, color, label in BANDS}
    for ax in axes.flat:
        for h, label in zip(*ax.get_legend_handles_labels(), strict=True):
            seen.setdefault(label, h)
    return list(seen.values()), list(seen.keys())
