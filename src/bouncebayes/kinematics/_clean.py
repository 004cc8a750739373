"""Rows as they come: order, repeated time stamps, outlier positions, plausible units.

Every condition is either a one-line note (rows merged or left out, with their lines) or an
:class:`InputFileError` naming the line, never a Python warning.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from .._errors import InputFileError

# Two rows with one time stamp are one frame written twice when their positions differ by at
# most this many noise standard deviations of a difference (sqrt(2) x the position noise,
# estimated robustly from second differences); they are merged (mean). Beyond: two frames.
REPEAT_AGREEMENT_SD = 4.0
# An outlier is a position that neither neighbouring pair of samples predicts (linear
# extrapolation from two samples on each side): off by more than 20 noise SD of that
# prediction (sqrt(6) x the noise) and by more than half the median frame-to-frame step.
# Motion through a bounce is predicted from one side, so impacts are not outliers.
OUTLIER_NOISE_SD = 20.0
OUTLIER_STEPS = 0.5
MAX_OUTLIER_FRACTION = 0.1  # more outliers than this: the file is rejected
# Plausible sampling and motion: 10 frames/s to 1 million frames/s; ball speeds 0.01-300 m/s
# (measured over at least 5 ms, so that noise at high frame rates does not count as motion).
SAMPLE_INTERVAL_RANGE = (1e-6, 0.1)  # s
SPEED_RANGE = (0.01, 300.0)  # m/s
SPEED_BASELINE = 5e-3  # s
_EXACT = 1e-9  # m: positions closer than this are equal (no tracker resolves a nanometre)


@dataclass(frozen=True)
class Rows:
    """Tracked rows in file order: times, positions ``(n, d)`` in metres, quality columns,
    the 1-based line of each row (None for arrays: problems are named by index)."""

    source: str
    t: np.ndarray
    pos: np.ndarray
    quality: dict
    lines: np.ndarray | None

    def where(self, i: int) -> dict:
        """``line=`` keyword for an error about row ``i``, where rows have lines."""
        return {} if self.lines is None else {"line": int(self.lines[i])}

    def name(self, i: int) -> str:
        """``line 12`` or ``index 11``."""
        return f"index {i}" if self.lines is None else f"line {int(self.lines[i])}"

    def names(self, rows: np.ndarray) -> str:
        """``lines 5, 9`` or ``indices 4, 8`` (the first five, then a count)."""
        values = rows if self.lines is None else self.lines[rows]
        shown = ", ".join(str(int(v)) for v in values[:5])
        more = f" and {values.size - 5} more" if values.size > 5 else ""
        one, many = ("index", "indices") if self.lines is None else ("line", "lines")
        return f"{one if values.size == 1 else many} {shown}{more}"

    def keep(self, mask: np.ndarray) -> Rows:
        """The rows where ``mask`` is true."""
        return replace(self, t=self.t[mask], pos=self.pos[mask],
                       quality={k: v[mask] for k, v in self.quality.items()},
                       lines=None if self.lines is None else self.lines[mask])


def noise_sd(pos: np.ndarray) -> np.ndarray:
    """Robust noise SD per coordinate from second differences (white noise: var(d2) =
    6 sigma^2; median absolute deviation, so a few kinks and outliers do not count)."""
    if pos.shape[0] < 4:
        return np.zeros(pos.shape[1])
    with np.errstate(all="ignore"):
        d2 = np.diff(pos, 2, axis=0)
        mad = np.median(np.abs(d2 - np.median(d2, axis=0)), axis=0)
    return np.nan_to_num(1.4826 * mad / math.sqrt(6.0), nan=math.inf)


def check_order(rows: Rows) -> None:
    """Time must not decrease: a row out of order is rejected with its line (it usually marks
    two tracks pasted together; sort the file by time if it is not)."""
    back = np.flatnonzero(np.diff(rows.t) < 0)
    if back.size:
        i = int(back[0]) + 1
        at = "" if rows.lines is not None else f" at index {i}"
        raise InputFileError(rows.source, f"time must increase from row to row; got t = "
                                          f"{float(rows.t[i])!r} s{at} after t = "
                                          f"{float(rows.t[i - 1])!r} s (rows out of order: sort "
                                          "the file by time, or remove the stray row)",
                             field="t", **rows.where(i))


def merge_repeats(rows: Rows) -> tuple[Rows, list[str]]:
    """Merge rows that repeat a time stamp with agreeing positions; reject disagreeing ones."""
    first = np.r_[True, np.diff(rows.t) != 0]
    if first.all():
        return rows, []
    group = np.cumsum(first) - 1
    tol = np.maximum(REPEAT_AGREEMENT_SD * math.sqrt(2.0) * noise_sd(rows.pos[first]), _EXACT)
    with np.errstate(all="ignore"):
        for g in np.unique(group[~first]):
            members = np.flatnonzero(group == g)
            spread = np.ptp(rows.pos[members], axis=0)
            if not np.all(spread <= tol):
                _repeat_error(rows, members, spread, tol)
        merged = rows.keep(first)
        pos = np.array([rows.pos[group == g].mean(axis=0) for g in range(first.sum())])
        quality = {k: np.array([np.nanmean(v[group == g]) if np.isfinite(v[group == g]).any()
                                else math.nan for g in range(first.sum())])
                   for k, v in rows.quality.items()}
    repeated = np.flatnonzero(~first)
    note = (f"{repeated.size} row(s) repeating the time stamp of the row before merged with it "
            f"(positions agree within {REPEAT_AGREEMENT_SD:g} noise SD; {rows.names(repeated)})")
    return replace(merged, pos=pos, quality=quality), [note]


def _repeat_error(rows: Rows, members: np.ndarray, spread: np.ndarray, tol: np.ndarray) -> None:
    i = int(members[-1])
    c = int(np.argmax(spread / tol))
    raise InputFileError(rows.source, f"t = {float(rows.t[i])!r} s repeats the time of "
                                      f"{rows.name(int(members[0]))} but the position differs "
                                      f"by {spread[c] * 1e3:.3g} mm in {'xyz'[c]} (rows of one "
                                      f"frame agree within {tol[c] * 1e3:.2g} mm): two frames "
                                      "with one time stamp? write the times with more digits, "
                                      "or remove one row", field="t", **rows.where(i))


def drop_outliers(rows: Rows) -> tuple[Rows, list[str]]:
    """Leave out positions far from what both neighbouring pairs predict (one note naming
    their lines); too many of them reject the file."""
    n = rows.t.size
    if n < 5:
        return rows, []
    with np.errstate(all="ignore"):
        dev = np.minimum(_extrapolation_error(rows.t, rows.pos),
                         _extrapolation_error(rows.t[::-1], rows.pos[::-1])[::-1])
        step = float(np.median(np.max(np.abs(np.diff(rows.pos, axis=0)), axis=1)))
        threshold = max(OUTLIER_NOISE_SD * math.sqrt(6.0) * float(np.max(noise_sd(rows.pos))),
                        OUTLIER_STEPS * step, _EXACT)
        bad = ~(dev <= threshold)
    if not bad.any():
        return rows, []
    worst = int(np.flatnonzero(bad)[0])
    values = ", ".join(f"{'xyz'[c]} = {float(rows.pos[worst, c]):.4g} m"
                       for c in range(rows.pos.shape[1]))
    if bad.sum() > MAX_OUTLIER_FRACTION * n:
        raise InputFileError(rows.source, f"{int(bad.sum())} of {n} positions are outliers "
                                          f"(first at {rows.name(worst)}: {values}); is this "
                                          "one ball tracked in one unit?", **rows.where(worst))
    note = (f"{int(bad.sum())} outlier position(s) left out ({rows.names(np.flatnonzero(bad))}; "
            f"first {values}: more than {threshold * 1e3:.3g} mm from what the neighbouring "
            "samples predict)")
    return rows.keep(~bad), [note]


def _extrapolation_error(t: np.ndarray, pos: np.ndarray) -> np.ndarray:
    """|p_i - linear extrapolation from samples i-2, i-1| (max over coordinates); inf for the
    first two samples."""
    err = np.full(t.size, np.inf)
    ratio = (t[2:] - t[1:-1]) / (t[1:-1] - t[:-2])
    pred = pos[1:-1] + (pos[1:-1] - pos[:-2]) * ratio[:, None]
    err[2:] = np.max(np.abs(pos[2:] - pred), axis=1)
    return np.where(np.isnan(err), np.inf, err)


def check_plausible(rows: Rows, length_unit: str, scales: dict[str, float]) -> None:
    """Stop a file whose sampling interval or speed is outside the plausible ranges, with a
    hint at the unit that would make it plausible."""
    dt = float(np.median(np.diff(rows.t)))
    low, high = SAMPLE_INTERVAL_RANGE
    if not low <= dt <= high:
        hint = ("are the times in ms? times must be in seconds" if low <= dt / 1e3 <= high
                else "times must be in seconds")
        raise InputFileError(rows.source, f"the median sample interval is {dt:.4g} s "
                                          f"({1 / dt:.4g} frames/s), outside the plausible "
                                          f"{low:g}-{high:g} s: {hint}", field="t")
    speed = _median_speed(rows.t, rows.pos, dt)
    low, high = SPEED_RANGE
    if not low <= speed <= high:
        raise InputFileError(rows.source, f"{speed:.4g} m/s: the ball's median speed is outside "
                                          f"the plausible {low:g}-{high:g} m/s; "
                                          f"{_speed_hint(speed, length_unit, scales)}")


def _median_speed(t: np.ndarray, pos: np.ndarray, dt: float) -> float:
    stride = max(1, min(t.size - 1, round(SPEED_BASELINE / dt)))
    with np.errstate(all="ignore"):
        dist = np.sqrt(np.sum((pos[stride:] - pos[:-stride]) ** 2, axis=1))
        return float(np.median(dist / (t[stride:] - t[:-stride])))


def _speed_hint(speed: float, length_unit: str, scales: dict[str, float]) -> str:
    """The units that would make ``speed`` plausible, most typical first (a bouncing ball
    moves at about 3 m/s)."""
    low, high = SPEED_RANGE
    fits = sorted(((abs(math.log(speed * scale / scales[length_unit] / 3.0)), unit,
                    speed * scale / scales[length_unit]) for unit, scale in scales.items()
                   if unit != length_unit and low <= speed * scale / scales[length_unit] <= high))
    if fits:
        units = " or ".join(f"{unit} ({value:.3g} m/s)" for _, unit, value in fits)
        return (f"are the positions in {units}? set `length_unit` in [trajectories] (it is "
                f"{length_unit!r})")
    if low <= speed * 1e3 <= high:
        return "are the times in ms? times must be in seconds"
    return f"check the units: times in s, positions in `length_unit` ({length_unit!r})"
