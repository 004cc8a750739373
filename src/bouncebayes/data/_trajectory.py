"""The trajectory file: one tracked ball, one row per frame (one writer, one reader).

Layout written by :func:`write_trajectory` (the tracker and ``synth``)::

    # provenance: {"bouncebayes_version": ..., ...}      optional comment lines
    t,x,y[,z][,residual][,visible][,flag]
    0.0,0.1012,0.0531,...

``t`` in seconds, positions in metres (or the experiment's ``length_unit``). The per-frame
quality columns are written by the video tracker: ``residual`` (RMS misfit of the ball model,
grey levels), ``visible`` (fraction of the ball inside the frame, 0-1), ``flag`` (1: the
tracker does not trust the frame). :func:`read_trajectory_table` also reads Tracker's "Export
> Data" text (below) and any CSV naming ``t``, ``x``, ``y``; it leaves out, and says so,
untracked frames (an empty or NaN cell) and frames flagged 1.

The tracker may write a sidecar ``<name>.track.json`` beside ``<name>.csv`` with its
calibration uncertainty, read by :func:`read_track_sidecar`::

    {"calibration": {"metres_per_pixel": .., "relative_sd": ..},
     "surface": {"angle_deg": .., "angle_sd_deg": ..}, ...}
"""

from __future__ import annotations

import csv
import json
import math
import os
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .._errors import InputFileError
from .._io import write_text
from .._provenance import comment_line, parse_comment_line

POSITION_COLUMNS = ("t", "x", "y", "z")  # z optional
REQUIRED_COLUMNS = ("t", "x", "y")
# name -> (meaning, low, high); NaN or an empty cell: not known
QUALITY_COLUMNS: dict[str, tuple[str, float, float]] = {
    "residual": ("RMS misfit of the tracker's ball model in the frame, grey levels", 0.0,
                 math.inf),
    "visible": ("fraction of the ball inside the frame", 0.0, 1.0),
    "flag": ("1: the tracker does not trust the frame (left out), 0: fine", 0.0, 1.0),
}
SIDECAR_SUFFIX = ".track.json"
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
_NAN_WORDS = {"nan", "+nan", "-nan", "\ufffd"}
_INF_WORDS = {"inf", "+inf", "-inf", "infinity", "+infinity", "-infinity", "\u221e", "-\u221e"}
_NUMBER = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?")
_MIN_MESSAGE_LINES = 5  # line numbers quoted in a message before "..."


@dataclass(frozen=True)
class TrajectoryTable:
    """The rows of a trajectory file as read, before any interpretation (units, frame).

    ``columns``: ``t``, ``x``, ``y`` (, ``z``) and the quality columns present, float arrays of
    the kept rows in file order; ``lines``: the 1-based line of each kept row; ``notes``:
    one-line messages about rows left out; ``n_untracked`` / ``n_flagged``: rows left out for
    an empty or NaN cell / for ``flag = 1``.
    """

    source: str
    columns: Mapping[str, np.ndarray]
    lines: np.ndarray
    notes: tuple[str, ...] = ()
    provenance: Mapping[str, Any] | None = None
    n_untracked: int = 0
    n_flagged: int = 0


@dataclass(frozen=True)
class TrackSidecar:
    """The calibration uncertainty a tracker stated for one trajectory (None: not stated)."""

    path: str
    scale_rel_sd: float | None = None  #: relative SD of metres per pixel
    surface_angle_sd_deg: float | None = None  #: SD of the detected surface angle, deg
    position_sd: float | None = None  #: per-frame SD of the tracked centres, m per coordinate
    #: what set the scale (``calibration.source``: "ball diameter", "reference"); None: not said
    calibration_source: str | None = None


def line_list(lines: Sequence[int]) -> str:
    """``"lines 5, 9, 12"`` (the first few, then the count)."""
    shown = ", ".join(str(int(i)) for i in lines[:_MIN_MESSAGE_LINES])
    more = f" and {len(lines) - _MIN_MESSAGE_LINES} more" if len(lines) > _MIN_MESSAGE_LINES else ""
    return f"line{'s' if len(lines) > 1 else ''} {shown}{more}"


# ------------------------------------------------------------------------------------ writer

