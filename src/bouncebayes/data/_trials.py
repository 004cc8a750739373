"""The trial table: one row per bounce with its rebound (and optionally incidence) kinematics.

One schema (:data:`MEASURED`, :data:`SYSTEMATIC`, :data:`LABEL_COLUMNS`), one writer
(:func:`write_trials`) and one reader (:func:`load_trials`). Everything that writes a trial
table (``bouncebayes kinematics``, ``synth``, ``run``) goes through the writer, which refuses
to write what the reader would reject. ``docs/trial-table.md`` is generated from the schema
(:func:`trial_table_reference`).
"""

from __future__ import annotations

import csv
import hashlib
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np

from .._errors import InputFileError
from .._io import write_text
from .._validate import in_range_mask, range_text
from .._provenance import comment_line, parse_comment_line
from ._experiment import Experiment


@dataclass(frozen=True)
class Column:
    """One numeric column of the trial table: unit, allowed range, meaning."""

    unit: str
    doc: str
    low: float | None = None
    high: float | None = None
    low_open: bool = False
    high_open: bool = False

    def allowed(self) -> str:
        """The allowed values in words, e.g. ``a finite number > 0 m/s``."""
        return range_text(self.low, self.high, self.low_open, self.high_open, self.unit)


MEASURED: dict[str, Column] = {
    "rebound_speed": Column("m/s", "speed at separation (required)", 0.0, None, True),
    "rebound_angle": Column("deg", "angle of the rebound velocity from the plane normal, "
                                   "positive when the ball keeps moving forward (required)",
                            -90.0, 90.0),
    "incidence_speed": Column("m/s", "speed at first contact; absent: the experiment's "
                                     "nominal value", 0.0, None, True),
    "incidence_angle": Column("deg", "angle of the incident velocity from the plane normal; "
                                     "absent: the nominal value", 0.0, 90.0, False, True),
    "incidence_spin": Column("rad/s", "spin at first contact, counter-clockwise positive with x "
                                      "along the travel and y up, so topspin (rolling forward) "
                                      "is negative; absent: the nominal value"),
}
COLUMNS = MEASURED  # the measured quantities (each may have a standard-error column)
SE_SUFFIX = "_se"
SE_DOC = "standard error of `{name}` (same unit); an empty cell: not known"
NOTES = (
    "Angle standard errors include the uncertainty of the surface angle where the tracker "
    "stated one: a tilt of the surface by d changes the incidence angle by -d and the rebound "
    "angle by +d, so that part of their errors is perfectly anti-correlated (the table holds "
    "standard errors only).",
    "Consecutive bounces of one trajectory file (`<file>#<k>`, `<file>#<k+1>`) share the "
    "flight between them, so the rebound of one and the incidence of the next have correlated "
    "errors.",
    "An optional column is all filled or all empty. An absent incidence column means the "
    "experiment's nominal value with its bounce-to-bounce spread.",
)
SYSTEMATIC: dict[str, Column] = {
    "scale_rel_sd": Column("", "relative standard deviation of the length scale (the camera "
                               "calibration, metres per pixel) the trial was measured with. "
                               "Every speed of a trial scales with it and every trial filmed "
                               "with one calibration shares the same error, so it is a "
                               "campaign-level systematic, not part of the `_se` columns",
                           0.0, None),
}
REQUIRED = ("rebound_speed", "rebound_angle")
LABEL_COLUMNS = ("trial", "file", "note")
LABEL_DOC = {"trial": "the trial's name (kinematics writes `<file>` for a file with one bounce "
                      "and `<file>#<k>` for bounce k of a file with several)",
             "file": "accepted as the name where `trial` is absent (older tables)",
             "note": "free text, ignored"}
ALLOWED = (*MEASURED, *(c + SE_SUFFIX for c in MEASURED), *SYSTEMATIC, *LABEL_COLUMNS)


def _column(name: str) -> Column:
    """The schema entry of a numeric column (standard errors: >= 0 in the quantity's unit)."""
    if name.endswith(SE_SUFFIX) and name[:-len(SE_SUFFIX)] in MEASURED:
        return Column(MEASURED[name[:-len(SE_SUFFIX)]].unit, "", 0.0, None)
    return MEASURED.get(name) or SYSTEMATIC[name]


