"""The population of the hierarchical (``population``) likelihood: its density over the
parameter's range with the posterior's uncertainty band, the predictive density of a new
bounce, and each measured bounce's estimate."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ._figure import new_figure, styled
from ._layout import place_panels
from ._limits import headroom, robust_limits

if TYPE_CHECKING:
    from matplotlib.figure import Figure

BAND_DRAWS = 400  #: posterior draws whose population densities make the band
BINS = 300  #: bins of the density curves


def population_band(result, k: int, edges: np.ndarray) -> tuple[np.ndarray, ...]:
    """Per bin of ``edges``: the population density (bin averages, finite for any spread) of
    evenly spaced draws, summarised as their 5 %, 50 % and 95 % quantiles and their mean (the
    predictive density of a new bounce)."""
    from ..inference import population_density

    pop = result.population
    like_family = pop.record["family"]
    name = pop.names[k]
    s = result.draws.samples.reshape(-1, result.draws.samples.shape[-1])
    pick = np.unique(np.linspace(0, s.shape[0] - 1, BAND_DRAWS).round().astype(int))
    mean = s[pick, result.names.index(f"{name}_mean")]
    sd = s[pick, result.names.index(f"{name}_sd")]
    domain = result.experiment.priors[name].support
    dens = population_density(edges, mean, sd, domain, like_family)
    lo, med, hi = np.quantile(dens, [0.05, 0.5, 0.95], axis=0)
    return lo, med, hi, dens.mean(axis=0)


@styled
def plot_population(result, truth: dict | None = None) -> Figure | None:
    """The population density of each parameter with its 90 % band, the predictive density of
    a new bounce, the prior, and the measured bounces' estimates (with the population and on
    their own); ``None`` without a population."""
    pop = getattr(result, "population", None)
    if pop is None:
        return None
    d = len(pop.names)
    fig = new_figure(5.4 * d, 4.4)
    axes = fig.subplots(1, d, squeeze=False)[0]
    for k, ax in enumerate(axes):
        _panel(ax, result, k, truth)
    fig.suptitle(f"Population of the bounces' parameters ({pop.record['family']}, truncated to "
                 f"the prior; {result.trials.n} bounces)")
    place_panels(fig, [axes])
    return fig


def _panel(ax, result, k: int, truth: dict | None) -> None:
    pop = result.population
    name, unit = pop.names[k], pop.units[k]
    prior = result.experiment.priors[name]
    lo_box, hi_box = prior.box(1e-6)
    b = pop.bounces
    shown = [pop.predictive[..., k].ravel()]
    shown += [np.asarray(b[key]) for key in (f"{name}_mean", f"{name}_alone_mean") if key in b]
    view = robust_limits(*shown, pad=0.15)
    view = (max(view[0], lo_box), min(view[1], hi_box))
    zoomed = (view[1] - view[0]) < 0.8 * (hi_box - lo_box)
    edges = np.linspace(view[0], view[1], BINS + 1)
    x = 0.5 * (edges[1:] + edges[:-1])
    lo, med, hi, predictive = population_band(result, k, edges)
    u = f" {unit}" if unit else ""
    ax.fill_between(x, lo, hi, color="C0", alpha=0.3, label="population density: 90 % band")
    ax.plot(x, med, color="C0", lw=1.5, label="population density: median")
    ax.plot(x, predictive, color="C1", lw=2, ls="--", label="predictive density of a new bounce")
    prior_pdf = np.exp(prior.logpdf(x))
    ax.plot(x, prior_pdf, "k:", lw=1.2, label=f"prior: {prior.describe()}"
            + (" (wider than the axis)" if zoomed else ""))
    top = float(max(np.max(hi), np.max(predictive), np.max(prior_pdf)))
    n_legend = 4
    if f"{name}_mean" in b:
        est = np.asarray(b[f"{name}_mean"])
        alone = np.asarray(b[f"{name}_alone_mean"])
        ax.plot(alone, np.full(alone.size, 0.06 * top), "|", color="0.55", ms=10,
                label="each bounce on its own (posterior mean)")
        ax.plot(est, np.full(est.size, 0.02 * top), "|", color="k", ms=10,
                label="each bounce with the population (shrunk)")
        n_legend += 2
    if truth and f"{name}" in truth:
        ax.axvline(truth[name], color="C3", lw=1.5, label=f"true population mean of {name}")
        n_legend += 1
    entry = pop.record["predictive"][name]
    if "bound" in entry:
        ax.axvline(entry["bound"]["value"], color="C2", lw=1.5, ls="-.",
                   label="lower bound of the population mean (95 %)")
        ax.set_title(f"{name}: bounded from below only (most bounces roll)", fontsize=10)
        n_legend += 1
    else:
        q = entry["quantiles"]
        ax.set_title(f"{name}: 90 % of bounces in [{q['5%']:.3g}, {q['95%']:.3g}]{u}",
                     fontsize=10)
    ax.set_xlim(view)
    headroom(ax, top, n_legend)
    ax.set_xlabel(f"{name} ({unit})" if unit else name)
    ax.set_ylabel(f"probability density (1/{unit})" if unit else "probability density")
    ax.legend(loc="upper right", fontsize=7)