def write_trajectory(path: str | os.PathLike, t, x, y, z=None, *,
                     quality: Mapping[str, Any] | None = None,
                     provenance: Mapping[str, Any] | None = None) -> Path:
    """Write one trajectory file atomically (layout in the module docstring).

    Arguments:
        path: the CSV file to write.
        t: times (s), 1-D, finite.
        x: positions along the plane (m), as long as ``t``, finite.
        y: positions along the normal (m).
        z: optional second coordinate in the plane (m).
        quality: optional per-frame columns ``residual``, ``visible`` (NaN: not known, written
            as an empty cell) and ``flag`` (0 or 1), each of the same length.
        provenance: written as a first comment line ``# provenance: {...}`` (one line of JSON).

    Raises:
        ValueError, TypeError: arrays of different lengths, non-finite positions, a quality
            column that is unknown or out of range, a provenance that is not JSON.
    """
    cols = {"t": t, "x": x, "y": y} | ({} if z is None else {"z": z})
    arrays = {k: np.asarray(v, dtype=float) for k, v in cols.items()}
    arrays |= _quality_arrays(quality or {})
    shapes = {k: v.shape for k, v in arrays.items()}
    if any(len(s) != 1 for s in shapes.values()) or len(set(shapes.values())) != 1:
        raise ValueError(f"trajectory columns must be 1-D and of one length; got shapes {shapes}")
    for name in cols:
        bad = np.flatnonzero(~np.isfinite(arrays[name]))
        if bad.size:
            raise ValueError(f"`{name}` must be finite (write tracked frames only); got "
                             f"{float(arrays[name][bad[0]])!r} at index {int(bad[0])}")
    lines = [] if provenance is None else [comment_line(provenance)]
    lines.append(",".join(arrays))
    lines += [",".join("" if math.isnan(v) else repr(v) for v in row)
              for row in zip(*(a.tolist() for a in arrays.values()), strict=True)]
    return write_text(path, "\n".join(lines) + "\n")


def _quality_arrays(quality: Mapping[str, Any]) -> dict[str, np.ndarray]:
    out = {}
    for name, values in quality.items():
        if name not in QUALITY_COLUMNS:
            raise ValueError(f"`quality` has an unknown column {name!r}; allowed: "
                             f"{', '.join(QUALITY_COLUMNS)}")
        _, low, high = QUALITY_COLUMNS[name]
        a = np.asarray(values, dtype=float)
        bad = ~((a >= low) & (a <= high)) & ~(np.isnan(a) & (name != "flag"))
        if name == "flag":
            bad |= ~np.isin(a, (0.0, 1.0))
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise ValueError(f"`quality['{name}']` must be {_quality_range(name)}; got "
                             f"{float(a.flat[i])!r} at index {i}")
        out[name] = a
    return out


def _quality_range(name: str) -> str:
    _, low, high = QUALITY_COLUMNS[name]
    return "0 or 1" if name == "flag" else (f"in [{low:g}, {high:g}]" if math.isfinite(high)
                                            else f">= {low:g}") + " (NaN: not known)"


# ------------------------------------------------------------------------------------ reader

