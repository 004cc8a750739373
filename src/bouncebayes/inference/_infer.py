"""``infer``: experiment + trials -> posterior draws, diagnostics and an honest summary."""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .._io import json_text, write_all
from .._validate import check_choice
from .._version import __version__
from ..data import Experiment, Trials
from ._likelihood import LIKELIHOODS, MEANINGS, NOISE_PARAMETERS, NOISE_UNITS, make_likelihood
from ._likelihood import noise_priors
from ._posterior import SAMPLERS, LogPosterior, SamplerConfig
from ._samplers import Draws, sample_ensemble, sample_grid, sample_mh
from ._summary import (ParameterSummary, diagnostics, import_arviz, summarize_parameter,
                       warnings_for)

SAMPLER_FUNCTIONS = {"mh": sample_mh, "ensemble": sample_ensemble, "grid": sample_grid}
SAMPLER_MEANINGS = {
    "mh": "random-walk Metropolis–Hastings (the paper's), several chains from dispersed starts",
    "ensemble": "emcee's affine-invariant ensemble sampler",
    "grid": "exact quadrature on a grid over the prior box (no Monte Carlo error beyond the "
            "grid spacing)",
}
REGIME_DRAWS = 2000  # posterior draws re-simulated to find the friction regime


@dataclass(frozen=True)
class InferenceResult:
    """Everything an inference produced; :func:`write_outputs` saves it."""

    experiment: Experiment
    trials: Trials
    likelihood: str
    sampler: str
    seed: int
    config: SamplerConfig
    posterior: LogPosterior
    draws: Draws
    parameters: tuple[ParameterSummary, ...]
    regimes: dict
    warnings: tuple[str, ...]
    likelihood_info: dict
    seconds: float

    @property
    def names(self) -> tuple[str, ...]:
        return self.posterior.names

    def samples(self, name: str) -> np.ndarray:
        """All draws of one parameter, chains flattened."""
        return self.draws.samples[..., self.names.index(name)].ravel()

    def summary(self) -> dict:
        """The content of summary.json."""
        info = {k: v for k, v in self.draws.info.items() if k != "grid"}
        return {
            "parameters": {p.name: p.to_dict() for p in self.parameters},
            "likelihood": self.likelihood, "likelihood_meaning": MEANINGS[self.likelihood],
            "likelihood_details": self.likelihood_info,
            "sampler": self.sampler, "sampler_meaning": SAMPLER_MEANINGS[self.sampler],
            "sampler_settings": self.config.__dict__ | {"result": info},
            "seed": self.seed, "n_draws": int(self.draws.samples.shape[0]
                                              * self.draws.samples.shape[1]),
            "regimes": self.regimes, "warnings": list(self.warnings),
            "data": {"file": self.trials.source, "sha256": self.trials.sha256,
                     "n_trials": self.trials.n},
            "experiment": {"file": self.experiment.source, "name": self.experiment.name,
                           "sha256": self.experiment.text_sha256,
                           "normal_law": self.experiment.normal_law},
            "bouncebayes_version": __version__, "seconds": self.seconds,
        }


def infer(experiment: Experiment, trials: Trials, *, likelihood: str = "gaussian",
          sampler: str = "mh", seed: int = 0, config: SamplerConfig | None = None,
          noise: str = "auto", progress: bool = False) -> InferenceResult:
    """Posterior of the experiment's inferred parameters given the trials.

    Arguments:
        likelihood: ``"gaussian"`` (measurement model, default), ``"kde"`` (the paper's) or
            ``"consistent"`` (data-consistent inversion); see MODEL.md §5 and the README.
        sampler: ``"mh"`` (the paper's Metropolis–Hastings), ``"ensemble"`` (emcee) or
            ``"grid"`` (exact quadrature, up to 3 parameters).
        seed: the only source of randomness; same seed and inputs, identical draws.
        noise: for ``gaussian``: ``"given"`` (table standard errors), ``"inferred"`` (noise
            levels ``sigma_speed``, ``sigma_angle`` sampled with log-uniform priors) or
            ``"auto"`` (given when every trial has them).
    """
    check_choice("likelihood", likelihood, LIKELIHOODS)
    check_choice("sampler", sampler, SAMPLERS)
    check_choice("noise", noise, ("auto", "given", "inferred"))
    names = experiment.parameter_names
    if not names:
        raise ValueError(f"{experiment.source}: no [parameters.NAME] table: nothing to infer")
    config = config or SamplerConfig()
    start = time.perf_counter()
    rng_likelihood, rng_sampler, rng_regime = np.random.default_rng(seed).spawn(3)
    like = make_likelihood(likelihood, experiment, trials, names, rng=rng_likelihood,
                           noise=noise)
    all_names, priors, units = names, [experiment.priors[n] for n in names], \
        [experiment.unit(n) for n in names]
    if getattr(like, "noise", "given") == "inferred":
        extra = noise_priors(trials)
        all_names = names + NOISE_PARAMETERS
        priors += [extra[n] for n in NOISE_PARAMETERS]
        units += [NOISE_UNITS[n] for n in NOISE_PARAMETERS]
    post = LogPosterior(tuple(all_names), tuple(priors), tuple(units), like)
    draws = SAMPLER_FUNCTIONS[sampler](post, config, rng_sampler, progress)
    regimes = _regimes(like, draws, len(names), rng_regime)
    diag = diagnostics(draws.samples, post.names)
    params = tuple(summarize_parameter(n, u, p, draws.samples[..., i].ravel(), diag[n],
                                       regimes["share_rolling"])
                   for i, (n, u, p) in enumerate(zip(post.names, post.units, post.priors,
                                                     strict=True)))
    warns = warnings_for(list(params), draws.samples, post.priors, sampler, draws.info)
    if likelihood == "gaussian":
        warns += [f"{c} was measured but has no standard errors ({c}_se): the gaussian "
                  f"likelihood treats it as exact, which makes the posterior too narrow if it "
                  f"is not; add the column" for c in sorted(trials.measured)
                  if np.isnan(trials.se[c]).any()]
    return InferenceResult(experiment, trials, likelihood, sampler, int(seed), config, post,
                           draws, params, regimes, tuple(warns), like.describe(),
                           time.perf_counter() - start)


