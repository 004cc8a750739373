"""One simulated campaign of a design (a study task): truth from the prior, synthetic trial
table with the design's standard errors, exact grid posterior for each number of bounces."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ._errors import design_document, kinematics_errors, table_errors

TRUTH_KEYS = {"mu": ("contact", "mu"), "eta": ("contact", "eta"),
              "youngs_modulus": ("ball", "youngs_modulus_Pa"), "spin": ("incidence", "spin_rad_s")}
ERROR_TRAJECTORIES = 16  #: simulated trajectories whose kinematics fit gives the errors


def setting_errors(doc: dict, setting: tuple, source: str, seed: int) -> dict[str, float]:
    """The trial-table standard errors of a setting (angle, speed, rate, noise)."""
    from ..data import parse_experiment

    angle, speed, rate, noise = setting
    exp = parse_experiment(design_document(doc, angle_deg=angle, speed_m_s=speed,
                                           frame_rate_hz=rate, position_noise_m=noise),
                           source="design")
    if source == "table":
        return table_errors(exp)
    return kinematics_errors(exp, seed=seed, n=ERROR_TRAJECTORIES)


def design_campaign(doc: dict, setting: tuple, n_bounces: tuple[int, ...], errors: dict,
                    truth_seed: int, seed: int, grid_points: int,
                    memory_budget: int | None = None) -> dict[str, Any]:
    """Posterior widths, information gain and identifiability of one campaign, for each number
    of bounces (the first n of one campaign of max(n_bounces)); ``memory_budget``: bytes
    each inference may hold (its default if None)."""
    from ..data import make_trials, parse_experiment, synthesize
    from ..inference import DEFAULT_MEMORY_BUDGET, GridConfig, infer

    angle, speed, rate, noise = setting
    base = parse_experiment(doc, source="design")
    truth = {k: float(p.sample(np.random.default_rng(truth_seed), 1)[0])
             for k, p in base.priors.items()}
    d = design_document(doc, angle_deg=angle, speed_m_s=speed, frame_rate_hz=rate,
                        position_noise_m=noise, errors=errors)
    for name, value in truth.items():
        table, key = TRUTH_KEYS[name]
        d.setdefault(table, {})[key] = value
    exp = parse_experiment(d, source="design")
    synth_seed, infer_seed = (int(s) for s in np.random.default_rng(seed).integers(0, 2**31 - 1, 2))
    campaign = synthesize(exp, seed=synth_seed, n=max(n_bounces))
    full = campaign.trials
    slid = np.array(campaign.truth["per_bounce"]["regime"]) == "slip"
    rows = {}
    for n in n_bounces:
        cut = {c: full.column(c)[:n] for c in errors}
        trials = make_trials(exp, rebound_speed=cut["rebound_speed"],
                             rebound_angle=cut["rebound_angle"],
                             incidence_speed=cut["incidence_speed"],
                             incidence_angle=cut["incidence_angle"],
                             se={c: np.asarray(full.se[c])[:n] for c in errors},
                             labels=full.labels[:n], source="design")
        result = infer(exp, trials, likelihood="gaussian", sampler="grid", seed=infer_seed,
                       noise="given", discrepancy="none",
                       config=GridConfig(draws=100, points=grid_points),
                       memory_budget=memory_budget or DEFAULT_MEMORY_BUDGET)
        run = result.draws.info
        rolling = result.regimes["share_rolling"]
        rows[str(n)] = {"sd": dict(zip(result.names, map(float, run.exact_sd), strict=True)),
                        "information_gain": information_gain(run.grid, result.posterior.priors),
                        "posterior_share_rolling": float(rolling),
                        "all_sliding": bool(slid[:n].all())}
    return {"truth": truth, "by_n": rows}


def information_gain(grid, priors) -> float:
    """Kullback–Leibler divergence from the prior to the posterior (nats), by quadrature on the
    posterior's grid (cells outside the grid hold below 1e-10 of the posterior)."""
    steps = [float(c[1] - c[0]) for c in grid.centres]
    log_prior = np.zeros(())
    for prior, c in zip(priors, grid.centres, strict=True):
        log_prior = np.add.outer(log_prior, prior.logpdf(c))
    p = grid.density
    mass = p * math.prod(steps)
    keep = p > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        terms = mass[keep] * (np.log(p[keep]) - np.broadcast_to(log_prior, p.shape)[keep])
    return float(np.sum(terms[np.isfinite(terms)]))
