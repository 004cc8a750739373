"""Axis limits that a few wild values cannot stretch, and honest marks for what lies beyond.

The limits hold every value inside Tukey's outer fences (Tukey, *Exploratory Data Analysis*,
1977): quartiles minus and plus ``fence`` times the interquartile range. For normal data the
default fence of 3 lies 4.7 standard deviations from the median, so a normal sample is
practically never clipped, while one stray value (a failed fit at 80,000 m/s) cannot squash the
rest into a line. What falls outside is drawn at the edge of the axes with an arrowhead marker
and counted in the legend: clipped, never dropped.
"""

from __future__ import annotations

from typing import Any

import numpy as np

FENCE = 3.0
PAD = 0.05
CLIP_COLOR = "C3"


def finite(*arrays: Any) -> np.ndarray:
    """The finite values of several arrays, flattened into one."""
    x = np.concatenate([np.asarray(a, dtype=float).ravel() for a in arrays]) if arrays else \
        np.empty(0)
    return x[np.isfinite(x)]


def robust_limits(*arrays: Any, fence: float = FENCE, pad: float = PAD,
                  include: tuple[float, ...] = ()) -> tuple[float, float]:
    """(low, high) around the values inside the fences of the pooled arrays, widened to hold
    ``include`` and padded by ``pad`` of the width on each side.

    The fences are ``Q1 - fence IQR`` and ``Q3 + fence IQR``; with a zero interquartile range
    (half the values equal) nothing is clipped. Non-finite values are ignored; with no finite
    value the limits come from ``include`` alone, or are (0, 1).
    """
    x = finite(*arrays)
    if x.size:
        q1, q3 = np.percentile(x, [25.0, 75.0])
        iqr = q3 - q1
        inside = x[(x >= q1 - fence * iqr) & (x <= q3 + fence * iqr)] if iqr > 0 else x
        lo, hi = float(inside.min()), float(inside.max())
    elif include:
        lo, hi = float(min(include)), float(max(include))
    else:
        return 0.0, 1.0
    if include:
        lo, hi = min(lo, *include), max(hi, *include)
    width = hi - lo or abs(hi) * 0.1 or 1.0
    return lo - pad * width, hi + pad * width


def beyond_text(values: np.ndarray, what: str, unit: str) -> str:
    """``"2 bounces beyond the axis (7.1 to 8e+04 m/s)"`` (``what`` in the plural)."""
    n = values.size
    what = what[:-1] if n == 1 and what.endswith("s") else what
    unit = f" {unit}" if unit else ""
    where = (f"at {values[0]:.3g}{unit}" if n == 1 else
             f"{values.min():.3g} to {values.max():.3g}{unit}")
    return f"{n} {what} beyond the axis ({where})"


def mark_beyond_x(ax, x: Any, limits: tuple[float, float], *, what: str, unit: str,
                  y: float = 0.04) -> int:
    """Arrowheads at the left/right edge (``y`` in axes fraction) for values of ``x`` outside
    ``limits``, with one legend entry saying how many and where; returns the count."""
    x = finite(x)
    lo, hi = limits
    out = x[(x < lo) | (x > hi)]
    if out.size == 0:
        return 0
    trans = ax.get_xaxis_transform()
    label: str | None = beyond_text(np.sort(out), what, unit)
    for edge, marker, sel in ((lo, "<", out < lo), (hi, ">", out > hi)):
        if sel.any():
            ax.plot([edge], [y], ls="", marker=marker, ms=9, color=CLIP_COLOR,
                    transform=trans, clip_on=False, zorder=5, label=label)
            label = None  # one legend entry for both edges
    return int(out.size)


def clip_points_y(ax, x: Any, y: Any, limits: tuple[float, float], *, what: str,
                  unit: str, **style) -> int:
    """Scatter the points of ``y`` outside ``limits`` at the top/bottom edge with arrowheads
    pointing outwards, one legend entry for them; returns how many there were."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    lo, hi = limits
    out = (y < lo) | (y > hi)
    if not out.any():
        return 0
    label: str | None = beyond_text(np.sort(y[out]), what, unit)
    n = 0
    for edge, marker, sel in ((lo, "v", y < lo), (hi, "^", y > hi)):
        if sel.any():
            ax.plot(x[sel], np.full(sel.sum(), edge), ls="", marker=marker, ms=8,
                    color=CLIP_COLOR, clip_on=False, zorder=5, label=label, **style)
            label = None
            n += int(sel.sum())
    return n


def headroom(ax, top: float, n_legend: int) -> None:
    """Set y from 0 to above ``top`` so that a legend of ``n_legend`` lines in an upper corner
    sits above the curves instead of on them."""
    share = min(0.55, 0.06 + 0.075 * n_legend)  # of the axes height the legend takes
    ax.set_ylim(0.0, (top if top > 0 else 1.0) * 1.04 / (1.0 - share))


def curve_limits(curves: list[np.ndarray], *, include: tuple[float, ...] = (),
                 pad: float = PAD) -> tuple[float, float]:
    """Limits for many curves along one axis: robust over each curve's own extremes, so that a
    few curves far from the rest leave the axes instead of squashing the bundle."""
    lows = [float(np.nanmin(c)) for c in curves if np.isfinite(c).any()]
    highs = [float(np.nanmax(c)) for c in curves if np.isfinite(c).any()]
    return robust_limits(lows, highs, include=include, pad=pad)


def mark_curves_beyond(ax, xs: list[np.ndarray], ys: list[np.ndarray],
                       xlim: tuple[float, float], ylim: tuple[float, float], *,
                       what: str) -> int:
    """For every curve that leaves the box ``xlim`` x ``ylim``, a marker where its farthest
    point meets the edge; one legend entry with the count. Returns the count."""
    at = []
    for x, y in zip(xs, ys, strict=True):
        sx = np.maximum(xlim[0] - x, x - xlim[1]) / (xlim[1] - xlim[0])
        sy = np.maximum(ylim[0] - y, y - ylim[1]) / (ylim[1] - ylim[0])
        excess = np.nan_to_num(np.maximum(sx, sy), nan=-1.0)
        if excess.max(initial=-1.0) > 0:
            i = int(np.argmax(excess))
            at.append((np.clip(x[i], *xlim), np.clip(y[i], *ylim)))
    if at:
        px, py = np.array(at).T
        ax.plot(px, py, ls="", marker="X", ms=7, color=CLIP_COLOR, clip_on=False, zorder=5,
                label=f"{len(at)} {what if len(at) > 1 else what[:-1]} beyond the axes "
                      "(farthest point marked at the edge)")
    return len(at)
