"""Figure objects without pyplot, the shared style, and atomic saving.

Figures are ``matplotlib.figure.Figure`` instances drawn by the Agg renderer: no pyplot state,
no backend selection, nothing registered globally, so nothing has to be closed and importing
this package does not import matplotlib. Panels are placed once, before drawing, from their
texts (:mod:`._layout`): no layout engine, no ``bbox_inches="tight"``, each of which costs a
pass over the figure; a figure is drawn once per file it is saved to.
"""

from __future__ import annotations

import functools
import os
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal, TypeVar, cast

import numpy as np

from .._io import write_with

if TYPE_CHECKING:
    from matplotlib.figure import Figure

FIGURE_FORMATS = (".png", ".svg", ".pdf")
# Unhinted glyphs: text is about half of a figure's drawing time, and FreeType's hinting
# doubles it, for no difference the eye sees at this resolution. Titles at a fixed height
# (axes.titley): placed automatically, each title measures the panel's tick labels at every
# draw, to dodge tick labels on top, which these figures never have.
STYLE: dict[str, Any] = {"figure.dpi": 110, "axes.grid": True, "grid.alpha": 0.3,
                         "font.size": 10, "axes.titlesize": 11, "axes.titley": 1.0,
                         "legend.fontsize": 9, "savefig.dpi": "figure",
                         "text.hinting": "no_hinting"}

LAYOUT: Literal["constrained", "tight"] | None = None  # layout engine of new figures (benchmarks compare)
F = TypeVar("F", bound=Callable[..., Any])


def styled(draw: F) -> F:
    """Run a figure-making function inside the package's matplotlib style (rc parameters are
    read when artists are created, so the whole drawing happens inside the context)."""

    @functools.wraps(draw)
    def wrapper(*args, **kwargs):
        import matplotlib

        with matplotlib.rc_context(cast(Any, STYLE)):
            return draw(*args, **kwargs)

    return wrapper  # type: ignore[return-value]


def new_figure(width: float, height: float) -> Figure:
    """An empty figure (inches), detached from pyplot; its panels are placed by
    :func:`~bouncebayes.plots._layout.place_panels`."""
    from matplotlib.figure import Figure

    return Figure(figsize=(width, height), layout=LAYOUT)


def check_suffix(path: str | os.PathLike) -> str:
    """The format of a figure file from its suffix (``"png"``, ``"svg"`` or ``"pdf"``)."""
    suffix = Path(path).suffix.lower()
    if suffix not in FIGURE_FORMATS:
        raise ValueError(f"figure file {str(path)!r} must end in one of "
                         f"{', '.join(FIGURE_FORMATS)}; got {suffix or 'no suffix'!r}")
    return suffix[1:]


def fix_layout(fig: Figure) -> None:
    """Run the figure's layout engine once and keep its result.

    Saving a figure that still has a layout engine costs an extra pass (matplotlib draws it once
    without rendering to lay it out, then again to render); with the layout fixed, every saved
    format of the figure is rendered in one pass, from the same layout.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.layout_engine import PlaceHolderLayoutEngine

    engine = fig.get_layout_engine()
    if engine is None or isinstance(engine, PlaceHolderLayoutEngine):
        return  # no engine, or one whose layout was fixed already
    if not isinstance(fig.canvas, FigureCanvasAgg):
        FigureCanvasAgg(fig)
    with np.errstate(over="ignore", invalid="ignore"):
        engine.execute(fig)
    fig.set_layout_engine(None)  # None, not "none": a placeholder engine still costs a pass


def save_figure(fig: Figure, path: str | os.PathLike) -> Path:
    """Save ``fig`` atomically; the format follows the suffix (.png, .svg or .pdf)."""
    import matplotlib

    fmt = check_suffix(path)
    # the style holds for drawing too (some rc parameters are read when the figure is drawn);
    # mplot3d's projection can overflow in float arithmetic for a very narrow posterior far
    # from the origin (axes 1e-4 wide at 5.0): harmless to the image, so not a warning
    with matplotlib.rc_context(cast(Any, STYLE)), np.errstate(over="ignore", invalid="ignore"):
        fix_layout(fig)
        # zlib level 3: a third faster than the default 6, and as small for these images
        extra: dict[str, Any] = {"pil_kwargs": {"compress_level": 3}} if fmt == "png" else {}
        return write_with(path, lambda tmp: fig.savefig(tmp, format=fmt, **extra))


def save_figures(files: list[tuple[Figure, list[Path]]], workers: int | None = None) -> None:
    """Save each figure to each of its paths (:func:`save_figure`), rendering in ``workers``
    processes (default: the environment variable ``BOUNCEBAYES_FIGURE_WORKERS``, else one per
    idle core, up to four; 1: in this process).

    Rendering (text layout, rasterising, encoding) is most of a figure's cost and involves
    only matplotlib, so the figures, drawn here, are rendered by forked copies of this process
    (Linux only: elsewhere fork is unsafe or missing) as well as by this one, each taking its
    share (the figures with most panels first, to the least loaded). The files are the same
    bytes either way. A copy that fails leaves its figures to this process, which renders them
    again and raises what goes wrong. With other (non-daemon) Python threads running,
    everything is rendered here.
    """
    from .._background import can_fork, fork_call

    if workers is None:
        workers = _default_workers()
    workers = max(1, min(workers, len(files)))
    if workers == 1 or not can_fork():
        _save_all(files)
        return
    shares: list[list[tuple[Figure, list[Path]]]] = [[] for _ in range(workers)]
    load = [0] * workers
    for job in sorted(files, key=lambda job: -len(job[0].axes)):
        k = load.index(min(load))
        shares[k].append(job)
        load[k] += len(job[0].axes) + 1
    children = [fork_call(functools.partial(_save_all, share)) for share in shares[1:]]
    _save_all(shares[0])
    for child in children:
        child.join()  # a copy that failed: its figures rendered here


def _default_workers() -> int:
    """``BOUNCEBAYES_FIGURE_WORKERS`` (a positive integer), else one per idle core, up to four.

    Idle: the cores less the 1-minute load average, this process's own share counted as idle
    (forked copies only add work on a machine whose cores are busy: measured on a shared
    2-core machine at load 7, rendering in two processes took 30 % longer than in one)."""
    text = os.environ.get("BOUNCEBAYES_FIGURE_WORKERS", "").strip()
    if text:
        if not text.isdigit() or int(text) < 1:
            raise ValueError(f"environment variable BOUNCEBAYES_FIGURE_WORKERS must be a "
                             f"positive integer (processes rendering figures); got {text!r}")
        return int(text)
    from .._background import idle_cores

    cores, idle = idle_cores()
    return max(1, min(4, cores, int(idle + 0.5)))


def _save_all(files: list[tuple[Figure, list[Path]]]) -> None:
    for fig, paths in files:
        for path in paths:
            save_figure(fig, path)
