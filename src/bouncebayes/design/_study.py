"""The design study: tasks, aggregation over campaigns, identifiability, the recommendation."""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ._campaign import design_campaign, setting_errors
from ._space import MAX_GRID_PARAMETERS, DesignSpace, cost

PRIOR_DRAWS = 4000  #: prior-predictive campaigns behind each p_mu_identified
#: a design recommended for a target on mu must identify it with at least this probability
#: (below it a small sd may only reflect a lower bound of mu against the prior's upper end)
MIN_P_IDENTIFIED = 0.9
METHOD = ("simulated campaigns: for each design, `campaigns` truths drawn from the prior, a "
          "synthetic campaign each (bouncebayes.data.synthesize, the design's incidence and the "
          "trial-table standard errors it gives), the exact grid posterior of the gaussian "
          "likelihood (noise given) for each number of bounces (the first n bounces of one "
          "campaign); expected_sd is the mean over campaigns of the posterior sd, "
          "information_gain the mean Kullback-Leibler divergence from prior to posterior "
          "(nats); p_mu_identified the prior-predictive probability that every bounce of the "
          "campaign slides throughout. No Fisher-information shortcut is used.")


def study_key(doc: Mapping, space: DesignSpace, seed: int) -> str:
    """A short hash of everything the campaigns depend on (names the resume folder)."""
    text = json.dumps({"doc": doc, "space": space.to_dict(), "seed": seed}, sort_keys=True,
                      default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:12]


def design_tasks(doc: dict, space: DesignSpace, seed: int, store: Path | None,
                 memory_budget: int | None = None):
    """One task per (setting, campaign). Campaign j draws its truth from seed j of the study
    (the same truths at every setting: common random numbers across designs); task i is
    seeded with task_seed(seed, i); a setting's standard errors with its own seed."""
    from ..studies import Task, task_seed

    tasks, settings = [], space.settings()
    n_settings = len(settings)
    for s, setting in enumerate(settings):
        errors = setting_errors(doc, setting, space.errors, task_seed(seed + 1, s))
        for j in range(space.campaigns):
            i = s * space.campaigns + j
            key = f"design-{s:04d}-campaign-{j:04d}"
            args = (doc, setting, space.n_bounces, errors, task_seed(seed, n_settings
                    * space.campaigns + j), task_seed(seed, i), space.grid_points,
                    memory_budget)
            spec = {"setting": list(setting), "campaign": j, "errors": errors,
                    "study": study_key(doc, space, seed)}
            tasks.append(Task(key, design_campaign, args, spec,
                              None if store is None else store / f"{key}.json"))
    return tasks


def run_design(doc: dict, space: DesignSpace, *, seed: int = 0, targets: Mapping | None = None,
               store: Path | None = None, scheduler: str | None = "serial",
               workers: int | None = None, progress: bool = False,
               log: Callable[[str], None] | None = None,
               memory_budget: int | None = None) -> dict[str, Any]:
    """Evaluate every design of ``space`` for the experiment document ``doc`` (parsed TOML)
    and recommend the cheapest reaching ``targets`` (parameter -> posterior sd); returns the
    content of design.json. ``store``, ``scheduler``, ``workers``: as
    :func:`bouncebayes.studies.run_tasks`; ``memory_budget``: bytes each campaign's inference
    may hold (the largest is planned before any task starts, and refused if it cannot fit)."""
    from ..data import parse_experiment
    from ..studies import run_tasks

    experiment = parse_experiment(doc, source="design")
    names = experiment.parameter_names
    if not 1 <= len(names) <= MAX_GRID_PARAMETERS:
        raise ValueError(f"the design study uses the grid posterior (1 to 3 inferred "
                         f"parameters); the experiment infers {len(names)}")
    targets = check_targets(targets or {}, names)
    check_memory(space, len(names), memory_budget)
    tasks = design_tasks(doc, space, seed, store, memory_budget)
    outcome = run_tasks(tasks, scheduler=scheduler, workers=workers, progress=progress,
                        log=log, desc="design")
    designs = aggregate(experiment, space, tasks, outcome.results, seed)
    for d in designs:
        d["reaches_targets"] = reaches(d, targets) if targets else None
    return {"designs": designs, "recommended": recommend(designs, targets),
            "targets": dict(targets), "method": METHOD, "space": space.to_dict(),
            "seed": seed, "parameters": {n: experiment.unit(n) for n in names},
            "boundary": boundaries(experiment, space),
            "failed": outcome.failed, "where": outcome.where, "seconds": outcome.seconds,
            "task_cpu_seconds": outcome.task_cpu_seconds}


