"""The log posterior: prior + likelihood of parameter rows, in memory-bounded batches."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..data import Prior, Uniform


@dataclass(frozen=True)
class LogPosterior:
    """``log prior + log likelihood`` of parameter rows (n, d); ``-inf`` outside the support.

    The likelihood is only evaluated where the prior is positive, and at most ``batch_rows``
    rows at a time (the memory plan of :func:`~bouncebayes.inference.infer`).
    """

    names: tuple[str, ...]
    priors: tuple[Prior, ...]
    units: tuple[str, ...]
    likelihood: Any  #: callable(theta (n, d)) -> (n,); see ``_likelihood``
    batch_rows: int = 1 << 62
    _lower: np.ndarray = field(init=False, repr=False, compare=False)
    _upper: np.ndarray = field(init=False, repr=False, compare=False)
    _shaped: tuple[int, ...] = field(init=False, repr=False, compare=False)
    _constant: float = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        support = np.array([p.support for p in self.priors], dtype=float).reshape(-1, 2)
        object.__setattr__(self, "_lower", support[:, 0].copy())
        object.__setattr__(self, "_upper", support[:, 1].copy())
        # uniform priors are a constant inside their support: only the others are evaluated
        shaped = tuple(i for i, p in enumerate(self.priors) if not isinstance(p, Uniform))
        object.__setattr__(self, "_shaped", shaped)
        object.__setattr__(self, "_constant", float(sum(
            -math.log(p.high - p.low) for p in self.priors if isinstance(p, Uniform))))

    @property
    def dim(self) -> int:
        return len(self.names)

    def log_prior(self, theta: np.ndarray) -> np.ndarray:
        """Log prior density of rows (n, d); ``-inf`` outside the support."""
        theta = np.atleast_2d(theta)
        inside = ((theta >= self._lower) & (theta <= self._upper)).all(axis=1)
        out = np.where(inside, self._constant, -np.inf)
        for i in self._shaped:
            out = out + self.priors[i].logpdf(theta[:, i])
        return out

    def __call__(self, theta: np.ndarray) -> np.ndarray:
        theta = np.atleast_2d(np.asarray(theta, dtype=float))
        if theta.shape[0] > self.batch_rows:
            return np.concatenate([self(theta[s:s + self.batch_rows])
                                   for s in range(0, theta.shape[0], self.batch_rows)])
        lp = self.log_prior(theta)
        inside = lp > -np.inf
        if inside.all():
            out = lp + self.likelihood(theta)
        else:
            out = np.full(theta.shape[0], -np.inf)
            if inside.any():
                out[inside] = lp[inside] + self.likelihood(theta[inside])
        out[np.isnan(out)] = -np.inf
        return out

    def box(self, mass: float = 1e-6) -> np.ndarray:
        """(d, 2): the prior supports, cut to finite quantiles where unbounded."""
        return np.array([p.box(mass) for p in self.priors])
