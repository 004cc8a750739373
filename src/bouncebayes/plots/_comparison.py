"""The model comparison's figure: each candidate's posterior band of the rebound against the
incidence angle, with the measured trials."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ._figure import new_figure, styled
from ._layout import place_panels

if TYPE_CHECKING:
    from matplotlib.figure import Figure

PANELS = (("rebound_speed", "rebound speed (m/s)"), ("rebound_angle", "rebound angle (deg)"),
          ("tangential_restitution", "tangential restitution u' / u"))
STYLES = ("-", "--", "-.", ":")


def _measured(trials) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Each panel's measured values and their standard errors (u'/u: propagated from the
    rebound speed's and angle's, taken independent)."""
    s, g = np.asarray(trials.rebound_speed), np.radians(trials.rebound_angle)
    ss = np.nan_to_num(np.asarray(trials.se["rebound_speed"], dtype=float))
    sg = np.radians(np.nan_to_num(np.asarray(trials.se["rebound_angle"], dtype=float)))
    u = np.asarray(trials.incidence_speed) * np.sin(np.radians(trials.incidence_angle))
    with np.errstate(divide="ignore", invalid="ignore"):
        e_t = s * np.sin(g) / u
        se_t = np.hypot(np.sin(g) * ss, s * np.cos(g) * sg) / np.abs(u)
    return {"rebound_speed": (s, ss), "rebound_angle": (np.degrees(g), np.degrees(sg)),
            "tangential_restitution": (e_t, se_t)}


@styled
def plot_comparison(bands: dict, trials, verdicts: dict[str, str]) -> Figure:
    """Three panels against the incidence angle: rebound speed, rebound angle, tangential
    restitution; per model its median and 90 % posterior band (at the trials' median speed and
    spin), the trials with +-1 standard error. ``verdicts``: a short label per model."""
    fig = new_figure(8.5, 10.5)
    axes = fig.subplots(3, 1, squeeze=False, sharex=True)
    measured = _measured(trials)
    x = np.asarray(trials.incidence_angle, dtype=float)
    for ax, (key, label) in zip(axes[:, 0], PANELS, strict=True):
        for k, (name, m) in enumerate(bands["models"].items()):
            lo, mid, hi = m[key]
            color = f"C{k % 10}"
            ax.fill_between(bands["angles"], lo, hi, color=color, alpha=0.25, lw=0)
            ax.plot(bands["angles"], mid, color=color, ls=STYLES[k % len(STYLES)], lw=1.5,
                    label=f"{name}: {verdicts.get(name, '')}".rstrip(": "))
        y, se = measured[key]
        ax.errorbar(x, y, yerr=se, fmt="o", ms=4, color="k", ecolor="0.3", capsize=2, lw=1,
                    label=f"measured ({trials.n} trials, ±1 standard error)", zorder=5)
        ax.set_ylabel(label)
    axes[-1, 0].set_xlabel("incidence angle from the normal (deg)")
    axes[0, 0].legend(loc="best", fontsize=8)
    speed = f"{bands['speed']:.3g} m/s" + (" (median; the trials' speeds vary)"
                                           if bands["speed_varies"] else "")
    fig.suptitle(f"Candidate models against the data: median and 90 % posterior band at "
                 f"{speed},\nspin {bands['spin']:.3g} rad/s")
    place_panels(fig, axes)
    return fig