def check_memory(space: DesignSpace, dim: int, memory_budget: int | None) -> None:
    """Refuse, before any task, a study whose largest campaign cannot be inferred within the
    memory budget (each task would fail after simulating it)."""
    from ..inference import DEFAULT_MEMORY_BUDGET, GridConfig, MemoryBudgetError, plan_memory

    n = max(space.n_bounces)
    try:
        plan_memory(n, dim, "grid", GridConfig(draws=100, points=space.grid_points),
                    budget=memory_budget or DEFAULT_MEMORY_BUDGET)
    except MemoryBudgetError as exc:
        raise ValueError(f"the largest campaign ({n} bounces) cannot be inferred: {exc}; or "
                         f"lower `n_bounces`") from None


def check_targets(targets: Mapping, names) -> dict[str, float]:
    """Targets name inferred parameters and are positive numbers."""
    out = {}
    for k, v in targets.items():
        if k not in names:
            raise ValueError(f"`target` names {k!r}, which is not inferred; the experiment "
                             f"infers {', '.join(names)}")
        if isinstance(v, bool) or not isinstance(v, int | float) or not 0 < v < math.inf:
            raise ValueError(f"`target` of {k} must be a positive number; got {v!r}")
        out[k] = float(v)
    return out


def aggregate(experiment, space: DesignSpace, tasks, results: Mapping, seed: int) -> list[dict]:
    """One record per design from the campaigns that finished."""
    designs = []
    for s, setting in enumerate(space.settings()):
        mine = [results[t.key] for t in tasks[s * space.campaigns:(s + 1) * space.campaigns]
                if t.key in results]
        errors = tasks[s * space.campaigns].args[3]
        p_id = p_mu_identified(experiment, setting, space.n_bounces, seed + s)
        for n in space.n_bounces:
            rows = [r["by_n"][str(n)] for r in mine]
            designs.append(_record(setting, n, rows, errors, p_id.get(n), experiment))
    return designs


def _mean_mcse(values) -> tuple[float, float]:
    v = np.asarray(values, dtype=float)
    if v.size == 0:
        return math.nan, math.nan
    return float(v.mean()), float(v.std(ddof=1) / math.sqrt(v.size)) if v.size > 1 else math.nan


def _record(setting, n, rows, errors, p_id, experiment) -> dict:
    angle, speed, rate, noise = setting
    names = experiment.parameter_names
    sd = {k: _mean_mcse([r["sd"][k] for r in rows]) for k in names}
    gain = _mean_mcse([r["information_gain"] for r in rows])
    return {"angle_deg": angle, "speed_m_s": speed, "n_bounces": n, "frame_rate_hz": rate,
            "position_noise_m": noise, "cost": cost(n, rate), "standard_errors": errors,
            "expected_sd": {k: v[0] for k, v in sd.items()},
            "expected_sd_mcse": {k: v[1] for k, v in sd.items()},
            "p_mu_identified": p_id,
            "share_campaigns_sliding": (float(np.mean([r["all_sliding"] for r in rows]))
                                        if rows else math.nan),
            "information_gain": gain[0], "information_gain_mcse": gain[1],
            "campaigns": len(rows)}


