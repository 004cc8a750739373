"""Measured incident spin beside the trajectories: ``spin.csv`` with ``file,incidence_spin``
(rad/s; optional ``incidence_spin_se``), one row per trial.

A row names a trajectory file of the folder (``b7.csv``) for a file with one bounce, or one
bounce of a file with several (``b7.csv#2``, 1-based). The spin is in the model's frame (x along
the travel, y up, counter-clockwise positive), so topspin (rolling forward) is negative whatever
the direction of travel in the image.
"""

from __future__ import annotations

import csv
import io
import math
import os
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

from .._errors import InputFileError

SPIN_FILE = "spin.csv"
_COLUMNS = ("file", "incidence_spin", "incidence_spin_se", "note")


@dataclass(frozen=True)
class SpinRow:
    """One measured spin (rad/s) with its standard error (None: not given) and its line."""

    spin: float
    se: float | None
    line: int


def read_spin_table(path: str | os.PathLike) -> dict[str, SpinRow]:
    """Rows of a spin table by trial name.

    Raises:
        InputFileError: unreadable file, a missing or unknown column, an empty name, a value
            that is not a finite number (standard error: >= 0), a name given twice (each with
            its line).
    """
    path = Path(path)
    try:
        text = path.read_bytes().decode("utf-8-sig")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputFileError(path, f"cannot read the spin table ({exc})") from None
    rows = [(i + 1, r) for i, r in enumerate(csv.reader(io.StringIO(text)))
            if r and any(c.strip() for c in r) and not r[0].lstrip().startswith("#")]
    if not rows:
        raise InputFileError(path, "empty: expected a header `file,incidence_spin`")
    header_line, header = rows[0]
    names = [h.strip() for h in header]
    _check_header(path, header_line, names)
    out: dict[str, SpinRow] = {}
    for line, row in rows[1:]:
        if len(row) != len(names):
            raise InputFileError(path, f"has {len(row)} cells, the header has {len(names)}",
                                 line=line)
        cells = dict(zip(names, (c.strip() for c in row), strict=True))
        name = cells["file"]
        if not name:
            raise InputFileError(path, "empty file name", line=line, field="file")
        if name in out:
            raise InputFileError(path, f"{name!r} is given twice (first on line "
                                       f"{out[name].line})", line=line, field="file")
        se_text = cells.get("incidence_spin_se", "")
        out[name] = SpinRow(_number(path, line, "incidence_spin", cells["incidence_spin"]),
                            _number(path, line, "incidence_spin_se", se_text, nonneg=True)
                            if se_text else None, line)
    return out


def _check_header(path: Path, line: int, names: list[str]) -> None:
    unknown = [n for n in names if n not in _COLUMNS]
    if unknown:
        raise InputFileError(path, f"unknown column {unknown[0]!r}; allowed: "
                                   f"{', '.join(_COLUMNS)}", line=line)
    missing = [n for n in ("file", "incidence_spin") if n not in names]
    if missing:
        raise InputFileError(path, f"missing column(s) {', '.join(missing)}; the header has "
                                   f"{', '.join(names)}", line=line)


def _number(path: Path, line: int, name: str, text: str, nonneg: bool = False) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not math.isfinite(value) or (nonneg and value < 0):
        allowed = "a finite number >= 0" if nonneg else "a finite number"
        raise InputFileError(path, f"must be {allowed} (rad/s); got {text!r}", line=line,
                             field=name)
    return value


def check_spin_names(path: str | os.PathLike, table: dict[str, SpinRow],
                     files: Iterable[str]) -> None:
    """Every row names a trajectory file of the folder (``name`` or ``name#k``).

    Raises:
        InputFileError: the first row naming no such file, with its line.
    """
    known = set(files)
    for name, row in table.items():
        base, _, bounce = name.partition("#")
        if base not in known:
            raise InputFileError(path, f"{name!r} names no trajectory file of the folder; "
                                       f"the files are {_some(sorted(known))}", line=row.line,
                                 field="file")
        if bounce and not (bounce.isdigit() and int(bounce) >= 1):
            raise InputFileError(path, f"{name!r}: a bounce is named <file>#<k> with k = 1, "
                                       "2, ...", line=row.line, field="file")


def spin_for(path: str | os.PathLike, table: dict[str, SpinRow], file: str,
             n_bounces: int) -> list[SpinRow | None]:
    """The spin row of each bounce of ``file`` (None where the table has none).

    Raises:
        InputFileError: a row names a bounce the file does not have, or names a file of
            several bounces without saying which.
    """
    for name, row in table.items():
        base, _, bounce = name.partition("#")
        if base != file:
            continue
        if not bounce and n_bounces > 1:
            raise InputFileError(path, f"{name!r} holds {n_bounces} bounces: give one row per "
                                       f"bounce, {file}#1 ... {file}#{n_bounces}",
                                 line=row.line, field="file")
        if bounce and int(bounce) > n_bounces:
            raise InputFileError(path, f"{name!r}: {file} holds {n_bounces} bounce(s)",
                                 line=row.line, field="file")
    if n_bounces == 1:
        return [table.get(file) or table.get(f"{file}#1")]
    return [table.get(f"{file}#{k + 1}") for k in range(n_bounces)]


def _some(names: list[str]) -> str:
    return ", ".join(names[:5]) + (f" and {len(names) - 5} more" if len(names) > 5 else "")