@dataclass(frozen=True)
class Trials:
    """Per-bounce kinematics, arrays of length ``n`` (read-only).

    Incidence columns missing from the file hold the experiment's nominal value (NaN without
    an experiment); ``measured`` says which were in the file. Standard errors (``se[column]``)
    and ``scale_rel_sd`` are NaN where not given. ``provenance``: the dict of the file's
    provenance comment, if it had one.
    """

    rebound_speed: np.ndarray  #: m/s
    rebound_angle: np.ndarray  #: deg from the normal
    incidence_speed: np.ndarray  #: m/s
    incidence_angle: np.ndarray  #: deg from the normal
    incidence_spin: np.ndarray  #: rad/s
    se: MappingProxyType  #: column -> standard errors (NaN: not given)
    measured: frozenset  #: incidence columns present in the source
    labels: tuple[str, ...]
    source: str = "<arrays>"
    sha256: str = ""
    scale_rel_sd: np.ndarray = field(default_factory=lambda: np.empty(0))
    provenance: Mapping[str, Any] | None = None

    def __post_init__(self) -> None:
        if self.scale_rel_sd.size == 0 and self.n > 0:  # not given: NaN for every trial
            object.__setattr__(self, "scale_rel_sd", _frozen(np.full(self.n, np.nan)))

    @property
    def n(self) -> int:
        """Number of trials."""
        return int(self.rebound_speed.size)

    def column(self, name: str) -> np.ndarray:
        """The values of a measured column (or ``scale_rel_sd``) by name."""
        return getattr(self, name)


def make_trials(experiment: Experiment | None, *, rebound_speed, rebound_angle,
                incidence_speed=None, incidence_angle=None, incidence_spin=None, se=None,
                labels=None, scale_rel_sd=None, source: str = "<arrays>", sha256: str = "",
                provenance: Mapping[str, Any] | None = None) -> Trials:
    """Build :class:`Trials` from arrays; absent incidence columns take the experiment's
    nominal values (NaN when ``experiment`` is None)."""
    inc = experiment.incidence if experiment is not None else None
    nominal = {"incidence_speed": inc.speed if inc else math.nan,
               "incidence_angle": inc.angle if inc else math.nan,
               "incidence_spin": inc.spin if inc else math.nan}
    given = {"rebound_speed": rebound_speed, "rebound_angle": rebound_angle,
             "incidence_speed": incidence_speed, "incidence_angle": incidence_angle,
             "incidence_spin": incidence_spin}
    n = np.asarray(rebound_speed).size
    cols = {k: _frozen(np.full(n, nominal[k]) if v is None else np.asarray(v, dtype=float))
            for k, v in given.items()}
    se = dict(se or {})
    se_cols = {k: _frozen(np.asarray(se[k], dtype=float) if k in se else np.full(n, np.nan))
               for k in MEASURED}
    measured = frozenset(k for k in nominal if given[k] is not None)
    labels = tuple(str(x) for x in labels) if labels is not None else tuple(
        str(i + 1) for i in range(n))
    scale = _frozen(np.full(n, np.nan) if scale_rel_sd is None else np.asarray(scale_rel_sd,
                                                                                dtype=float))
    return Trials(**cols, se=MappingProxyType(se_cols), measured=measured, labels=labels,
                  source=source, sha256=sha256, scale_rel_sd=scale,
                  provenance=None if provenance is None else MappingProxyType(dict(provenance)))


# ------------------------------------------------------------------------------------ reader

def load_trials(path: str | os.PathLike, experiment: Experiment, *,
                rebound_required: bool = True) -> Trials:
    """Read a trial table (CSV with a header row; lines starting with ``#`` are comments).

    Columns (``docs/trial-table.md``): ``rebound_speed`` (m/s) and ``rebound_angle`` (deg from
    the normal), required (unless ``rebound_required`` is false: bounces to predict, whose
    rebounds are then NaN where absent); ``incidence_speed``, ``incidence_angle``,
    ``incidence_spin`` (rad/s), optional; standard errors as ``<column>_se``; ``scale_rel_sd``
    (the calibration's relative uncertainty); labels ``trial``, ``file``, ``note``. A ``#
    provenance: {...}`` comment is read into ``Trials.provenance``. Every problem names the
    file, the line and the column.
    """
    path = Path(path)
    raw, rows, provenance = _read_rows(path)
    header_line, header = rows[0]
    names = [h.strip() for h in header]
    required = REQUIRED if rebound_required else ()
    _check_header(path, header_line, names, required)
    data = rows[1:]
    if not data:
        raise InputFileError(path, "no data rows after the header", line=header_line)
    values: dict[str, list[float]] = {n: [] for n in names if n not in LABEL_COLUMNS}
    labels: list[str] = []
    for line, row in data:
        if len(row) != len(names):
            raise InputFileError(path, f"has {len(row)} cells, the header has {len(names)}",
                                 line=line)
        cells = dict(zip(names, (c.strip() for c in row), strict=True))
        labels.append(cells.get("trial") or cells.get("file") or str(len(labels) + 1))
        for name in values:
            values[name].append(_cell(path, line, name, cells[name]))
    arrays = {k: np.array(v) for k, v in values.items()}
    _check_filled(path, arrays, [line for line, _ in data], required)
    for name in REQUIRED:
        arrays.setdefault(name, np.full(len(data), np.nan))
    return make_trials(experiment, **{k: arrays.get(k) for k in MEASURED},
                       se={k[:-3]: v for k, v in arrays.items() if k.endswith(SE_SUFFIX)},
                       scale_rel_sd=arrays.get("scale_rel_sd"), labels=labels,
                       source=str(path), sha256=hashlib.sha256(raw).hexdigest(),
                       provenance=provenance)


