"""Prior distributions of the inferred parameters: small frozen objects backed by scipy.stats.

Each prior checks its arguments on construction: a bad one raises ``ValueError`` (``TypeError``
for a value that is not a real number) with one line naming the prior, the argument, the value
received and what is allowed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import Any, Literal, get_args

import numpy as np
from scipy import stats

from .._validate import range_text

PriorKind = Literal["uniform", "normal", "lognormal"]
PRIOR_KINDS: tuple[str, ...] = get_args(PriorKind)


def _real(prior: Any, name: str, *, low: float | None = None, low_open: bool = False,
          infinite: float = 0.0) -> float:
    """Field ``name`` of ``prior`` as a float: a real number, finite (or the infinity of sign
    ``infinite`` where that is allowed) and above ``low``; stored back as a float."""
    value = getattr(prior, name)
    what = f"`{name}` of a {prior.kind} prior"
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise TypeError(f"{what} must be a real number; got {value!r} of type "
                        f"{type(value).__name__}")
    x = float(value)
    if infinite and x == math.copysign(math.inf, infinite):
        pass
    elif not math.isfinite(x) or (low is not None and (x <= low if low_open else x < low)):
        allowed = range_text(low, None, low_open, False)
        if infinite:
            allowed += f" (or {math.copysign(math.inf, infinite):g}: no bound)"
        raise ValueError(f"{what} must be {allowed}; got {x!r}")
    object.__setattr__(prior, name, x)
    return x


def _ordered(prior: Any, low_name: str = "low", high_name: str = "high") -> None:
    """``low < high`` with a finite width."""
    low, high = getattr(prior, low_name), getattr(prior, high_name)
    if not low < high:
        raise ValueError(f"`{high_name}` of a {prior.kind} prior must be greater than "
                         f"`{low_name}` ({low!r}); got {high!r}")
    if not math.isfinite(high - low) and math.isfinite(low) and math.isfinite(high):
        raise ValueError(f"the {prior.kind} prior on [{low:g}, {high:g}] is wider than the "
                         f"largest float; narrow `{low_name}` or `{high_name}`")


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

    def __post_init__(self) -> None:
        _real(self, "low")
        _real(self, "high")
        _ordered(self)

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

    def __post_init__(self) -> None:
        _real(self, "loc")
        _real(self, "scale", low=0.0, low_open=True)
        _real(self, "low", infinite=-1.0)
        _real(self, "high", infinite=1.0)
        _ordered(self)
        if not self._mass > 0.0:
            raise ValueError(f"the truncation [{self.low:g}, {self.high:g}] of the normal prior "
                             f"(mean {self.loc:g}, sd {self.scale:g}) holds no probability: put "
                             f"it within a few sd of the mean")

    @cached_property
    def _mass(self) -> float:
        """Probability of ``[low, high]`` under the untruncated normal (upper tail by the
        survival function, so that a truncation far above the mean keeps its digits)."""
        a, b = (self.low - self.loc) / self.scale, (self.high - self.loc) / self.scale
        if a > 0:
            return float(stats.norm.sf(a) - stats.norm.sf(b))
        return float(stats.norm.cdf(b) - stats.norm.cdf(a))

    @cached_property
    def _log_norm(self) -> float:
        return math.log(self.scale * math.sqrt(2 * math.pi)) + math.log(self._mass)

    def _logpdf(self, x):
        z = (x - self.loc) / self.scale
        inside = (x >= self.low) & (x <= self.high)
        return np.where(inside, -0.5 * z * z - self._log_norm, -np.inf)

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

    def __post_init__(self) -> None:
        _real(self, "median", low=0.0, low_open=True)
        _real(self, "sd_log", low=0.0, low_open=True)

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

    def __post_init__(self) -> None:
        _real(self, "low", low=0.0, low_open=True)
        _real(self, "high", low=0.0, low_open=True)
        _ordered(self)

    def _logpdf(self, x):
        inside = (x >= self.low) & (x <= self.high)
        with np.errstate(divide="ignore", invalid="ignore"):
            out = -np.log(x) - math.log(math.log(self.high) - math.log(self.low))
        return np.where(inside, out, -np.inf)

    @cached_property
    def dist(self):
        return stats.loguniform(self.low, self.high)

    def describe(self) -> str:
        return f"log-uniform on [{self.low:g}, {self.high:g}]"


Prior = Uniform | Normal | LogNormal | LogUniform