def read_trajectory_table(path: str | os.PathLike) -> TrajectoryTable:
    """Read the rows of a trajectory file (CSV or Tracker's data export), as they are.

    Accepted layouts (the delimiter is taken from the header row: tab, then ``;``, then ``,``,
    else runs of spaces): a header row naming ``t``, ``x``, ``y`` (optionally ``z`` and the
    quality columns; any order, other columns ignored, names matched case-insensitively),
    optionally after a title line (Tracker writes the track name) and ``#`` comment lines (a
    ``# provenance: {...}`` line is read). Tracker writes numbers with the locale's decimal
    separator (``1,245986911E-1`` is read whenever the delimiter is not a comma) and leaves a
    cell empty where a frame was not tracked. Rows with an empty or NaN position or time are
    untracked frames and rows with ``flag = 1`` untrusted ones: both are left out (never filled
    in) and counted in a note.

    Raises:
        InputFileError: missing/unreadable/empty file, no header naming t, x and y (the message
            lists the columns found), a cell that is not a number or is infinite, a quality
            value out of range (each with its line and column).
    """
    source = os.fspath(path)
    lines = _read_lines(path)
    provenance = next((p for p in map(parse_comment_line, lines) if p is not None), None)
    start, delimiter, names = _find_header(source, lines)
    index = _column_index(source, start, names)
    values: dict[str, list[float]] = {n: [] for n in index}
    kept, untracked, flagged = [], [], []
    for i in range(start + 1, len(lines)):
        if not lines[i].strip() or lines[i].lstrip().startswith("#"):
            continue
        cells = _split(lines[i], delimiter)
        row = {n: _cell(source, i + 1, n, j, cells[j] if j < len(cells) else "",
                        delimiter != ",") for n, j in index.items()}
        if any(math.isnan(row[n]) for n in index if n in POSITION_COLUMNS):
            untracked.append(i + 1)  # an untracked frame: never invented
        elif row.get("flag") == 1.0:
            flagged.append(i + 1)
        else:
            for name, value in row.items():
                values[name].append(value)
            kept.append(i + 1)
    notes = ([f"{len(untracked)} untracked row(s) left out (an empty or NaN cell; "
              f"{line_list(untracked)})"] if untracked else []) + (
        [f"{len(flagged)} row(s) flagged by the tracker (flag = 1) left out "
         f"({line_list(flagged)})"] if flagged else [])
    return TrajectoryTable(source, {k: np.array(v, dtype=float) for k, v in values.items()},
                           np.array(kept, dtype=int), tuple(notes), provenance,
                           len(untracked), len(flagged))


def _read_lines(path: str | os.PathLike) -> list[str]:
    p = Path(path)
    if not p.exists():
        raise InputFileError(p, "no such file; expected a CSV or Tracker text export with "
                                "columns t, x, y")
    if p.is_dir():
        raise InputFileError(p, "is a folder; expected one trajectory file")
    try:
        text = p.read_bytes().decode("utf-8-sig")
    except OSError as exc:
        raise InputFileError(p, f"cannot read the file ({exc.strerror})") from None
    except UnicodeDecodeError:
        raise InputFileError(p, "not UTF-8 text; expected a CSV or Tracker text export") from None
    lines = text.splitlines()
    if not any(line.strip() and not line.lstrip().startswith("#") for line in lines):
        raise InputFileError(p, "the file is empty; expected a header row naming the columns "
                                "t, x, y and rows of numbers")
    return lines


def _delimiter(line: str) -> str | None:
    return next((d for d in ("\t", ";", ",") if d in line), None)


def _split(line: str, delimiter: str | None) -> list[str]:
    cells = line.split() if delimiter is None else next(csv.reader([line], delimiter=delimiter))
    return [c.strip() for c in cells]


def _column_name(cell: str) -> str:
    return cell.strip().strip("\"'").strip().lower()


def _number(cell: str, decimal_comma: bool) -> float | None:
    """The value of a cell: NaN for an empty cell or a NaN word, +-inf for an infinity word,
    None if it is not a number."""
    text = cell.replace(",", ".") if decimal_comma else cell
    word = text.lower()
    if word == "" or word in _NAN_WORDS:
        return math.nan
    if word in _INF_WORDS:
        return -math.inf if word.startswith("-") else math.inf
    return float(text) if _NUMBER.fullmatch(text) else None


def _find_header(path: str, lines: list[str]) -> tuple[int, str | None, list[str]]:
    """Index, delimiter and column names of the first row naming t, x and y."""
    candidate, i = None, 0
    for i, line in enumerate(lines):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        delimiter = _delimiter(line)
        cells = _split(line, delimiter)
        names = [_column_name(c) for c in cells]
        if set(REQUIRED_COLUMNS) <= set(names):
            return i, delimiter, names
        first = next((c for c in cells if c), "")
        if first and _number(first, delimiter != ",") is not None:
            break  # numbers before any header
        candidate = (i, names)
    if candidate is None:
        raise InputFileError(path, "no header row: the first row already holds numbers; the "
                                   "first row (after an optional title line) must name the "
                                   "columns, e.g. `t,x,y`", line=i + 1)
    i, names = candidate
    missing = ", ".join(f"`{n}`" for n in REQUIRED_COLUMNS if n not in names)
    found = ", ".join(repr(n) for n in names if n) or "none"
    raise InputFileError(path, f"no header row naming the columns t, x and y: missing {missing}; "
                               f"the columns found are {found}", line=i + 1)


