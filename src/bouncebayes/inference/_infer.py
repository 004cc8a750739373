"""``infer``: experiment + trials -> posterior draws, diagnostics and an honest summary."""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .._validate import check_choice
from .._version import __version__
from ..data import Experiment, Trials
from ._adequacy import Adequacy, assess
from ._checks import data_warnings
from ._config import (GRID_POINTS, SAMPLERS, AnyConfig, MHConfig, config_for,
                      resolve_sampler, sampler_config)
from ._draws import Draws
from ._ensemble import EnsembleRun, sample_ensemble
from ._grid import GridRun, check_grid_memory, grid_bytes, sample_grid
from ._likelihood import (DISCREPANCIES, DISCREPANCY_MEANINGS, LIKELIHOODS, MEANINGS,
                          discrepancy_priors, make_likelihood, noise_priors)
from ._memory import (BYTES_PER_BOUNCE, BYTES_PER_TRIAL, DEFAULT_MEMORY_BUDGET, RESIDENT_SHARE,
                      batch_rows, check_memory_budget, require)
from ._mh import MHRun, sample_mh
from ._outputs import read_posterior
from ._pass import PosteriorPass, Replicates, posterior_pass
from ._posterior import LogPosterior, SamplingSpace, sampling_space
from ._summary import ParameterSummary, diagnostics, summarize_parameter, warnings_for

SAMPLER_MEANINGS = {
    "mh": "random-walk Metropolis–Hastings (the paper's), several chains from dispersed starts",
    "ensemble": "emcee's affine-invariant ensemble sampler",
    "grid": "exact quadrature on a grid over the prior box (no Monte Carlo error beyond the "
            "grid spacing)",
}
REFIT_BURN_IN = 2000  #: mh burn-in of the refit with a discrepancy (discrepancy="auto")
MISFIT = "the model misfits the data; see the adequacy verdict"
RUN_TYPES: dict[str, Any] = {"mh": MHRun, "ensemble": EnsembleRun, "grid": GridRun}


@dataclass(frozen=True)
class InferenceResult:
    """Everything an inference produced; :func:`write_outputs` saves it."""

    experiment: Experiment
    trials: Trials
    likelihood: str
    sampler: str
    seed: int
    config: AnyConfig
    posterior: LogPosterior
    draws: Draws
    parameters: tuple[ParameterSummary, ...]
    regimes: dict
    warnings: tuple[str, ...]
    likelihood_info: dict
    seconds: float
    log_likelihood: np.ndarray | None = None  #: (chains, draws, observations)
    replicates: Replicates | None = None
    memory_budget: int = DEFAULT_MEMORY_BUDGET
    adequacy: Adequacy | None = None
    discrepancy: str = "none"  #: the model discrepancy of this posterior
    first_fit: dict | None = None  #: with discrepancy "auto": the fit without it, summarised
    population: Any = None  #: likelihood "population": predictive, per-bounce estimates

    @property
    def names(self) -> tuple[str, ...]:
        return self.posterior.names

    @property
    def observations(self) -> tuple[str, ...]:
        """What the pointwise log-likelihood is over: the trials, or the whole campaign."""
        return (self.trials.labels if self.likelihood in ("gaussian", "population")
                else ("campaign",))

    def parameter_draws(self) -> tuple[np.ndarray, tuple[str, ...]]:
        """Draws of the model parameters (chains, draws, d) and their names: the posterior's,
        or with the population likelihood the population predictive (a new bounce's
        parameters per draw), which is what propagates to new bounces."""
        if self.population is not None:
            return self.population.predictive, self.population.names
        return self.draws.samples, self.names

    def samples(self, name: str) -> np.ndarray:
        """All draws of one parameter, chains flattened."""
        return self.draws.samples[..., self.names.index(name)].ravel()

    def summary(self) -> dict:
        """The content of summary.json."""
        return {
            "parameters": {p.name: p.to_dict() for p in self.parameters},
            "likelihood": self.likelihood, "likelihood_meaning": MEANINGS[self.likelihood],
            "likelihood_details": self.likelihood_info,
            "sampler": self.sampler, "sampler_meaning": SAMPLER_MEANINGS[self.sampler],
            "sampler_settings": self.config.to_dict() | {"result": self.draws.info.to_dict()},
            "seed": self.seed, "n_draws": self.draws.n_draws,
            "regimes": self.regimes, "warnings": list(self.warnings),
            "data": {"file": self.trials.source, "sha256": self.trials.sha256,
                     "n_trials": self.trials.n},
            "experiment": {"file": self.experiment.source, "name": self.experiment.name,
                           "sha256": self.experiment.text_sha256,
                           "normal_law": self.experiment.normal_law,
                           "tangential": self.experiment.tangential},
            "memory_budget_bytes": self.memory_budget,
            "discrepancy": self.discrepancy,
            "discrepancy_meaning": DISCREPANCY_MEANINGS[self.discrepancy],
            "adequacy": None if self.adequacy is None else self.adequacy.to_dict(),
            "fit_without_discrepancy": self.first_fit,
            **({"population": self.population.to_dict()} if self.population is not None
               else {}),
            "bouncebayes_version": __version__, "seconds": self.seconds,
        }


