"""Draw docs/figures/population_readings.png: the four readings of one campaign whose bounces
have both a real bounce-to-bounce spread of mu and eta and measurement noise, against the truth.

Run from the repository root: ``python docs/figures/population_readings.py``. The campaign is
the paper's experiment (the bundled demo's file) synthesised with ``bouncebayes.data.synthesize``
(seed 2024, 55 bounces): mu ~ N(0.16, 0.02), eta ~ N(1.35, 0.25) kg/s per bounce (truncated at
0), rebound noise 0.02 m/s and 0.5 deg (stated as standard errors). Each likelihood's posterior
of mu and eta (gaussian, kde, consistent: grid quadrature; population: mh, its predictive
density of a new bounce) is drawn over the true population and the true per-bounce values.
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
from scipy import stats

ROOT = Path(__file__).resolve().parents[2]
TRUE = {"mu": (0.16, 0.02), "eta": (1.35, 0.25)}
SEED = 2024
STYLE = {"gaussian": ("C0", "-", "gaussian: one true value (posterior)"),
         "kde": ("C2", "--", "kde (the paper's): posterior"),
         "consistent": ("C4", "-.", "consistent: distribution of the parameters"),
         "population": ("C1", "-", "population: predictive of a new bounce")}


def campaign():
    """The experiment and the synthetic campaign with spread and noise."""
    from bouncebayes.data import demo_campaign, parse_experiment, synthesize

    doc = tomllib.loads(demo_campaign().experiment.read_text(encoding="utf-8"))
    doc["synth"] |= {"mu_sd": TRUE["mu"][1], "eta_sd": TRUE["eta"][1]}
    doc["contact"] |= {"mu": TRUE["mu"][0], "eta": TRUE["eta"][0]}
    exp = parse_experiment(doc, source="population-readings")
    return exp, synthesize(exp, seed=SEED, n=55)


def readings(exp, trials) -> dict:
    """Draws of mu and eta under each reading (the population: its predictive)."""
    from bouncebayes.inference import GridConfig, MHConfig, infer

    out = {}
    for name in ("gaussian", "kde", "consistent"):
        r = infer(exp, trials, likelihood=name, sampler="grid", seed=1,
                  config=GridConfig(draws=20000, points=256), discrepancy="none")
        out[name] = {p: r.samples(p) for p in ("mu", "eta")}
    r = infer(exp, trials, likelihood="population", sampler="mh", seed=1,
              config=MHConfig(draws=15000, burn_in=2000))
    pred, names = r.parameter_draws()
    out["population"] = {p: pred[..., names.index(p)].ravel() for p in ("mu", "eta")}
    out["population_result"] = r
    return out


def main(out: Path = ROOT / "docs" / "figures" / "population_readings.png") -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    exp, c = campaign()
    draws = readings(exp, c.trials)
    per = c.truth["per_bounce"]
    fig, axes = plt.subplots(1, 2, figsize=(13, 4.8), constrained_layout=True)
    for ax, (p, unit) in zip(axes, (("mu", ""), ("eta", "kg/s")), strict=True):
        x_true = np.asarray(per[p])
        m, s = TRUE[p]
        lo, hi = m - 4 * s, m + 4 * s
        grid = np.linspace(lo, hi, 400)
        ax.hist(x_true, bins=14, range=(lo, hi), density=True, color="0.85",
                label=f"the {x_true.size} bounces' true values")
        ax.plot(grid, stats.norm.pdf(grid, m, s), "k:", lw=2,
                label=f"true population N({m:g}, {s:g}{' ' + unit if unit else ''})")
        curves = {}
        for name, (color, ls, label) in STYLE.items():
            x = draws[name][p]
            curves[name] = stats.gaussian_kde(x[:: max(1, x.size // 5000)])(grid)
        top = 1.5 * max(max(float(c.max()) for k, c in curves.items() if k != "gaussian"),
                        float(stats.norm.pdf(m, m, s)))
        for name, (color, ls, label) in STYLE.items():
            y = curves[name]
            if y.max() > top:  # the one-value posterior is a spike: cut, its height said
                label += f" (peak {y.max():.0f}, cut)"
            ax.plot(grid, np.minimum(y, top), color=color, ls=ls, lw=2, label=label)
        ax.set_ylim(0, top * 1.45)
        ax.set_xlim(lo, hi)
        ax.set_xlabel(f"{p} ({unit})" if unit else p)
        ax.set_ylabel(f"probability density (1/{unit})" if unit else "probability density")
        ax.set_title(f"{p}: four readings of the same 55 bounces")
        ax.legend(fontsize=8, loc="upper right")
    r = draws["population_result"]
    words = {s.name: s.paper_form() for s in r.parameters}
    fig.suptitle("One campaign with bounce-to-bounce scatter of the parameters and measurement "
                 "noise (truth: dotted, grey)\npopulation likelihood's hyper-parameters: "
                 + ", ".join(words[k] for k in ("mu_mean", "mu_sd", "eta_mean", "eta_sd")),
                 fontsize=10)
    fig.savefig(out, dpi=110)
    print(f"written: {out}")
    for name in STYLE:
        print(name, {p: (round(float(np.mean(draws[name][p])), 4),
                         round(float(np.std(draws[name][p])), 4)) for p in ("mu", "eta")})
    print("truth sample", {p: (round(float(np.mean(per[p])), 4), round(float(np.std(per[p])), 4))
                           for p in ("mu", "eta")})


if __name__ == "__main__":
    main()
