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

from numba import njit

from ..model import rebound_rows
from . import _kernels as _kernel_module
from ._config import MHConfig
from ._draws import ESS_LIMIT, RHAT_LIMIT, Draws, ess_warnings, floats
from ._forward import Forward
from ._likelihood import GaussianLikelihood
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
        self.block()
        self.j += 1
        return self.increments[self.j - 1], self.log_u[self.j - 1]

    def block(self) -> int:
        """Draw the next block where this one is used up; the index of the next step's."""
        if self.j == RANDOM_BLOCK:
            c, d = self.chains, self.chol_t.shape[0]
            self.increments = self.rng.standard_normal((RANDOM_BLOCK, c, d)) @ self.chol_t
            self.log_u = np.log(self.rng.uniform(size=(RANDOM_BLOCK, c)))
            self.j = 0
        return self.j


@dataclass
class _Chains:
    """The run's state and records: the chains' state, kept draws, log densities, accepts."""

    state: MHState
    samples: np.ndarray
    lps: np.ndarray
    accepted: np.ndarray
    n_accept: np.ndarray

    def record(self, it: int, info: MHInfo, burn_in: int, thin: int, target: float) -> None:
        """After step ``it``: tune the scale during the burn-in, then count accepts and keep
        the state at the end of every ``thin`` steps (as :func:`_chain_block`)."""
        if it < burn_in:
            self.state = adapt(self.state, info, it, target)
            return
        self.n_accept += info.accepted
        k, r = divmod(it - burn_in, thin)
        if r == thin - 1:
            self.samples[k], self.lps[k] = self.state.position, self.state.logdensity
            self.accepted[k] = info.accepted


def sample_mh(post: LogPosterior, config: MHConfig, rng: np.random.Generator,
              progress: bool = False) -> Draws:
    """Random-walk Metropolis–Hastings with a symmetric Gaussian proposal (the mode's covariance
    times 2.38^2 / d, Gelman, Roberts & Gilks 1996), chains from overdispersed starts (2 sd
    around the mode), each chain's proposal scale tuned during the burn-in.

    Where the posterior is a box prior times the gaussian likelihood with given noise on a
    model with closed-form tables, whole blocks of iterations run in one compiled call
    (:func:`_chain_block`); a step that needs the ODE solver, and any other posterior, goes
    through :func:`step`. Both give the same draws, bit for bit."""
    from tqdm.auto import tqdm

    mode, cov = find_mode(post, rng)
    c, d = config.chains, post.dim
    starts = dispersed_starts(post, mode, cov, c, rng, spread=2.0)
    noise = _Noise(rng, (np.linalg.cholesky(cov) * (2.38 / math.sqrt(d))).T, c)
    target = 0.44 if d == 1 else 0.234  # optimal acceptance rates (Roberts & Rosenthal 2001)
    keep = config.per_chain()
    chains = _Chains(init(starts, post), np.empty((keep, c, d)), np.empty((keep, c)),
                     np.zeros((keep, c), dtype=bool), np.zeros(c, dtype=np.int64))
    compiled = compiled_posterior(post)
    total = config.burn_in + keep * config.thin
    with tqdm(total=total, desc="mh", disable=not progress, leave=False, unit="it",
              mininterval=0.2) as bar:
        it = 0
        while it < total:
            done = it
            if compiled is not None:
                it = _run_compiled(chains, noise, compiled, it, total, config, target)
            if it < total:  # a step the compiled block cannot do, or no compiled posterior
                state, info = step(chains.state, post, *noise())
                chains.state = state
                chains.record(it, info, config.burn_in, config.thin, target)
                it += 1
            bar.update(it - done)
    run = MHRun(floats(chains.n_accept / (keep * config.thin)),
                floats(np.exp(chains.state.log_scale)), floats(mode),
                tuple(floats(s) for s in starts), config.iterations())
    return Draws(chains.samples.transpose(1, 0, 2).copy(), chains.lps.T.copy(), run,
                 chains.accepted.T.copy())


def compiled_posterior(post: LogPosterior) -> tuple | None:
    """What :func:`_chain_block` needs to evaluate ``post`` itself: the prior's box and
    constant, the gaussian likelihood's observations and inverse covariances, and the model's
    compiled rebound kernel; ``None`` for any other posterior (shaped priors, other
    likelihoods, inferred noise, a wrapped forward model, a law without tables)."""
    like = post.likelihood
    if not isinstance(post, LogPosterior):  # sampled in other coordinates (SamplingSpace)
        return None
    if (post._shaped or not isinstance(like, GaussianLikelihood) or not like.simple
            or type(like.forward) is not Forward
            or post.dim != len(like.forward.names)):
        return None
    kernel = like.forward.model.rebound_kernel()
    if kernel is None:
        return None
    return (post._lower, post._upper, post._constant) + tuple(like._terms) + kernel


