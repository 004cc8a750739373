"""Simulation-based calibration (Talts et al. 2018) of the population likelihood.

Each campaign: draw the hyper-parameters (``mu_mean``, ``mu_sd``, ``eta_mean``, ``eta_sd``) from
their hyper-priors (``docs/likelihoods.md`` §6: means uniform on the prior box, spreads uniform on
``[0, half the box]``), draw each bounce's ``mu`` and ``eta`` from the truncated normal
population (``scipy.stats.truncnorm``, independent of the package's own sampler), each bounce's
incidence around the paper's (3 m/s at 60 deg, 0.05 m/s and 1 deg bounce-to-bounce; measured
exactly), simulate its rebound (``bouncebayes.simulate``), add Gaussian noise of the demo's sizes
(0.02 m/s, 0.5 deg) and state them as standard errors; infer with ``likelihood="population"``
and the ensemble sampler (the tool's default for it; ``--sampler mh`` for the paper's); record
the rank of each true hyper-parameter among ``RANK_DRAWS`` evenly spaced posterior draws (thinned so that they are nearly independent) and whether the 90 %
interval holds it. Calibrated: ranks uniform (Pearson chi-square over ``BINS`` bins, p > 0.01),
coverage inside the central 99 % binomial band of Binomial(campaigns, 0.9). Reported for all
campaigns, for the first 200 (the study's minimum), and for those whose chains agree (R-hat at
most 1.01 for every hyper-parameter: the campaigns where the tool gives no convergence
warning), since a sampler that has not converged is not a calibrated posterior and says so.

Setup: the prior box mu in [0, 0.2] (every bounce slides: the smallest mu that leaves rolling is
0.219, ``benchmarks/sbc.py``), eta in [0, 5] kg/s (the paper's); 55 bounces per campaign (the
paper's count). Campaign ``i`` is seeded with child ``i`` of ``SeedSequence(seed)``.

``python benchmarks/population_sbc.py [--campaigns 300] [--part K/N]`` runs campaigns (part K of
N, for several processes sharing the store folder; results are kept per campaign and resumed),
then, once all are stored, writes ``benchmarks/results/population_sbc.json``.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy is imported

import argparse  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import tomllib  # noqa: E402
from datetime import datetime, timezone  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
from scipy import stats  # noqa: E402

from bouncebayes._io import write_json  # noqa: E402
from bouncebayes.studies import SERIAL, Task, rank_test, run_tasks, task_seed  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results" / "population_sbc.json"
STORE = Path(os.environ.get("POPULATION_SBC_STORE", "/tmp/population_sbc"))
HYPER = ("mu_mean", "mu_sd", "eta_mean", "eta_sd")
BOX = {"mu": (0.0, 0.2), "eta": (0.0, 5.0)}
N_TRIALS = 55
NOISE = {"rebound_speed": 0.02, "rebound_angle": 0.5}  # m/s, deg
DRAWS, BURN_IN, THIN, CHAINS = 4000, 2000, 4, 4  #: the mh runs (--sampler mh)
#: the ensemble runs (--sampler ensemble, the tool's default for this likelihood): its defaults
ENSEMBLE = {"draws": 15_000, "walkers": 32, "burn_in": 500, "thin": 5}
RANK_DRAWS = 99  #: ranks 0..99
BINS = 20
SEED = 20131306
RHAT_LIMIT = 1.01  #: the tool warns about chains that disagree above this (inference/_draws.py)
FIRST = 200  #: the study's minimum, whose result is also reported on its own


def experiment():
    """The paper's experiment (the bundled demo's file) with the study's prior box."""
    from bouncebayes.data import demo_campaign, parse_experiment

    doc = tomllib.loads(demo_campaign().experiment.read_text(encoding="utf-8"))
    for name, (low, high) in BOX.items():
        doc["parameters"][name] = {"prior": "uniform", "low": low, "high": high}
    return parse_experiment(doc, source="population-sbc")


def truth(rng: np.random.Generator) -> dict[str, float]:
    """Hyper-parameters from the hyper-priors."""
    out = {}
    for name, (low, high) in BOX.items():
        out[f"{name}_mean"] = float(rng.uniform(low, high))
        out[f"{name}_sd"] = float(rng.uniform(0.0, 0.5 * (high - low)))
    return out