def infer(experiment: Experiment, trials: Trials, *, likelihood: str | None = None,
          sampler: str | None = None, seed: int = 0, config: Any = None,
          noise: str | None = None, discrepancy: str | None = None, progress: bool = False,
          memory_budget: int = DEFAULT_MEMORY_BUDGET,
          population: str | None = None) -> InferenceResult:
    """Posterior of the experiment's inferred parameters given the trials, and whether the
    model reproduces them (``InferenceResult.adequacy``).

    Arguments:
        experiment: the experiment (ball, incidence, priors of the inferred parameters, and in
            its [inference] table the defaults of ``likelihood``, ``noise``, ``discrepancy``).
        trials: the measured bounces.
        likelihood: ``"gaussian"`` (measurement model), ``"kde"`` (the paper's),
            ``"consistent"`` (data-consistent inversion) or ``"population"`` (hierarchical:
            each bounce its own parameters from an inferred population, whose means and
            spreads ``<p>_mean``, ``<p>_sd`` are sampled); see ``docs/likelihoods.md``;
            default: the experiment's (``"gaussian"`` unless it says otherwise).
        sampler: ``"mh"`` (the paper's Metropolis–Hastings), ``"ensemble"`` (emcee) or
            ``"grid"`` (exact quadrature, up to 3 parameters); default: the sampler of
            ``config``, else ``"mh"`` (``"ensemble"`` for the population likelihood,
            :func:`resolve_sampler`).
        seed: the only source of randomness; same seed and inputs, identical draws.
        config: the sampler's settings, :class:`MHConfig`, :class:`EnsembleConfig` or
            :class:`GridConfig` (default: the sampler's defaults; the paper's for mh).
        noise: for ``gaussian``: ``"given"`` (table standard errors), ``"inferred"`` (noise
            levels ``sigma_speed``, ``sigma_angle`` sampled with log-uniform priors) or
            ``"auto"`` (given when every trial has them); default: the experiment's.
        discrepancy: for ``gaussian`` with given noise: ``"none"`` (the model is exact),
            ``"normal"`` or ``"student-t"`` (an inferred model error per observable,
            ``discrepancy_speed`` and ``discrepancy_angle``, in quadrature to the standard
            errors; Student-t residuals let outlying trials count less), or ``"auto"``
            (none, unless the adequacy check fails without it: then the posterior is computed
            again with ``"normal"``, with the mh sampler where the grid cannot hold the two
            extra parameters); default: the experiment's (``"auto"``).
        progress: show progress bars.
        memory_budget: bytes the inference may hold at once (default 2 GiB). Large tables and
            grids are worked through in batches within it; a request that cannot fit (a grid
            too fine, too many draws) is refused up front with the estimate.
        population: for ``population``: the family of the population of each parameter,
            ``"normal"`` or ``"lognormal"``, truncated to the prior's domain; default: the
            experiment's (``"normal"``).
    """
    settings = experiment.inference
    likelihood = settings["likelihood"] if likelihood is None else likelihood
    noise = settings["noise"] if noise is None else noise
    discrepancy = settings["discrepancy"] if discrepancy is None else discrepancy
    sampler = resolve_sampler(sampler, config, likelihood)
    _check_arguments(likelihood, sampler, noise, discrepancy, seed)
    budget = check_memory_budget(memory_budget)
    config = config_for(sampler, config)
    if not experiment.parameter_names:
        raise ValueError(f"{experiment.source}: no [parameters.NAME] table: nothing to infer")
    fixed = "none" if discrepancy == "auto" else discrepancy
    if likelihood == "population":
        from ._population_run import infer_population

        family = settings.get("population", "normal") if population is None else population
        return infer_population(experiment, trials, sampler, seed, config, noise, fixed,
                                family, progress, budget)
    result = _infer_once(experiment, trials, likelihood, sampler, seed, config, noise, fixed,
                         progress, budget)
    if discrepancy != "auto" or result.adequacy is None or result.adequacy.adequate or (
            likelihood != "gaussian" or result.likelihood_info.get("noise") != "given"):
        return result
    return _refit_with_discrepancy(result, noise, progress)


