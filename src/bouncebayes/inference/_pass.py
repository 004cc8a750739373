"""One pass of the model over the posterior draws: pointwise log-likelihood, friction regimes,
and replicated data (posterior predictive), in batches that fit the memory budget."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ._draws import Draws
from ._memory import WORK_SHARE, batch_rows, format_bytes

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
                   memory_budget: int) -> PosteriorPass:
    """Evaluate the likelihood's terms at every draw when they fit in half the budget (else
    at REGIME_DRAWS evenly spaced draws, for the regimes only), then replicate the data at
    PREDICTIVE_DRAWS evenly spaced draws."""
    chains, n, _ = draws.samples.shape
    m = len(like.observations)
    size = chains * n * m * 8.0
    note = ""
    if size <= WORK_SHARE * memory_budget:
        pick = np.arange(n)
    else:
        pick = _even(n, math.ceil(REGIME_DRAWS / chains))
        note = (f"the pointwise log-likelihood of {chains * n} draws x {m} observations "
                f"({format_bytes(size)}) does not fit in half the memory budget "
                f"({format_bytes(memory_budget)}); posterior.nc has no log_likelihood group: "
                f"raise `memory_budget` to keep it")
    terms, regimes = _evaluate(like, draws.samples[:, pick], memory_budget)
    replicates = _replicate(like, draws, rng, memory_budget)
    return PosteriorPass(None if note else terms.reshape(chains, n, m), replicates, regimes,
                         note)


def _evaluate(like, samples: np.ndarray, budget: int) -> tuple[np.ndarray, dict]:
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


def _replicate(like, draws: Draws, rng: np.random.Generator, budget: int) -> Replicates:
    """Replicated rebounds at evenly spaced draws of every chain."""
    chains, n, d = draws.samples.shape
    pick = _even(n, math.ceil(PREDICTIVE_DRAWS / chains))
    flat = draws.samples[:, pick].reshape(-1, d)
    rows = batch_rows(budget, like.bytes_per_row)
    speed, angle = [], []
    for s in range(0, flat.shape[0], rows):
        theta = flat[s:s + rows]
        v, a = like.predict(theta, like.pointwise(theta).rebounds, rng)
        speed.append(v)
        angle.append(a)
    shape = (chains, pick.size, -1)
    return Replicates(pick, np.concatenate(speed).reshape(shape),
                      np.concatenate(angle).reshape(shape))
