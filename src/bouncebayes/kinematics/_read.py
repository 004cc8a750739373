"""Reading one tracked bounce: a CSV file or a Tracker data export -> :class:`Trajectory`."""

from __future__ import annotations

import csv
import math
import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from .._errors import InputFileError
from .._validate import check_choice, check_scalar

LengthUnit = Literal["m", "cm", "mm"]
LENGTH_UNITS: dict[str, float] = {"m": 1.0, "cm": 1e-2, "mm": 1e-3}
MIN_TRACKED_POINTS = 6  # fewer rows than this cannot hold two fitted free-flight segments
_REQUIRED = ("t", "x", "y")
# Tracker's "File > Export > Data" text file, as written by its source
# (github.com/OpenSourcePhysics/tracker, src/org/opensourcephysics/cabrillo/tracker/):
# ExportDataDialog.saveAsAction writes the track name with spaces replaced by "_" and a newline,
# then TrackerIO.getData: the column names joined by the delimiter, then one row per frame, each
# number formatted "0.000000000E0" (unformatted export; e.g. 3.200000000E-2) with
# OSPRuntime.getDecimalFormatSymbols() (so a decimal comma in such locales), and nothing written
# for a null cell (an untracked frame) but the delimiter. TrackerIO.delimiters: tab (default),
# space, comma, semicolon, plus custom ones. A worked example of the layout ("cm_A", then
# "t  x  y", then "0.000000000E0  1.245986911E1  -1.328191643E1") is in the Brock University
# Tracker notes, physics.brocku.ca/Courses/2P20/Tracker/index.php?page=21. Several tracks exported
# together repeat the column names ("#multi:" title): we ask for one track per file.
# Java's DecimalFormat writes NaN as U+FFFD (or "NaN") and infinity as U+221E.
_NON_FINITE = {"nan", "+nan", "-nan", "inf", "+inf", "-inf", "infinity", "+infinity",
               "-infinity", "\ufffd", "\u221e", "-\u221e"}
_NUMBER = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?")


@dataclass(frozen=True, eq=False)
class Trajectory:
    """Tracked centre positions in the plane-aligned frame (read-only arrays, SI units).

    ``flipped_x``: the incident travel was towards -x in the file, so x (and z, keeping the axes
    right-handed: a half-turn about the normal) were negated. ``rotation_deg``: the camera-to-plane
    rotation that was applied. ``n_dropped``: rows skipped because a t/x/y(/z) cell was empty.
    """

    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    z: np.ndarray | None
    source: str
    flipped_x: bool
    sample_rate_hz: float
    rotation_deg: float = 0.0
    n_dropped: int = 0

    @property
    def n(self) -> int:
        return int(self.t.size)

    def positions(self) -> np.ndarray:
        """Positions as an ``(n, d)`` array, columns x, y (, z)."""
        cols = (self.x, self.y) if self.z is None else (self.x, self.y, self.z)
        return np.column_stack(cols)


def read_trajectory(path: str | os.PathLike, *, rotation_deg: float = 0.0,
                    length_unit: LengthUnit = "m") -> Trajectory:
    """Read one tracked bounce from a CSV file or a Tracker data export.

    Accepted layouts (the delimiter is taken from the header row: tab, then ``;``, then ``,``,
    else runs of spaces):

    - CSV with a header row naming ``t``, ``x``, ``y`` and optionally ``z`` (any order, other
      columns ignored; names are matched case-insensitively);
    - Tracker's "Export > Data" text file: a title line with the track name (spaces written as
      ``_``, e.g. ``mass_A``), a header row of column names joined by the chosen delimiter (tab by
      default; space, comma, semicolon or custom), then one row per frame. Tracker writes numbers
      with the locale's decimal separator (``1,245986911E-1`` in a decimal-comma locale, read here
      whenever the delimiter is not a comma) and leaves a cell empty where a frame was not
      tracked; such rows are dropped, never filled in (sources: the comment on Tracker's
      format at the top of this module).

    Times are in seconds; positions in ``length_unit`` ("m", "cm" or "mm") and in the
    plane-aligned frame unless ``rotation_deg`` is given. Camera-to-plane rotation, in words::

        camera (as tracked)                          plane frame (returned)
          y_cam                                        y = outward normal
          |           _.-' plane surface               |
          |      _.-'  ) a = rotation_deg              |
          +---------------------- x_cam                +------------------- x (along the plane)

    ``a`` is the angle from the camera's x axis to the plane's surface line, counter-clockwise
    positive (a ramp rising to the right of the image has a > 0). Points are turned by -a:
    ``x = x_cam cos a + y_cam sin a``, ``y = -x_cam sin a + y_cam cos a`` (z is unchanged). Then, if
    the ball moved towards -x before its lowest point, x and z are negated (``flipped_x``; a
    half-turn about the normal, which keeps the axes right-handed).

    Raises:
        InputFileError: missing/unreadable/empty file, no header row naming t, x and y (the
            message lists the columns found), a non-numeric or non-finite cell (line and column),
            time not increasing (line), fewer than 6 tracked rows.
        ValueError, TypeError: a bad ``rotation_deg`` or ``length_unit``.
    """
    rotation = check_scalar("rotation_deg", rotation_deg, unit="deg")
    scale = LENGTH_UNITS[check_choice("length_unit", length_unit, LENGTH_UNITS)]
    lines = _read_lines(path)
    columns, line_numbers, n_dropped = _parse_table(os.fspath(path), lines)
    return _build(os.fspath(path), columns, line_numbers, rotation, scale, n_dropped)


