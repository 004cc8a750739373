"""One simulated bounce: the path of the centre near contact and the contact forces."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ._figure import new_figure, styled
from ._layout import place_panels

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from ..model import BounceHistory


@styled
def plot_bounce(history: BounceHistory, *, title: str | None = None) -> Figure:
    """Trajectory of the centre near contact, and the contact force histories of one bounce."""
    fig = new_figure(11, 4.2)
    ax_path, ax_force = fig.subplots(1, 2, gridspec_kw={"width_ratios": [1.15, 1]})
    _trajectory_panel(ax_path, history)
    _force_panel(ax_force, history)
    if title:
        fig.suptitle(title)
    place_panels(fig, [[ax_path, ax_force]])
    return fig


def _trajectory_panel(ax, h: BounceHistory) -> None:
    from matplotlib.patches import Circle

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
