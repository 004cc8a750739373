"""The measured rebounds (paper Fig. 3) and what the posterior predicts of them (Fig. 7).

Both figures draw the same density of the measured rebounds: the
:class:`~bouncebayes.density.ReboundDensity` the ``kde`` likelihood evaluates (normal-reference
bandwidth; for a joint KDE its exact marginals).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ._figure import new_figure, styled
from ._kde import kde_curve
from ._layout import place_panels
from ._limits import headroom, mark_beyond_x, robust_limits

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from ..density import KDE1D, ReboundDensity

VARIABLES = (("speed", "rebound speed", "m/s"), ("angle", "rebound angle", "deg"))
N_GRID = 400
PREDICTIVE_REACH = 2.0  # the predictive figure shows at most this many data widths beyond


def _kde_label(density: ReboundDensity, kde: KDE1D, unit: str) -> str:
    what = "marginal of the joint KDE" if density.kind == "joint" else "KDE"
    return f"{what}, {kde.rule} bandwidth {kde.bandwidth:.3g} {unit}"


@styled
def plot_data(density: ReboundDensity) -> Figure:
    """Fig. 3: histograms of the measured rebound speed and angle with the density the
    likelihood uses (:func:`bouncebayes.density.rebound_density`)."""
    fig = new_figure(10, 3.9)
    axes = fig.subplots(1, 2)
    for ax, (attr, label, unit) in zip(axes, VARIABLES, strict=True):
        kde = getattr(density, attr)
        x = kde.data
        view = robust_limits(x, pad=0.15)
        inside = x[(x >= view[0]) & (x <= view[1])]
        edges = np.histogram_bin_edges(inside, bins="auto")
        # normalised by all bounces, so that bounces beyond the axis do not inflate the rest
        ax.hist(inside, bins=edges, weights=np.full(inside.size, 1.0 / (x.size * np.diff(
            edges)[0])), color="C0", alpha=0.35, edgecolor="C0",
            label=f"histogram ({x.size} bounces)")
        grid = np.linspace(*view, N_GRID)
        pdf = kde.pdf(grid)
        ax.plot(grid, pdf, color="C3", lw=2, label=_kde_label(density, kde, unit))
        ax.plot(inside, np.zeros_like(inside), "|", color="k", ms=10, label="bounces")
        n_out = mark_beyond_x(ax, x, view, what="bounces", unit=unit)
        ax.set_xlim(view)
        counts = np.histogram(inside, edges)[0] / (x.size * np.diff(edges)[0])
        headroom(ax, max(pdf.max(), counts.max()), 3 + (n_out > 0))
        ax.set_xlabel(f"{label} ({unit})")
        ax.set_ylabel(f"probability density (1/{unit})")
        ax.legend(loc="upper left")
    c = density.correlation
    fig.suptitle(f"Measured rebounds (Pearson r = {c.r:.2f}, p = {c.p_value:.2g}; "
                 f"density: {density.kind})")
    place_panels(fig, [axes])
    return fig


def predictive_view(obs: np.ndarray, pred: np.ndarray) -> tuple[float, float]:
    """x-limits of a predicted-against-measured panel: the bulk of both samples, but never more
    than ``PREDICTIVE_REACH`` widths of the data beyond the data (a predictive distribution
    thousands of times wider than the data is shown as such by the share of it beyond the axis,
    not by squashing the data into a line)."""
    o_lo, o_hi = robust_limits(obs, pad=0.0)
    p_lo, p_hi = robust_limits(pred, pad=0.0, include=(o_lo, o_hi))
    w = o_hi - o_lo or abs(o_hi) * 0.1 or 1.0
    lo, hi = max(p_lo, o_lo - PREDICTIVE_REACH * w), min(p_hi, o_hi + PREDICTIVE_REACH * w)
    return lo - 0.1 * (hi - lo), hi + 0.1 * (hi - lo)


@styled
def plot_predictive(prop, density: ReboundDensity) -> Figure:
    """Fig. 7: predicted (posterior predictive) and measured densities of the rebound; the
    measured one is the likelihood's density, the same curve as in :func:`plot_data`."""
    fig = new_figure(10, 3.9)
    preds = (prop.predicted_speed, prop.predicted_angle)
    axes = fig.subplots(1, 2)
    for ax, (attr, label, unit), pred in zip(axes, VARIABLES, preds, strict=True):
        kde = getattr(density, attr)
        pred = np.asarray(pred, dtype=float)
        view = predictive_view(kde.data, pred)
        grid = np.linspace(*view, N_GRID)
        fp, fo = kde_curve(pred, grid), kde.pdf(grid)
        if fp is not None:
            ax.plot(grid, fp, color="C0", lw=2,
                    label=f"model (posterior predictive, {pred.size} draws)")
        ax.plot(grid, fo, "k--", lw=2, label=f"experiment ({_kde_label(density, kde, unit)})")
        marked = (mark_beyond_x(ax, kde.data, view, what="bounces", unit=unit) > 0) + (
            mark_beyond_x(ax, pred, view, what="predicted draws", unit=unit, y=0.1) > 0)
        ax.set_xlim(view)
        headroom(ax, max(fo.max(), 0.0 if fp is None else fp.max()), 2 + marked)
        m = prop.match.get(f"rebound_{attr}", {})
        if m.get("ks_statistic") is not None:
            ax.set_title(f"KS D = {m['ks_statistic']:.2f}, p = {m['ks_p_value']:.2g}; "
                         f"Hellinger {m['hellinger']:.2f}", fontsize=9)
        ax.set_xlabel(f"{label} ({unit})")
        ax.set_ylabel(f"probability density (1/{unit})")
        ax.legend(loc="upper left", fontsize=8)
    fig.suptitle("Reconstruction of the measured rebounds")
    place_panels(fig, [axes])
    return fig


def measured_density(result) -> ReboundDensity:
    """The density of a run's measured rebounds that its ``kde`` likelihood uses (the kind and
    bandwidths recorded in the run's likelihood details; the likelihood's defaults otherwise:
    ``kind="auto"``, MATLAB's normal-reference bandwidth)."""
    from ..density import rebound_density

    info = result.likelihood_info or {}
    details = info.get("density") or info.get("observed_density") or {}
    kind = details.get("kind", "auto")
    bandwidth = details.get("bandwidth_rule", "normal-reference")
    if bandwidth == "user":
        bandwidth = (details["bandwidth_speed_m_s"], details["bandwidth_angle_deg"])
    t = result.trials
    return rebound_density(t.rebound_speed, t.rebound_angle, kind=kind, bandwidth=bandwidth)