def _infer_once(experiment: Experiment, trials: Trials, likelihood: str, sampler: str,
                seed: int, config: AnyConfig, noise: str, discrepancy: str, progress: bool,
                budget: int) -> InferenceResult:
    """One posterior with fixed settings: sampler, posterior pass, adequacy, summaries."""
    names = experiment.parameter_names
    extra = 2 if discrepancy != "none" else 0
    work = budget - _plan(likelihood, sampler, config, len(names) + extra, trials, budget)
    notes = data_warnings(experiment, trials)
    start = time.perf_counter()
    rng_likelihood, rng_sampler, rng_pass = np.random.default_rng(seed).spawn(3)
    like = make_likelihood(likelihood, experiment, trials, names, rng=rng_likelihood,
                           noise=noise, discrepancy=discrepancy, memory_budget=work)
    post = _log_posterior(like, experiment, names, work)
    run = {"mh": sample_mh, "ensemble": sample_ensemble, "grid": sample_grid}[sampler]
    space = post if sampler == "grid" else sampling_space(post)  # scales as their logarithm
    draws = run(space, config, rng_sampler, progress)  # type: ignore[operator]
    if isinstance(space, SamplingSpace):
        draws = space.natural(draws)
    checked = posterior_pass(like, draws, rng_pass, work)
    adequacy = assess(like, draws.samples, draws.lp, checked.replicates, trials, work)
    params, warns = _summarize(post, draws, checked, notes, likelihood, trials, adequacy)
    return InferenceResult(experiment, trials, likelihood, sampler, int(seed), config, post,
                           draws, params, checked.regimes, tuple(warns), like.describe(),
                           time.perf_counter() - start, checked.log_likelihood,
                           checked.replicates, budget, adequacy, discrepancy)


def _refit_with_discrepancy(first: InferenceResult, noise: str,
                            progress: bool) -> InferenceResult:
    """``discrepancy="auto"`` after a failed adequacy check: the posterior again with a normal
    model discrepancy (mh where the grid cannot hold two more parameters), saying why."""
    sampler, config = first.sampler, first.config
    if sampler == "grid" and len(first.names) + 2 > max(GRID_POINTS):
        sampler, config = "mh", sampler_config("mh", draws=max(first.config.draws, 4000))
    if isinstance(config, MHConfig):  # two more parameters, started further from their mode
        config = dataclasses.replace(config, burn_in=max(config.burn_in, REFIT_BURN_IN))
    second = _infer_once(first.experiment, first.trials, first.likelihood, sampler, first.seed,
                         config, noise, "normal", progress, first.memory_budget)
    a = first.adequacy
    assert a is not None  # the caller refits only after a failed check
    how = "" if sampler == first.sampler else " by the mh sampler (the grid holds 3 parameters)"
    why = (f"the model without a discrepancy term did not reproduce the data (chi-square per "
           f"degree of freedom {a.chi2 / max(a.dof, 1):.3g}), so with `discrepancy` = auto the "
           f"posterior was computed again with an inferred model discrepancy (normal){how}; its "
           f"intervals include the model error")
    record = {"adequacy": a.to_dict(),
              "parameters": {p.name: p.to_dict() for p in first.parameters},
              "sampler": first.sampler, "seconds": first.seconds}
    k = len(data_warnings(first.experiment, first.trials))  # what the data cannot be: first
    warns = second.warnings[:k] + (why,) + second.warnings[k:]
    return dataclasses.replace(second, warnings=warns, first_fit=record,
                               seconds=first.seconds + second.seconds)


