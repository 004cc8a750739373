"""Memory planning: how much an inference may hold at once, checked before it is allocated.

An inference holds what lives through the run (the trial table and the likelihood's arrays per
trial, the draws, the grid of the grid sampler: refused up front when they take more than half
the budget), the per-trial log-likelihoods of the draws (left out, with a warning, when they do
not fit in half of what remains) and the model evaluations of one batch of parameter rows
(batches are split to fit the rest). The budget is an argument of
:func:`~bouncebayes.inference.infer`, ``memory_budget`` in bytes.
"""

from __future__ import annotations

import math

from .._errors import Rebuilt

DEFAULT_MEMORY_BUDGET = 2 * 2**30  #: bytes; safe on a laptop with 4 GB or more
MIN_MEMORY_BUDGET = 16 * 2**20
#: Peak working memory of one simulated bounce inside one likelihood call (kernel inputs and
#: outputs, rebounds, likelihood terms). Measured at ~380 bytes (resident-set growth of a
#: 2.2-million-bounce call); the planning value keeps a margin of more than two, and
#: tests/test_inference.py checks the measured value against it.
BYTES_PER_BOUNCE = 1024
#: Memory held per trial through a run: the table's columns and standard errors, the
#: likelihood's observations, covariances and inverses, the model's prepared conditions.
BYTES_PER_TRIAL = 512
RESIDENT_SHARE = 0.5  #: share of the budget for what lives through the run
#: share of the remaining budget that one batch of model evaluations plans to use: the rest is
#: margin for what the planning does not count (the model's caches, the allocator's slack)
WORK_SHARE = 0.5


class MemoryBudgetError(Rebuilt, ValueError):
    """A request that cannot fit in the memory budget; ``needed`` and ``budget`` in bytes
    (``share``: the part of the budget this kind of request may use)."""

    def __init__(self, what: str, needed: float, budget: float, remedy: str,
                 share: float = 1.0):
        self.needed = float(needed)
        self.budget = float(budget)
        part = "" if share == 1.0 else f", of which {100 * share:.0f} % may hold it"
        super().__init__(f"{what} needs about {format_bytes(needed)}, more than the memory "
                         f"budget allows (`memory_budget` = {format_bytes(budget)}{part}); "
                         f"{remedy}")


def format_bytes(n: float) -> str:
    """``1536`` -> ``'1.5 KiB'``; ``8e10`` -> ``'74.5 GiB'``."""
    for unit in ("B", "KiB", "MiB", "GiB", "TiB", "PiB"):
        if abs(n) < 1024 or unit == "PiB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1024
    raise AssertionError("unreachable")  # pragma: no cover


def check_memory_budget(value: object) -> int:
    """The budget as an integer number of bytes, at least 16 MiB."""
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise TypeError(f"`memory_budget` must be a number of bytes; got {value!r}")
    if value < MIN_MEMORY_BUDGET:
        raise ValueError(f"`memory_budget` must be at least {MIN_MEMORY_BUDGET} bytes "
                         f"({format_bytes(MIN_MEMORY_BUDGET)}); got {value!r}")
    return int(value)


def batch_rows(work: float, bytes_per_row: float) -> int:
    """Most parameter rows one model evaluation may take within ``work`` bytes (at least 1;
    WORK_SHARE of them planned)."""
    return max(1, int(WORK_SHARE * work // max(bytes_per_row, 1.0)))


def require(what: str, needed: float, budget: float, remedy: str, share: float = 1.0) -> None:
    """Refuse (:class:`MemoryBudgetError`) when ``needed`` bytes exceed ``share`` of the
    budget."""
    if needed > share * budget:
        raise MemoryBudgetError(what, needed, budget, remedy, share)
