"""DEM-ready quantities (derived.json): the posterior bands of the curves a DEM user sets."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ._figure import new_figure, styled
from ._layout import place_panels

if TYPE_CHECKING:
    from matplotlib.figure import Figure

#: (quantity, y label, scale of the values, where the data lie: "speeds" or "angles")
PANELS = (("normal_restitution", "normal restitution e = v'n / vn", 1.0, "speeds"),
          ("contact_time", "contact time (ms)", 1e3, "speeds"),
          ("tangential_restitution", "tangential restitution u' / u", 1.0, "angles"),
          ("rebound_spin", "rebound spin (rad/s)", 1.0, "angles"))


def _values(q: dict, key: str, scale: float) -> np.ndarray:
    return np.array([np.nan if v is None else v * scale for v in q[key]], dtype=float)


def _readable_y(ax, lo: np.ndarray, hi: np.ndarray) -> None:
    """Plain tick labels, and a visible range where the curve is flat (a restitution fixed by
    the experiment file is the same at every speed to 1e-12)."""
    ax.ticklabel_format(axis="y", useOffset=False)
    top, bottom = np.nanmax(hi), np.nanmin(lo)
    if np.isfinite(top) and top - bottom < 1e-3 * max(abs(top), 1e-12):
        middle = 0.5 * (top + bottom)
        half = 0.01 * max(abs(middle), 1e-12)
        ax.set_ylim(middle - half, middle + half)


@styled
def plot_derived(derived: dict) -> Figure:
    """Four panels: normal restitution and contact time against the impact speed (head-on),
    tangential restitution and rebound spin against the incidence angle (at the campaign's
    speed); the posterior median and 90 % band, with the range the data measured shaded."""
    fig = new_figure(10, 7.2)
    axes = fig.subplots(2, 2, squeeze=False)
    measured = {"speeds": derived.get("measured_normal_speeds_m_s",
                                      derived["measured_speeds_m_s"]),
                "angles": derived["measured_angles_deg"]}
    for ax, (name, label, scale, span) in zip(axes.ravel(), PANELS, strict=True):
        q = derived["quantities"][name]
        x = np.asarray(q["grid"], dtype=float)
        if name == "contact_time" and np.nanmax(_values(q, "q95", 1.0)) < 1e-3:
            label, scale = "contact time (µs)", 1e6  # a hard ball's microseconds
        lo, mid, hi = (_values(q, k, scale) for k in ("q05", "median", "q95"))
        lo_m, hi_m = measured[span]
        ax.axvspan(lo_m - 0.01 * (x[-1] - x[0]) if lo_m == hi_m else lo_m,
                   hi_m + 0.01 * (x[-1] - x[0]) if lo_m == hi_m else hi_m, color="0.85",
                   label="normal speeds measured" if span == "speeds" else "angles measured",
                   zorder=0)
        ax.fill_between(x, lo, hi, color="C0", alpha=0.3, lw=0, label="90 % posterior band")
        ax.plot(x, mid, color="C0", lw=1.5, label="posterior median")
        ax.set_xlabel("impact speed (m/s), head-on" if span == "speeds"
                      else f"incidence angle from the normal (deg), at "
                           f"{derived['reference_speed_m_s']:.3g} m/s")
        ax.set_ylabel(label)
        _readable_y(ax, lo, hi)
        if span == "speeds":
            from matplotlib.ticker import NullFormatter, ScalarFormatter

            ax.set_xscale("log")
            ax.set_xticks([t for t in (0.5, 1, 2, 5, 10, 20) if x[0] <= t <= x[-1]])
            ax.xaxis.set_major_formatter(ScalarFormatter())
            ax.xaxis.set_minor_formatter(NullFormatter())
        ax.legend(loc="best")
    fig.suptitle(f"DEM-ready quantities ({derived['normal_law']} normal law, tangential "
                 f"{derived['tangential']}; {derived['n_draws']} posterior draws; no spin, no "
                 f"gravity)")
    place_panels(fig, axes)
    return fig
