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
from matplotlib.ticker import MaxNLocator  # noqa: E402

from ._io import write_with  # noqa: E402
from .model import BounceHistory  # noqa: E402

FIGURE_FORMATS = (".png", ".svg", ".pdf")
STYLE = {"figure.dpi": 110, "axes.grid": True, "grid.alpha": 0.3, "font.size": 10,
         "axes.titlesize": 11, "legend.fontsize": 9}


def save_figure(fig: Figure, path: str | os.PathLike, *, close: bool = True) -> Path:
    """Save ``fig`` atomically; the format follows the suffix (.png, .svg or .pdf)."""
    suffix = Path(path).suffix.lower()
    if suffix not in FIGURE_FORMATS:
        raise ValueError(f"figure file {str(path)!r} must end in one of "
                         f"{', '.join(FIGURE_FORMATS)}; got {suffix or 'no suffix'!r}")
    # mplot3d's projection can overflow in float arithmetic for a very narrow posterior far
    # from the origin (axes 1e-4 wide at 5.0): harmless to the image, so not a warning
    with np.errstate(over="ignore", invalid="ignore"):
        out = write_with(path, lambda tmp: fig.savefig(tmp, format=suffix[1:],
                                                       bbox_inches="tight"))
    if close:
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


# --- The figures of a run (the paper's Figs. 3-9 and MCMC diagnostics) -----------------------

def _kde_line(x: np.ndarray, lo: float, hi: float, n: int = 400):
    from scipy import stats

    grid = np.linspace(lo, hi, n)
    if x.size < 2 or np.ptp(x) == 0:
        return grid, np.zeros_like(grid)
    return grid, stats.gaussian_kde(x)(grid)


def _span(*arrays, pad: float = 0.15):
    lo = min(float(np.min(a)) for a in arrays)
    hi = max(float(np.max(a)) for a in arrays)
    width = hi - lo or abs(hi) * 0.1 or 1.0
    return lo - pad * width, hi + pad * width


def plot_data(speed, angle, summary) -> Figure:
    """Fig. 3: histograms of the measured rebound speed and angle with their KDEs."""
    with plt.rc_context(STYLE):
        fig, axes = plt.subplots(1, 2, figsize=(10, 3.8))
        for ax, x, var, label, unit in ((axes[0], speed, summary.speed, "rebound speed", "m/s"),
                                        (axes[1], angle, summary.angle, "rebound angle",
                                         "deg")):
            x = np.asarray(x)
            ax.hist(x, bins=var.bin_edges, density=True, color="C0", alpha=0.35,
                    edgecolor="C0", label=f"histogram ({x.size} bounces)")
            grid = np.linspace(*_span(x), 400)
            ax.plot(grid, var.kde.pdf(grid), color="C3", lw=2,
                    label=f"KDE (bandwidth {var.kde.bandwidth:.3g} {unit})")
            ax.plot(x, np.zeros_like(x), "|", color="k", ms=10, label="bounces")
            ax.set_xlabel(f"{label} ({unit})")
            ax.set_ylabel(f"probability density (1/{unit})")
            ax.legend(loc="upper left")
        c = summary.correlation
        fig.suptitle(f"Measured rebounds (Pearson r = {c.r:.2f}, p = {c.p_value:.2g}; "
                     f"density: {summary.density_kind})")
        fig.tight_layout()
    return fig


