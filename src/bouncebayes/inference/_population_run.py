"""The population likelihood's inference: hyper-parameter draws, then what they say about a new
bounce (the population predictive), about each measured bounce (estimates and shrinkage), and
whether the model reproduces the data (a mixed-predictive adequacy check)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import stats

from ._adequacy import Adequacy, _mahalanobis, _trends, distribution_check, failures
from ._draws import Draws
from ._pass import Replicates
from ._population import (BOUNCE_DRAWS, ERROR_DRAWS, PREDICTIVE_DRAWS, ROLLING_LIMIT,
                          PopulationLikelihood, sample_population)

QUADRATURE_LIMIT = 0.1  #: variation of the log-likelihood's error (nats) over the draws above
#: which the grid's spacing is halved and the hyper-parameters sampled again
PREDICTIVE_QUANTILES = (0.05, 0.5, 0.95)
BOUNCE_FIELDS = ("mean", "sd", "alone_mean", "alone_sd", "shrinkage")


@dataclass(frozen=True)
class Population:
    """What the population posterior says beyond its hyper-parameters.

    ``predictive`` (chains, draws, d): one new bounce's parameters per posterior draw (what a
    DEM user samples from); ``bounces``: per trial and parameter, the estimate under the
    population (``mean``, ``sd``), the trial's own (``alone_mean``, ``alone_sd``: its likelihood
    times the prior) and the ``shrinkage`` (the share of the way from its own estimate to the
    population mean that the population moved it); ``record``: the summary.json object."""

    names: tuple[str, ...]
    units: tuple[str, ...]
    predictive: np.ndarray
    bounces: dict[str, np.ndarray]  #: "<p>_<field>" -> (trials,)
    record: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return self.record


def rolling_share(like: PopulationLikelihood, theta: np.ndarray) -> np.ndarray:
    """(trials,): each measured bounce's posterior probability of leaving rolling, averaged
    over the hyper-parameter rows ``theta``."""
    g = like.grid
    w = like.weights(theta)
    roll = g.rolling.astype(float)
    if len(w) == 1:
        num, den = w[0] @ (g.relative * roll).T, w[0] @ g.relative.T
    else:
        num = np.einsum("rj,ijk,rk->ri", w[0], g.relative * roll, w[1], optimize=True)
        den = np.einsum("rj,ijk,rk->ri", w[0], g.relative, w[1], optimize=True)
    return np.mean(num / np.maximum(den, 1e-300), axis=0)


def bounce_estimates(like: PopulationLikelihood, theta: np.ndarray, priors,
                     population_mean: np.ndarray) -> dict[str, np.ndarray]:
    """Per trial and parameter: posterior mean and sd under the population (averaged over the
    hyper-parameter rows), alone (likelihood times the prior on the grid), and shrinkage."""
    g = like.grid
    w = like.weights(theta)
    rel = g.relative if len(w) > 1 else g.relative[:, :, None]
    if len(w) == 1:
        w = w + [np.ones((theta.shape[0], 1))]
    out: dict[str, np.ndarray] = {}
    prior_w = [np.exp(p.logpdf(c)) for p, c in zip(priors, g.nodes, strict=True)]
    if len(prior_w) == 1:
        prior_w.append(np.ones(1))
    for k, name in enumerate(like.names):
        c = g.nodes[k]
        if k == 0:
            joint = np.einsum("ijk,rk->irj", rel, w[1], optimize=True) * w[0][None]
            alone = np.einsum("ijk,k->ij", rel, prior_w[1]) * prior_w[0][None]
        else:
            joint = np.einsum("ijk,rj->irk", rel, w[0], optimize=True) * w[1][None]
            alone = np.einsum("ijk,j->ik", rel, prior_w[0]) * prior_w[1][None]
        p = joint / np.maximum(joint.sum(axis=-1, keepdims=True), 1e-300)
        m1 = p @ c
        m2 = p @ (c * c)
        mean = m1.mean(axis=1)
        var = np.maximum(m2.mean(axis=1) - mean**2, 0.0)  # total variance over the draws
        a = alone / np.maximum(alone.sum(axis=-1, keepdims=True), 1e-300)
        a_mean = a @ c
        a_sd = np.sqrt(np.maximum(a @ (c * c) - a_mean**2, 0.0))
        gap = a_mean - population_mean[k]
        with np.errstate(divide="ignore", invalid="ignore"):
            shrink = np.where(np.abs(gap) > 1e-3 * (c[-1] - c[0]), (a_mean - mean) / gap,
                              np.nan)
        out |= {f"{name}_mean": mean, f"{name}_sd": np.sqrt(var), f"{name}_alone_mean": a_mean,
                f"{name}_alone_sd": a_sd, f"{name}_shrinkage": shrink}
    return out


def _even(n: int, k: int) -> np.ndarray:
    return np.unique(np.linspace(0, n - 1, min(n, k)).round().astype(int))


def replicate(like: PopulationLikelihood, draws: Draws, rng: np.random.Generator):
    """Replicated measurements of every trial at evenly spaced draws: per draw and trial a new
    bounce's parameters from the population (mixed replication: Gelman, Meng & Stern 1996,
    Statistica Sinica 6, 733), its rebound at the trial's own incidence, plus its noise. Also
    the rolling flags of those bounces and the number that failed."""
    chains, n, _ = draws.samples.shape
    pick = _even(n, math.ceil(PREDICTIVE_DRAWS / chains))
    flat = draws.samples[:, pick].reshape(-1, draws.samples.shape[-1])
    n_trials = len(like.observations)
    cov = like.gauss.covariances(flat[:1, ::2])[0]
    l00 = np.sqrt(cov[:, 0, 0])
    l10 = cov[:, 0, 1] / l00
    l11 = np.sqrt(np.maximum(cov[:, 1, 1] - l10**2, 0.0))
    speed = np.empty((flat.shape[0], n_trials))
    angle = np.empty_like(speed)
    rolling = np.zeros_like(speed, dtype=bool)
    ok = np.zeros_like(speed, dtype=bool)
    for r, row in enumerate(flat):
        theta = np.column_stack([
            sample_population(rng, np.full(n_trials, row[2 * k]), np.full(n_trials, row[2 * k + 1]),
                              like.domains[k], like.family) for k in range(len(like.names))])
        h = like.forward(theta)
        diag = np.arange(n_trials)
        speed[r], angle[r] = h.speed[diag, diag], h.angle[diag, diag]
        rolling[r], ok[r] = h.rolling[diag, diag], h.ok[diag, diag]
    z = rng.standard_normal((2,) + speed.shape)
    speed = np.where(ok, speed + l00 * z[0], np.nan)
    angle = np.where(ok, angle + l10 * z[0] + l11 * z[1], np.nan)
    shape = (chains, pick.size, n_trials)
    return Replicates(pick, speed.reshape(shape), angle.reshape(shape)), rolling, ok


def regimes(rolling: np.ndarray, ok: np.ndarray) -> dict:
    """The friction regimes of the replicated new bounces (rows: draws, columns: trials)."""
    roll = np.where(ok, rolling, False)
    per = roll.sum(axis=1) / np.maximum(ok.sum(axis=1), 1)
    rows = max(roll.shape[0], 1)
    return {"share_rolling": float(roll.sum() / max(ok.sum(), 1)),
            "draws_all_slip": float(np.sum(per == 0.0) / rows),
            "draws_all_roll": float(np.sum(per == 1.0) / rows),
            "draws_mixed": float(np.sum((per > 0) & (per < 1)) / rows),
            "failed_simulations": int(np.count_nonzero(~ok)),
            "conditions": "per trial: a new bounce from the population at each trial's incidence",
            "n_draws": int(roll.shape[0])}


def adequacy(replicates: Replicates, trials) -> Adequacy:
    """The adequacy checks against each trial's own mixed predictive distribution (approximated
    as normal by its replicates' mean and covariance): standardised residuals, their
    chi-square with 2 n degrees of freedom, per-trial p-values, and the distribution check."""
    from ._adequacy import _with_verdict

    y = np.column_stack([trials.rebound_speed, trials.rebound_angle]).astype(float)
    s = replicates.rebound_speed.reshape(-1, y.shape[0])
    a = replicates.rebound_angle.reshape(-1, y.shape[0])
    n = y.shape[0]
    z = np.full((n, 2), np.nan)
    d2 = np.full(n, np.nan)
    for i in range(n):
        ok = np.isfinite(s[:, i]) & np.isfinite(a[:, i])
        if ok.sum() < 10:
            continue
        pool = np.column_stack([s[ok, i], a[ok, i]])
        mean, cov = pool.mean(axis=0), np.cov(pool, rowvar=False)
        d = y[i] - mean
        z[i] = d / np.sqrt(np.diag(cov))
        d2[i] = _mahalanobis(d[:1], d[1:], cov[None])[0]
    good = np.isfinite(d2)
    chi2 = float(np.sum(d2[good]))
    dof = 2 * int(good.sum())
    p = float(stats.chi2.sf(chi2, dof)) if dof > 0 else float("nan")
    ppp = np.exp(-0.5 * d2)
    dist = distribution_check({"rebound_speed": y[:, 0], "rebound_angle": y[:, 1]},
                              {"rebound_speed": s.ravel(), "rebound_angle": a.ravel()})
    basis = ("each trial's population predictive distribution (a new bounce from the "
             "population at the trial's incidence, plus its noise; mean and covariance of the "
             "replicates)")
    out = Adequacy(tuple(trials.labels), z[:, 0], z[:, 1], ppp, chi2, dof, p, dist, basis,
                   _trends(z, trials))
    return _with_verdict(out, failures(out))


def quadrature_error(like: PopulationLikelihood, draws: Draws) -> tuple[float, float]:
    """The error of the log-likelihood at evenly spaced draws, by Richardson extrapolation (the
    grid of every other node has about 4 times the full grid's error, h^2, so the full grid's
    is about a third of their difference): its variation over the draws (5 to 95 % range:
    what moves the posterior; a constant offset does not) and its largest size."""
    flat = draws.samples.reshape(-1, draws.samples.shape[-1])
    rows = flat[_even(flat.shape[0], ERROR_DRAWS)]
    diff = (like(rows) - like.on_coarser_grid(rows)) / 3.0
    diff = diff[np.isfinite(diff)]
    if not diff.size:
        return float("inf"), float("inf")
    q = np.quantile(diff, [0.05, 0.95])
    return float(q[1] - q[0]), float(np.max(np.abs(diff)))


def log_likelihood(like: PopulationLikelihood, draws: Draws) -> np.ndarray:
    """(chains, draws, trials) per-trial log marginal likelihood of every draw."""
    chains, n, d = draws.samples.shape
    flat = draws.samples.reshape(-1, d)
    out = np.empty((flat.shape[0], len(like.observations)))
    for s in range(0, flat.shape[0], 4096):
        out[s:s + 4096] = like.pointwise(flat[s:s + 4096])
    return out.reshape(chains, n, -1)


def describe_population(like: PopulationLikelihood, units: tuple[str, ...],
                        predictive: np.ndarray, hyper: dict[str, np.ndarray],
                        bounces: dict[str, np.ndarray], share_rolling: float,
                        quad_error: tuple[float, float]) -> tuple[dict, list[str]]:
    """The summary.json ``population`` object and the words of the result."""
    flat = predictive.reshape(-1, predictive.shape[-1])
    record: dict[str, Any] = {"family": like.family, "parameters": list(like.names),
                              "predictive": {}, "bounces": {},
                              "share_of_bounces_rolling": share_rolling,
                              "quadrature_error_log_likelihood": {
                                  "variation_over_draws": quad_error[0],
                                  "largest": quad_error[1],
                                  "meaning": "Richardson estimate (nats) of the grid's error of "
                                             "the log-likelihood at posterior draws; its "
                                             "variation moves the posterior, a constant offset "
                                             "does not"}}
    words = []
    for k, (name, unit) in enumerate(zip(like.names, units, strict=True)):
        x = flat[:, k]
        q = np.quantile(x, PREDICTIVE_QUANTILES)
        u = f" {unit}" if unit else ""
        entry = {"mean": float(np.mean(x)), "sd": float(np.std(x, ddof=1)),
                 "quantiles": {f"{100 * p:g}%": float(v) for p, v in
                               zip(PREDICTIVE_QUANTILES, q, strict=True)}, "unit": unit}
        rolls = name == "mu" and share_rolling >= ROLLING_LIMIT
        if rolls:
            lower = float(np.quantile(hyper[f"{name}_mean"], 0.05))
            entry["bound"] = {"side": "lower", "value": lower, "level": 0.95,
                              "of": f"{name}_mean"}
            text = (f"{100 * share_rolling:.0f} % of the bounces leave rolling, and a rolling "
                    f"rebound does not depend on mu: the data only bound the population of mu "
                    f"from below (population mean mu > {lower:.3g} at 95 %); its spread and "
                    f"upper values are not measured, so no range of mu from contact to contact "
                    f"is given")
        else:
            text = (f"{name} varies from contact to contact: 90 % of new bounces between "
                    f"{q[0]:.3g} and {q[2]:.3g}{u} (median {q[1]:.3g}{u}), population mean "
                    f"{np.mean(hyper[f'{name}_mean']):.3g}{u} and spread (sd) "
                    f"{np.mean(hyper[f'{name}_sd']):.3g}{u}, uncertainties included")
        entry["statement"] = text
        words.append(text)
        record["predictive"][name] = entry
        shrink = bounces[f"{name}_shrinkage"]
        record["bounces"][name] = {
            "median_shrinkage": (float(np.nanmedian(shrink)) if np.isfinite(shrink).any()
                                 else None),
            "median_sd_alone": float(np.median(bounces[f"{name}_alone_sd"])),
            "median_sd_with_population": float(np.median(bounces[f"{name}_sd"]))}
    record["statements"] = words
    return record, words


def run_population(like: PopulationLikelihood, draws: Draws, experiment, trials,
                   rng: np.random.Generator):
    """Everything after the sampler: the per-trial log-likelihood, the predictive, the
    per-bounce estimates, the replicates, regimes and adequacy, the quadrature error."""
    rng_pred, rng_rep = rng.spawn(2)
    names = like.names
    units = tuple(experiment.unit(n) for n in names)
    s = draws.samples
    predictive = np.stack([sample_population(rng_pred, s[..., 2 * k].ravel(),
                                             s[..., 2 * k + 1].ravel(), like.domains[k],
                                             like.family).reshape(s.shape[:2])
                           for k in range(len(names))], axis=-1)
    flat = s.reshape(-1, s.shape[-1])
    some = flat[_even(flat.shape[0], BOUNCE_DRAWS)]
    priors = tuple(experiment.priors[n] for n in names)
    centre = predictive.reshape(-1, len(names)).mean(axis=0)
    bounces = bounce_estimates(like, some, priors, centre)
    share = float(np.mean(rolling_share(like, some)))
    reps, rolling, ok = replicate(like, draws, rng_rep)
    hyper = {n: flat[:, i] for i, n in enumerate(_hyper(names))}
    quad = quadrature_error(like, draws)
    record, words = describe_population(like, units, predictive, hyper, bounces, share, quad)
    record["grid_points"] = [int(c.size) for c in like.grid.nodes]
    pop = Population(names, units, predictive, bounces, record)
    return pop, reps, regimes(rolling, ok), adequacy(reps, trials), log_likelihood(like, draws)


def _hyper(names):
    from ._population import hyper_names

    return hyper_names(names)


def population_warnings(like: PopulationLikelihood, pop: Population) -> list[str]:
    """The grid's resolution, in words, where it limits the result."""
    out = []
    g = like.grid
    quad = pop.record["quadrature_error_log_likelihood"]["variation_over_draws"]
    if not quad <= QUADRATURE_LIMIT:
        out.append(f"the integration grid ({' x '.join(str(c.size) for c in g.nodes)} nodes) "
                   f"resolves the trials' likelihoods only roughly: the log-likelihood may be "
                   f"off by {quad:.2g} (interpolation miss {g.interpolation_error:.2g} of a "
                   f"trial's peak): the measurement errors are very small compared with the "
                   f"prior box; narrow the priors to where the bounces lie")
    return out