def _read_rows(path: Path) -> tuple[bytes, list[tuple[int, list[str]]], dict | None]:
    """Raw bytes, the non-comment rows with their line numbers, the provenance comment."""
    if path.is_dir():
        raise InputFileError(path, "is a folder; expected a trial table (CSV file)")
    try:
        raw = path.read_bytes()
        text = raw.decode("utf-8-sig")
    except OSError as exc:
        raise InputFileError(path, f"cannot read the trial table ({exc.strerror})") from None
    except UnicodeDecodeError:
        raise InputFileError(path, "not UTF-8 text; a trial table is CSV") from None
    rows, provenance = [], None
    for i, line in enumerate(text.splitlines()):
        if line.lstrip().startswith("#"):  # a comment: decided on the raw text
            provenance = provenance or parse_comment_line(line)
            continue
        row = next(csv.reader([line]), [])
        if row and any(c.strip() for c in row):
            rows.append((i + 1, row))
    if not rows:
        raise InputFileError(path, "empty: expected a header row with at least "
                                   f"{', '.join(REQUIRED)}")
    return raw, rows, provenance


def _check_header(path: Path, line: int, names: list[str], required: Sequence[str]) -> None:
    for name in names:
        if name not in ALLOWED:
            raise InputFileError(path, f"unknown column {name!r}; allowed columns: "
                                       f"{', '.join(ALLOWED)}", line=line)
    dupes = sorted({n for n in names if names.count(n) > 1})
    if dupes:
        raise InputFileError(path, f"duplicate column(s) {', '.join(dupes)}", line=line)
    missing = [n for n in required if n not in names]
    if missing:
        raise InputFileError(path, f"missing required column(s) {', '.join(missing)}; the "
                                   f"header has {', '.join(names)}", line=line)


def _check_filled(path: Path, arrays: dict[str, np.ndarray], lines: list[int],
                  required: Sequence[str]) -> None:
    """Required columns have no empty cell; optional measured columns are all or nothing."""
    for name in required:
        missing = np.flatnonzero(np.isnan(arrays[name]))
        if missing.size:
            raise InputFileError(path, "empty cell; this column is required",
                                 line=lines[missing[0]], field=name)
    for name in (c for c in (*MEASURED, *SYSTEMATIC) if c not in required and c in arrays):
        if np.isnan(arrays[name]).any() and not np.isnan(arrays[name]).all():
            line = lines[int(np.flatnonzero(np.isnan(arrays[name]))[0])]
            raise InputFileError(path, "empty cell in a column that has values elsewhere; "
                                       "fill it or drop the column (a dropped incidence column "
                                       "means the nominal value)", line=line, field=name)


def _cell(path: Path, line: int, name: str, text: str) -> float:
    if text == "":
        return math.nan
    try:
        value = float(text)
    except ValueError:
        raise InputFileError(path, f"{text!r} is not a number", line=line, field=name) from None
    column = _column(name)
    if not in_range_mask(np.array(value), column.low, column.high, column.low_open,
                         column.high_open):
        raise InputFileError(path, f"must be {column.allowed()}; got {text}", line=line,
                             field=name)
    return value


# ------------------------------------------------------------------------------------ writer

