"""The log posterior: prior + likelihood of parameter rows, in memory-bounded batches."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ..data import Prior, Uniform
from . import _kernels as _kernel_module

_kernels: Any = _kernel_module  # numba dispatchers: mypy cannot see their signatures


def _rows(theta: Any) -> np.ndarray:
    """Parameter rows as a float64 (n, d) array (one row from a 1-D vector)."""
    theta = np.asarray(theta, dtype=float)
    return theta[None, :] if theta.ndim == 1 else theta


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
        return self._log_prior(_rows(theta))[0]

    def _log_prior(self, theta: np.ndarray) -> tuple[np.ndarray, int]:
        """Log prior of rows (n, d) and the number of rows inside the support."""
        out = np.empty(theta.shape[0])
        inside = _kernels.box_log_prior(theta, self._lower, self._upper, self._constant, out)
        if self._shaped:
            for i in self._shaped:
                out += self.priors[i].logpdf(theta[:, i])
            inside = int(np.count_nonzero(out > -np.inf))
        return out, inside

    def __call__(self, theta: np.ndarray) -> np.ndarray:
        theta = _rows(theta)
        if theta.shape[0] > self.batch_rows:
            return np.concatenate([self(theta[s:s + self.batch_rows])
                                   for s in range(0, theta.shape[0], self.batch_rows)])
        lp, inside_rows = self._log_prior(theta)
        if inside_rows == theta.shape[0]:  # the common case: no copies
            _kernels.add_log_densities(lp, self.likelihood(theta), lp)
            return lp
        inside = lp > -np.inf
        if inside.any():
            part = lp[inside]
            _kernels.add_log_densities(part, self.likelihood(theta[inside]), part)
            lp[inside] = part
        return lp

    def subset(self, most: int) -> LogPosterior:
        """The posterior given at most ``most`` evenly spaced trials (see the likelihoods'
        ``subset``)."""
        like = self.likelihood.subset(most)
        return self if like is self.likelihood else replace(self, likelihood=like)

    def box(self, mass: float = 1e-6) -> np.ndarray:
        """(d, 2): the prior supports, cut to finite quantiles where unbounded."""
        return np.array([p.box(mass) for p in self.priors])


@dataclass(frozen=True)
class SamplingSpace:
    """The posterior in the coordinates the random-walk samplers (mh, ensemble) move in: a
    parameter with a log-uniform prior (a scale: an inferred noise level or model discrepancy)
    as its natural logarithm, in which its prior is flat and a posterior reaching towards zero
    has no funnel for a random walk to get stuck in. ``post`` is the posterior in natural
    units; :meth:`natural` maps the samplers' draws back (log densities included)."""

    post: LogPosterior
    logged: tuple[int, ...]

    @property
    def names(self) -> tuple[str, ...]:
        return self.post.names

    @property
    def units(self) -> tuple[str, ...]:
        return self.post.units

    @property
    def priors(self) -> tuple[Prior, ...]:
        return self.post.priors

    @property
    def likelihood(self) -> Any:
        return self.post.likelihood

    @property
    def batch_rows(self) -> int:
        return self.post.batch_rows

    @property
    def dim(self) -> int:
        return self.post.dim

    def to_natural(self, u: np.ndarray) -> np.ndarray:
        """Rows in natural units from rows in sampling coordinates."""
        x = _rows(u).copy()
        idx = list(self.logged)
        x[:, idx] = np.exp(x[:, idx])
        return x

    def _jacobian(self, u: np.ndarray) -> np.ndarray:
        """Log |dx/du| of rows in sampling coordinates (``x = exp(u)``: the sum of the u)."""
        return _rows(u)[:, list(self.logged)].sum(axis=1)

    def log_prior(self, u: np.ndarray) -> np.ndarray:
        return self.post.log_prior(self.to_natural(u)) + self._jacobian(u)

    def __call__(self, u: np.ndarray) -> np.ndarray:
        return self.post(self.to_natural(u)) + self._jacobian(u)

    def subset(self, most: int) -> SamplingSpace:
        return replace(self, post=self.post.subset(most))

    def box(self, mass: float = 1e-6) -> np.ndarray:
        box = self.post.box(mass)
        box[list(self.logged)] = np.log(box[list(self.logged)])
        return box

    def natural(self, draws: Any) -> Any:
        """The samplers' draws in natural units, with log densities of the natural posterior
        and the run record's mode and starts mapped back."""
        samples = draws.samples.copy()
        lp = draws.lp - samples[..., list(self.logged)].sum(axis=-1)
        samples[..., list(self.logged)] = np.exp(samples[..., list(self.logged)])
        info = draws.info
        changes = {k: _natural_tuple(self, getattr(info, k)) for k in ("mode", "starts")
                   if hasattr(info, k)}
        return replace(draws, samples=samples, lp=lp,
                       info=replace(info, **changes) if changes else info)


def _natural_tuple(space: SamplingSpace, value: tuple) -> tuple:
    """A point (or points) of a run record in natural units."""
    if value and isinstance(value[0], tuple):
        return tuple(_natural_tuple(space, v) for v in value)
    return tuple(float(v) for v in space.to_natural(np.asarray(value, dtype=float))[0])


def sampling_space(post: LogPosterior) -> LogPosterior | SamplingSpace:
    """``post`` itself, or its :class:`SamplingSpace` where a parameter has a log-uniform
    prior."""
    from ..data import LogUniform

    logged = tuple(i for i, p in enumerate(post.priors) if isinstance(p, LogUniform))
    return SamplingSpace(post, logged) if logged else post