def _column_index(path: str, start: int, names: list[str]) -> dict[str, int]:
    wanted = [n for n in (*POSITION_COLUMNS, *QUALITY_COLUMNS) if n in names]
    for name in wanted:
        if names.count(name) > 1:
            where = [j + 1 for j, n in enumerate(names) if n == name]
            raise InputFileError(path, f"column `{name}` appears {len(where)} times (columns "
                                       f"{where}); Tracker writes this when several tracks are "
                                       "exported together: export one track per file",
                                 line=start + 1)
    return {n: names.index(n) for n in wanted}


def _cell(path: str, line: int, name: str, column: int, cell: str, decimal_comma: bool) -> float:
    value = _number(cell, decimal_comma)
    if value is None:
        raise InputFileError(path, f"column {column + 1} holds {cell!r}, which is not a number; "
                                   "allowed: decimal numbers such as 0.0125 or 1.25E-2"
                                   + (" (a decimal comma is accepted)" if decimal_comma else ""),
                             line=line, field=name)
    if math.isinf(value):
        raise InputFileError(path, f"column {column + 1} holds {cell!r}, which is not a finite "
                                   "number; leave the cells of an untracked frame empty",
                             line=line, field=name)
    if name in QUALITY_COLUMNS and not math.isnan(value):
        _, low, high = QUALITY_COLUMNS[name]
        if not low <= value <= high or (name == "flag" and value not in (0.0, 1.0)):
            raise InputFileError(path, f"must be {_quality_range(name)}; got {cell!r}",
                                 line=line, field=name)
    return value


# ----------------------------------------------------------------------------------- sidecar

def sidecar_path(trajectory_path: str | os.PathLike) -> Path:
    """``<name>.track.json`` beside the trajectory file ``<name>.csv``."""
    p = Path(trajectory_path)
    return p.with_name(p.stem + SIDECAR_SUFFIX)


def read_track_sidecar(trajectory_path: str | os.PathLike) -> TrackSidecar | None:
    """The tracker's calibration uncertainty for a trajectory file; None if no sidecar.

    Reads ``calibration.relative_sd``, ``surface.angle_sd_deg`` and ``ball.centre_sd_px``
    times ``calibration.metres_per_pixel`` (each optional, a finite number >= 0) and
    ``calibration.source`` (optional, a string); other keys are ignored.

    Raises:
        InputFileError: the sidecar is not JSON, not an object, or a value is not allowed.
    """
    path = sidecar_path(trajectory_path)
    if not path.is_file():
        return None
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise InputFileError(path, f"not a readable JSON file ({exc})") from None
    if not isinstance(data, dict):
        raise InputFileError(path, f"must hold a JSON object; got {type(data).__name__}")
    values = {key: _sidecar_value(path, data, section, key)
              for section, key in (("calibration", "relative_sd"),
                                   ("surface", "angle_sd_deg"), ("ball", "centre_sd_px"),
                                   ("calibration", "metres_per_pixel"))}
    sd_px, mpp = values["centre_sd_px"], values["metres_per_pixel"]
    source = (data.get("calibration") or {}).get("source")
    if source is not None and not isinstance(source, str):
        raise InputFileError(path, f"must be a string; got {source!r}",
                             field="calibration.source")
    return TrackSidecar(os.fspath(path), values["relative_sd"], values["angle_sd_deg"],
                        None if sd_px is None or mpp is None else sd_px * mpp, source)


def _sidecar_value(path: Path, data: dict, section: str, key: str) -> float | None:
    part = data.get(section)
    if part is None:
        return None
    if not isinstance(part, dict):
        raise InputFileError(path, f"must be a JSON object; got {part!r}", field=section)
    value = part.get(key)
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int | float) or not (
            math.isfinite(value) and value >= 0):
        raise InputFileError(path, f"must be a finite number >= 0; got {value!r}",
                             field=f"{section}.{key}")
    return float(value)
