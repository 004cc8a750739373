"""The log posterior (prior + likelihood) and the samplers' configuration."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal, get_args

import numpy as np

from .._validate import check_scalar
from ..data import Prior

SamplerName = Literal["mh", "ensemble", "grid"]
SAMPLERS: tuple[str, ...] = get_args(SamplerName)
GRID_POINTS = {1: 2048, 2: 512, 3: 96}  # default grid points per dimension


@dataclass(frozen=True)
class LogPosterior:
    """``log prior + log likelihood`` of parameter rows (n, d); ``-inf`` outside the support.

    The likelihood is only evaluated where the prior is positive."""

    names: tuple[str, ...]
    priors: tuple[Prior, ...]
    units: tuple[str, ...]
    likelihood: object  # callable(theta (n, d)) -> (n,)

    @property
    def dim(self) -> int:
        return len(self.names)

    def log_prior(self, theta: np.ndarray) -> np.ndarray:
        theta = np.atleast_2d(theta)
        return sum(p.logpdf(theta[:, i]) for i, p in enumerate(self.priors))

    def __call__(self, theta: np.ndarray) -> np.ndarray:
        theta = np.atleast_2d(np.asarray(theta, dtype=float))
        lp = self.log_prior(theta)
        inside = np.isfinite(lp)
        out = np.full(theta.shape[0], -np.inf)
        if inside.any():
            out[inside] = lp[inside] + self.likelihood(theta[inside])
        return np.where(np.isnan(out), -np.inf, out)

    def box(self, mass: float = 1e-6) -> np.ndarray:
        """(d, 2): the prior supports, cut to finite quantiles where unbounded."""
        return np.array([p.box(mass) for p in self.priors])


@dataclass(frozen=True, kw_only=True)
class SamplerConfig:
    """How to sample. Defaults are the paper's Metropolis–Hastings settings (15000 draws,
    burn-in 100, thinning 3), split over 4 chains.

    Arguments:
        draws: posterior draws kept in all (mh: over all chains; ensemble: over all walkers;
            grid: draws resampled from the grid for propagation).
        chains: independent Metropolis–Hastings chains, started from dispersed points.
        burn_in: iterations per chain (mh) or steps (ensemble) discarded at the start; the mh
            proposal scale is tuned during them.
        thin: keep every ``thin``-th iteration (mh) or step (ensemble).
        walkers: walkers of the ensemble sampler (at least 2 x the number of parameters).
        ensemble_burn_in: discarded steps of the ensemble sampler.
        grid_points: grid points per parameter (default 2048, 512, 96 for 1, 2, 3 parameters).
    """

    draws: int = 15_000
    chains: int = 4
    burn_in: int = 100
    thin: int = 3
    walkers: int = 32
    ensemble_burn_in: int = 500
    ensemble_thin: int = 5
    grid_points: int | None = None

    def __post_init__(self) -> None:
        for name, low in (("draws", 100), ("chains", 1), ("burn_in", 0), ("thin", 1),
                          ("walkers", 4), ("ensemble_burn_in", 0), ("ensemble_thin", 1)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < low:
                raise ValueError(f"`{name}` must be an integer >= {low}; got {value!r}")
        if self.grid_points is not None:
            check_scalar("grid_points", self.grid_points, low=8, high=1e5)

    def points(self, dim: int) -> int:
        if dim not in GRID_POINTS:
            raise ValueError(f"the grid sampler handles 1 to 3 parameters; this problem has "
                             f"{dim}: use `mh` or `ensemble`")
        return int(self.grid_points or GRID_POINTS[dim])

    def per_chain(self) -> int:
        return math.ceil(self.draws / self.chains)
