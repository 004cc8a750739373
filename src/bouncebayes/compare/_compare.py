"""Compare candidate models (contact law + parameters + priors) on the same trials.

Every candidate is inferred with the same fixed settings: the gaussian likelihood (a density of
each trial's rebound, so that evidences and leave-one-out predictive densities of different
models compare), no model discrepancy (an inferred discrepancy would absorb the very misfit that
tells contact laws apart), and the noise of the experiment's [inference] table. Then, per model,
the evidence (grid quadrature where the dimension allows, nested sampling otherwise,
:mod:`._evidence`), PSIS-LOO (:mod:`._loo`) and the adequacy check of the inference; across
models, Bayes factors in words and a verdict (:mod:`._verdict`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .._validate import check_choice
from .._version import __version__
from ._evidence import LIVE_POINTS, grid_evidence, nested_evidence
from ._loo import loo_compare, loo_of, loo_record
from ._verdict import verdict

EVIDENCE_METHODS = ("auto", "grid", "nested")
#: grid points per parameter, by number of parameters: laws with a closed-form tangential
#: outcome, and with a tangential spring (every bounce an ODE solution, about 100 times dearer)
GRID_POINTS = {"closed": {1: 2048, 2: 512, 3: 96}, "spring": {1: 512, 2: 96}}
GRID_DRAWS = 4000  #: draws resampled from the grid (LOO, propagation, figures)
FIXED_SETTINGS: dict[str, Any] = {"likelihood": "gaussian", "discrepancy": "none"}


@dataclass(frozen=True)
class Plan:
    """How one candidate is inferred and how its evidence is computed."""

    name: str
    experiment: Any
    sampler: str
    config: Any
    evidence: str  #: "grid" or "nested"
    noise: str  #: "given" or "inferred"

    def settings(self) -> dict[str, Any]:
        return {**FIXED_SETTINGS, "noise": self.noise, "sampler": self.sampler,
                "sampler_settings": self.config.to_dict(), "evidence": self.evidence}


def select_candidates(experiment, names=None) -> dict:
    """The candidates to compare (all of [models] by default), by name, at least two."""
    models = dict(experiment.models)
    if not models:
        raise ValueError(f"{experiment.source}: no [models.NAME] tables: describe the candidate "
                         f"models there (docs/experiment-file.md, docs/comparison.md)")
    names = list(models) if names is None else list(names)
    unknown = [n for n in names if n not in models]
    if unknown:
        raise ValueError(f"`models`: {', '.join(map(repr, unknown))} not in "
                         f"{experiment.source}, whose candidates are {', '.join(models)}")
    if len(set(names)) < 2:
        raise ValueError(f"`models`: a comparison needs at least two different candidates; "
                         f"got {', '.join(names) or 'none'}")
    return {n: models[n] for n in dict.fromkeys(names)}


def plan_for(name: str, experiment, trials, *, evidence: str = "auto",
             grid_points: int | None = None, draws: int | None = None) -> Plan:
    """Grid quadrature where it is exact and affordable (up to 3 parameters, 2 with a
    tangential spring), else Metropolis–Hastings draws and nested sampling for the evidence."""
    from ..inference import sampler_config

    check_choice("evidence", evidence, EVIDENCE_METHODS)
    noise = experiment.inference["noise"]
    if noise == "auto":
        se = np.column_stack([trials.se["rebound_speed"], trials.se["rebound_angle"]])
        noise = "given" if bool(np.all(np.isfinite(se)) and np.all(se > 0)) else "inferred"
    dim = len(experiment.parameter_names) + (2 if noise == "inferred" else 0)
    kind = "closed" if experiment.tangential == "none" else "spring"
    if evidence == "grid" and dim > 3:
        raise ValueError(f"`evidence` grid: candidate {name!r} has {dim} parameters and the grid "
                         f"handles at most 3; use evidence='nested' or 'auto'")
    if evidence == "grid" or (evidence == "auto" and dim in GRID_POINTS[kind]):
        points = grid_points or GRID_POINTS[kind].get(dim, GRID_POINTS["closed"][dim])
        config = sampler_config("grid", draws=draws or GRID_DRAWS, points=points)
        return Plan(name, experiment, "grid", config, "grid", noise)
    return Plan(name, experiment, "mh", sampler_config("mh", draws=draws), "nested", noise)


@dataclass(frozen=True)
class Comparison:
    """The comparison: per model its record (comparison.json's ``models``), ArviZ's LOO
    comparison, the verdict, the settings; ``results``: each model's InferenceResult."""

    models: dict
    loo: dict
    verdict: dict
    settings: dict
    results: dict = field(repr=False, compare=False)

    def to_dict(self) -> dict[str, Any]:
        """The content of comparison.json."""
        return {"models": self.models, "verdict": self.verdict, "loo_comparison": self.loo,
                "settings": self.settings, "bouncebayes_version": __version__}


def compare_models(experiment, trials, models=None, *, seed: int = 0, evidence: str = "auto",
                   grid_points: int | None = None, draws: int | None = None,
                   live_points: int = LIVE_POINTS, progress: bool = False) -> Comparison:
    """Infer every candidate of ``experiment.models`` (``models``: names, default all) on
    ``trials`` with the comparison's fixed settings and compare them."""
    from ..inference import infer

    plans = {n: plan_for(n, c.experiment, trials, evidence=evidence, grid_points=grid_points,
                         draws=draws) for n, c in select_candidates(experiment, models).items()}
    results = {n: infer(p.experiment, trials, sampler=p.sampler, config=p.config, seed=seed,
                        noise=p.noise, progress=progress, **FIXED_SETTINGS)
               for n, p in plans.items()}
    return compare_results(results, plans, seed=seed, live_points=live_points,
                           progress=progress)


def compare_results(results: dict, plans: dict, *, seed: int, live_points: int = LIVE_POINTS,
                    progress: bool = False) -> Comparison:
    """Evidence, LOO, adequacy and the verdict for inference results of the same trials."""
    start = time.perf_counter()
    records, elpds = {}, {}
    for name, r in results.items():
        ev = (grid_evidence(r) if r.sampler == "grid"
              else nested_evidence(r, seed=seed, live_points=live_points, progress=progress))
        elpds[name] = loo_of(r)
        records[name] = _record(plans[name], r, ev.to_dict() | loo_record(elpds[name]))
    loo = loo_compare(elpds)
    for name, row in loo.items():
        records[name]["loo_rank"] = row["rank"]
    settings = {**FIXED_SETTINGS, "seed": int(seed), "live_points": int(live_points),
                "n_trials": next(iter(results.values())).trials.n,
                "why": "the gaussian likelihood is a density of each trial's rebound, so "
                       "evidences and LOO of different models compare; no model discrepancy, "
                       "so that the evidence judges the contact laws themselves",
                "seconds": time.perf_counter() - start}
    return Comparison(records, loo, verdict(records, loo), settings, results)


def _record(plan: Plan, r, scores: dict) -> dict[str, Any]:
    """One model's entry of comparison.json."""
    e, a = r.experiment, r.adequacy
    return {"description": e.description,
            "normal_law": e.normal_law, "tangential": e.tangential,
            "parameters": {p.name: {"prior": _prior_text(r, p.name), "result": p.paper_form(),
                                    "mean": p.mean, "sd": p.sd, "ci90": list(p.ci90),
                                    "unit": p.unit} for p in r.parameters},
            "n_parameters": len(r.names), **scores,
            "adequate": bool(a is None or a.adequate),
            "adequacy_verdict": None if a is None else a.verdict,
            "chi2_per_dof": None if a is None or a.dof <= 0 else a.chi2 / a.dof,
            **plan.settings(), "seconds": r.seconds, "warnings": list(r.warnings)}


def _prior_text(r, name: str) -> str:
    return r.posterior.priors[r.names.index(name)].describe()
