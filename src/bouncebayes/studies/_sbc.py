"""Simulation-based calibration (Talts et al. 2018, arXiv:1804.06788) of the gaussian likelihood.

Each campaign (one task): draw ``(mu, eta)`` from the prior, synthesise a campaign with
:func:`bouncebayes.data.synthesize`, infer with the gaussian likelihood and the grid sampler
(exact quadrature: independent draws, no thinning needed), and record the rank of the true value
among the posterior draws and whether the 90 % interval holds it. If the inference is calibrated
the ranks are uniform on ``0..draws`` and the intervals hold the truth in 90 % of campaigns.
"""

from __future__ import annotations

import platform
import tomllib
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from ._tasks import Task, run_tasks, task_seed

NAMES = ("mu", "eta")
SBC_DEFAULTS: dict[str, Any] = {
    "campaigns": 300, "n_trials": 30, "draws": 999, "bins": 20, "grid_points": 512,
    "seed": 20180413, "mu_box": (0.0, 0.2), "eta_box": (0.0, 5.0), "memory_budget": None}


def sbc_experiment(mu: float, eta: float, settings: dict):
    """The paper's experiment (the bundled demo's file) with the study's uniform prior box and
    ``(mu, eta)`` as the synthetic truth."""
    from ..data import demo_campaign, parse_experiment

    doc = tomllib.loads(demo_campaign().experiment.read_text(encoding="utf-8"))
    doc["contact"] |= {"mu": float(mu), "eta": float(eta)}
    for name in NAMES:
        low, high = settings[f"{name}_box"]
        doc["parameters"][name] = {"prior": "uniform", "low": float(low), "high": float(high)}
    return parse_experiment(doc, source="sbc")


def sbc_campaign(seed: int, settings: dict) -> dict:
    """One campaign of the study from its own seed: truth from the prior, synthesis, grid
    posterior; the rank of the truth among the draws and the 90 % coverage per parameter."""
    from ..data import synthesize
    from ..inference import GridConfig, adequacy_failures as failures, infer

    rng = np.random.default_rng(seed)
    prior = sbc_experiment(0.1, 1.0, settings).priors
    theta = tuple(float(prior[k].sample(rng, 1)[0]) for k in NAMES)
    synth_seed, infer_seed = (int(s) for s in rng.integers(0, 2**31 - 1, size=2))
    exp = sbc_experiment(theta[0], theta[1], settings)
    c = synthesize(exp, seed=synth_seed, n=settings["n_trials"])
    config = GridConfig(draws=settings["draws"], points=settings["grid_points"])
    budget = settings.get("memory_budget")
    result = infer(exp, c.trials, likelihood="gaussian", sampler="grid", seed=infer_seed,
                   config=config, noise="given", discrepancy="none",
                   **({} if budget is None else {"memory_budget": budget}))
    a = result.adequacy
    out: dict[str, Any] = {"truth": dict(zip(NAMES, theta, strict=True)),
                           "share_rolling_data": c.truth["share_rolling"]}
    if a is not None:  # every fresh inference has it; a reloaded one may not
        out["adequacy"] = {"adequate": a.adequate, "chi2_p_value": a.p_value,
                           "worst_trial_p_value": a.worst_p_value, "failed": failures(a)}
    for i, name in enumerate(NAMES):
        draws = result.samples(name)
        p = result.parameters[result.names.index(name)]
        out[name] = {"rank": int(np.sum(draws < theta[i])),
                     "covered": bool(p.ci90[0] <= theta[i] <= p.ci90[1]),
                     "posterior_sd": p.sd}
    return out


def _check_memory(settings: dict) -> None:
    """Refuse, before any task, campaigns whose inference cannot fit the memory budget."""
    from ..inference import DEFAULT_MEMORY_BUDGET, GridConfig, plan_memory

    plan_memory(settings["n_trials"], len(NAMES), "grid",
                GridConfig(draws=settings["draws"], points=settings["grid_points"]),
                budget=settings.get("memory_budget") or DEFAULT_MEMORY_BUDGET)