def infer_population(experiment, trials, sampler: str, seed: int, config, noise: str,
                     discrepancy: str, family: str, progress: bool, budget: int):
    """:func:`~bouncebayes.inference.infer` with the population likelihood: the hyper-parameters
    sampled by ``sampler``, then :func:`run_population`."""
    import dataclasses
    import time

    from ._checks import data_warnings
    from ._ensemble import sample_ensemble
    from ._grid import sample_grid
    from ._infer import InferenceResult, plan_memory
    from ._config import MHConfig
    from ._mh import sample_mh
    from ._population import hyper_names, hyper_priors, make_population, refined
    from ._posterior import LogPosterior

    names = experiment.parameter_names
    hyper = hyper_names(names)
    if isinstance(config, MHConfig) and config.burn_in < BURN_IN:
        # the paper's 100 burn-in iterations tune the proposal of a posterior with its mode
        # inside the box; a spread's posterior piled at zero needs longer to tune
        config = dataclasses.replace(config, burn_in=BURN_IN)
    plan_memory(trials.n, len(hyper), sampler, config, "population", budget)
    notes = data_warnings(experiment, trials)
    start = time.perf_counter()
    _, rng_sampler, rng_pass = np.random.default_rng(seed).spawn(3)
    priors = hyper_priors(experiment, names)
    units = tuple(experiment.unit(n) for n in names for _ in (0, 1))
    run = {"mh": sample_mh, "ensemble": sample_ensemble, "grid": sample_grid}[sampler]
    points = None
    while True:  # the grid is judged again where the posterior lies, and refined if needed
        like = make_population(experiment, trials, names, family=family, noise=noise,
                               discrepancy=discrepancy, memory_budget=0.5 * budget,
                               points=points)
        post = LogPosterior(hyper, tuple(priors[h] for h in hyper), units, like)
        points = refined(like.grid.nodes[0].size, len(names))
        draws = run(post, config, rng_sampler.spawn(1)[0], progress)  # type: ignore[operator]
        if quadrature_error(like, draws)[0] <= QUADRATURE_LIMIT or points is None:
            break
    pop, reps, regime, check, loglik = run_population(like, draws, experiment, trials,
                                                      rng_pass)
    params, warns = _summaries(post, draws, pop, check, notes)
    return InferenceResult(experiment, trials, "population", sampler, int(seed), config, post,
                           draws, tuple(params), regime, tuple(warns), like.describe(),
                           time.perf_counter() - start, loglik, reps, budget, check,
                           discrepancy, None, pop)