def campaign(seed: int, sampler: str = "ensemble") -> dict:
    """One campaign: truth, synthetic table, population posterior, ranks and coverage."""
    from bouncebayes import simulate
    from bouncebayes.data import make_trials
    from bouncebayes.inference import EnsembleConfig, MHConfig, infer

    rng = np.random.default_rng(seed)
    exp = experiment()
    hyper = truth(rng)
    per = {}
    for name, (low, high) in BOX.items():
        m, s = hyper[f"{name}_mean"], hyper[f"{name}_sd"]
        per[name] = stats.truncnorm.rvs((low - m) / s, (high - m) / s, loc=m, scale=s,
                                        size=N_TRIALS, random_state=rng)
    inc = exp.incidence
    speed = inc.speed + inc.speed_sd * rng.standard_normal(N_TRIALS)
    angle = inc.angle + inc.angle_sd * rng.standard_normal(N_TRIALS)
    out = simulate(exp.ball, speed=speed, angle=angle,
                   **exp.model_values({"mu": per["mu"], "eta": per["eta"]}),
                   errors="flag", **exp.model_options)
    trials = make_trials(
        exp, rebound_speed=np.abs(out.rebound_speed + NOISE["rebound_speed"]
                                  * rng.standard_normal(N_TRIALS)),
        rebound_angle=out.rebound_angle + NOISE["rebound_angle"] * rng.standard_normal(N_TRIALS),
        incidence_speed=speed, incidence_angle=angle,
        se={k: np.full(N_TRIALS, v) for k, v in NOISE.items()}, source="population-sbc")
    config = (MHConfig(draws=DRAWS, chains=CHAINS, burn_in=BURN_IN, thin=THIN)
              if sampler == "mh" else EnsembleConfig(**ENSEMBLE))
    r = infer(exp, trials, likelihood="population", sampler=sampler,
              seed=int(rng.integers(2**31)), config=config)
    row: dict = {"truth": hyper, "n_failed_bounces": int(out.n_failed),
                 "share_rolling_data": float(np.mean(out.rolling)),
                 "grid_points": r.population.record["grid_points"],
                 "adequate": bool(r.adequacy.adequate), "seconds": r.seconds}
    for i, name in enumerate(HYPER):
        s = r.draws.samples[..., i]  # (chains, draws)
        pick = np.linspace(0, s.shape[1] - 1, -(-RANK_DRAWS // s.shape[0])).round().astype(int)
        thinned = s[:, pick].ravel()[:RANK_DRAWS]
        p = r.parameters[i]
        row[name] = {"rank": int(np.sum(thinned < hyper[name])),
                     "covered": bool(p.ci90[0] <= hyper[name] <= p.ci90[1]),
                     "r_hat": p.r_hat, "ess_bulk": p.ess_bulk, "posterior_sd": p.sd}
    return row


def tasks(n: int, seed: int, sampler: str = "ensemble") -> list[Task]:
    spec = {"n_trials": N_TRIALS, "box": {k: list(v) for k, v in BOX.items()},
            "noise": NOISE, "sampler": sampler, "rank_draws": RANK_DRAWS} | _settings(sampler)
    store = STORE / sampler
    return [Task(f"campaign-{i:05d}", campaign, (task_seed(seed, i), sampler),
                 spec | {"index": i}, store / f"campaign-{i:05d}.json") for i in range(n)]


def _settings(sampler: str) -> dict:
    return ({"draws": DRAWS, "burn_in": BURN_IN, "thin": THIN, "chains": CHAINS}
            if sampler == "mh" else dict(ENSEMBLE))


def summary(rows: list[dict], seconds: float, seed: int, sampler: str = "ensemble") -> dict:
    n = len(rows)
    lo, hi = stats.binom.interval(0.99, n, 0.9)
    out: dict = {
        "study": "simulation-based calibration (Talts et al. 2018) of the population likelihood "
                 f"with the {sampler} sampler",
        "settings": {"campaigns": n, "n_trials": N_TRIALS, "box": {k: list(v) for k, v in
                                                                   BOX.items()},
                     "hyper_priors": "means uniform on the box, spreads uniform on [0, half "
                                     "the box]",
                     "population": "normal truncated to the box",
                     "incidence": "3 m/s at 60 deg, 0.05 m/s and 1 deg spread, measured "
                                  "exactly", "noise": NOISE,
                     "sampler": {sampler: _settings(sampler)},
                     "rank_draws": RANK_DRAWS, "bins": BINS, "seed": seed},
        "campaigns_done": n, "coverage_bounds_99": [lo / n, hi / n],
        "campaigns_with_rolling_bounces": int(sum(r["share_rolling_data"] > 0 for r in rows)),
        "adequacy_false_alarms": int(sum(not r["adequate"] for r in rows)),
        "grid_points_used": sorted({tuple(r["grid_points"]) for r in rows}),
        "median_seconds_per_campaign": float(np.median([r["seconds"] for r in rows])),
        "seconds": seconds, "parameters": {},
        "python": platform.python_version(), "numpy": np.__version__,
        "generated_at": datetime.now(timezone.utc).isoformat(timespec="seconds")}
    _parameters(out, rows, lo, hi)
    agreed = [r for r in rows if max(r[k]["r_hat"] or 1.0 for k in HYPER) <= RHAT_LIMIT]
    if agreed:  # where the tool gives no convergence warning
        m = len(agreed)
        lo2, hi2 = stats.binom.interval(0.99, m, 0.9)
        conv: dict = {"campaigns": m, "r_hat_at_most": RHAT_LIMIT, "parameters": {},
                      "coverage_bounds_99": [lo2 / m, hi2 / m]}
        _parameters(conv, agreed, lo2, hi2)
        out["chains_agree"] = conv
    if n > FIRST:  # the study's pre-set minimum, reported on its own too
        first: dict = {"campaigns": FIRST, "parameters": {}}
        lo1, hi1 = stats.binom.interval(0.99, FIRST, 0.9)
        first["coverage_bounds_99"] = [lo1 / FIRST, hi1 / FIRST]
        _parameters(first, rows[:FIRST], lo1, hi1)
        out["first_campaigns"] = first
    return out


def _parameters(out: dict, rows: list[dict], lo: float, hi: float) -> None:
    """Rank test and coverage per hyper-parameter into ``out["parameters"]``."""
    n = len(rows)
    for name in HYPER:
        ranks = np.array([r[name]["rank"] for r in rows])
        coverage = float(np.mean([r[name]["covered"] for r in rows]))
        test = rank_test(ranks, RANK_DRAWS, BINS)
        out["parameters"][name] = test | {
            "coverage90": coverage, "coverage_ok": bool(lo / n <= coverage <= hi / n),
            "uniform_ok": bool(test["chi2_p_value"] > 0.01),
            "max_r_hat": float(max(r[name]["r_hat"] or 1.0 for r in rows)),
            "median_ess_bulk": float(np.median([r[name]["ess_bulk"] or 0 for r in rows]))}


def main(argv=None) -> dict | None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--campaigns", type=int, default=300)
    ap.add_argument("--seed", type=int, default=SEED)
    ap.add_argument("--part", default="1/1", help="K/N: run every N-th campaign from K-1")
    ap.add_argument("--out", type=Path, default=RESULTS)
    ap.add_argument("--sampler", choices=("ensemble", "mh"), default="ensemble",
                    help="ensemble: the tool's default for the population likelihood")
    args = ap.parse_args(argv)
    k, n_parts = (int(x) for x in args.part.split("/"))
    (STORE / args.sampler).mkdir(parents=True, exist_ok=True)
    every = tasks(args.campaigns, args.seed, args.sampler)
    mine = every[k - 1::n_parts]
    outcome = run_tasks(mine, scheduler=SERIAL, progress=False, desc="population-sbc")
    done = [json.loads(t.record.read_text())["result"] for t in every
            if t.record is not None and t.record.is_file()]
    if len(done) < len(every):
        print(f"part {args.part}: {len(mine)} campaigns ({len(outcome.failed)} failed); "
              f"{len(done)} of {len(every)} stored")
        return None
    result = summary(done, outcome.seconds, args.seed, args.sampler)
    write_json(args.out, result)
    for name, p in result["parameters"].items():
        print(f"{name:<9} chi2 p = {p['chi2_p_value']:.3f}, coverage90 = {p['coverage90']:.3f} "
              f"(band {result['coverage_bounds_99'][0]:.3f}-{result['coverage_bounds_99'][1]:.3f}),"
              f" ranks {p['rank_histogram']}")
    print(f"written: {args.out}")
    return result


if __name__ == "__main__":
    main()