def rank_test(ranks: np.ndarray, draws: int, bins: int) -> dict:
    """Histogram of the ranks (0..draws) in ``bins`` equal bins and Pearson's chi-square test."""
    from scipy import stats

    if (draws + 1) % bins:
        raise ValueError(f"`draws` + 1 ({draws + 1}) must be a multiple of `bins` ({bins})")
    counts = np.bincount(np.asarray(ranks) // ((draws + 1) // bins), minlength=bins)
    chi2, p = stats.chisquare(counts)
    return {"rank_histogram": counts.tolist(), "chi2": float(chi2), "chi2_dof": bins - 1,
            "chi2_p_value": float(p)}


def sbc_tasks(settings: dict, store: Path | None) -> list[Task]:
    """The study's tasks: campaign ``i`` seeded with :func:`task_seed` (seed, i)."""
    spec = {k: list(v) if isinstance(v, tuple) else v for k, v in settings.items()
            if k not in ("campaigns", "memory_budget")}  # neither changes a campaign's result
    return [Task(f"campaign-{i:05d}", sbc_campaign, (task_seed(settings["seed"], i), settings),
                 spec | {"index": i},
                 None if store is None else store / f"campaign-{i:05d}.json")
            for i in range(int(settings["campaigns"]))]


def run_sbc(campaigns: int | None = None, *, seed: int | None = None,
            store: Path | None = None, scheduler: str | None = "serial",
            workers: int | None = None, progress: bool = False,
            log: Callable[[str], None] | None = None, **overrides: Any) -> dict:
    """Run the study (``campaigns`` campaigns, default 300) and return its summary.

    Arguments:
        campaigns: synthetic campaigns (default 300).
        seed: the study's seed (campaign i gets :func:`task_seed` (seed, i)).
        store: folder of the per-campaign results (written as they arrive; a rerun with the
            same settings resumes); ``None``: keep nothing.
        scheduler: where to run: "serial", "local" or an address
            (:func:`bouncebayes.studies.run_tasks`).
        workers: processes of a local cluster.
        progress: a progress bar.
        log: receives the failure lines.
        overrides: settings of :data:`SBC_DEFAULTS` (``n_trials``, ``draws``, ``bins``,
            ``grid_points``, ``mu_box``, ``eta_box``, ``memory_budget``: bytes each
            campaign's inference may hold, checked before any task starts).
    """
    unknown = sorted(set(overrides) - set(SBC_DEFAULTS))
    if unknown:
        raise ValueError(f"`{unknown[0]}` is not a setting of the study; it has "
                         f"{', '.join(SBC_DEFAULTS)}")
    given = {"campaigns": campaigns, "seed": seed}
    settings = SBC_DEFAULTS | overrides | {k: v for k, v in given.items() if v is not None}
    _check_memory(settings)
    tasks = sbc_tasks(settings, store)
    outcome = run_tasks(tasks, scheduler=scheduler, workers=workers, progress=progress, log=log,
                        desc="sbc")
    rows = [r for r in outcome.ordered(tasks) if r is not None]
    return _summary(settings, rows, outcome)


def _false_alarms(rows: list[dict]) -> dict | None:
    """How often the adequacy check flags these well-specified campaigns, against its level
    (with the one-sided 99 % binomial upper bound of the level's count)."""
    from scipy import stats

    from ..inference import ADEQUACY_LEVEL

    flagged = [r for r in rows if "adequacy" in r]
    if not flagged:
        return None
    alarms = sum(not r["adequacy"]["adequate"] for r in flagged)
    n = len(flagged)
    return {"campaigns": n, "alarms": alarms, "false_alarm_rate": alarms / n,
            "level": ADEQUACY_LEVEL,
            "at_most_level_within_binomial": bool(
                alarms <= stats.binom.ppf(0.99, n, ADEQUACY_LEVEL)),
            "by_check": {k: sum(k in r["adequacy"]["failed"] for r in flagged)
                         for k in ("residuals", "trials", "distributions")}}


def _summary(settings: dict, rows: list[dict], outcome) -> dict:
    from scipy import stats

    from .._version import __version__

    n = len(rows)
    lo, hi = stats.binom.interval(0.99, n, 0.9) if n else (float("nan"),) * 2
    result: dict[str, Any] = {
        "study": "simulation-based calibration (Talts et al. 2018) of the gaussian likelihood "
                 "with the grid sampler",
        "settings": {k: list(v) if isinstance(v, tuple) else v for k, v in settings.items()}
                    | {"likelihood": "gaussian", "sampler": "grid", "noise": "given",
                       "incidence": "3 m/s at 60 deg (paper's experiment, demo noise levels)",
                       "seeding": "campaign i: numpy SeedSequence(seed).spawn(...)[i]"},
        "seed": settings["seed"], "campaigns_done": n, "failed": outcome.failed,
        "coverage_bounds_99": [lo / n, hi / n] if n else None,
        "campaigns_with_rolling_bounces": int(sum(r["share_rolling_data"] > 0 for r in rows)),
        "parameters": {}, "seconds": outcome.seconds, "where": outcome.where,
        "task_cpu_seconds": outcome.task_cpu_seconds, "resumed": len(outcome.resumed),
        "bouncebayes_version": __version__, "python": platform.python_version(),
        "numpy": np.__version__,
    }
    result["adequacy"] = _false_alarms(rows)
    for name in NAMES:
        if not n:
            break
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
    return result