def _summaries(post, draws: Draws, pop: Population, check: Adequacy, notes: list[str]):
    """The hyper-parameters' summaries (spreads at zero and mu's population among rolling
    bounces as bounds) and the warnings in words."""
    from ._summary import diagnostics, summarize_parameter, warnings_for

    diag = diagnostics(draws.samples, post.names)
    misfit = "" if check.adequate else MISFIT
    share = pop.record["share_of_bounces_rolling"]
    params = []
    for i, (h, u, p) in enumerate(zip(post.names, post.units, post.priors, strict=True)):
        x = draws.samples[..., i].ravel()
        s = summarize_parameter(h, u, p, x, diag[h], misfit=misfit)
        params.append(_population_bound(s, x, share))
    warns = notes + ([] if check.adequate else [check.verdict]) + warnings_for(
        params, draws.samples, post.priors, draws.info, impossible_data=bool(notes))
    return params, warns + population_warnings(post.likelihood, pop)


BURN_IN = 2000  #: mh burn-in with the default settings (the paper's 100 tunes too little)
MISFIT = "the model misfits the data; see the adequacy verdict"
SPREAD_AT_ZERO = 0.1  #: 5 % quantile below this share of the 95 %: the spread reaches zero


def _population_bound(s, x: np.ndarray, share_rolling: float):
    """A spread whose posterior reaches zero is an upper bound (the data show no spread larger
    than it); with most bounces rolling, mu's population mean is a lower bound and its spread
    is not identified (a rolling rebound does not depend on mu)."""
    import dataclasses

    name = s.name
    lo, hi = np.quantile(x, [0.05, 0.95])
    if name == "mu_mean" and share_rolling >= ROLLING_LIMIT:
        why = (f"{100 * share_rolling:.0f} % of the bounces leave rolling, and a rolling rebound "
               f"does not depend on mu: the data only bound the population of mu from below")
        return dataclasses.replace(s, identifiable=False, why_not_identified=why,
                                   bound={"side": "lower", "value": float(lo), "level": 0.95})
    if name == "mu_sd" and share_rolling >= ROLLING_LIMIT:
        why = (f"{100 * share_rolling:.0f} % of the bounces leave rolling, where mu does not "
               f"change the rebound: the spread of mu from contact to contact is not measured")
        return dataclasses.replace(s, identifiable=False, why_not_identified=why)
    if name.endswith("_sd") and lo < SPREAD_AT_ZERO * hi:
        why = (f"the posterior of the spread reaches zero: the data show no bounce-to-bounce "
               f"spread of {name[:-3]} beyond the measurement noise, only bound it from above")
        return dataclasses.replace(s, identifiable=False, why_not_identified=why,
                                   bound={"side": "upper", "value": float(hi), "level": 0.95})
    return s
