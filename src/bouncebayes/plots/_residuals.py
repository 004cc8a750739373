"""Standardised residuals of the measured rebounds per trial, and their figure.

:class:`Residuals` is the figure's whole input (arrays of residuals per trial with the trials'
labels and incidence), so that any computation of residuals can be drawn.
:func:`posterior_residuals` takes them from a run's adequacy check
(``bouncebayes.inference.Adequacy``), which standardises each trial by the likelihood's own
covariance at the best-fitting posterior draw (measurement model) or by the posterior predictive
distribution (kde, consistent); ``docs/likelihoods.md`` §10.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ._figure import new_figure, styled
from ._layout import place_panels
from ._limits import clip_points_y, robust_limits

if TYPE_CHECKING:
    from matplotlib.figure import Figure

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


def posterior_residuals(result) -> Residuals | None:
    """The per-trial standardised residuals of a run's adequacy check (``result.adequacy``),
    or ``None`` for a result without one (a run folder written before the check existed)."""
    a = getattr(result, "adequacy", None)
    if a is None:
        return None
    t = result.trials
    return Residuals(a.residual_speed, a.residual_angle, tuple(t.labels),
                     np.asarray(t.incidence_speed), np.asarray(t.incidence_angle), a.basis,
                     {"incidence_speed", "incidence_angle"} <= set(t.measured))


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
    fig.suptitle(_wrapped(f"Standardised residuals (observed − model) / sd per trial; sd: "
                          f"{res.scale}"))
    place_panels(fig, axes, legend_rows=1)
    return fig


def _wrapped(text: str, width: int = 110) -> str:
    import textwrap

    return "\n".join(textwrap.wrap(text, width))


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
