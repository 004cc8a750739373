"""The posterior: joint density (paper Fig. 4), marginals (Fig. 5) and sampler diagnostics."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ._figure import new_figure, styled
from ._kde import binned_kde_2d, kde_curve
from ._layout import place_panels, right_room
from ._limits import CLIP_COLOR, clip_points_y, headroom, mark_beyond_x, robust_limits

if TYPE_CHECKING:
    from matplotlib.figure import Figure

N_JOINT_GRID = 160  # nodes per axis of the joint density (binned KDE)
SURFACE_FACETS = 50  # per axis of the 3-D surface
MAX_CHAINS_SHOWN = 8


def _label(result, name: str) -> str:
    unit = result.posterior.units[result.names.index(name)]
    return f"{name} ({unit})" if unit else name


def _units(result, names) -> str:
    units = [result.posterior.units[result.names.index(n)] for n in names]
    units = [u for u in units if u]
    return " ".join(units) if units else "1"


def joint_density(result, grid_file=None):
    """Density of the first two parameters on a grid: the grid sampler's (exact; the run's own,
    else ``grid_file``, its grid.npz), or a binned KDE of all draws over robust limits.
    Returns names, axes, density and its source."""
    names = result.names[:2]
    grid = getattr(result.draws.info, "grid", None)  # None when reloaded from a run folder
    if grid is not None and len(result.names) == 2:
        return names, *grid.centres, grid.density, "grid quadrature"
    if grid_file is not None and len(result.names) == 2:
        g = np.load(grid_file)
        return names, g["centres_0"], g["centres_1"], g["density"], "grid quadrature"
    x, y = result.samples(names[0]), result.samples(names[1])
    gx = np.linspace(*robust_limits(x, pad=0.1), N_JOINT_GRID)
    gy = np.linspace(*robust_limits(y, pad=0.1), N_JOINT_GRID)
    return names, gx, gy, binned_kde_2d(x, y, gx, gy), "kernel density estimate of the draws"


@styled
def plot_joint_posterior(result, grid_file=None, truth: dict | None = None) -> Figure | None:
    """Fig. 4: the joint posterior of the first two parameters as a surface and as contours."""
    if len(result.names) < 2:
        return None
    names, gx, gy, dens, source = joint_density(result, grid_file)
    fig = new_figure(11, 4.6)
    mx, my = np.meshgrid(gx, gy, indexing="ij")
    ax3 = fig.add_subplot(1, 2, 1, projection="3d")
    # relative to the maximum: a narrow posterior has densities of 1e8 and more, which
    # overflow the 3-D projection; the contour panel carries the absolute scale
    ax3.plot_surface(mx, my, dens / dens.max(), cmap="viridis", linewidth=0,
                     rcount=SURFACE_FACETS, ccount=SURFACE_FACETS, antialiased=False)
    _surface_axes(ax3, result, names)
    ax = fig.add_subplot(1, 2, 2)
    cs = ax.contourf(mx, my, dens, levels=12, cmap="viridis")
    unit = _units(result, names)
    cbar = fig.colorbar(cs, ax=ax, label="density" if unit == "1" else f"density (1/({unit}))")
    _clipped_draws(ax, result, names, gx, gy)
    means = [float(np.mean(result.samples(n))) for n in names]
    ax.plot(*means, "P", ms=10, color="w", mec="k", ls="", label="posterior mean")
    if truth and all(n in truth for n in names):
        ax.plot(truth[names[0]], truth[names[1]], "r*", ms=14, ls="", label="true value")
    ax.legend(loc="upper right")
    ax.set_xlim(gx[0], gx[-1])
    ax.set_ylim(gy[0], gy[-1])
    ax.set_xlabel(_label(result, names[0]))
    ax.set_ylabel(_label(result, names[1]))
    ax.set_title("b) contours")
    _few_ticks(ax.xaxis, 5)
    fig.suptitle(f"Joint posterior ({source}; likelihood {result.likelihood})")
    # the 3-D panel draws its labels inside its own cell
    place_panels(fig, [[ax3, ax]], right=right_room(cbar.ax) + 0.1, left=0.05)
    return fig


def _few_ticks(axis, n: int) -> None:
    from matplotlib.ticker import MaxNLocator

    axis.set_major_locator(MaxNLocator(n))


def _surface_axes(ax3, result, names) -> None:
    ax3.set_xlabel(_label(result, names[0]))
    ax3.set_ylabel(_label(result, names[1]))
    ax3.set_zlabel("density / maximum")
    for axis in (ax3.xaxis, ax3.yaxis):
        _few_ticks(axis, 4)
    ax3.set_title("a) surface", y=1.08)  # the 3-D box sits below the top of its cell


def _clipped_draws(ax, result, names, gx, gy) -> None:
    """Draws outside the contour panel, drawn on its edge (a grid file is exact: none)."""
    x, y = result.samples(names[0]), result.samples(names[1])
    out = (x < gx[0]) | (x > gx[-1]) | (y < gy[0]) | (y > gy[-1])
    if out.any():
        ax.plot(np.clip(x[out], gx[0], gx[-1]), np.clip(y[out], gy[0], gy[-1]), ls="",
                marker="x", ms=5, color=CLIP_COLOR, clip_on=False,
                label=f"{int(out.sum())} draws beyond the axes (at the edge)")


@styled
def plot_marginals(result, truth: dict | None = None) -> Figure:
    """Fig. 5: prior (dashed) and posterior (solid) marginals, the 90 % interval shaded."""
    d = len(result.names)
    fig = new_figure(4.6 * d, 4.0)
    axes = fig.subplots(1, d, squeeze=False)[0]
    for ax, p, prior in zip(axes, result.parameters, result.posterior.priors, strict=True):
        _marginal_panel(ax, result, p, prior, truth)
    fig.suptitle("Prior and posterior marginals")
    place_panels(fig, [axes])
    return fig


def _marginal_panel(ax, result, p, prior, truth) -> None:
    x = result.samples(p.name)
    lo, hi = prior.box(1e-3)
    view = robust_limits(x, pad=0.3)
    zoomed = (view[1] - view[0]) < 0.2 * (hi - lo)  # the posterior is a spike: zoom
    if not zoomed:
        view = (min(view[0], lo), max(view[1], hi))
    grid = np.linspace(*view, 400)
    dens = kde_curve(x, grid)
    dens = np.zeros_like(grid) if dens is None else dens
    prior_grid = np.linspace(max(lo, view[0]), min(hi, view[1]), 400)
    prior_pdf = np.exp(prior.logpdf(prior_grid))
    ax.plot(prior_grid, prior_pdf, "k--", lw=1.5,
            label=f"prior: {prior.describe()}" + (" (beyond the axis)" if zoomed else ""))
    ax.plot(grid, dens, color="C0", lw=2, label=f"posterior ({x.size} draws)")
    sel = (grid >= p.ci90[0]) & (grid <= p.ci90[1])
    ax.fill_between(grid[sel], 0, dens[sel], color="C0", alpha=0.25,
                    label=f"90 % interval [{p.ci90[0]:.4g}, {p.ci90[1]:.4g}]")
    n_legend = 3
    if truth and p.name in truth:
        ax.axvline(truth[p.name], color="C3", lw=1.5, label="true value")
        n_legend += 1
    unit = result.posterior.units[result.names.index(p.name)]
    n_legend += mark_beyond_x(ax, x, view, what="draws", unit=unit) > 0
    ax.set_xlim(view)
    headroom(ax, max(dens.max(), float(np.max(prior_pdf, initial=0.0))), n_legend)
    ax.set_xlabel(_label(result, p.name) + (" (zoomed on the posterior)" if zoomed else ""))
    ax.set_ylabel(f"probability density (1/{unit})" if unit else "probability density")
    ax.set_title(p.paper_form())
    ax.legend(loc="upper right", fontsize=8)


def trace_limits(samples: np.ndarray) -> tuple[float, float]:
    """y-limits of a trace plot: every chain's own robust range, so that a chain stuck away
    from the others stays in view while single wild draws do not stretch the axis."""
    ranges = np.array([robust_limits(chain, pad=0.0) for chain in samples])
    lo, hi = float(ranges[:, 0].min()), float(ranges[:, 1].max())
    pad = 0.05 * (hi - lo or abs(hi) * 0.1 or 1.0)
    return lo - pad, hi + pad


@styled
def plot_diagnostics(result) -> Figure:
    """Traces and rank histograms per chain (uniform ranks: the chains agree)."""
    s = result.draws.samples
    c, _, d = s.shape
    fig = new_figure(11, 2.6 * d + 0.8)
    axes = fig.subplots(d, 2, squeeze=False)
    for i, p in enumerate(result.parameters):
        _trace_panel(axes[i, 0], result, p, s[..., i])
        _rank_panel(axes[i, 1], s[..., i])
    # one legend for the chains of every panel, below them
    handles, labels = axes[0, 1].get_legend_handles_labels()
    ncols = min(len(labels), 9)
    fig.legend(handles, labels, loc="lower center", ncols=ncols, fontsize=8)
    shown = f"; {MAX_CHAINS_SHOWN} shown" if c > MAX_CHAINS_SHOWN else ""
    fig.suptitle(f"Sampler diagnostics ({result.sampler}, {c} chain(s){shown})")
    place_panels(fig, axes, legend_rows=-(-len(labels) // ncols))
    return fig


def _trace_panel(ax, result, p, samples: np.ndarray) -> None:
    c, n = samples.shape
    k = min(c, MAX_CHAINS_SHOWN)
    limits = trace_limits(samples)
    for ch in range(k):
        ax.plot(samples[ch], lw=0.4, alpha=0.7, color=f"C{ch % 10}")
    unit = result.posterior.units[result.names.index(p.name)]
    steps = np.broadcast_to(np.arange(n), (k, n))
    if clip_points_y(ax, steps.ravel(), samples[:k].ravel(), limits, what="draws", unit=unit):
        ax.legend(loc="upper right", fontsize=7)
    ax.set_ylim(limits)
    rhat = f"R-hat {p.r_hat:.3f}, " if p.r_hat is not None else ""
    ax.set_title(f"{p.name}: {rhat}ESS {p.ess_bulk:.0f}" if p.ess_bulk else p.name,
                 fontsize=9)
    ax.set_xlabel("draw (after burn-in and thinning)")
    ax.set_ylabel(_label(result, p.name))


def _rank_panel(ax, samples: np.ndarray) -> None:
    from scipy import stats

    c, n = samples.shape
    ranks = stats.rankdata(samples.ravel()).reshape(c, n)
    top = 0.0
    for ch in range(min(c, MAX_CHAINS_SHOWN)):
        # the same 20 bins for every chain: ranks run from 1 to c n
        counts, _, _ = ax.hist(ranks[ch], bins=20, range=(0.5, c * n + 0.5), histtype="step",
                               lw=1.2, color=f"C{ch % 10}", label=f"chain {ch + 1}")
        top = max(top, float(np.max(counts)))
    ax.axhline(n / 20, color="k", ls="--", lw=1, label="uniform ranks (chains agree)")
    ax.set_ylim(0, 1.1 * top)
    ax.set_xlabel("rank of the draw among all chains")
    ax.set_ylabel("draws per bin")