def _check_arguments(likelihood: str, sampler: str, noise: str, discrepancy: str,
                     seed: Any) -> None:
    check_choice("likelihood", likelihood, LIKELIHOODS)
    check_choice("sampler", sampler, SAMPLERS)
    check_choice("noise", noise, ("auto", "given", "inferred"))
    check_choice("discrepancy", discrepancy, DISCREPANCIES)
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ValueError(f"`seed` must be a non-negative integer; got {seed!r}")


def _plan(likelihood: str, sampler: str, config: Any, dim: int, trials: Trials,
          budget: int) -> float:
    return plan_memory(trials.n, dim, sampler, config, likelihood, budget)


def plan_memory(n_trials: int, dim: int, sampler: str, config: Any,
                likelihood: str = "gaussian", budget: int = DEFAULT_MEMORY_BUDGET) -> float:
    """Bytes an inference of ``n_trials`` trials and ``dim`` parameters holds through the run
    (the table, the draws, a grid); refuse up front (:class:`MemoryBudgetError`) what cannot
    fit: these beyond half the budget, or one likelihood evaluation beyond the rest. Studies
    call it for their largest campaign before any task starts."""
    if sampler == "grid":
        check_grid_memory(config.points_for(dim), dim, budget, RESIDENT_SHARE)
    kept = config.draws + (config.chains if sampler == "mh" else 0)
    draws = kept * (dim + 4) * 8.0
    require(f"keeping {config.draws} draws of {dim} or more parameters", draws, budget,
            "lower `draws`, or raise `memory_budget`", RESIDENT_SHARE)
    resident = (n_trials * BYTES_PER_TRIAL + draws
                + (grid_bytes(config.points_for(dim), dim) if sampler == "grid" else 0.0))
    require(f"holding {n_trials} trials, the draws and the grid through the run", resident,
            budget, "raise `memory_budget`, or split the table", RESIDENT_SHARE)
    if likelihood == "gaussian":
        require(f"one evaluation of the gaussian likelihood ({n_trials} trials, each simulated "
                f"at its own incidence)", n_trials * BYTES_PER_BOUNCE, budget - resident,
                "raise `memory_budget`, or split the table")
    return resident


def _log_posterior(like, experiment: Experiment, names, work: float) -> LogPosterior:
    """Prior of the model parameters and of the likelihood's own (noise levels)."""
    extra = like.extra_parameters
    return LogPosterior(tuple(names) + tuple(e[0] for e in extra),
                        tuple(experiment.priors[n] for n in names) + tuple(e[1] for e in extra),
                        tuple(experiment.unit(n) for n in names) + tuple(e[2] for e in extra),
                        like, batch_rows(work, like.bytes_per_row))


def _summarize(post: LogPosterior, draws: Draws, checked: PosteriorPass, notes: list[str],
               likelihood: str, trials: Trials, adequacy: Adequacy):
    diag = diagnostics(draws.samples, post.names)
    misfit = "" if adequacy.adequate else MISFIT
    params = tuple(summarize_parameter(n, u, p, draws.samples[..., i].ravel(), diag[n],
                                       checked.regimes["share_rolling"], misfit=misfit)
                   for i, (n, u, p) in enumerate(zip(post.names, post.units, post.priors,
                                                     strict=True)))
    # what the data cannot be, then whether the model reproduces them, then the sampler's own
    warns = notes + ([] if adequacy.adequate else [adequacy.verdict]) + warnings_for(
        list(params), draws.samples, post.priors, draws.info, impossible_data=bool(notes))
    if likelihood == "gaussian":
        warns += [f"{c} was measured but has no standard errors ({c}_se): the gaussian "
                  f"likelihood treats it as exact, which makes the posterior too narrow if it "
                  f"is not; add the column" for c in sorted(trials.measured)
                  if np.isnan(trials.se[c]).any()]
    if checked.note:
        warns.append(checked.note)
    return params, warns


