"""Simulation-based calibration (Talts et al. 2018, arXiv:1804.06788) of the gaussian likelihood.

The study: draw ``(mu, eta)`` from the prior, synthesise a campaign with
``bouncebayes.data.synthesize`` (the package's own generator: per-bounce incidence scatter,
measured incidence and rebound with Gaussian noise, standard errors in the table), infer with the
gaussian likelihood (noise given by the table, incidence uncertainty propagated) and the grid
sampler (exact quadrature: its draws are independent, so no thinning is needed), and record the
rank of the true value among ``draws`` posterior draws. If the inference is calibrated the ranks
are uniform on ``0..draws`` and the 90 % intervals hold the truth in 90 % of the campaigns.

Checks reported (and asserted by ``tests/test_sbc.py``):

- uniformity: Pearson chi-square test of the ranks in ``bins`` equal bins, p > 0.01 for each
  parameter;
- coverage: the share of 90 % intervals (5 % and 95 % quantiles of the draws) holding the truth
  lies inside the central 99 % binomial interval of Binomial(campaigns, 0.9) / campaigns.

Setup: the paper's experiment (3 m/s at 60 deg, 1 deg and 0.05 m/s bounce-to-bounce spread,
the demo's noise levels) with the prior box restricted to mu in [0, 0.2] (eta in [0, 5] kg/s, the
paper's) so that every campaign stays in the sliding regime: the smallest mu for which a bounce
leaves rolling is 0.219 (bisection on ``bb.simulate``: eta = 0, i.e. the highest restitution, and
57 deg, 3 sd below the nominal incidence; 0.246 at 60 deg). Campaigns with rolling bounces are
counted in the output (expected 0).
The same prior is used to draw the truth and to infer, as SBC requires.

``python benchmarks/sbc.py [--campaigns N] [--seed S]`` runs it and writes
``benchmarks/results/sbc.json``; the last stdout line is the JSON summary.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy is imported

import argparse  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import tomllib  # noqa: E402
from datetime import datetime, timezone  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
from scipy import stats  # noqa: E402

import bouncebayes as bb  # noqa: E402
from bouncebayes._io import write_json  # noqa: E402
from bouncebayes.data import demo_campaign, parse_experiment, synthesize  # noqa: E402
from bouncebayes.inference import GridConfig, infer  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results" / "sbc.json"
NAMES = ("mu", "eta")
DEFAULTS = {"campaigns": 300, "n_trials": 30, "draws": 999, "bins": 20, "grid_points": 512,
            "seed": 20180413, "mu_box": (0.0, 0.2), "eta_box": (0.0, 5.0)}


def sbc_experiment(mu: float, eta: float, settings: dict):
    """The paper's experiment with the study's prior box and (mu, eta) as the synthetic truth."""
    doc = tomllib.loads(demo_campaign().experiment.read_text(encoding="utf-8"))
    doc["contact"] |= {"mu": float(mu), "eta": float(eta)}
    for name in NAMES:
        low, high = settings[f"{name}_box"]
        doc["parameters"][name] = {"prior": "uniform", "low": low, "high": high}
    return parse_experiment(doc, source="sbc")


def one_campaign(theta: np.ndarray, synth_seed: int, infer_seed: int, settings: dict) -> dict:
    """Rank of the truth among the posterior draws, and 90 % interval coverage, per parameter."""
    exp = sbc_experiment(*theta, settings)
    c = synthesize(exp, seed=int(synth_seed), n=settings["n_trials"])
    config = GridConfig(draws=settings["draws"], points=settings["grid_points"])
    result = infer(exp, c.trials, likelihood="gaussian", sampler="grid", seed=int(infer_seed),
                   config=config)
    out = {"share_rolling_data": c.truth["share_rolling"]}
    for i, name in enumerate(NAMES):
        draws = result.samples(name)
        p = result.parameters[result.names.index(name)]
        out[name] = {"rank": int(np.sum(draws < theta[i])),
                     "covered": bool(p.ci90[0] <= theta[i] <= p.ci90[1]),
                     "posterior_sd": p.sd}
    return out


def rank_test(ranks: np.ndarray, draws: int, bins: int) -> dict:
    """Histogram of the ranks (0..draws) in ``bins`` equal bins and Pearson's chi-square test."""
    if (draws + 1) % bins:
        raise ValueError(f"`draws` + 1 ({draws + 1}) must be a multiple of `bins` ({bins})")
    counts = np.bincount(ranks // ((draws + 1) // bins), minlength=bins)
    chi2, p = stats.chisquare(counts)
    return {"rank_histogram": counts.tolist(), "chi2": float(chi2), "chi2_dof": bins - 1,
            "chi2_p_value": float(p)}


def run_sbc(campaigns: int | None = None, *, seed: int | None = None, out: Path | None = RESULTS,
            log=print, **overrides) -> dict:
    """Run the study; write the JSON to ``out`` (unless None) and return it."""
    settings = DEFAULTS | overrides | {k: v for k, v in (("campaigns", campaigns),
                                                          ("seed", seed)) if v is not None}
    n = int(settings["campaigns"])
    rng = np.random.default_rng(settings["seed"])
    prior_exp = sbc_experiment(0.1, 1.0, settings)
    thetas = np.column_stack([prior_exp.priors[k].sample(rng, n) for k in NAMES])
    seeds = rng.integers(0, 2**31 - 1, size=(n, 2))
    start = time.perf_counter()
    rows = []
    for i in range(n):
        rows.append(one_campaign(thetas[i], *seeds[i], settings))
        if log and ((i + 1) % 25 == 0 or i + 1 == n):
            log(f"sbc: {i + 1}/{n} campaigns, {time.perf_counter() - start:.0f} s")
    seconds = time.perf_counter() - start
    lo, hi = stats.binom.interval(0.99, n, 0.9)
    result = {
        "study": "simulation-based calibration (Talts et al. 2018) of the gaussian likelihood "
                 "with the grid sampler",
        "settings": {k: list(v) if isinstance(v, tuple) else v for k, v in settings.items()}
                    | {"likelihood": "gaussian", "sampler": "grid", "noise": "given",
                       "incidence": "3 m/s at 60 deg (paper's experiment, demo noise levels)"},
        "seed": settings["seed"],
        "coverage_bounds_99": [lo / n, hi / n],
        "campaigns_with_rolling_bounces": int(sum(r["share_rolling_data"] > 0 for r in rows)),
        "parameters": {},
        "seconds": seconds,
        "bouncebayes_version": bb.__version__,
        "python": platform.python_version(), "numpy": np.__version__,
        "generated_at": datetime.now(timezone.utc).isoformat(timespec="seconds"),
    }
    for name in NAMES:
        ranks = np.array([r[name]["rank"] for r in rows])
        coverage = float(np.mean([r[name]["covered"] for r in rows]))
        test = rank_test(ranks, settings["draws"], settings["bins"])
        result["parameters"][name] = test | {
            "coverage90": coverage,
            "coverage_ok": bool(lo / n <= coverage <= hi / n),
            "uniform_ok": bool(test["chi2_p_value"] > 0.01),
            "median_posterior_sd": float(np.median([r[name]["posterior_sd"] for r in rows])),
            "prior_box": list(settings[f"{name}_box"]),
        }
    if out is not None:
        write_json(out, result)
    return result


def report(result: dict) -> str:
    lines = [f"SBC: {result['settings']['campaigns']} campaigns of "
             f"{result['settings']['n_trials']} bounces, {result['settings']['draws']} draws, "
             f"{result['seconds']:.0f} s; 99 % binomial band of the 90 % coverage: "
             f"[{result['coverage_bounds_99'][0]:.3f}, {result['coverage_bounds_99'][1]:.3f}]; "
             f"campaigns with rolling bounces: {result['campaigns_with_rolling_bounces']}"]
    for name, p in result["parameters"].items():
        lines.append(f"  {name:<4} chi2 = {p['chi2']:.1f} ({p['chi2_dof']} dof), "
                     f"p = {p['chi2_p_value']:.3f}; coverage90 = {p['coverage90']:.3f}; "
                     f"ranks {p['rank_histogram']}")
    return "\n".join(lines)


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--campaigns", type=int, default=DEFAULTS["campaigns"])
    ap.add_argument("--seed", type=int, default=DEFAULTS["seed"])
    ap.add_argument("--out", type=Path, default=RESULTS)
    args = ap.parse_args(argv)
    result = run_sbc(args.campaigns, seed=args.seed, out=args.out,
                     log=lambda m: print(m, file=sys.stderr))
    print(report(result))
    print(f"written: {args.out}")
    print(json.dumps({"campaigns": result["settings"]["campaigns"],
                      "seconds": round(result["seconds"], 1),
                      **{f"{k}_p_value": v["chi2_p_value"] for k, v in
                         result["parameters"].items()},
                      **{f"{k}_coverage90": v["coverage90"] for k, v in
                         result["parameters"].items()}}))
    return result


if __name__ == "__main__":
    main()
