"""Random-walk Metropolis–Hastings as a pure ``(init, step)`` pair, all chains advanced together.

``step`` takes the state of every chain and its random inputs (the proposal's Gaussian
increments and the log-uniforms of the accept test) and returns the new state and what happened;
it makes one batched call of the log posterior for all chains. :func:`sample_mh` is the driver:
starts, burn-in with Robbins–Monro tuning of each chain's proposal scale, thinning, bookkeeping.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from ._config import MHConfig
from ._draws import ESS_LIMIT, RHAT_LIMIT, Draws, ess_warnings, floats
from ._mode import dispersed_starts, find_mode
from ._posterior import LogPosterior

RANDOM_BLOCK = 1024  #: iterations whose random inputs are drawn at once


class MHState(NamedTuple):
    """The chains' positions (chains, d), log densities (chains,) and log proposal scales."""

    position: np.ndarray
    logdensity: np.ndarray
    log_scale: np.ndarray


class MHInfo(NamedTuple):
    """What one step did: ``accepted`` (chains,) and the log acceptance ratio (chains,)."""

    accepted: np.ndarray
    log_ratio: np.ndarray


def init(position: np.ndarray, logdensity_fn: Callable[[np.ndarray], np.ndarray]) -> MHState:
    """The state of chains started at ``position`` (chains, d), proposal scale 1."""
    position = np.atleast_2d(np.asarray(position, dtype=float))
    return MHState(position, logdensity_fn(position), np.zeros(position.shape[0]))


def step(state: MHState, logdensity_fn: Callable[[np.ndarray], np.ndarray],
         increment: np.ndarray, log_u: np.ndarray) -> tuple[MHState, MHInfo]:
    """One Metropolis–Hastings step of every chain: propose ``position + scale * increment``
    (``increment`` (chains, d): the proposal's correlated Gaussian draws), accept where
    ``log_u`` (chains,) is below the log ratio of the densities (symmetric proposal)."""
    proposal = state.position + increment * np.exp(state.log_scale)[:, None]
    lp = logdensity_fn(proposal)
    log_ratio = lp - state.logdensity
    accepted = log_u < log_ratio
    position = np.where(accepted[:, None], proposal, state.position)
    logdensity = np.where(accepted, lp, state.logdensity)
    return MHState(position, logdensity, state.log_scale), MHInfo(accepted, log_ratio)


def adapt(state: MHState, info: MHInfo, iteration: int, target: float) -> MHState:
    """Robbins–Monro update of each chain's log proposal scale towards the acceptance rate
    ``target`` (step size ``1 / sqrt(iteration + 1)``)."""
    gain = 1.0 / math.sqrt(iteration + 1.0)
    return state._replace(log_scale=state.log_scale + (info.accepted - target) * gain)


@dataclass(frozen=True)
class MHRun:
    """How the Metropolis–Hastings run went."""

    acceptance_rate: tuple[float, ...]  #: per chain, after the burn-in
    proposal_scale: tuple[float, ...]  #: per chain, tuned factor on the mode's covariance
    mode: tuple[float, ...]
    starts: tuple[tuple[float, ...], ...]
    iterations_per_chain: int

    def to_dict(self) -> dict[str, Any]:
        return {"acceptance_rate": list(self.acceptance_rate),
                "proposal_scale": list(self.proposal_scale), "mode": list(self.mode),
                "starts": [list(s) for s in self.starts],
                "iterations_per_chain": self.iterations_per_chain}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> MHRun:
        return cls(tuple(d["acceptance_rate"]), tuple(d["proposal_scale"]), tuple(d["mode"]),
                   tuple(tuple(s) for s in d["starts"]), int(d["iterations_per_chain"]))

    def warnings(self, summaries: list[Any]) -> list[str]:
        """Chains that disagree (R-hat) and too few effective draws."""
        out = [f"{s.name}: the chains disagree (R-hat {s.r_hat:.3f} > {RHAT_LIMIT}); run "
               f"longer (raise `draws` and `burn_in` of MHConfig) or check for several modes"
               for s in summaries if s.r_hat is not None and s.r_hat > RHAT_LIMIT]
        return out + ess_warnings(summaries, f"run longer (raise `draws` of MHConfig to "
                                             f"hold >= {ESS_LIMIT} effective draws)")


def sample_mh(post: LogPosterior, config: MHConfig, rng: np.random.Generator,
              progress: bool = False) -> Draws:
    """Random-walk Metropolis–Hastings with a symmetric Gaussian proposal (the mode's covariance
    times 2.38^2 / d, Gelman, Roberts & Gilks 1996), chains from overdispersed starts (2 sd
    around the mode), each chain's proposal scale tuned during the burn-in."""
    from tqdm.auto import tqdm

    mode, cov = find_mode(post, rng)
    c, d = config.chains, post.dim
    starts = dispersed_starts(post, mode, cov, c, rng, spread=2.0)
    chol_t = (np.linalg.cholesky(cov) * (2.38 / math.sqrt(d))).T
    target = 0.44 if d == 1 else 0.234  # optimal acceptance rates (Roberts & Rosenthal 2001)
    keep, total = config.per_chain(), config.iterations()
    samples, lps = np.empty((c, keep, d)), np.empty((c, keep))
    accepted = np.zeros((c, keep), dtype=bool)
    n_accept = np.zeros(c)
    state = init(starts, post)
    bar = tqdm(total=total, desc="mh", disable=not progress, leave=False, unit="it",
               mininterval=0.2)
    for block in range(0, total, RANDOM_BLOCK):
        size = min(RANDOM_BLOCK, total - block)
        increments = rng.standard_normal((size, c, d)) @ chol_t
        log_u = np.log(rng.uniform(size=(size, c)))
        for j in range(size):
            it = block + j
            state, info = step(state, post, increments[j], log_u[j])
            if it < config.burn_in:
                state = adapt(state, info, it, target)
                continue
            n_accept += info.accepted
            k, r = divmod(it - config.burn_in, config.thin)
            if r == config.thin - 1:
                samples[:, k], lps[:, k], accepted[:, k] = (state.position, state.logdensity,
                                                            info.accepted)
        bar.update(size)
    bar.close()
    run = MHRun(floats(n_accept / (keep * config.thin)), floats(np.exp(state.log_scale)),
                floats(mode), tuple(floats(s) for s in starts), total)
    return Draws(samples, lps, run, accepted)