def load_inference(posterior: str | Path, summary: dict, experiment: Experiment,
                   trials: Trials) -> InferenceResult:
    """Rebuild the :class:`InferenceResult` saved as ``posterior`` (posterior.nc) and
    ``summary`` (the content of summary.json), without its likelihood object."""
    names = tuple(summary["parameters"])
    arrays = read_posterior(posterior, names)
    discrepancy = summary.get("discrepancy", "none")
    extra: dict[str, Any] = {}
    population = None
    if summary["likelihood"] == "population":
        from ._population import hyper_priors
        from ._population_run import Population

        record = summary["population"]
        model = tuple(record["parameters"])
        extra = hyper_priors(experiment, model)
        pred = arrays.get("population_predictive") or {}
        population = Population(model, tuple(experiment.unit(n) for n in model),
                                np.stack([pred[n] for n in model], axis=-1),
                                arrays.get("bounces") or {}, record)
    elif set(names) - set(experiment.priors):
        extra = discrepancy_priors(trials) if discrepancy != "none" else noise_priors(trials)
    priors = tuple(experiment.priors[n] if n in experiment.priors else extra[n] for n in names)
    units = tuple(p["unit"] for p in summary["parameters"].values())
    params = tuple(ParameterSummary(**_fields(p)) for p in summary["parameters"].values())
    sampler = summary["sampler"]
    settings = {k: v for k, v in summary["sampler_settings"].items() if k != "result"}
    config = sampler_config(sampler, **settings)
    stats = arrays["stats"]
    draws = Draws(arrays["samples"], stats["lp"],
                  RUN_TYPES[sampler].from_dict(summary["sampler_settings"]["result"]),
                  stats.get("accepted"))
    rep = arrays["replicates"]
    return InferenceResult(experiment, trials, summary["likelihood"], sampler, summary["seed"],
                           config, LogPosterior(names, priors, units, None), draws, params,
                           summary["regimes"], tuple(summary["warnings"]),
                           summary["likelihood_details"], summary["seconds"],
                           arrays["log_likelihood"], None if rep is None else Replicates(*rep),
                           int(summary.get("memory_budget_bytes", DEFAULT_MEMORY_BUDGET)),
                           _saved_adequacy(summary, trials, arrays), discrepancy,
                           summary.get("fit_without_discrepancy"), population)


def _saved_adequacy(summary: dict, trials: Trials, arrays: dict) -> Adequacy | None:
    record = summary.get("adequacy")
    if record is None or arrays.get("adequacy") is None:
        return None
    return Adequacy.from_saved(record, tuple(trials.labels), arrays["adequacy"])


def _fields(p: dict[str, Any]) -> dict[str, Any]:
    """A ParameterSummary's fields from its summary.json record."""
    return {k: (tuple(v) if k in ("ci90", "modes") else v) for k, v in p.items()
            if k != "paper_form"}


def format_table(result: InferenceResult) -> str:
    """The printed results table."""
    lines = [f"posterior of {', '.join(result.names)} from {result.trials.n} bounces "
             f"(likelihood {result.likelihood}, sampler {result.sampler}, seed {result.seed})",
             f"  {'parameter':<12} {'mean':>11} {'sd':>10} {'90 % interval':>25} "
             f"{'R-hat':>6} {'ESS':>7}  result"]
    for p in result.parameters:
        rhat = f"{p.r_hat:.3f}" if p.r_hat is not None else "-"
        ess = f"{min(p.ess_bulk, p.ess_tail or np.inf):.0f}" if p.ess_bulk else "-"
        interval = f"[{p.ci90[0]:.4g}, {p.ci90[1]:.4g}]"
        lines.append(f"  {p.name + (' (' + p.unit + ')' if p.unit else ''):<12} "
                     f"{p.mean:>11.4g} {p.sd:>10.3g} {interval:>25} {rhat:>6} {ess:>7}  "
                     f"{p.paper_form()}")
    r = result.regimes
    lines.append(f"  friction regime of the posterior's bounces: {100 * (1 - r['share_rolling']):.0f}"
                 f" % sliding throughout, {100 * r['share_rolling']:.0f} % leaving rolling")
    for w in result.warnings:
        lines.append(f"  warning: {w}")
    return "\n".join(lines)