def p_mu_identified(experiment, setting, n_bounces, seed: int) -> dict[int, float | None]:
    """Prior-predictive probability that every one of n bounces slides throughout (mu is then
    identified), from PRIOR_DRAWS campaigns of max(n) bounces (parameters from the prior,
    incidences from the experiment's spreads); None when mu is not inferred."""
    from ..model import simulate

    if "mu" not in experiment.priors:
        return {n: None for n in n_bounces}
    angle, speed, _, _ = setting
    rng = np.random.default_rng(seed)
    k, m = PRIOR_DRAWS, max(n_bounces)
    theta = {name: experiment.priors[name].sample(rng, k)[:, None]
             for name in experiment.priors}
    inc = experiment.incidence
    args = {"mu": theta["mu"], "eta": theta.get("eta", experiment.fixed_value("eta")),
            "speed": np.abs(speed + inc.speed_sd * rng.standard_normal((k, m))),
            "angle": np.clip(angle + inc.angle_sd * rng.standard_normal((k, m)), 0.0, 89.9),
            "spin": theta.get("spin", inc.spin)}
    if "youngs_modulus" in theta:
        args["youngs_modulus"] = theta["youngs_modulus"]
    out = simulate(experiment.ball, **args, inclination=experiment.inclination,
                   normal_law=experiment.normal_law, gravity=experiment.gravity, errors="flag")
    sliding = out.ok & ~out.rolling
    return {n: float(np.mean(sliding[:, :n].all(axis=1))) for n in n_bounces}


def reaches(design: dict, targets: Mapping) -> bool:
    """Every targeted parameter's expected sd is at or below its target, and a targeted mu is
    identified with probability at least MIN_P_IDENTIFIED."""
    p = design["p_mu_identified"]
    if "mu" in targets and p is not None and p < MIN_P_IDENTIFIED:
        return False
    return all(design["expected_sd"][k] <= v for k, v in targets.items())


def recommend(designs: list[dict], targets: Mapping) -> dict | None:
    """The cheapest design reaching the targets (ties: the larger information gain), or a
    record saying why there is none."""
    if not targets:
        return {"design": None, "reason": "no target widths given (--target mu=0.01,...)"}
    ok = [d for d in designs if d["reaches_targets"]]
    if not ok:
        worst = min(designs, key=lambda d: max(d["expected_sd"][k] / v
                                               for k, v in targets.items()))
        return {"design": None, "reason": "no candidate design reaches the targets; closest: "
                f"{describe(worst)}", "closest": worst}
    best = min(ok, key=lambda d: (d["cost"], -d["information_gain"]))
    return {"design": best, "reason": f"the cheapest design (cost {best['cost']:g}) whose "
                                      f"expected posterior sd reaches every target"
                                      + (f" and that identifies mu with probability >= "
                                         f"{MIN_P_IDENTIFIED:g}" if "mu" in targets else "")}


def describe(d: dict) -> str:
    """One design in words."""
    return (f"{d['n_bounces']} bounces at {d['angle_deg']:g} deg, {d['speed_m_s']:g} m/s, "
            f"{d['frame_rate_hz']:g} frames/s, position noise {d['position_noise_m']:g} m")


def sliding_boundary(experiment, mu: float, eta: float, speed: float) -> float | None:
    """The smallest incidence angle (deg) at which a bounce with ``mu``, ``eta`` at ``speed``
    slides throughout (bisection on the simulator; rolling sets in below it); None if it rolls
    at every angle below 89 deg."""
    from ..model import simulate

    def slides(angle: float) -> bool:
        r = simulate(experiment.ball, mu=mu, eta=eta, speed=speed, angle=angle,
                     inclination=experiment.inclination, normal_law=experiment.normal_law,
                     gravity=experiment.gravity)
        return not bool(r.rolling)

    lo, hi = 0.5, 89.0
    if not slides(hi):
        return None
    if slides(lo):
        return lo
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if slides(mid) else (mid, hi)
    return hi


def boundaries(experiment, space: DesignSpace) -> dict[str, Any]:
    """Sliding/rolling boundary angles at the first speed: for the experiment's [contact] mu
    (if given) and for the prior's upper end of mu (above it every mu of the prior slides)."""
    if "mu" not in experiment.priors:
        return {}
    eta = experiment.contact.get("eta", 0.0) if "eta" in experiment.priors else \
        experiment.fixed_value("eta")
    speed = space.speeds_m_s[0]
    out: dict[str, Any] = {"speed_m_s": speed, "eta": eta}
    if "mu" in experiment.contact:
        mu = experiment.contact["mu"]
        out["contact_mu"] = {"mu": mu, "angle_deg": sliding_boundary(experiment, mu, eta, speed)}
    top = experiment.priors["mu"].box(1e-3)[1]
    out["prior_upper_mu"] = {"mu": top, "angle_deg": sliding_boundary(experiment, top, eta, speed)}
    return out
