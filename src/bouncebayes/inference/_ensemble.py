"""emcee's affine-invariant ensemble sampler as a pure ``(init, step)`` pair.

The engine is emcee's stretch move (Goodman & Weare 2010; Foreman-Mackey et al. 2013), used
through its documented move interface: ``step`` hands emcee the walkers' state and a model
whose log-probability function evaluates a whole half-ensemble in one batched call, and returns
emcee's result as a typed state. emcee's random generator state travels in the state record,
so a step depends on nothing but its arguments.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from ._config import EnsembleConfig
from ._draws import Draws, ess_warnings, floats
from ._mode import dispersed_starts, find_mode
from ._posterior import LogPosterior

AUTOCORRELATION_LIMIT = 50  #: kept steps per autocorrelation time (Foreman-Mackey et al. 2013)


class EnsembleState(NamedTuple):
    """Walker positions (walkers, d), their log densities and emcee's generator state."""

    position: np.ndarray
    logdensity: np.ndarray
    random_state: Any  #: ``numpy.random.RandomState.get_state()``


class EnsembleInfo(NamedTuple):
    """Which walkers moved in this step (walkers,)."""

    accepted: np.ndarray


def init(position: np.ndarray, logdensity_fn: Callable[[np.ndarray], np.ndarray],
         seed: int) -> EnsembleState:
    """The state of walkers at ``position`` (walkers, d), emcee's generator seeded."""
    position = np.atleast_2d(np.asarray(position, dtype=float))
    return EnsembleState(position, logdensity_fn(position),
                         np.random.RandomState(seed).get_state())


def step(state: EnsembleState,
         logdensity_fn: Callable[[np.ndarray], np.ndarray]) -> tuple[EnsembleState,
                                                                     EnsembleInfo]:
    """One stretch move of every walker (two half-ensembles, one batched call each)."""
    import emcee

    random = np.random.RandomState()
    random.set_state(state.random_state)
    model = emcee.model.Model(log_prob_fn=logdensity_fn,
                              compute_log_prob_fn=lambda q: (logdensity_fn(q), None),
                              map_fn=map, random=random)
    # emcee's move updates the state it is given in place: hand it copies
    new, accepted = emcee.moves.StretchMove().propose(
        model, emcee.State(state.position.copy(), log_prob=state.logdensity.copy()))
    return (EnsembleState(new.coords, new.log_prob, random.get_state()),
            EnsembleInfo(accepted))


@dataclass(frozen=True)
class EnsembleRun:
    """How the ensemble run went. Walkers are not independent chains: convergence is judged by
    the autocorrelation time (run for at least 50 of them), not by R-hat across walkers."""

    acceptance_rate: tuple[float, ...]  #: per walker
    walkers: int
    mode: tuple[float, ...]
    steps: int
    autocorrelation_steps: tuple[float, ...]  #: per parameter
    kept_steps_per_autocorrelation: tuple[float, ...]  #: per parameter

    def to_dict(self) -> dict[str, Any]:
        return {"acceptance_rate": list(self.acceptance_rate), "walkers": self.walkers,
                "mode": list(self.mode), "steps": self.steps,
                "autocorrelation_steps": list(self.autocorrelation_steps),
                "kept_steps_per_autocorrelation": list(self.kept_steps_per_autocorrelation)}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> EnsembleRun:
        return cls(tuple(d["acceptance_rate"]), int(d["walkers"]), tuple(d["mode"]),
                   int(d["steps"]), tuple(d["autocorrelation_steps"]),
                   tuple(d["kept_steps_per_autocorrelation"]))

    def warnings(self, summaries: list[Any]) -> list[str]:
        """Too few autocorrelation times, too few effective draws."""
        out = [f"{s.name}: the ensemble ran for only {ratio:.0f} autocorrelation times "
               f"(< {AUTOCORRELATION_LIMIT}); run longer (raise `draws` of EnsembleConfig)"
               for s, ratio in zip(summaries, self.kept_steps_per_autocorrelation, strict=True)
               if not ratio >= AUTOCORRELATION_LIMIT]
        return out + ess_warnings(summaries, "run longer (raise `draws` of EnsembleConfig)")


def _autocorrelation_time(chain: np.ndarray) -> np.ndarray:
    """Integrated autocorrelation time (emcee's) per parameter; its log message about a short
    chain is silenced, since :meth:`EnsembleRun.warnings` says so in words."""
    import logging

    from emcee.autocorr import integrated_time

    log = logging.getLogger("emcee.autocorr")
    level = log.level
    log.setLevel(logging.ERROR)
    try:
        return integrated_time(chain, quiet=True)
    finally:
        log.setLevel(level)


def sample_ensemble(post: LogPosterior, config: EnsembleConfig, rng: np.random.Generator,
                    progress: bool = False) -> Draws:
    """Walkers started in a ball (1 sd) around the mode; burn-in, thinning."""
    from tqdm.auto import tqdm

    mode, cov = find_mode(post, rng)
    w = config.walkers_for(post.dim)
    start = dispersed_starts(post, mode, cov, w, rng, spread=1.0)
    per_walker = -(-config.draws // w)
    total = config.burn_in + per_walker * config.thin
    chain = np.empty((per_walker, w, post.dim))
    lps = np.empty((per_walker, w))
    n_accept = np.zeros(w)
    state = init(start, post, int(rng.integers(2**31 - 1)))
    for it in tqdm(range(total), desc="ensemble", disable=not progress, leave=False,
                   unit="it", mininterval=0.2):
        state, info = step(state, post)
        n_accept += info.accepted
        k, r = divmod(it - config.burn_in, config.thin)
        if k >= 0 and r == config.thin - 1:
            chain[k], lps[k] = state.position, state.logdensity
    tau = _autocorrelation_time(chain) * config.thin
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = per_walker * config.thin / tau
    run = EnsembleRun(floats(n_accept / total), w, floats(mode), total, floats(tau),
                      floats(ratio))
    return Draws(np.swapaxes(chain, 0, 1), lps.T, run)
