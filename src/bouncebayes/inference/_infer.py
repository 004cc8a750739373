"""``infer``: experiment + trials -> posterior draws, diagnostics and an honest summary."""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .._validate import check_choice
from .._version import __version__
from ..data import Experiment, Trials
from ._checks import data_warnings
from ._config import SAMPLERS, AnyConfig, config_for, sampler_config, sampler_of
from ._draws import Draws
from ._ensemble import EnsembleRun, sample_ensemble
from ._grid import GridRun, check_grid_memory, grid_bytes, sample_grid
from ._likelihood import LIKELIHOODS, MEANINGS, make_likelihood, noise_priors
from ._memory import (BYTES_PER_BOUNCE, BYTES_PER_TRIAL, DEFAULT_MEMORY_BUDGET, RESIDENT_SHARE,
                      batch_rows, check_memory_budget, require)
from ._mh import MHRun, sample_mh
from ._outputs import read_posterior
from ._pass import PosteriorPass, Replicates, posterior_pass
from ._posterior import LogPosterior
from ._summary import ParameterSummary, diagnostics, summarize_parameter, warnings_for

SAMPLER_MEANINGS = {
    "mh": "random-walk Metropolis–Hastings (the paper's), several chains from dispersed starts",
    "ensemble": "emcee's affine-invariant ensemble sampler",
    "grid": "exact quadrature on a grid over the prior box (no Monte Carlo error beyond the "
            "grid spacing)",
}
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

    @property
    def names(self) -> tuple[str, ...]:
        return self.posterior.names

    @property
    def observations(self) -> tuple[str, ...]:
        """What the pointwise log-likelihood is over: the trials, or the whole campaign."""
        return self.trials.labels if self.likelihood == "gaussian" else ("campaign",)

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
            "bouncebayes_version": __version__, "seconds": self.seconds,
        }


def infer(experiment: Experiment, trials: Trials, *, likelihood: str = "gaussian",
          sampler: str | None = None, seed: int = 0, config: Any = None, noise: str = "auto",
          progress: bool = False,
          memory_budget: int = DEFAULT_MEMORY_BUDGET) -> InferenceResult:
    """Posterior of the experiment's inferred parameters given the trials.

    Arguments:
        experiment: the experiment (ball, incidence, priors of the inferred parameters).
        trials: the measured bounces.
        likelihood: ``"gaussian"`` (measurement model, default), ``"kde"`` (the paper's) or
            ``"consistent"`` (data-consistent inversion); see ``docs/model.md`` and the README.
        sampler: ``"mh"`` (the paper's Metropolis–Hastings), ``"ensemble"`` (emcee) or
            ``"grid"`` (exact quadrature, up to 3 parameters); default: the sampler of
            ``config``, else ``"mh"``.
        seed: the only source of randomness; same seed and inputs, identical draws.
        config: the sampler's settings, :class:`MHConfig`, :class:`EnsembleConfig` or
            :class:`GridConfig` (default: the sampler's defaults; the paper's for mh).
        noise: for ``gaussian``: ``"given"`` (table standard errors), ``"inferred"`` (noise
            levels ``sigma_speed``, ``sigma_angle`` sampled with log-uniform priors) or
            ``"auto"`` (given when every trial has them).
        progress: show progress bars.
        memory_budget: bytes the inference may hold at once (default 2 GiB). Large tables and
            grids are worked through in batches within it; a request that cannot fit (a grid
            too fine, too many draws) is refused up front with the estimate.
    """
    sampler = sampler if sampler is not None else (sampler_of(config) or "mh")
    _check_arguments(likelihood, sampler, noise, seed)
    budget = check_memory_budget(memory_budget)
    config = config_for(sampler, config)
    names = experiment.parameter_names
    if not names:
        raise ValueError(f"{experiment.source}: no [parameters.NAME] table: nothing to infer")
    work = budget - _plan(likelihood, sampler, config, len(names), trials, budget)
    notes = data_warnings(experiment, trials)
    start = time.perf_counter()
    rng_likelihood, rng_sampler, rng_pass = np.random.default_rng(seed).spawn(3)
    like = make_likelihood(likelihood, experiment, trials, names, rng=rng_likelihood,
                           noise=noise, memory_budget=work)
    post = _log_posterior(like, experiment, names, work)
    run = {"mh": sample_mh, "ensemble": sample_ensemble, "grid": sample_grid}[sampler]
    draws = run(post, config, rng_sampler, progress)  # type: ignore[operator]
    checked = posterior_pass(like, draws, rng_pass, work)
    params, warns = _summarize(post, draws, checked, notes, likelihood, trials)
    return InferenceResult(experiment, trials, likelihood, sampler, int(seed), config, post,
                           draws, params, checked.regimes, tuple(warns), like.describe(),
                           time.perf_counter() - start, checked.log_likelihood,
                           checked.replicates, budget)


def _check_arguments(likelihood: str, sampler: str, noise: str, seed: Any) -> None:
    check_choice("likelihood", likelihood, LIKELIHOODS)
    check_choice("sampler", sampler, SAMPLERS)
    check_choice("noise", noise, ("auto", "given", "inferred"))
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ValueError(f"`seed` must be a non-negative integer; got {seed!r}")


def _plan(likelihood: str, sampler: str, config: Any, dim: int, trials: Trials,
          budget: int) -> float:
    """Bytes held through the run (the table, the draws, a grid); refuse up front what cannot
    fit: these beyond half the budget, or one likelihood evaluation beyond the rest."""
    if sampler == "grid":
        check_grid_memory(config.points_for(dim), dim, budget, RESIDENT_SHARE)
    kept = config.draws + (config.chains if sampler == "mh" else 0)
    draws = kept * (dim + 4) * 8.0
    require(f"keeping {config.draws} draws of {dim} or more parameters", draws, budget,
            "lower `draws`, or raise `memory_budget`", RESIDENT_SHARE)
    resident = (trials.n * BYTES_PER_TRIAL + draws
                + (grid_bytes(config.points_for(dim), dim) if sampler == "grid" else 0.0))
    require(f"holding {trials.n} trials, the draws and the grid through the run", resident,
            budget, "raise `memory_budget`, or split the table", RESIDENT_SHARE)
    if likelihood == "gaussian":
        require(f"one evaluation of the gaussian likelihood ({trials.n} trials, each simulated "
                f"at its own incidence)", trials.n * BYTES_PER_BOUNCE, budget - resident,
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
               likelihood: str, trials: Trials):
    diag = diagnostics(draws.samples, post.names)
    params = tuple(summarize_parameter(n, u, p, draws.samples[..., i].ravel(), diag[n],
                                       checked.regimes["share_rolling"])
                   for i, (n, u, p) in enumerate(zip(post.names, post.units, post.priors,
                                                     strict=True)))
    warns = notes + warnings_for(list(params), draws.samples, post.priors, draws.info,
                                 impossible_data=bool(notes))
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
    extra = noise_priors(trials) if set(names) - set(experiment.priors) else {}
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
                           int(summary.get("memory_budget_bytes", DEFAULT_MEMORY_BUDGET)))


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