def trajectory_from_arrays(t, x, y, z=None, *, rotation_deg: float = 0.0,
                           length_unit: LengthUnit = "m",
                           source: str = "<arrays>") -> Trajectory:
    """Build a :class:`Trajectory` from arrays, with the checks and transforms of
    :func:`read_trajectory` (problems are reported by 0-based index instead of line)."""
    rotation = check_scalar("rotation_deg", rotation_deg, unit="deg")
    scale = LENGTH_UNITS[check_choice("length_unit", length_unit, LENGTH_UNITS)]
    named = {"t": t, "x": x, "y": y} | ({} if z is None else {"z": z})
    columns = {k: np.asarray(v, dtype=float) for k, v in named.items()}
    shapes = {k: v.shape for k, v in columns.items()}
    if any(len(s) != 1 for s in shapes.values()) or len(set(shapes.values())) != 1:
        raise InputFileError(source, f"`t`, `x`, `y` (and `z`) must be 1-D arrays of one length; "
                                     f"got shapes {shapes}")
    for name, values in columns.items():
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            raise InputFileError(source, f"must be finite; got {float(values[bad[0]])!r} at "
                                         f"index {int(bad[0])}", field=name)
    return _build(source, columns, None, rotation, scale, 0)


def _read_lines(path: str | os.PathLike) -> list[str]:
    p = Path(path)
    if not p.exists():
        raise InputFileError(p, "no such file; expected a CSV or Tracker text export with "
                                "columns t, x, y")
    if p.is_dir():
        raise InputFileError(p, "is a folder; expected one trajectory file (use "
                                "kinematics_from_folder for a folder)")
    try:
        text = p.read_bytes().decode("utf-8-sig")
    except OSError as exc:
        raise InputFileError(p, f"cannot read the file ({exc.strerror})") from None
    except UnicodeDecodeError:
        raise InputFileError(p, "not UTF-8 text; expected a CSV or Tracker text export") from None
    lines = text.splitlines()
    if not any(line.strip() for line in lines):
        raise InputFileError(p, "the file is empty; expected a header row naming the columns "
                                f"t, x, y and at least {MIN_TRACKED_POINTS} rows of numbers")
    return lines


def _delimiter(line: str) -> str | None:
    return next((d for d in ("\t", ";", ",") if d in line), None)


def _split(line: str, delimiter: str | None) -> list[str]:
    cells = line.split() if delimiter is None else next(csv.reader([line], delimiter=delimiter))
    return [c.strip() for c in cells]


def _column_name(cell: str) -> str:
    return cell.strip().strip("\"'").strip().lower()


def _number(cell: str, decimal_comma: bool) -> float | None:
    """The value of a cell, NaN for a non-finite word, None if it is not a number."""
    text = cell.replace(",", ".") if decimal_comma else cell
    if text.lower() in _NON_FINITE:
        return math.nan
    return float(text) if _NUMBER.fullmatch(text) else None


def _find_header(path: str, lines: list[str]) -> tuple[int, str | None, list[str]]:
    """Index, delimiter and column names of the first row naming t, x and y."""
    candidate = None
    for i, line in enumerate(lines):
        if not line.strip():
            continue
        delimiter = _delimiter(line)
        cells = _split(line, delimiter)
        names = [_column_name(c) for c in cells]
        if set(_REQUIRED) <= set(names):
            return i, delimiter, names
        first = next((c for c in cells if c), "")
        if _number(first, delimiter != ",") is not None:
            break  # numbers before any header
        candidate = (i, names)
    if candidate is None:
        raise InputFileError(path, "no header row: the first row already holds numbers; the "
                                   "first row (after an optional title line) must name the "
                                   "columns, e.g. `t,x,y`", line=i + 1)
    i, names = candidate
    missing = ", ".join(f"`{n}`" for n in _REQUIRED if n not in names)
    found = ", ".join(repr(n) for n in names if n) or "none"
    raise InputFileError(path, f"no header row naming the columns t, x and y: missing {missing}; "
                               f"the columns found are {found}", line=i + 1)