def _joint_density(result, grid_file=None):
    """Density of the first two parameters on a grid: the grid sampler's, or a KDE of draws."""
    from scipy import stats

    names = result.names[:2]
    if grid_file is not None and len(result.names) == 2:
        g = np.load(grid_file)
        return names, g["centres_0"], g["centres_1"], g["density"], "grid quadrature"
    x, y = result.samples(names[0]), result.samples(names[1])
    sub = np.column_stack([x, y])[:: max(1, x.size // 4000)]
    gx = np.linspace(*_span(x, pad=0.1), 120)
    gy = np.linspace(*_span(y, pad=0.1), 120)
    mx, my = np.meshgrid(gx, gy, indexing="ij")
    dens = stats.gaussian_kde(sub.T)(np.vstack([mx.ravel(), my.ravel()])).reshape(mx.shape)
    return names, gx, gy, dens, "kernel density estimate of the draws"


def _label(result, name):
    unit = result.posterior.units[result.names.index(name)]
    return f"{name} ({unit})" if unit else name


def plot_joint_posterior(result, grid_file=None, truth: dict | None = None) -> Figure | None:
    """Fig. 4: the joint posterior of the first two parameters as a surface and as contours."""
    if len(result.names) < 2:
        return None
    names, gx, gy, dens, source = _joint_density(result, grid_file)
    with plt.rc_context(STYLE):
        fig = plt.figure(figsize=(11, 4.4))
        ax3 = fig.add_subplot(1, 2, 1, projection="3d")
        mx, my = np.meshgrid(gx, gy, indexing="ij")
        step = max(1, gx.size // 80)
        # relative to the maximum: a narrow posterior has densities of 1e8 and more, which
        # overflow the 3-D projection; the contour panel carries the absolute scale
        ax3.plot_surface(mx[::step, ::step], my[::step, ::step],
                         dens[::step, ::step] / dens.max(), cmap="viridis", linewidth=0,
                         antialiased=True)
        ax3.set_xlabel(_label(result, names[0]))
        ax3.set_ylabel(_label(result, names[1]))
        ax3.set_zlabel("density / maximum")
        for axis in (ax3.xaxis, ax3.yaxis):
            axis.set_major_locator(MaxNLocator(4))
        ax3.set_title("a) surface")
        ax = fig.add_subplot(1, 2, 2)
        cs = ax.contourf(mx, my, dens, levels=12, cmap="viridis")
        unit = _units(result, names)
        fig.colorbar(cs, ax=ax, label="density" if unit == "1" else f"density (1/({unit}))")
        if truth and all(n in truth for n in names):
            ax.plot(truth[names[0]], truth[names[1]], "r*", ms=14, label="true value")
            ax.legend(loc="upper right")
        ax.set_xlabel(_label(result, names[0]))
        ax.set_ylabel(_label(result, names[1]))
        ax.set_title("b) contours")
        ax.xaxis.set_major_locator(MaxNLocator(5))
        fig.suptitle(f"Joint posterior ({source}; likelihood {result.likelihood})")
        fig.tight_layout()
    return fig


def _units(result, names):
    units = [result.posterior.units[result.names.index(n)] for n in names]
    units = [u for u in units if u]
    return " ".join(units) if units else "1"


def plot_marginals(result, truth: dict | None = None) -> Figure:
    """Fig. 5: prior (dashed) and posterior (solid) marginals, the 90 % interval shaded."""
    d = len(result.names)
    with plt.rc_context(STYLE):
        fig, axes = plt.subplots(1, d, figsize=(4.6 * d, 3.8), squeeze=False)
        for ax, p, prior in zip(axes[0], result.parameters, result.posterior.priors,
                                strict=True):
            x = result.samples(p.name)
            lo, hi = prior.box(1e-3)
            view = _span(x, pad=0.3)
            zoomed = (view[1] - view[0]) < 0.2 * (hi - lo)  # the posterior is a spike: zoom
            if not zoomed:
                view = (min(view[0], lo), max(view[1], hi))
            grid, dens = _kde_line(x, *view)
            prior_grid = np.linspace(max(lo, view[0]), min(hi, view[1]), 400)
            ax.plot(prior_grid, np.exp(prior.logpdf(prior_grid)), "k--", lw=1.5,
                    label=f"prior: {prior.describe()}"
                          + (" (beyond the axis)" if zoomed else ""))
            ax.plot(grid, dens, color="C0", lw=2, label="posterior")
            sel = (grid >= p.ci90[0]) & (grid <= p.ci90[1])
            ax.fill_between(grid[sel], 0, dens[sel], color="C0", alpha=0.25,
                            label=f"90 % interval [{p.ci90[0]:.4g}, {p.ci90[1]:.4g}]")
            if truth and p.name in truth:
                ax.axvline(truth[p.name], color="C3", lw=1.5, label="true value")
            ax.set_xlabel(_label(result, p.name) + (" (zoomed on the posterior)" if zoomed
                                                     else ""))
            unit = result.posterior.units[result.names.index(p.name)]
            ax.set_ylabel(f"probability density (1/{unit})" if unit else "probability density")
            ax.set_title(p.paper_form())
            ax.legend(loc="upper right", fontsize=8)
        fig.suptitle("Prior and posterior marginals")
        fig.tight_layout()
    return fig


def plot_trajectories(prop, radius: float) -> Figure:
    """Fig. 6: centre-of-mass trajectories through the collision for posterior draws."""
    h = prop.histories
    mm = 1e3
    with plt.rc_context(STYLE):
        fig, ax = plt.subplots(figsize=(8, 4.2))
        for i in range(h["x"].shape[0]):
            ax.plot(h["x"][i] * mm, h["y"][i] * mm, color="C0", lw=0.6, alpha=0.25,
                    label="posterior draws" if i == 0 else None)
        ax.axhline(radius * mm, color="0.5", ls=":", lw=1, label="centre height at first touch")
        ax.axhline(0, color="k", lw=1.2, label="plane")
        ax.set_xlabel("x along the plane (mm)")
        ax.set_ylabel("y: height of the centre (mm)")
        ax.set_title(f"Trajectory of the centre of mass through the collision "
                     f"({h['x'].shape[0]} draws)")
        ax.legend(loc="upper right")
        fig.tight_layout()
    return fig


def plot_predictive(prop, trials) -> Figure:
    """Fig. 7: predicted (posterior predictive) and measured PDFs of the rebound."""
    with plt.rc_context(STYLE):
        fig, axes = plt.subplots(1, 2, figsize=(10, 3.8))
        for ax, pred, obs, key, label, unit in (
                (axes[0], prop.predicted_speed, trials.rebound_speed, "rebound_speed",
                 "rebound speed", "m/s"),
                (axes[1], prop.predicted_angle, trials.rebound_angle, "rebound_angle",
                 "rebound angle", "deg")):
            obs = np.asarray(obs)
            lo, hi = _span(pred, obs)
            g, fp = _kde_line(pred, lo, hi)
            ax.plot(g, fp, color="C0", lw=2, label="model (posterior predictive)")
            g, fo = _kde_line(obs, lo, hi)
            ax.plot(g, fo, "k--", lw=2, label="experiment (KDE)")
            m = prop.match.get(key, {})
            if m.get("ks_statistic") is not None:
                ax.set_title(f"KS D = {m['ks_statistic']:.2f}, p = {m['ks_p_value']:.2g}; "
                             f"Hellinger {m['hellinger']:.2f}", fontsize=9)
            ax.set_xlabel(f"{label} ({unit})")
            ax.set_ylabel(f"probability density (1/{unit})")
            ax.legend(loc="upper left", fontsize=8)
        fig.suptitle("Reconstruction of the measured rebounds")
        fig.tight_layout()
    return fig


def plot_forces(prop) -> Figure:
    """Fig. 8: realisations of the normal and friction force histories."""
    h = prop.histories
    ms = 1e3
    with plt.rc_context(STYLE):
        fig, axes = plt.subplots(1, 2, figsize=(10, 3.8))
        for ax, key, title in ((axes[0], "normal_force", "a) normal force"),
                               (axes[1], "friction_force", "b) friction force")):
            for i in range(h[key].shape[0]):
                c = h["in_contact"][i]
                ax.plot(h["time"][i][c] * ms, h[key][i][c], color="C0" if key[0] == "n" else
                        "C1", lw=0.6, alpha=0.3, label="posterior draws" if i == 0 else None)
            ax.axhline(0, color="k", lw=0.8)
            ax.set_xlabel("time since first contact (ms)")
            ax.set_ylabel("force (N)")
            ax.set_title(title)
            ax.legend(loc="best")
        fig.suptitle(f"Contact forces of {h['time'].shape[0]} posterior draws")
        fig.tight_layout()
    return fig


def plot_contact_time(prop) -> Figure:
    """Fig. 9: the PDF of the contact time, with its modes marked."""
    tc = prop.bounces.contact_time[prop.bounces.ok] * 1e3
    with plt.rc_context(STYLE):
        fig, ax = plt.subplots(figsize=(6.5, 3.8))
        ax.hist(tc, bins="auto", density=True, color="C0", alpha=0.3, label="histogram")
        g, f = _kde_line(tc, *_span(tc))
        ax.plot(g, f, color="C0", lw=2, label="kernel density estimate")
        for i, m in enumerate(prop.contact_time_modes):
            ax.axvline(m * 1e3, color="C3", ls="--", lw=1,
                       label="modes" if i == 0 else None)
        ax.set_xlabel("contact time (ms)")
        ax.set_ylabel("probability density (1/ms)")
        n = len(prop.contact_time_modes)
        shape = {1: "unimodal", 2: "bimodal"}.get(n, f"{n} modes")
        ax.set_title(f"PDF of the contact time ({shape})")
        ax.legend(loc="upper right")
        fig.tight_layout()
    return fig


def plot_diagnostics(result) -> Figure:
    """Traces and rank histograms per chain (uniform ranks: the chains agree)."""
    from scipy import stats

    s = result.draws.samples
    c, n, d = s.shape
    with plt.rc_context(STYLE):
        fig, axes = plt.subplots(d, 2, figsize=(11, 2.6 * d), squeeze=False)
        for i, p in enumerate(result.parameters):
            ranks = stats.rankdata(s[..., i].ravel()).reshape(c, n)
            for ch in range(min(c, 8)):
                axes[i, 0].plot(s[ch, :, i], lw=0.4, alpha=0.7, label=f"chain {ch + 1}")
                axes[i, 1].hist(ranks[ch], bins=20, histtype="step", lw=1.2,
                                label=f"chain {ch + 1}")
            axes[i, 1].axhline(n / 20, color="k", ls="--", lw=1, label="uniform")
            rhat = f"R-hat {p.r_hat:.3f}, " if p.r_hat is not None else ""
            axes[i, 0].set_title(f"{p.name}: {rhat}ESS {p.ess_bulk:.0f}" if p.ess_bulk else
                                 p.name, fontsize=9)
            axes[i, 0].set_xlabel("draw (after burn-in and thinning)")
            axes[i, 0].set_ylabel(_label(result, p.name))
            axes[i, 1].set_xlabel("rank of the draw among all chains")
            axes[i, 1].set_ylabel("draws per bin")
            if i == 0:
                axes[i, 0].legend(loc="upper right", fontsize=7, ncol=2)
                axes[i, 1].legend(loc="lower right", fontsize=7, ncol=2)
        fig.suptitle(f"Sampler diagnostics ({result.sampler}, {c} chain(s))")
        fig.tight_layout()
    return fig
