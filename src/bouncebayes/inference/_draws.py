"""What a sampler returns: the draws and a typed record of how they were made."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

RHAT_LIMIT = 1.01  #: rank-normalised split R-hat above which chains disagree
ESS_LIMIT = 400  #: effective draws below which intervals are rough (Vehtari et al. 2021)


class RunInfo(Protocol):
    """The facts a sampler reports about its run (typed, immutable, JSON-ready)."""

    def to_dict(self) -> dict[str, Any]:
        """The record for summary.json."""
        ...  # pragma: no cover

    def warnings(self, summaries: list[Any]) -> list[str]:
        """Plain-language warnings about this run's convergence or resolution."""
        ...  # pragma: no cover


@dataclass(frozen=True)
class Draws:
    """Posterior draws, arrays of shape (chains, draws[, d]), and the sampler's run record."""

    samples: np.ndarray  #: (chains, draws, d)
    lp: np.ndarray  #: (chains, draws) log posterior of each draw
    info: Any  #: the sampler's run record: ``MHRun``, ``EnsembleRun`` or ``GridRun``
    accepted: np.ndarray | None = None  #: (chains, draws) bool, where the sampler accepts

    @property
    def stats(self) -> dict[str, np.ndarray]:
        """Per-draw statistics for the ``sample_stats`` group."""
        out = {"lp": self.lp}
        if self.accepted is not None:
            out["accepted"] = self.accepted
        return out

    @property
    def n_draws(self) -> int:
        return int(self.samples.shape[0] * self.samples.shape[1])


def ess_warnings(summaries: list[Any], remedy: str) -> list[str]:
    """Too few effective draws (bulk or tail) for an MCMC run."""
    out = []
    for s in summaries:
        if s.ess_bulk is not None and min(s.ess_bulk, s.ess_tail or np.inf) < ESS_LIMIT:
            out.append(f"{s.name}: only {min(s.ess_bulk, s.ess_tail or np.inf):.0f} effective "
                       f"draws (< {ESS_LIMIT}); intervals are rough: {remedy}")
    return out


def floats(x: Any) -> tuple[float, ...]:
    """A read-only, JSON-ready copy of a 1-D array."""
    return tuple(float(v) for v in np.ravel(x))
