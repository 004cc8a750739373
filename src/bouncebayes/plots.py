"""Figures. Every axis carries its unit; every figure is saved atomically as PNG or SVG."""

from __future__ import annotations

import os
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # headless: figures are files, never windows
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from matplotlib.patches import Circle  # noqa: E402

from ._io import write_with  # noqa: E402
from .model import BounceHistory  # noqa: E402

FIGURE_FORMATS = (".png", ".svg", ".pdf")
STYLE = {"figure.dpi": 110, "axes.grid": True, "grid.alpha": 0.3, "font.size": 10,
         "axes.titlesize": 11, "legend.fontsize": 9}


def save_figure(fig: Figure, path: str | os.PathLike) -> Path:
    """Save ``fig`` atomically; the format follows the suffix (.png, .svg or .pdf)."""
    suffix = Path(path).suffix.lower()
    if suffix not in FIGURE_FORMATS:
        raise ValueError(f"figure file {str(path)!r} must end in one of "
                         f"{', '.join(FIGURE_FORMATS)}; got {suffix or 'no suffix'!r}")
    out = write_with(path, lambda tmp: fig.savefig(tmp, format=suffix[1:], bbox_inches="tight"))
    plt.close(fig)
    return out


def plot_bounce(history: BounceHistory, *, title: str | None = None) -> Figure:
    """Trajectory of the centre near contact, and the contact force histories of one bounce."""
    with plt.rc_context(STYLE):
        fig, (ax_path, ax_force) = plt.subplots(1, 2, figsize=(11, 4.2),
                                                gridspec_kw={"width_ratios": [1.15, 1]})
        _trajectory_panel(ax_path, history)
        _force_panel(ax_force, history)
        if title:
            fig.suptitle(title)
        fig.tight_layout()
    return fig


def _trajectory_panel(ax, h: BounceHistory) -> None:
    mm = 1e3
    c = h.in_contact
    ax.plot(h.x[~c & (h.time < 0)] * mm, h.y[~c & (h.time < 0)] * mm, color="C0",
            label="free flight (incident)")
    ax.plot(h.x[c] * mm, h.y[c] * mm, color="C3", lw=2.2, label="in contact")
    ax.plot(h.x[~c & (h.time > 0)] * mm, h.y[~c & (h.time > 0)] * mm, color="C2",
            label="free flight (rebound)")
    first, last = np.argmax(c), len(c) - 1 - np.argmax(c[::-1])
    for i, style in ((first, "--"), (last, ":")):
        ax.add_patch(Circle((h.x[i] * mm, h.y[i] * mm), h.radius * mm, fill=False,
                            ls=style, color="0.4", lw=0.8))
    lo = min(h.x.min(), -h.radius) * mm
    hi = max(h.x.max(), h.radius) * mm
    ax.axhspan(-0.3 * h.radius * mm, 0, color="0.85", zorder=0)
    ax.axhline(0, color="k", lw=1.2, label="plane")
    ax.set_xlim(lo - h.radius * mm, hi + h.radius * mm)
    ax.set_ylim(-0.3 * h.radius * mm, max(h.y.max() + h.radius, 2.2 * h.radius) * mm)
    ax.set_aspect("equal")
    ax.set_xlabel("x along the plane (mm)")
    ax.set_ylabel("y: height of the centre (mm)")
    ax.set_title("Centre of mass (ball outline at first touch and separation)")
    ax.legend(loc="upper right")


def _force_panel(ax, h: BounceHistory) -> None:
    ms = 1e3
    c = h.in_contact
    t = h.time[c] * ms
    ax.plot(t, h.normal_force[c], color="C0", label="normal force $F_n$")
    ax.plot(t, h.friction_force[c], color="C1", label="friction force $F_t$")
    rolling = h.rolling[c]
    if rolling.any():
        ax.fill_between(t, 0, 1, where=rolling, transform=ax.get_xaxis_transform(),
                        color="C2", alpha=0.12, label="rolling (no slip)")
    ax.axhline(0, color="k", lw=0.8)
    b = h.bounce
    ax.set_xlabel("time since first contact (ms)")
    ax.set_ylabel("force (N)")
    ax.set_title(f"Contact forces (contact time {float(b.contact_time) * ms:.3f} ms)")
    ax.legend(loc="best")