def write_trials(path: str | os.PathLike, trials: Trials, *,
                 provenance: Mapping[str, Any] | None = None) -> Path:
    """Write a trial table atomically, in the layout :func:`load_trials` reads.

    Layout: an optional first line ``# provenance: {...}`` (``provenance`` as one line of
    JSON; default: ``trials.provenance``), the header, one row per trial: ``trial`` (the
    label), the required columns, the measured incidence columns, the standard errors given
    for any trial (an empty cell where a trial has none), and ``scale_rel_sd`` where given.
    Numbers are written with full precision.

    Raises:
        ValueError: a value the reader would reject (the message names the trial and column).
        TypeError: ``provenance`` is not a JSON-serialisable dict.
        InputFileError: ``path`` is a folder.
    """
    if Path(path).is_dir():
        raise InputFileError(path, "is a folder; expected the name of the trial table to "
                                   "write, e.g. trials.csv")
    cols = [*REQUIRED, *(c for c in MEASURED if c in trials.measured)]
    se_cols = [c + SE_SUFFIX for c in cols if not np.isnan(trials.se[c]).all()]
    extra = [c for c in SYSTEMATIC if not np.isnan(trials.column(c)).all()]
    table = {c: trials.column(c) for c in (*cols, *extra)} | {
        c: trials.se[c[:-len(SE_SUFFIX)]] for c in se_cols}
    _check_writable(trials.labels, table)
    provenance = trials.provenance if provenance is None else provenance
    order = [*cols, *se_cols, *extra]
    lines = [] if provenance is None else [comment_line(provenance)]
    lines.append(",".join(["trial", *order]))
    lines += [",".join([_label_cell(label), *(_text(float(table[c][i])) for c in order)])
              for i, label in enumerate(trials.labels)]
    return write_text(path, "\n".join(lines) + "\n")


def _label_cell(label: str) -> str:
    """A label as a CSV cell: quoted where it holds a comma, starts with ``#`` (which would
    read as a comment) or has surrounding spaces."""
    return f'"{label}"' if ("," in label or label.startswith("#") or label != label.strip()) \
        else label


def _text(value: float) -> str:
    return "" if math.isnan(value) else repr(value)


def _check_writable(labels: Sequence[str], table: dict[str, np.ndarray]) -> None:
    """Refuse what :func:`load_trials` would reject: out-of-range or non-finite values (NaN is
    an empty cell, allowed for standard errors and optional columns that are all NaN)."""
    for i, label in enumerate(labels):
        if "\n" in label or "\r" in label or '"' in label or not label.strip():
            raise ValueError(f"trial {i + 1}: a label must be one line of text without "
                             f"double quotes; got {label!r}")
    for name, values in table.items():
        column = _column(name)
        ok = in_range_mask(values, column.low, column.high, column.low_open, column.high_open)
        ok |= np.isnan(values) & name.endswith(SE_SUFFIX)  # an empty cell: not known
        if not ok.all():
            i = int(np.argmin(ok))
            raise ValueError(f"trial {labels[i]!r}, `{name}`: must be {column.allowed()}; got "
                             f"{float(values[i])!r} (a trial table must be readable by "
                             "load_trials)")


def trial_table_reference() -> str:
    """docs/trial-table.md, generated from the schema above (a test keeps them equal)."""
    lines = ["# The trial table", "",
             "A CSV file with a header row, one row per bounce. Lines starting with `#` are "
             "comments; the package writes its provenance (version, inputs, settings) as a "
             "first line `# provenance: {...}` of JSON. Columns may come in any order; "
             "`bouncebayes.data.load_trials` reads it, `bouncebayes.data.write_trials` "
             "writes it, and every problem is reported with the file, line and column. This "
             "page is generated from `bouncebayes/data/_trials.py`.", "",
             "| column | meaning | allowed |", "|---|---|---|"]
    for name, column in MEASURED.items():
        lines.append(f"| `{name}` | {column.doc} | {column.allowed()} |")
        lines.append(f"| `{name}{SE_SUFFIX}` | {SE_DOC.format(name=name)} | "
                     f"{_column(name + SE_SUFFIX).allowed()} or empty |")
    for name, column in SYSTEMATIC.items():
        lines.append(f"| `{name}` | {column.doc} | {column.allowed()} |")
    for name in LABEL_COLUMNS:
        lines.append(f"| `{name}` | {LABEL_DOC[name]} | text |")
    for note in NOTES:
        lines += ["", note]
    return "\n".join(lines) + "\n"


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=float)
    a.setflags(write=False)
    return a
