"""Prior distributions of the inferred parameters: small frozen objects backed by scipy.stats."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import Literal, get_args

import numpy as np
from scipy import stats

PriorKind = Literal["uniform", "normal", "lognormal"]
PRIOR_KINDS: tuple[str, ...] = get_args(PriorKind)


class _Prior:
    """Shared behaviour; subclasses define ``dist`` (a frozen scipy distribution)."""

    @property
    def dist(self):  # pragma: no cover - abstract
        raise NotImplementedError

    def _logpdf(self, x: np.ndarray) -> np.ndarray:
        return self.dist.logpdf(x)

    @property
    def support(self) -> tuple[float, float]:
        """(low, high) of the support; infinite ends where unbounded."""
        low, high = self.dist.support()
        return float(low), float(high)

    def logpdf(self, x) -> np.ndarray:
        """Log density (``-inf`` outside the support); closed forms, since samplers call it
        for every proposal (scipy.stats is checked against them in the tests)."""
        return self._logpdf(np.asarray(x, dtype=float))

    def sample(self, rng: np.random.Generator, size=None) -> np.ndarray:
        """Draws with the explicit generator ``rng``."""
        return self.dist.rvs(size=size, random_state=rng)

    def ppf(self, q) -> np.ndarray:
        """Quantile function."""
        return self.dist.ppf(q)

    def box(self, mass: float = 1e-6) -> tuple[float, float]:
        """A finite box holding all but ``mass`` of the prior (the support where finite)."""
        low, high = self.support
        if not math.isfinite(low):
            low = float(self.ppf(mass / 2))
        if not math.isfinite(high):
            high = float(self.ppf(1 - mass / 2))
        return low, high

    @property
    def mean(self) -> float:
        return float(self.dist.mean())

    @property
    def sd(self) -> float:
        return float(self.dist.std())


@dataclass(frozen=True)
class Uniform(_Prior):
    """Uniform on ``[low, high]``."""

    low: float
    high: float
    kind: str = "uniform"

    def _logpdf(self, x):
        inside = (x >= self.low) & (x <= self.high)
        return np.where(inside, -math.log(self.high - self.low), -np.inf)

    @cached_property
    def dist(self):
        return stats.uniform(loc=self.low, scale=self.high - self.low)

    def describe(self) -> str:
        return f"uniform on [{self.low:g}, {self.high:g}]"


@dataclass(frozen=True)
class Normal(_Prior):
    """Normal with mean ``loc`` and standard deviation ``scale``, optionally truncated to
    ``[low, high]``."""

    loc: float
    scale: float
    low: float = -math.inf
    high: float = math.inf
    kind: str = "normal"

    def _logpdf(self, x):
        z = (x - self.loc) / self.scale
        a, b = (self.low - self.loc) / self.scale, (self.high - self.loc) / self.scale
        mass = float(stats.norm.cdf(b) - stats.norm.cdf(a))  # of the untruncated normal
        log_norm = math.log(self.scale * math.sqrt(2 * math.pi) * mass)
        inside = (x >= self.low) & (x <= self.high)
        return np.where(inside, -0.5 * z * z - log_norm, -np.inf)

    @cached_property
    def dist(self):
        a, b = (self.low - self.loc) / self.scale, (self.high - self.loc) / self.scale
        if math.isinf(a) and math.isinf(b):
            return stats.norm(loc=self.loc, scale=self.scale)
        return stats.truncnorm(a, b, loc=self.loc, scale=self.scale)

    def describe(self) -> str:
        text = f"normal(mean {self.loc:g}, sd {self.scale:g})"
        if math.isfinite(self.low) or math.isfinite(self.high):
            text += f" truncated to [{self.low:g}, {self.high:g}]"
        return text


@dataclass(frozen=True)
class LogNormal(_Prior):
    """Log-normal: ``log(x)`` is normal with mean ``log(median)`` and sd ``sd_log``."""

    median: float
    sd_log: float
    kind: str = "lognormal"

    def _logpdf(self, x):
        with np.errstate(divide="ignore", invalid="ignore"):
            lx = np.log(x)
            z = (lx - math.log(self.median)) / self.sd_log
            out = -0.5 * z * z - lx - math.log(self.sd_log * math.sqrt(2 * math.pi))
        return np.where(x > 0, out, -np.inf)

    @cached_property
    def dist(self):
        return stats.lognorm(s=self.sd_log, scale=self.median)

    def describe(self) -> str:
        return f"log-normal(median {self.median:g}, sd of log {self.sd_log:g})"


@dataclass(frozen=True)
class LogUniform(_Prior):
    """Log-uniform (Jeffreys) on ``[low, high]``, ``0 < low < high``: the scale-free prior of the
    noise levels that the ``gaussian`` likelihood infers."""

    low: float
    high: float
    kind: str = "loguniform"

    def _logpdf(self, x):
        inside = (x >= self.low) & (x <= self.high)
        with np.errstate(divide="ignore", invalid="ignore"):
            out = -np.log(x) - math.log(math.log(self.high / self.low))
        return np.where(inside, out, -np.inf)

    @cached_property
    def dist(self):
        return stats.loguniform(self.low, self.high)

    def describe(self) -> str:
        return f"log-uniform on [{self.low:g}, {self.high:g}]"


Prior = Uniform | Normal | LogNormal | LogUniform
