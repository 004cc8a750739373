"""What the posterior predicts at the nominal incidence: trajectories (paper Fig. 6), force
realisations (Fig. 8) and the contact time (Fig. 9).

Bundles of curves are drawn as one ``LineCollection`` (one artist, not one per draw).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ._figure import new_figure, styled
from ._kde import kde_curve
from ._layout import place_panels
from ._limits import curve_limits, headroom, mark_beyond_x, mark_curves_beyond, robust_limits

if TYPE_CHECKING:
    from matplotlib.figure import Figure

MAX_CURVES = 100  # curves per bundle: beyond this the bundle looks the same


def _bundle(ax, xs: list[np.ndarray], ys: list[np.ndarray], color: str, label: str) -> None:
    from matplotlib.collections import LineCollection

    segments = [np.column_stack([x, y]) for x, y in zip(xs, ys, strict=True)]
    ax.add_collection(LineCollection(segments, colors=color, linewidths=0.6, alpha=0.3))
    ax.plot([], [], color=color, lw=1.2, label=label)  # the legend's line, opaque


def _curves(h: dict, key: str, scale: float, contact_only: bool = False) -> list[np.ndarray]:
    n = min(h[key].shape[0], MAX_CURVES)
    if contact_only:
        return [h[key][i][h["in_contact"][i]] * scale for i in range(n)]
    return [h[key][i] * scale for i in range(n)]


@styled
def plot_trajectories(prop, radius: float) -> Figure:
    """Fig. 6: centre-of-mass trajectories through the collision for posterior draws."""
    h = prop.histories
    mm = 1e3
    fig = new_figure(8, 4.2)
    ax = fig.subplots()
    xs, ys = _curves(h, "x", mm), _curves(h, "y", mm)
    _bundle(ax, xs, ys, "C0", f"posterior draws ({len(xs)})")
    ax.axhline(radius * mm, color="0.5", ls=":", lw=1, label="centre height at first touch")
    ax.axhline(0, color="k", lw=1.2, label="plane")
    xlim = curve_limits(xs, pad=0.02)
    ylim = curve_limits(ys, include=(0.0,), pad=0.05)
    mark_curves_beyond(ax, xs, ys, xlim, ylim, what="draws")
    ax.set_xlim(xlim)
    ax.set_ylim(ylim)
    ax.set_xlabel("x along the plane (mm)")
    ax.set_ylabel("y: height of the centre (mm)")
    ax.set_title(f"Trajectory of the centre of mass through the collision "
                 f"({len(xs)} draws, nominal incidence)")
    ax.legend(loc="lower right")
    place_panels(fig, [[ax]])
    return fig


@styled
def plot_forces(prop) -> Figure:
    """Fig. 8: realisations of the normal and friction force histories."""
    h = prop.histories
    fig = new_figure(10, 3.9)
    ts = _curves(h, "time", 1e3, contact_only=True)
    xlim = curve_limits(ts, include=(0.0,), pad=0.03)
    axes = fig.subplots(1, 2)
    for ax, key, color, title in zip(axes, ("normal_force", "friction_force"),
                                     ("C0", "C1"), ("a) normal force", "b) friction force"),
                                     strict=True):
        fs = _curves(h, key, 1.0, contact_only=True)
        _bundle(ax, ts, fs, color, f"posterior draws ({len(fs)})")
        ax.axhline(0, color="k", lw=0.8)
        ylim = curve_limits(fs, include=(0.0,), pad=0.06)
        mark_curves_beyond(ax, ts, fs, xlim, ylim, what="draws")
        ax.set_xlim(xlim)
        ax.set_ylim(ylim)
        ax.set_xlabel("time since first contact (ms)")
        ax.set_ylabel("force (N)")
        ax.set_title(title)
        # the forces are zero at the ends of the contact: a lower or upper middle is free
        peak_up = abs(ylim[1]) >= abs(ylim[0])
        ax.legend(loc="lower center" if peak_up else "upper center")
    fig.suptitle(f"Contact forces of {len(ts)} posterior draws (nominal incidence)")
    place_panels(fig, [axes])
    return fig


def _nothing_to_show(fig, ax, xlabel: str, ylabel: str, why: str) -> Figure:
    ax.text(0.5, 0.5, why, ha="center", va="center", transform=ax.transAxes, wrap=True)
    ax.plot([], [], ls="", label="no data")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.legend(loc="upper right")
    place_panels(fig, [[ax]])
    return fig


@styled
def plot_contact_time(prop) -> Figure:
    """Fig. 9: the PDF of the contact time, with its modes marked."""
    tc = prop.bounces.contact_time[prop.bounces.ok] * 1e3
    fig = new_figure(6.5, 3.9)
    ax = fig.subplots()
    if tc.size == 0:
        return _nothing_to_show(fig, ax, "contact time (ms)", "probability density (1/ms)",
                                "no propagated bounce separated: no contact time to show")
    view = robust_limits(tc, pad=0.15)
    inside = tc[(tc >= view[0]) & (tc <= view[1])]
    edges = np.histogram_bin_edges(inside, bins="auto")
    weight = 1.0 / (tc.size * np.diff(edges)[0])  # normalised by all draws
    counts, _, _ = ax.hist(inside, bins=edges.tolist(), weights=np.full(inside.size, weight),
                           color="C0", alpha=0.3, label=f"histogram ({tc.size} draws)")
    grid = np.linspace(*view, 400)
    f = kde_curve(tc, grid)
    if f is not None:
        ax.plot(grid, f, color="C0", lw=2, label="kernel density estimate")
    for i, m in enumerate(prop.contact_time_modes):
        ax.axvline(m * 1e3, color="C3", ls="--", lw=1, label="modes" if i == 0 else None)
    n_legend = 2 + (f is not None) + (mark_beyond_x(ax, tc, view, what="draws", unit="ms") > 0)
    ax.set_xlim(view)
    headroom(ax, max(float(np.max(counts, initial=0.0)),
                     0.0 if f is None else float(f.max())), n_legend)
    ax.set_xlabel("contact time (ms)")
    ax.set_ylabel("probability density (1/ms)")
    n = len(prop.contact_time_modes)
    shape = {1: "unimodal", 2: "bimodal"}.get(n, f"{n} modes")
    ax.set_title(f"PDF of the contact time at the nominal incidence ({shape})")
    ax.legend(loc="upper right")
    place_panels(fig, [[ax]])
    return fig
