"""The trial table: one row per bounce with its rebound (and optionally incidence) kinematics."""

from __future__ import annotations

import csv
import hashlib
import io
import math
import os
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType

import numpy as np

from .._errors import InputFileError
from .._io import write_text
from .._validate import range_text
from ._experiment import Experiment

# column -> (unit, low, high, low_open, high_open)
COLUMNS: dict[str, tuple[str, float | None, float | None, bool, bool]] = {
    "rebound_speed": ("m/s", 0.0, None, True, False),
    "rebound_angle": ("deg", -90.0, 90.0, False, False),
    "incidence_speed": ("m/s", 0.0, None, True, False),
    "incidence_angle": ("deg", 0.0, 90.0, False, True),
    "incidence_spin": ("rad/s", None, None, False, False),
}
REQUIRED = ("rebound_speed", "rebound_angle")
LABEL_COLUMNS = ("trial", "file", "note")
SE_SUFFIX = "_se"
ALLOWED = (*COLUMNS, *(c + SE_SUFFIX for c in COLUMNS), *LABEL_COLUMNS)


@dataclass(frozen=True)
class Trials:
    """Per-bounce kinematics, arrays of length ``n`` (read-only).

    Incidence columns missing from the file hold the experiment's nominal value; ``measured``
    says which were in the file. Standard errors (``se[column]``) are NaN where not given.
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

    @property
    def n(self) -> int:
        return int(self.rebound_speed.size)

    def column(self, name: str) -> np.ndarray:
        return getattr(self, name)


def make_trials(experiment: Experiment, *, rebound_speed, rebound_angle, incidence_speed=None,
                incidence_angle=None, incidence_spin=None, se=None, labels=None,
                source: str = "<arrays>", sha256: str = "") -> Trials:
    """Build :class:`Trials` from arrays; absent incidence columns take the nominal values."""
    nominal = {"incidence_speed": experiment.incidence.speed,
               "incidence_angle": experiment.incidence.angle,
               "incidence_spin": experiment.incidence.spin}
    given = {"rebound_speed": rebound_speed, "rebound_angle": rebound_angle,
             "incidence_speed": incidence_speed, "incidence_angle": incidence_angle,
             "incidence_spin": incidence_spin}
    n = np.asarray(rebound_speed).size
    cols = {k: _frozen(np.full(n, nominal[k]) if v is None else np.asarray(v, dtype=float))
            for k, v in given.items()}
    se = dict(se or {})
    se_cols = {k: _frozen(np.asarray(se[k], dtype=float) if k in se else np.full(n, np.nan))
               for k in COLUMNS}
    measured = frozenset(k for k in nominal if given[k] is not None)
    labels = tuple(str(x) for x in labels) if labels is not None else tuple(
        str(i + 1) for i in range(n))
    return Trials(**cols, se=MappingProxyType(se_cols), measured=measured, labels=labels,
                  source=source, sha256=sha256)


def load_trials(path: str | os.PathLike, experiment: Experiment) -> Trials:
    """Read a trial table (CSV with a header row; ``#`` lines are comments).

    Columns: ``rebound_speed`` (m/s) and ``rebound_angle`` (deg from the normal), required;
    ``incidence_speed``, ``incidence_angle``, ``incidence_spin`` (rad/s), optional; standard
    errors as ``<column>_se``; labels ``trial``, ``file``, ``note``. Every problem names the
    file, the line and the column.
    """
    path = Path(path)
    try:
        raw = path.read_bytes()
        text = raw.decode("utf-8-sig")
    except OSError as exc:
        raise InputFileError(path, f"cannot read the trial table ({exc.strerror})") from None
    except UnicodeDecodeError:
        raise InputFileError(path, "not UTF-8 text; a trial table is CSV") from None
    rows = [(i + 1, r) for i, r in enumerate(csv.reader(io.StringIO(text)))
            if r and any(c.strip() for c in r) and not r[0].lstrip().startswith("#")]
    if not rows:
        raise InputFileError(path, "empty: expected a header row with at least "
                                   f"{', '.join(REQUIRED)}")
    header_line, header = rows[0]
    names = [h.strip() for h in header]
    _check_header(path, header_line, names)
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
    for name in REQUIRED:
        missing = np.flatnonzero(np.isnan(arrays[name]))
        if missing.size:
            raise InputFileError(path, "empty cell; this column is required",
                                 line=data[missing[0]][0], field=name)
    for name in (c for c in COLUMNS if c not in REQUIRED and c in arrays):
        if np.isnan(arrays[name]).any() and not np.isnan(arrays[name]).all():
            line = data[int(np.flatnonzero(np.isnan(arrays[name]))[0])][0]
            raise InputFileError(path, "empty cell in a column that has values elsewhere; "
                                       "fill it or drop the column (a dropped incidence column "
                                       "means the nominal value)", line=line, field=name)
    return make_trials(experiment, **{k: arrays.get(k) for k in COLUMNS},
                       se={k[:-3]: v for k, v in arrays.items() if k.endswith(SE_SUFFIX)},
                       labels=labels, source=str(path), sha256=hashlib.sha256(raw).hexdigest())


def _check_header(path: Path, line: int, names: list[str]) -> None:
    for name in names:
        if name not in ALLOWED:
            raise InputFileError(path, f"unknown column {name!r}; allowed columns: "
                                       f"{', '.join(ALLOWED)}", line=line)
    dupes = sorted({n for n in names if names.count(n) > 1})
    if dupes:
        raise InputFileError(path, f"duplicate column(s) {', '.join(dupes)}", line=line)
    missing = [n for n in REQUIRED if n not in names]
    if missing:
        raise InputFileError(path, f"missing required column(s) {', '.join(missing)}; the "
                                   f"header has {', '.join(names)}", line=line)


def _cell(path: Path, line: int, name: str, text: str) -> float:
    if text == "":
        return math.nan
    try:
        value = float(text)
    except ValueError:
        raise InputFileError(path, f"{text!r} is not a number", line=line, field=name) from None
    column = name[:-3] if name.endswith(SE_SUFFIX) else name
    unit, low, high, low_open, high_open = COLUMNS[column]
    if name.endswith(SE_SUFFIX):
        low, high, low_open, high_open = 0.0, None, False, False
    ok = math.isfinite(value)
    if low is not None:
        ok &= value > low if low_open else value >= low
    if high is not None:
        ok &= value < high if high_open else value <= high
    if not ok:
        raise InputFileError(path, f"must be {range_text(low, high, low_open, high_open, unit)}"
                                   f"; got {text}", line=line, field=name)
    return value


def write_trials(path: str | os.PathLike, trials: Trials, *, header_comment: str = "") -> Path:
    """Write a trial table atomically: measured columns, then standard errors where given."""
    cols = [*REQUIRED, *(c for c in COLUMNS if c in trials.measured)]
    se_cols = [c for c in cols if not np.isnan(trials.se[c]).all()]
    out = io.StringIO()
    for line in header_comment.splitlines():
        out.write(f"# {line}\n")
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(["trial", *cols, *(c + SE_SUFFIX for c in se_cols)])
    for i in range(trials.n):
        writer.writerow([trials.labels[i], *(repr(float(trials.column(c)[i])) for c in cols),
                         *(repr(float(trials.se[c][i])) for c in se_cols)])
    return write_text(path, out.getvalue())


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=float)
    a.setflags(write=False)
    return a
