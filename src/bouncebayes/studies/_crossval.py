"""K-fold cross-validation of predictions, and the model-discrepancy study.

:func:`kfold_coverage` asks of one campaign what a user asks of a calibrated model: fitted to
all bounces but a fold, do the 90 % posterior predictive intervals (``predict_bounces``) of the
held-out bounces' rebound speed and angle contain what was measured? For a model that describes
the data, about 90 % of them do.

:func:`discrepancy_campaign` is one task of the study behind the default of ``discrepancy``
(``benchmarks/discrepancy.py``, ``docs/likelihoods.md`` §5): a synthetic campaign of a scenario
(well specified, or generated with physics the fitted model lacks), fitted with each setting of
``discrepancy``; it records the adequacy verdict, whether the 90 % intervals hold the true
parameters, their widths, and the k-fold predictive coverage.
"""

from __future__ import annotations

import copy
import time
import tomllib
from typing import Any

import numpy as np

SCENARIOS: dict[str, dict[str, Any]] = {
    "well-specified": {},
    "another normal law": {"model__normal": "hunt-crossley", "contact__eta": 0.3},
    "spin scatter at 20 deg": {"incidence__angle_deg": 20.0, "incidence__spin_sd_rad_s": 100.0},
    "outliers": {},
}
#: what every scenario's fitted experiment shares: the demo's ball over a range of incidences
WIDE = {"incidence__speed_sd_m_s": 1.0, "incidence__angle_sd_deg": 12.0,
        "incidence__angle_deg": 45.0}
OUTLIERS = 3  #: corrupted trials of the "outliers" scenario, moved by OUTLIER_SIZE errors
OUTLIER_SIZE = 12.0


def scenario_experiment(edits: dict[str, Any]):
    """The demo's experiment over a range of incidences with ``section__key`` edits."""
    from ..data import demo_campaign, parse_experiment

    doc = tomllib.loads(demo_campaign().experiment.read_text(encoding="utf-8"))
    doc = copy.deepcopy(doc)
    for key, value in (WIDE | edits).items():
        section, name = key.split("__")
        doc[section][name] = value
    return parse_experiment(doc, source="study")


def subset(experiment, trials, rows: np.ndarray):
    """The trials at ``rows`` (every measured column, standard error and label kept; absent
    incidence columns at ``experiment``'s nominal values)."""
    from ..data import make_trials

    given = {c: np.asarray(trials.column(c))[rows] for c in trials.measured}
    se = {k: np.asarray(v)[rows] for k, v in trials.se.items() if np.all(np.isfinite(v))}
    return make_trials(experiment, rebound_speed=np.asarray(trials.rebound_speed)[rows],
                       rebound_angle=np.asarray(trials.rebound_angle)[rows], se=se,
                       labels=[trials.labels[i] for i in rows],
                       scale_rel_sd=np.asarray(trials.scale_rel_sd)[rows],
                       source=trials.source, **given)


def kfold_coverage(experiment, trials, *, folds: int = 5, seed: int = 0,
                   discrepancy: str = "none", draws: int = 4000,
                   n_predict: int = 1000) -> dict[str, Any]:
    """Share of held-out rebound speeds and angles inside their 90 % posterior predictive
    intervals, over ``folds`` folds (trials dealt to folds by a seeded permutation), each fold
    predicted from the mh posterior of the others (``draws`` draws)."""
    from ..inference import MHConfig, infer
    from ..propagation import predict_bounces

    rng = np.random.default_rng(seed)
    fold = rng.permutation(trials.n) % folds
    inside: dict[str, list[bool]] = {"rebound_speed": [], "rebound_angle": []}
    alarms = 0
    for k in range(folds):
        train = subset(experiment, trials, np.flatnonzero(fold != k))
        test = subset(experiment, trials, np.flatnonzero(fold == k))
        result = infer(experiment, train, sampler="mh", seed=seed + k,
                       config=MHConfig(draws=draws), discrepancy=discrepancy)
        alarms += result.adequacy is not None and not result.adequacy.adequate
        pred = predict_bounces(result, test, n_draws=n_predict, seed=seed + k)
        for name, hit in inside.items():
            y = np.asarray(test.column(name))
            hit.extend((pred.columns[f"{name}_q05"] <= y) & (y <= pred.columns[f"{name}_q95"]))
    return {name: float(np.mean(hit)) for name, hit in inside.items()} | {
        "held_out": int(trials.n), "folds": folds, "discrepancy": discrepancy,
        "folds_flagged": int(alarms)}


def scenario_campaign(name: str, seed: int, n: int):
    """A synthetic campaign of scenario ``name``: (fitted experiment, trials, truth)."""
    from ..data import make_trials, synthesize

    rng = np.random.default_rng(seed)
    fitted = scenario_experiment({k: v for k, v in SCENARIOS[name].items()
                                  if k == "incidence__angle_deg"})
    truth = scenario_experiment(SCENARIOS[name])
    c = synthesize(truth, seed=int(rng.integers(2**31)), n=n)
    trials = c.trials
    if name == "outliers":
        speed = np.array(trials.rebound_speed)
        rows = rng.choice(n, OUTLIERS, replace=False)
        speed[rows] += OUTLIER_SIZE * np.asarray(trials.se["rebound_speed"])[rows]
        trials = make_trials(fitted, rebound_speed=speed, rebound_angle=trials.rebound_angle,
                             incidence_speed=trials.incidence_speed,
                             incidence_angle=trials.incidence_angle, labels=trials.labels,
                             se={k: v for k, v in trials.se.items()
                                 if np.all(np.isfinite(v))})
    same_law = "model__normal" not in SCENARIOS[name]
    return fitted, trials, {"mu": 0.16} | ({"eta": 1.35} if same_law else {})


def discrepancy_campaign(name: str, seed: int, n: int, folds: int,
                         settings: tuple[str, ...]) -> dict[str, Any]:
    """One campaign of scenario ``name`` fitted with each ``discrepancy`` setting: adequacy,
    truth inside the 90 % intervals, their widths, seconds, and (for "none" and "normal")
    the k-fold predictive coverage."""
    from ..inference import MHConfig, infer

    experiment, trials, truth = scenario_campaign(name, seed, n)
    out: dict[str, Any] = {"scenario": name, "seed": seed, "truth": truth}
    for setting in settings:
        start = time.perf_counter()
        result = infer(experiment, trials, sampler="mh", seed=seed, discrepancy=setting,
                       config=MHConfig(draws=4000))
        record: dict[str, Any] = {"seconds": time.perf_counter() - start,
                                  "used": result.discrepancy,
                                  "adequate": bool(result.adequacy and result.adequacy.adequate)}
        if result.first_fit is not None:
            record["first_fit_adequate"] = result.first_fit["adequacy"]["adequate"]
        for p in result.parameters:
            if p.name in truth:
                record[p.name] = {"covered": bool(p.ci90[0] <= truth[p.name] <= p.ci90[1]),
                                  "width90": p.ci90[1] - p.ci90[0]}
        if setting in ("none", "normal") and folds:
            record["kfold"] = kfold_coverage(experiment, trials, folds=folds, seed=seed,
                                             discrepancy=setting)
        out[setting] = record
    return out