def _run_compiled(chains: _Chains, noise: _Noise, compiled: tuple, it: int, total: int,
                  config: MHConfig, target: float) -> int:
    """Compiled iterations from ``it`` block by block of random inputs, until ``total`` or
    a step the compiled block cannot do; returns where it stopped."""
    state = chains.state
    position, logdensity, log_scale = (state.position.copy(), state.logdensity.copy(),
                                       state.log_scale.copy())
    nc = compiled[-8].shape[1]  # the conditions of the kernel's prepared ``cond``
    c = position.shape[0]
    work = (np.empty_like(position), np.empty(c), np.empty((4, c, nc)),
            np.empty((c, nc), dtype=np.int8), np.empty((c, nc), dtype=bool),
            np.empty((c, nc), dtype=bool), np.empty((c, nc), dtype=bool))
    while it < total:
        j = noise.block()
        stop = min(total, it + RANDOM_BLOCK - j)
        reached = _block(position, logdensity, log_scale, noise.increments, noise.log_u,
                         j - it, it, stop, config.burn_in, config.thin, target, chains.samples,
                         chains.lps, chains.accepted, chains.n_accept, *compiled, *work)
        noise.j += reached - it
        it = reached
        if it < stop:
            break
    chains.state = MHState(position, logdensity, log_scale)
    return it


@njit(cache=True, error_model="numpy")
def _chain_block(position, logdensity, log_scale, increments, log_u, shift, it, stop, burn_in,
                 thin, target, samples, lps, accepted, n_accept, lower, upper, constant,
                 obs_speed, obs_angle, i00, i01, i11, log_norm, cols, cond, cond_rows, ball,
                 bounds, main, pieces, gamma_max, kv, proposal, lp, out, status, rolling, ok,
                 fallback):
    """Iterations [it, stop) of every chain in place (random inputs of iteration ``i`` at
    ``i + shift`` of the block): the same arithmetic, in the same order, as :func:`step` on
    the posterior (``mh_propose``, ``box_log_prior``, the rebound kernel, ``given_noise_sum``,
    ``add_log_densities``, ``mh_accept``), :func:`adapt` and ``_Chains.record``. Returns the
    iteration it stopped at: ``stop``, or the first whose proposal needs the ODE solver
    (left undone)."""
    n_chains, d = position.shape
    while it < stop:
        b = it + shift
        for c in range(n_chains):  # proposal and log posterior of every chain
            scale = math.exp(log_scale[c])
            inside = True
            for j in range(d):
                x = position[c, j] + scale * increments[b, c, j]
                proposal[c, j] = x
                if not (lower[j] <= x <= upper[j]):
                    inside = False
            if not inside:
                lp[c] = -math.inf
                continue
            if rebound_rows(proposal, cols, cond, cond_rows, ball, bounds, main, pieces,
                            gamma_max, kv, c, c + 1, out, status, rolling, ok, fallback):
                return it
            total = 0.0
            for k in range(obs_speed.shape[0]):
                if not ok[c, k]:
                    total = -math.inf
                    break
                ds = out[0, c, k] - obs_speed[k]
                da = out[1, c, k] - obs_angle[k]
                total += (-0.5 * (i00[k] * ds * ds + 2.0 * i01[k] * ds * da + i11[k] * da * da)
                          - log_norm[k])
            total = total if total == total else -math.inf
            s = constant + total
            lp[c] = s if s == s else -math.inf
        gain = 1.0 / math.sqrt(it + 1.0)
        keep, phase = (it - burn_in) // thin, (it - burn_in) % thin
        for c in range(n_chains):  # accept, tune, count and keep
            acc = log_u[b, c] < lp[c] - logdensity[c]
            if acc:
                logdensity[c] = lp[c]
                for j in range(d):
                    position[c, j] = proposal[c, j]
            if it < burn_in:
                log_scale[c] = log_scale[c] + ((1.0 if acc else 0.0) - target) * gain
            else:
                n_accept[c] += acc
                if phase == thin - 1:
                    accepted[keep, c] = acc
                    lps[keep, c] = logdensity[c]
                    for j in range(d):
                        samples[keep, c, j] = position[c, j]
        it += 1
    return it


_block: Any = _chain_block  # a numba dispatcher: mypy cannot see its signature
