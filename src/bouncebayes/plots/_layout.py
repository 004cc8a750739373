"""A fixed layout of a grid of panels, from the sizes of its texts estimated without drawing.

matplotlib's layout engines (``constrained``, ``tight``) measure every tick label by laying the
figure out, which took longer than drawing it (a third of the time of a run's figures). The
figures here are grids of panels whose texts are known: axis labels, titles, and tick labels
whose strings come from each axis' own locator and formatter. :func:`place_panels` estimates
their extents from the font size (DejaVu Sans digits and most letters are at most 0.64 em wide)
and sets the figure's margins and gaps once, before the figure is drawn.
"""

from __future__ import annotations

from typing import Any

import numpy as np

PT = 1.0 / 72.0  # inch
EM_PER_CHAR = 0.64  # widest digit of DejaVu Sans is 0.636 em
LINE = 1.25  # line height, em
TICK_ROOM = 9.0  # tick length (3.5 pt) + pad (3.5 pt) + 2 pt slack
LABEL_PAD = 5.0  # axis labelpad (4 pt) + 1 pt slack
EDGE = 0.08  # inch between text and the figure's edge


def _size(key: str) -> float:
    import matplotlib
    from matplotlib.font_manager import FontProperties

    params: Any = matplotlib.rcParams
    return FontProperties(size=params[key]).get_size_in_points()


def _lines(text: str) -> int:
    return text.count("\n") + 1 if text else 0


def tick_label_chars(axis) -> int:
    """Characters of the longest tick label ``axis`` will draw (from its locator and
    formatter at the current view limits; no drawing)."""
    lo, hi = sorted(axis.get_view_interval())
    slack = 1e-9 * (hi - lo)
    ticks = [t for t in axis.get_major_locator()() if lo - slack <= t <= hi + slack]
    if not ticks:
        return 0
    return max(len(s) for s in axis.get_major_formatter().format_ticks(ticks))


def y_room(ax) -> float:
    """Inches left of a panel for its y tick labels and y label."""
    params = ax.yaxis.get_tick_params()
    size = _size("ytick.labelsize")
    width = (EM_PER_CHAR * size * tick_label_chars(ax.yaxis) + TICK_ROOM
             if params.get("labelleft", True) else 4.0)
    label = ax.yaxis.label
    return (width + LABEL_PAD + LINE * label.get_fontsize() * _lines(label.get_text())) * PT


def x_room(ax) -> float:
    """Inches below a panel for its x tick labels and x label."""
    params = ax.xaxis.get_tick_params()
    height = (LINE * _size("xtick.labelsize") + TICK_ROOM
              if params.get("labelbottom", True) else 4.0)
    label = ax.xaxis.label
    return (height + LABEL_PAD + LINE * label.get_fontsize() * _lines(label.get_text())) * PT


def title_room(axes) -> float:
    """Inches above a row of panels for the tallest of their titles."""
    lines = max((_lines(ax.get_title(loc)) for ax in axes for loc in ("left", "center")),
                default=0)
    return (LINE * _size("axes.titlesize") * lines + 6.0 * (lines > 0)) * PT


def right_room(ax) -> float:
    """Inches right of a colorbar for its tick labels and label."""
    size = _size("ytick.labelsize")
    label = ax.yaxis.label
    return (EM_PER_CHAR * size * tick_label_chars(ax.yaxis) + TICK_ROOM + LABEL_PAD
            + LINE * label.get_fontsize() * _lines(label.get_text())) * PT


def place_panels(fig, panels, *, legend_rows: int = 0, right: float = 0.15,
                 left: float | None = None) -> None:
    """Set the margins and gaps of the grid ``panels`` (2-D array of axes, as
    ``Figure.subplots(squeeze=False)`` returns) from their texts: y labels and tick labels on
    the left, x labels below, titles above, the figure's suptitle, and ``legend_rows`` rows of
    a figure legend at the bottom. ``right`` and ``left`` (default: from the first column's
    texts): inches kept free at the edges."""
    panels = np.atleast_2d(np.asarray(panels, dtype=object))
    nrows, ncols = panels.shape
    width, height = fig.get_size_inches()
    left = (max(y_room(ax) for ax in panels[:, 0]) if left is None else left) + EDGE
    gap_x = max((y_room(ax) for ax in panels[:, 1:].ravel()), default=0.0) + 0.25
    rows = [title_room(panels[i]) for i in range(nrows)]
    below = [max(x_room(ax) for ax in panels[i]) for i in range(nrows)]
    gap_y = max((below[i] + rows[i + 1] for i in range(nrows - 1)), default=0.0) + 0.15
    suptitle = fig.get_suptitle()
    top = rows[0] + EDGE + (LINE * _size("figure.titlesize") + 4.0) * PT * _lines(suptitle)
    bottom = below[-1] + EDGE + legend_rows * LINE * _size("legend.fontsize") * PT * 1.45
    cell_w = (width - left - right - (ncols - 1) * gap_x) / ncols
    cell_h = (height - top - bottom - (nrows - 1) * gap_y) / nrows
    fig.subplots_adjust(left=left / width, right=1.0 - right / width, bottom=bottom / height,
                        top=1.0 - top / height, wspace=gap_x / cell_w, hspace=gap_y / cell_h)