def _parse_table(path: str, lines: list[str]
                 ) -> tuple[dict[str, np.ndarray], np.ndarray, int]:
    """Columns t, x, y (, z) of the tracked rows, their line numbers, the count of dropped rows."""
    start, delimiter, names = _find_header(path, lines)
    wanted = [n for n in (*_REQUIRED, "z") if n in names]
    for name in wanted:
        if names.count(name) > 1:
            where = [j + 1 for j, n in enumerate(names) if n == name]
            raise InputFileError(path, f"column `{name}` appears {len(where)} times (columns "
                                       f"{where}); Tracker writes this when several tracks are "
                                       "exported together: export one track per file",
                                 line=start + 1)
    index = {n: names.index(n) for n in wanted}
    values: dict[str, list[float]] = {n: [] for n in wanted}
    line_numbers, dropped = [], 0
    for i in range(start + 1, len(lines)):
        if not lines[i].strip():
            continue
        cells = _split(lines[i], delimiter)
        row = {n: cells[j] if j < len(cells) else "" for n, j in index.items()}
        if any(c == "" for c in row.values()):
            dropped += 1  # an untracked frame: never invented
            continue
        for name, cell in row.items():
            values[name].append(_cell(path, i + 1, name, index[name], cell, delimiter != ","))
        line_numbers.append(i + 1)
    return {k: np.array(v) for k, v in values.items()}, np.array(line_numbers, int), dropped


def _cell(path: str, line: int, name: str, column: int, cell: str, decimal_comma: bool) -> float:
    value = _number(cell, decimal_comma)
    if value is None:
        raise InputFileError(path, f"column {column + 1} holds {cell!r}, which is not a number; "
                                   "allowed: decimal numbers such as 0.0125 or 1.25E-2"
                                   + (" (a decimal comma is accepted)" if decimal_comma else ""),
                             line=line, field=name)
    if not math.isfinite(value):
        raise InputFileError(path, f"column {column + 1} holds {cell!r}, which is not a finite "
                                   "number; leave the cells of an untracked frame empty",
                             line=line, field=name)
    return value


def _build(source: str, columns: dict[str, np.ndarray], line_numbers: np.ndarray | None,
           rotation_deg: float, scale: float, n_dropped: int) -> Trajectory:
    t = columns["t"]

    def where(i: int) -> dict:
        return {"line": int(line_numbers[i])} if line_numbers is not None else {}

    def at(i: int) -> str:
        return "" if line_numbers is not None else f" at index {i}"

    if t.size < MIN_TRACKED_POINTS:
        skipped = (f" ({n_dropped} row{'s' if n_dropped > 1 else ''} with an empty cell "
                   f"{'were' if n_dropped > 1 else 'was'} skipped)") if n_dropped else ""
        raise InputFileError(source, f"only {t.size} tracked rows{skipped}; need at least "
                                     f"{MIN_TRACKED_POINTS}")
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
        i = int(bad[0]) + 1
        raise InputFileError(source, f"time must increase from row to row; got t = "
                                     f"{float(t[i])!r} s{at(i)} after t = {float(t[i - 1])!r} s",
                             field="t", **where(i))
    x, y = _rotate(columns["x"] * scale, columns["y"] * scale, math.radians(rotation_deg))
    z = columns["z"] * scale if "z" in columns else None
    flipped = _travels_backwards(x, y)
    if flipped:
        x, z = -x, (None if z is None else -z)
    return Trajectory(t=_frozen(t), x=_frozen(x), y=_frozen(y),
                      z=None if z is None else _frozen(z), source=source, flipped_x=flipped,
                      sample_rate_hz=float(np.median(1.0 / np.diff(t))),
                      rotation_deg=rotation_deg, n_dropped=n_dropped)


def _rotate(x: np.ndarray, y: np.ndarray, a: float) -> tuple[np.ndarray, np.ndarray]:
    c, s = math.cos(a), math.sin(a)
    return c * x + s * y, -s * x + c * y


def _travels_backwards(x: np.ndarray, y: np.ndarray) -> bool:
    """True if x decreases from the first sample to the lowest (or the last, if that is first)."""
    low = int(np.argmin(y))
    return bool((x[low] if low > 0 else x[-1]) < x[0])


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=float)
    a.setflags(write=False)
    return a
