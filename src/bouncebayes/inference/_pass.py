"""One pass of the model over the posterior draws: pointwise log-likelihood, friction regimes,
and replicated data (posterior predictive), in batches that fit the memory budget."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ._draws import Draws
from ._memory import batch_rows, format_bytes

PREDICTIVE_DRAWS = 1000  #: draws (over all chains) with replicated data
REGIME_DRAWS = 2000  #: draws re-simulated for the regimes when the pass cannot keep all


@dataclass(frozen=True)
class Replicates:
    """Replicated rebounds of a subset of draws: ``draw`` (k,) indices along the draw axis
    (the same in every chain); speeds and angles (chains, k, observations)."""

    draw: np.ndarray
    rebound_speed: np.ndarray
    rebound_angle: np.ndarray


@dataclass(frozen=True)
class PosteriorPass:
    """What the pass produced. ``log_likelihood`` (chains, draws, observations), or ``None``
    with ``note`` saying why it was not kept."""

    log_likelihood: np.ndarray | None
    replicates: Replicates
    regimes: dict
    note: str = ""


def _even(n: int, k: int) -> np.ndarray:
    """``k`` evenly spaced indices of ``range(n)`` (all of them when k >= n)."""
    return np.unique(np.linspace(0, n - 1, min(n, k)).round().astype(int))


def posterior_pass(like, draws: Draws, rng: np.random.Generator,
                   work: float) -> PosteriorPass:
    """Evaluate the likelihood's terms at every draw when they fit in half of ``work`` bytes
    (else at REGIME_DRAWS evenly spaced draws, for the regimes only), and replicate the data at
    up to PREDICTIVE_DRAWS evenly spaced draws (as many as a quarter of ``work`` holds); model
    evaluations in batches within the rest."""
    chains, n, _ = draws.samples.shape
    m = len(like.observations)
    size = chains * n * m * 8.0
    note = ""
    if size <= 0.5 * work:
        pick = np.arange(n)
        work -= size
    else:
        pick = _even(n, math.ceil(REGIME_DRAWS / chains))
        note = (f"the pointwise log-likelihood of {chains * n} draws x {m} observations "
                f"({format_bytes(size)}) does not fit in the memory budget beside the rest "
                f"of the run; posterior.nc has no log_likelihood group: raise "
                f"`memory_budget` to keep it")
    per_chain = max(1, min(math.ceil(PREDICTIVE_DRAWS / chains),
                           int(0.25 * work // (chains * m * 16.0))))
    replicates = _replicate(like, draws, _even(n, per_chain), rng, 0.75 * work)
    terms, regimes = _evaluate(like, draws.samples[:, pick], 0.75 * work)
    return PosteriorPass(None if note else terms.reshape(chains, n, m), replicates, regimes,
                         note)


def _evaluate(like, samples: np.ndarray, budget: float) -> tuple[np.ndarray, dict]:
    """Terms (rows, observations) of the rows of ``samples`` and the regime counts."""
    flat = samples.reshape(-1, samples.shape[-1])
    rows = batch_rows(budget, like.bytes_per_row)
    terms = np.empty((flat.shape[0], len(like.observations)))
    counts = np.zeros(6)  # rolling, pairs, all slip, all roll, mixed, failed
    for s in range(0, flat.shape[0], rows):
        p = like.pointwise(flat[s:s + rows])
        terms[s:s + rows] = p.terms
        r = p.rebounds
        rolling = np.where(r.ok, r.rolling, False)
        per_draw = rolling.mean(axis=1)
        counts += [rolling.sum(), rolling.size, np.sum(per_draw == 0.0),
                   np.sum(per_draw == 1.0), np.sum((per_draw > 0) & (per_draw < 1)),
                   np.count_nonzero(~r.ok)]
    draws = max(flat.shape[0], 1)
    regimes = {"share_rolling": float(counts[0] / max(counts[1], 1)),
               "draws_all_slip": float(counts[2] / draws),
               "draws_all_roll": float(counts[3] / draws),
               "draws_mixed": float(counts[4] / draws), "failed_simulations": int(counts[5]),
               "conditions": ("per trial" if like.forward.n_conditions > 1
                              else "nominal incidence"),
               "n_draws": int(flat.shape[0])}
    return terms, regimes


def _replicate(like, draws: Draws, pick: np.ndarray, rng: np.random.Generator,
               budget: float) -> Replicates:
    """Replicated rebounds at the draws ``pick`` of every chain."""
    chains, _, d = draws.samples.shape
    flat = draws.samples[:, pick].reshape(-1, d)
    m = len(like.observations)
    speed, angle = np.empty((flat.shape[0], m)), np.empty((flat.shape[0], m))
    rows = batch_rows(budget, like.bytes_per_row)
    for s in range(0, flat.shape[0], rows):
        theta = flat[s:s + rows]
        speed[s:s + rows], angle[s:s + rows] = like.predict(
            theta, like.pointwise(theta).rebounds, rng)
    shape = (chains, pick.size, m)
    return Replicates(pick, speed.reshape(shape), angle.reshape(shape))
