"""Memory planning: how much an inference may hold at once, checked before it is allocated.

An inference holds arrays of three kinds: the model evaluations of one batch of parameter rows
(bounded by splitting large batches), the draws and their per-trial log-likelihoods (refused up
front, or left out, when they cannot fit), and the grid of the grid sampler (refused up front).
The budget is an argument of :func:`~bouncebayes.inference.infer`, ``memory_budget`` in bytes.
"""

from __future__ import annotations

import math

DEFAULT_MEMORY_BUDGET = 2 * 2**30  #: bytes; safe on a laptop with 4 GB or more
MIN_MEMORY_BUDGET = 16 * 2**20
#: Peak working memory of one simulated bounce inside one likelihood call (kernel inputs and
#: outputs, rebounds, likelihood terms). Measured at ~380 bytes (resident-set growth of a
#: 2.2-million-bounce call); the planning value keeps a margin of more than two, and
#: tests/test_inference.py checks the measured value against it.
BYTES_PER_BOUNCE = 1024
WORK_SHARE = 0.5  #: share of the budget that one batch of model evaluations may use


class MemoryBudgetError(ValueError):
    """A request that cannot fit in the memory budget; ``needed`` and ``budget`` in bytes."""

    def __init__(self, what: str, needed: float, budget: int, remedy: str):
        self.needed = float(needed)
        self.budget = int(budget)
        super().__init__(f"{what} needs about {format_bytes(needed)}, more than the memory "
                         f"budget (`memory_budget` = {format_bytes(budget)}); {remedy}")


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


def batch_rows(budget: int, bytes_per_row: float) -> int:
    """Most parameter rows one model evaluation may take within the budget (at least 1)."""
    return max(1, int(WORK_SHARE * budget // max(bytes_per_row, 1.0)))


def require(what: str, needed: float, budget: int, remedy: str) -> None:
    """Refuse (:class:`MemoryBudgetError`) when ``needed`` bytes exceed the budget."""
    if needed > budget:
        raise MemoryBudgetError(what, needed, budget, remedy)
