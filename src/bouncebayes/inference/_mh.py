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

from . import _kernels as _kernel_module
from ._config import MHConfig
from ._draws import ESS_LIMIT, RHAT_LIMIT, Draws, ess_warnings, floats
from ._mode import dispersed_starts, find_mode
from ._posterior import LogPosterior

_kernels: Any = _kernel_module  # numba dispatchers: mypy cannot see their signatures
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
    proposal = _kernels.mh_propose(state.position, increment, state.log_scale)
    position, logdensity, accepted, log_ratio = _kernels.mh_accept(
        state.position, state.logdensity, proposal, logdensity_fn(proposal), log_u)
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


class _Noise:
    """The random inputs of successive steps (proposal increments with the covariance's
    Cholesky factor applied, log-uniforms), drawn from ``rng`` in blocks of RANDOM_BLOCK."""

    def __init__(self, rng: np.random.Generator, chol_t: np.ndarray, chains: int):
        self.rng, self.chol_t, self.chains = rng, chol_t, chains
        self.j = RANDOM_BLOCK
        self.increments = self.log_u = np.empty(0)

    def __call__(self) -> tuple[np.ndarray, np.ndarray]:
        if self.j == RANDOM_BLOCK:
            c, d = self.chains, self.chol_t.shape[0]
            self.increments = self.rng.standard_normal((RANDOM_BLOCK, c, d)) @ self.chol_t
            self.log_u = np.log(self.rng.uniform(size=(RANDOM_BLOCK, c)))
            self.j = 0
        self.j += 1
        return self.increments[self.j - 1], self.log_u[self.j - 1]


def sample_mh(post: LogPosterior, config: MHConfig, rng: np.random.Generator,
              progress: bool = False) -> Draws:
    """Random-walk Metropolis–Hastings with a symmetric Gaussian proposal (the mode's covariance
    times 2.38^2 / d, Gelman, Roberts & Gilks 1996), chains from overdispersed starts (2 sd
    around the mode), each chain's proposal scale tuned during the burn-in."""
    from tqdm.auto import tqdm

    mode, cov = find_mode(post, rng)
    c, d = config.chains, post.dim
    starts = dispersed_starts(post, mode, cov, c, rng, spread=2.0)
    noise = _Noise(rng, (np.linalg.cholesky(cov) * (2.38 / math.sqrt(d))).T, c)
    target = 0.44 if d == 1 else 0.234  # optimal acceptance rates (Roberts & Rosenthal 2001)
    keep = config.per_chain()
    samples, lps = np.empty((keep, c, d)), np.empty((keep, c))
    accepted = np.zeros((keep, c), dtype=bool)
    n_accept = np.zeros(c, dtype=np.int64)
    state = init(starts, post)
    with tqdm(total=config.iterations(), desc="mh", disable=not progress, leave=False,
              unit="it", mininterval=0.2) as bar:
        for it in range(config.burn_in):
            state, info = step(state, post, *noise())
            state = adapt(state, info, it, target)
        bar.update(config.burn_in)
        for k in range(keep):
            for _ in range(config.thin):
                state, info = step(state, post, *noise())
                n_accept += info.accepted
            samples[k], lps[k], accepted[k] = state.position, state.logdensity, info.accepted
            if k % 256 == 255:
                bar.update(256 * config.thin)
    run = MHRun(floats(n_accept / (keep * config.thin)), floats(np.exp(state.log_scale)),
                floats(mode), tuple(floats(s) for s in starts), config.iterations())
    return Draws(samples.transpose(1, 0, 2).copy(), lps.T.copy(), run, accepted.T.copy())