def _regimes(like, draws: Draws, d_model: int, rng) -> dict:
    """Share of simulated bounces leaving rolling, over posterior draws and conditions."""
    flat = draws.samples.reshape(-1, draws.samples.shape[-1])[:, :d_model]
    pick = rng.choice(flat.shape[0], size=min(REGIME_DRAWS, flat.shape[0]), replace=False)
    r = like.forward(flat[np.sort(pick)])
    rolling = np.where(r.ok, r.rolling, False)
    per_draw = rolling.mean(axis=1)
    return {"share_rolling": float(rolling.mean()),
            "draws_all_slip": float(np.mean(per_draw == 0.0)),
            "draws_all_roll": float(np.mean(per_draw == 1.0)),
            "draws_mixed": float(np.mean((per_draw > 0) & (per_draw < 1))),
            "failed_simulations": int(np.count_nonzero(~r.ok)),
            "conditions": "per trial" if r.ok.shape[1] > 1 else "nominal incidence",
            "n_draws": int(pick.size)}


def inference_data(result: InferenceResult):
    """ArviZ InferenceData: posterior, sample_stats, observed_data, provenance attributes."""
    az = import_arviz()
    s = result.draws.samples
    t = result.trials
    observed = {"rebound_speed": np.asarray(t.rebound_speed),
                "rebound_angle": np.asarray(t.rebound_angle),
                "incidence_speed": np.asarray(t.incidence_speed),
                "incidence_angle": np.asarray(t.incidence_angle),
                "incidence_spin": np.asarray(t.incidence_spin)}
    attrs = {"likelihood": result.likelihood, "sampler": result.sampler,
             "seed": result.seed, "bouncebayes_version": __version__,
             "data_file": t.source, "data_sha256": t.sha256,
             "experiment_file": result.experiment.source,
             "experiment_sha256": result.experiment.text_sha256,
             "config": json.dumps(result.config.__dict__),
             "units": json.dumps(dict(zip(result.names, result.posterior.units, strict=True)))}
    return az.from_dict(
        posterior={n: s[..., i] for i, n in enumerate(result.names)},
        sample_stats={k: np.asarray(v) for k, v in result.draws.stats.items()},
        observed_data=observed, dims={k: ["trial"] for k in observed},
        coords={"trial": list(t.labels)}, attrs=attrs)


def write_outputs(result: InferenceResult, out: str | Path) -> dict[str, Path]:
    """Write ``posterior.nc`` (NetCDF via ArviZ/h5netcdf) and ``summary.json``, with the grid
    sampler also ``grid.npz`` (normalised joint density and marginals), as one: if any of them
    cannot be written, none of the earlier files is replaced."""
    out = Path(out)
    summary = json_text(result.summary())
    idata = inference_data(result)
    writers = {out / "posterior.nc": lambda tmp: idata.to_netcdf(str(tmp)),
               out / "summary.json": lambda tmp: tmp.write_text(summary, encoding="utf-8")}
    grid = result.draws.info.get("grid")
    if grid is not None:
        def save(tmp):
            with open(tmp, "wb") as fh:
                np.savez_compressed(
                    fh, density=grid["density"], names=np.array(result.names),
                    **{f"centres_{i}": np.array(c) for i, c in enumerate(grid["centres"])},
                    **{f"marginal_{i}": np.array(m) for i, m in enumerate(grid["marginals"])})
        writers[out / "grid.npz"] = save
    paths = write_all(writers)
    return dict(zip(("posterior", "summary", "grid"), paths))


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
