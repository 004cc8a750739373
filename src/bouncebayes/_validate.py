"""Boundary checks shared by every stage: each message names the argument, what was received
and what is allowed (the project rule: bad input gets a clear error that names the field)."""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import numpy as np


def _describe(value: Any) -> str:
    if isinstance(value, float | int | np.floating | np.integer):
        return repr(float(value)) if isinstance(value, float | np.floating) else repr(int(value))
    return repr(value)


def check_choice(name: str, value: Any, allowed: Iterable[str]) -> str:
    """Return ``value`` if it is one of ``allowed``; raise ``ValueError`` naming both otherwise."""
    allowed = tuple(allowed)
    if not isinstance(value, str) or value not in allowed:
        choices = ", ".join(repr(a) for a in allowed)
        raise ValueError(f"`{name}` must be one of {choices}; got {_describe(value)}")
    return value


def check_scalar(name: str, value: Any, *, unit: str = "", low: float | None = None,
                 high: float | None = None, low_open: bool = False,
                 high_open: bool = False) -> float:
    """Validate a finite real scalar inside ``[low, high]`` (ends open where asked)."""
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise TypeError(f"`{name}` must be a real number{_unit(unit)}; got {_describe(value)} "
                        f"of type {type(value).__name__}")
    return float(check_array(name, value, unit=unit, low=low, high=high, low_open=low_open,
                             high_open=high_open))


def check_array(name: str, value: Any, *, unit: str = "", low: float | None = None,
                high: float | None = None, low_open: bool = False,
                high_open: bool = False) -> np.ndarray:
    """Convert to a float64 array and check every element is finite and inside the range."""
    arr = as_float_array(name, value, unit=unit)
    ok = in_range_mask(arr, low, high, low_open, high_open)
    if not ok.all():
        index = np.unravel_index(int(np.argmin(ok)), arr.shape)
        where = f" at index {tuple(int(i) for i in index)}" if arr.ndim else ""
        raise ValueError(f"`{name}` must be {range_text(low, high, low_open, high_open, unit)}; "
                         f"got {float(arr[index])!r}{where}")
    return arr


def as_float_array(name: str, value: Any, *, unit: str = "") -> np.ndarray:
    """Convert to a float64 array, or raise ``TypeError`` naming the argument."""
    try:
        return np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"`{name}` must be a real number or an array of them{_unit(unit)}; "
                        f"got {_describe(value)}") from None


def in_range_mask(arr: np.ndarray, low: float | None, high: float | None, low_open: bool,
                      high_open: bool) -> np.ndarray:
    """True where ``arr`` is finite and inside the range."""
    ok = np.isfinite(arr)
    if low is not None:
        ok &= (arr > low) if low_open else (arr >= low)
    if high is not None:
        ok &= (arr < high) if high_open else (arr <= high)
    return ok


def range_text(low: float | None, high: float | None, low_open: bool, high_open: bool,
               unit: str = "") -> str:
    """Human words for an allowed interval, e.g. ``a finite number in (0, 0.5] Pa``."""
    u = f" {unit}" if unit else ""
    if low is None and high is None:
        return f"a finite number{_unit(unit)}"
    if high is None:
        return f"a finite number {'>' if low_open else '>='} {low:g}{u}"
    if low is None:
        return f"a finite number {'<' if high_open else '<='} {high:g}{u}"
    left, right = "(" if low_open else "[", ")" if high_open else "]"
    return f"a finite number in {left}{low:g}, {high:g}{right}{u}"


def _unit(unit: str) -> str:
    return f" (in {unit})" if unit else ""


def broadcast(**arrays: np.ndarray) -> dict[str, np.ndarray]:
    """Broadcast named arrays together; on failure name every argument and its shape."""
    try:
        out = np.broadcast_arrays(*arrays.values())
    except ValueError:
        shapes = ", ".join(f"`{k}` {np.shape(v)}" for k, v in arrays.items())
        raise ValueError(f"array arguments must broadcast to one shape; got {shapes}") from None
    return dict(zip(arrays, out, strict=True))
