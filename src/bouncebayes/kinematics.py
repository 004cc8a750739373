"""Tracked trajectories -> incidence and rebound kinematics of one bounce per file (MODEL.md §4).

A user films a ball bouncing on a plane (100 Hz - 10 kHz), tracks its centre (Tracker or any
tracker) and exports one file per bounce. For each file this module fits the free flight before
and after the impact with constant acceleration, evaluates both fits at the impact and returns
the incidence and rebound speed and angle with standard errors, or a :class:`TrajectoryError`
that names the file and says why it could not be used.

Frame and signs (MODEL.md §1): ``x`` along the plane in the direction of incident travel, ``y``
along the outward normal, metres and seconds. Angles are measured from the normal, in degrees:
incidence ``atan2(v_x, |v_y|)`` with ``v_y < 0``; rebound ``atan2(v_x, |v_y|)`` with ``v_y > 0``,
positive when the ball keeps moving forward (+x). With a ``z`` column, (x, z) span the plane and
the velocities are projected onto the plane of incidence (see :func:`fit_kinematics`).

Pipeline: :func:`read_trajectory` (parse, scale, rotate, flip) -> :func:`fit_kinematics`
(detect the impact, fit the segments, delta-method errors) -> :func:`write_trial_table` (the CSV
that ``bouncebayes.data.load_trials`` reads); :func:`kinematics_from_folder` runs a folder.
"""

from __future__ import annotations

import csv
import math
import os
import re
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Literal, get_args

import numpy as np
from scipy.linalg import block_diag
from scipy.optimize import least_squares
from scipy.signal import find_peaks

from ._errors import InputFileError
from ._io import atomic_path
from ._validate import check_choice, check_scalar

__all__ = ["DRAG_MODELS", "LENGTH_UNITS", "TRIAL_TABLE_COLUMNS", "FolderKinematics", "Kinematics",
           "Trajectory", "TrajectoryError", "fit_kinematics", "kinematics_from_folder",
           "read_trajectory", "trajectory_from_arrays", "write_trial_table"]

LengthUnit = Literal["m", "cm", "mm"]
LENGTH_UNITS: dict[str, float] = {"m": 1.0, "cm": 1e-2, "mm": 1e-3}
Drag = Literal["none", "quadratic"]  # "none" (or None): constant acceleration
DRAG_MODELS: tuple[str, ...] = get_args(Drag)
FailureReason = Literal["no bounce", "several bounces", "too few points", "no crossing",
                        "bad fit"]
MIN_TRACKED_POINTS = 6  # fewer rows than this cannot hold two fitted free-flight segments
# A bounce is a local minimum of y that rises on both sides by more than this many noise
# standard deviations (noise estimated from second differences): a robust form of "dy/dt changes
# sign from - to +" that ignores the sign flips noise causes where |dy| per frame ~ noise.
PROMINENCE_IN_NOISE_SD = 12.0
TRIAL_TABLE_COLUMNS = ("file", "incidence_speed", "incidence_speed_se", "incidence_angle",
                       "incidence_angle_se", "rebound_speed", "rebound_speed_se",
                       "rebound_angle", "rebound_angle_se")
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
_RK4_MAX_STEP = 2e-3  # s; RK4 error (h/T)^4 with T = 1/(k|v|) >~ 0.1 s is below 1e-10 relative


class TrajectoryError(InputFileError):
    """A trajectory file that was read but cannot give kinematics.

    ``reason`` is a short code (:data:`FailureReason`: ``"no bounce"``, ``"several bounces"``,
    ``"too few points"``, ``"no crossing"``, ``"bad fit"``); the message says what was found
    and what to do.
    """

    def __init__(self, path: str | os.PathLike, message: str, *, reason: FailureReason,
                 line: int | None = None, field: str | None = None):
        super().__init__(path, f"{reason}: {message}", line=line, field=field)
        self.reason = reason
        self.detail = message


# ----------------------------------------------------------------------------------- reading

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


# ----------------------------------------------------------------------------------- fitting

@dataclass(frozen=True)
class Kinematics:
    """Incidence and rebound of one bounce, with standard errors (m/s, deg, s, m, m/s^2).

    Angles are from the plane normal; the rebound angle is positive when the ball keeps moving
    forward. ``acceleration_before``/``after``: the fitted constant accelerations (x, y[, z]) of
    the free flight, in the trajectory's frame (with ``drag``: the constant part ``a``).
    ``lateral_angle`` (3-D only): the angle between the rebound velocity and the plane of
    incidence, positive towards ``t x n`` (``t``: incident direction in the plane, ``n``: normal).
    ``flipped_x``: the reported x axis points opposite to the file's (after any rotation).
    ``drag_coefficient``: fitted ``k`` (1/m) before and after, with ``drag="quadratic"``.
    """

    incidence_speed: float
    incidence_speed_se: float
    incidence_angle: float
    incidence_angle_se: float
    rebound_speed: float
    rebound_speed_se: float
    rebound_angle: float
    rebound_angle_se: float
    impact_time: float
    impact_time_se: float
    n_before: int
    n_after: int
    residual_rms: float
    acceleration_before: tuple[float, ...]
    acceleration_after: tuple[float, ...]
    sample_rate_hz: float
    source: str
    lateral_angle: float | None = None
    lateral_angle_se: float | None = None
    flipped_x: bool = False
    drag: str | None = None
    drag_coefficient: tuple[float, float] | None = None
    instants: str = "crossing"  #: "crossing" of the fitted flights, or "contact" (referred)

    def to_row(self) -> dict[str, str | float]:
        """The trial-table row: ``file`` (name) plus the eight columns ``load_trials`` reads."""
        return {name: Path(self.source).name if name == "file" else float(getattr(self, name))
                for name in TRIAL_TABLE_COLUMNS}


@dataclass(frozen=True)
class _Segment:
    """A fitted free-flight segment; ``params`` (flat) and ``cov`` for the delta method."""

    index: np.ndarray  # samples used
    params: np.ndarray
    cov: np.ndarray
    rss: float
    n_resid: int
    acceleration: tuple[float, ...]
    drag_k: float | None = None


def fit_kinematics(trajectory: Trajectory, *, min_points: int = 5, contact_guard: int = 1,
                   drag: Drag | None = None) -> Kinematics:
    """Incidence and rebound kinematics of the single bounce in ``trajectory``.

    1. Impact detection: the bounce is the one local minimum of ``y`` where ``dy/dt`` changes sign
       from - to + and ``y`` rises by more than 12 noise standard deviations on both sides (noise
       from second differences, robustly); none -> ``"no bounce"``, more -> ``"several bounces"``.
    2. Free flight: the samples before and after the impact, leaving out the ``contact_guard``
       samples nearest the impact on each side (the ball may touch the plane for one or two
       frames at 1 kHz; use ``contact_guard >= ceil(contact time x rate / 2)``). Fewer than
       ``min_points`` on a side -> ``"too few points"``. The split is re-made at the fitted
       impact time until it no longer changes.
    3. Each segment is fitted with constant acceleration, ``r(t) = r0 + v0 t + a t^2 / 2``, by
       ordinary least squares per coordinate (acceleration free: the camera may be tilted).
       ``drag="quadratic"`` (default ``None`` or ``"none"``: no drag) fits
       ``r'' = a - k |v| v`` instead (``scipy.optimize.least_squares`` on an RK4 solution; one
       ``k`` and one noise level per segment). Drag matters for light, large balls:
       ``k = rho C_d A / (2 m)`` is ~0.14 /m for a table-tennis ball (``k v^2`` ~ 3.5 m/s^2 at
       5 m/s), ~0.01 /m for a tennis ball, ~1e-3 /m for a steel ball. What biases the
       constant-acceleration fit is the *change* of the drag along a segment, so it grows with
       the segment's duration: for a table-tennis ball at 5 m/s filmed at 1 kHz with 0.2 mm
       noise, the constant-acceleration rebound speed is biased by ~0.7 standard errors with
       0.05 s segments, ~4 with 0.1 s and ~30 with 0.2 s; the drag fit removes the bias at the
       price of ~2.5x larger errors (tests/test_kinematics.py, ``test_quadratic_drag_*``).
    4. Impact time ``t_i``: the crossing of the two fitted ``y(t)`` nearest the lowest sample.
       Incidence = velocity of the pre-impact fit at ``t_i``, rebound = post-impact fit at
       ``t_i``; speed ``|v|``, angle ``atan2(v_x, |v_y|)`` (incident ``v_y < 0``, rebound
       ``v_y > 0``). If the incident ``v_x`` comes out negative (near head-on, where the file's
       direction was ambiguous) both angles are mirrored and ``flipped_x`` toggled.
    5. Standard errors: coefficient covariance ``s^2 (X^T X)^-1`` per coordinate and segment
       (``s^2`` = residual variance, ``n - 3`` degrees of freedom; with drag ``s^2 (J^T J)^-1``),
       propagated by the delta method through the whole map coefficients -> (``t_i``, velocities,
       speed, angle), so the uncertainty of ``t_i`` is included. With few points the z-scores
       follow Student's t with ``n - 3`` degrees of freedom rather than a normal.

    3-D (a ``z`` column): (x, z) span the plane. The plane of incidence contains the normal and the
    fitted incident in-plane velocity; incidence and rebound are its projections onto that plane
    (the incident velocity lies in it), and ``lateral_angle`` reports the rebound's out-of-plane
    part.

    Raises:
        TrajectoryError: with ``reason`` "no bounce", "several bounces", "too few points",
            "no crossing" (the fitted parabolas do not cross near the impact) or "bad fit".
        ValueError, TypeError: bad ``min_points`` (an integer >= 4), ``contact_guard`` (>= 0) or
            ``drag``.
    """
    min_points, contact_guard, drag = _check_fit_options(min_points, contact_guard, drag)
    t, pos, src = trajectory.t, trajectory.positions(), trajectory.source
    low = _find_bounce(trajectory)
    t_ref = float(t[low])
    pre, post, tau_i = _split_and_fit(trajectory, low, t_ref, min_points, contact_guard)
    model: Callable[[np.ndarray], np.ndarray]
    if drag == "quadratic":
        pre = _fit_drag(src, t[pre.index] - t_ref, pos[pre.index], pre)
        post = _fit_drag(src, t[post.index] - t_ref, pos[post.index], post)
        model = _drag_model(pos.shape[1], pre.params.size, tau_i)
    else:
        model = _quadratic_model(pos.shape[1])
    theta = np.concatenate([pre.params, post.params])
    values, se = _delta_method(model, theta, block_diag(pre.cov, post.cov))
    _check_directions(src, values, t_ref)
    return _kinematics(trajectory, values, se, pre, post, t_ref, drag)


def _check_fit_options(min_points, contact_guard, drag) -> tuple[int, int, str | None]:
    _check_int("min_points", min_points, 4, "a quadratic fit needs >= 4 points for a residual "
                                            "variance")
    _check_int("contact_guard", contact_guard, 0, "samples left out on each side of the impact")
    if drag is not None:
        check_choice("drag", drag, DRAG_MODELS)
    return int(min_points), int(contact_guard), None if drag == "none" else drag


def _check_int(name: str, value, low: int, why: str) -> None:
    message = f"`{name}` must be an integer >= {low} ({why}); got {value!r}"
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise TypeError(message)
    if value < low:
        raise ValueError(message)


def _noise_sd(y: np.ndarray) -> float:
    """Robust noise SD from second differences (white noise: var(d2) = 6 sigma^2)."""
    d2 = np.diff(y, 2)
    return float(1.4826 * np.median(np.abs(d2 - np.median(d2))) / math.sqrt(6.0))


def _find_bounce(traj: Trajectory) -> int:
    """Index of the lowest sample of the single clear bounce."""
    y, t = traj.y, traj.t
    threshold = max(PROMINENCE_IN_NOISE_SD * _noise_sd(y), 1e-6 * float(np.ptp(y)), 1e-12)
    peaks, _ = find_peaks(-y, prominence=threshold)
    if peaks.size > 1:
        times = ", ".join(f"{t[i]:.6g}" for i in peaks)
        raise TrajectoryError(traj.source, f"found {peaks.size} bounces (lowest points at t = "
                                           f"{times} s); keep one bounce per file",
                              reason="several bounces")
    if peaks.size == 0:
        low = int(np.argmin(y))
        where = ("the first sample" if low == 0 else "the last sample (does the file end at the "
                 "impact?)" if low == traj.n - 1 else f"at t = {t[low]:.6g} s, but it does not "
                 f"rise by more than {threshold * 1e3:.3g} mm on both sides")
        raise TrajectoryError(traj.source, "the normal position y has no clear minimum where "
                                           f"dy/dt changes sign from - to +; its lowest point is "
                                           f"{where}. Check that y points away from the plane "
                                           "(up) and that the file holds one whole bounce",
                              reason="no bounce")
    return int(peaks[0])


def _split_and_fit(traj: Trajectory, low: int, t_ref: float, min_points: int, guard: int
                   ) -> tuple[_Segment, _Segment, float]:
    """Split into free-flight segments around the impact, refit until the split is stable."""
    t, pos = traj.t, traj.positions()
    t_split, last = t_ref, None
    for _ in range(5):
        before = np.flatnonzero(t < t_split)[: max(0, np.sum(t < t_split) - guard)]
        after = np.flatnonzero(t > t_split)[guard:]
        if last is not None and np.array_equal(before, last[0]) and np.array_equal(after,
                                                                                   last[1]):
            break
        for side, idx in (("before", before), ("after", after)):
            if idx.size < min_points:
                raise TrajectoryError(traj.source, f"too few points {side} the impact (got "
                                                   f"{idx.size}, need {min_points}) after leaving "
                                                   f"out {guard} sample(s) next to it "
                                                   "(`contact_guard`); record more of the flight "
                                                   "or lower `min_points`",
                                      reason="too few points")
        pre, post = (_fit_quadratic(t[i] - t_ref, pos[i], i) for i in (before, after))
        tau_i = _crossing(pre.params.reshape(-1, 3)[1], post.params.reshape(-1, 3)[1])
        if tau_i is None or not t[0] <= t_ref + tau_i <= t[-1]:
            raise TrajectoryError(traj.source, "the fitted y(t) before and after the impact do "
                                               "not cross within the record; is the bounce "
                                               "tracked on both sides?", reason="no crossing")
        t_split, last = t_ref + tau_i, (before, after)
    return pre, post, tau_i


def _fit_quadratic(tau: np.ndarray, pos: np.ndarray, index: np.ndarray) -> _Segment:
    """OLS of each coordinate on (1, tau, tau^2); params per coordinate: r0, v0, a/2."""
    X = np.column_stack([np.ones_like(tau), tau, tau * tau])
    coef, *_ = np.linalg.lstsq(X, pos, rcond=None)
    resid = pos - X @ coef
    rss = np.sum(resid * resid, axis=0)
    s2 = rss / (tau.size - 3)
    xtx_inv = np.linalg.inv(X.T @ X)
    cov = block_diag(*(s * xtx_inv for s in s2))
    return _Segment(index=index, params=coef.T.ravel(), cov=cov, rss=float(rss.sum()),
                    n_resid=resid.size, acceleration=tuple(float(a) for a in 2 * coef[2]))


def _crossing(p: np.ndarray, q: np.ndarray) -> float | None:
    """Root nearest 0 of (p - q)(tau) for coefficients (c0, c1, c2); None if they never cross."""
    c0, c1, c2 = p - q
    disc = c1 * c1 - 4.0 * c2 * c0
    if disc < 0:
        return None
    qq = -0.5 * (c1 + math.copysign(math.sqrt(disc), c1))
    if qq == 0.0:
        return None
    roots = [c0 / qq] + ([qq / c2] if c2 != 0.0 else [])
    return min(roots, key=abs)


def _observables(v_in: np.ndarray, v_out: np.ndarray) -> list[float]:
    """[incidence speed, angle, rebound speed, angle(, lateral angle)] from impact velocities."""
    if v_in.size == 2:
        return [math.hypot(*v_in), math.degrees(math.atan2(v_in[0], abs(v_in[1]))),
                math.hypot(*v_out), math.degrees(math.atan2(v_out[0], abs(v_out[1])))]
    h = math.hypot(v_in[0], v_in[2])
    ex, ez = (v_in[0] / h, v_in[2] / h) if h > 0 else (1.0, 0.0)
    u = v_out[0] * ex + v_out[2] * ez  # along the incident direction
    w = -v_out[0] * ez + v_out[2] * ex  # towards t x n
    return [math.hypot(h, v_in[1]), math.degrees(math.atan2(h, abs(v_in[1]))),
            math.hypot(u, v_out[1]), math.degrees(math.atan2(u, abs(v_out[1]))),
            math.degrees(math.atan2(w, math.hypot(u, v_out[1])))]


def _quadratic_model(d: int) -> Callable[[np.ndarray], np.ndarray]:
    """theta (both segments' r0, v0, a/2 per coordinate) -> observables + [tau_i, vy_in, vy_out]."""
    def model(theta: np.ndarray) -> np.ndarray:
        pre, post = theta[: 3 * d].reshape(d, 3), theta[3 * d:].reshape(d, 3)
        tau = _crossing(pre[1], post[1])
        tau = math.nan if tau is None else tau
        v_in, v_out = pre[:, 1] + 2 * pre[:, 2] * tau, post[:, 1] + 2 * post[:, 2] * tau
        return np.array([*_observables(v_in, v_out), tau, v_in[1], v_out[1]])
    return model


def _delta_method(f: Callable[[np.ndarray], np.ndarray], theta: np.ndarray, cov: np.ndarray,
                  rel_step: float = 1e-4) -> tuple[np.ndarray, np.ndarray]:
    """f(theta) and its standard errors sqrt(diag(J cov J^T)), J by central differences with
    steps of ``rel_step`` standard deviations of each parameter."""
    f0 = f(theta)
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    jac = np.zeros((f0.size, theta.size))
    for j in np.flatnonzero(sd > 0):
        step = np.zeros_like(theta)
        step[j] = rel_step * sd[j]
        jac[:, j] = (f(theta + step) - f(theta - step)) / (2 * step[j])
    var = np.einsum("ij,jk,ik->i", jac, cov, jac)
    return f0, np.sqrt(np.clip(var, 0.0, None))


def _check_directions(source: str, values: np.ndarray, t_ref: float) -> None:
    tau, vy_in, vy_out = values[-3:]
    if not (np.isfinite(values).all() and vy_in < 0 < vy_out):
        raise TrajectoryError(source, f"at the fitted impact (t = {t_ref + tau:.6g} s) the normal "
                                      f"velocity is {vy_in:.4g} m/s before and {vy_out:.4g} m/s "
                                      "after; a bounce needs v_y < 0 before and > 0 after",
                              reason="bad fit")


def _kinematics(traj: Trajectory, values: np.ndarray, se: np.ndarray, pre: _Segment,
                post: _Segment, t_ref: float, drag: str | None) -> Kinematics:
    three_d = traj.z is not None
    mirror = -1.0 if (not three_d and values[1] < 0) else 1.0  # near head-on, see step 4

    def mirrored(a: tuple[float, ...]) -> tuple[float, ...]:
        return (mirror * a[0], *a[1:])

    rms = math.sqrt((pre.rss + post.rss) / (pre.n_resid + post.n_resid))
    return Kinematics(
        incidence_speed=float(values[0]), incidence_speed_se=float(se[0]),
        incidence_angle=float(mirror * values[1]), incidence_angle_se=float(se[1]),
        rebound_speed=float(values[2]), rebound_speed_se=float(se[2]),
        rebound_angle=float(mirror * values[3]), rebound_angle_se=float(se[3]),
        impact_time=t_ref + float(values[-3]), impact_time_se=float(se[-3]),
        n_before=int(pre.index.size), n_after=int(post.index.size), residual_rms=rms,
        acceleration_before=mirrored(pre.acceleration),
        acceleration_after=mirrored(post.acceleration),
        sample_rate_hz=traj.sample_rate_hz, source=traj.source,
        lateral_angle=float(values[4]) if three_d else None,
        lateral_angle_se=float(se[4]) if three_d else None,
        flipped_x=traj.flipped_x != (mirror < 0), drag=drag,
        drag_coefficient=(pre.drag_k, post.drag_k) if drag else None)


# ----------------------------------------------------------------------- quadratic air drag

def _drag_accel(v: np.ndarray, a: np.ndarray, k: float) -> np.ndarray:
    return a - k * np.linalg.norm(v) * v


def _rk4(p: np.ndarray, d: int, tau_end: float, n_steps: int
         ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Nodes, positions and velocities of r'' = a - k|v|v from tau = 0 (state r0, v0) to tau_end.

    ``p`` = (r0, v0, a, k). Fixed steps make the result a smooth function of ``p``, as the
    finite-difference Jacobians need."""
    r, v, a, k = p[:d].copy(), p[d:2 * d].copy(), p[2 * d:3 * d], p[3 * d]
    h = tau_end / n_steps
    rs, vs = [r], [v]
    for _ in range(n_steps):
        k1 = _drag_accel(v, a, k)
        k2 = _drag_accel(v + 0.5 * h * k1, a, k)
        k3 = _drag_accel(v + 0.5 * h * k2, a, k)
        k4 = _drag_accel(v + h * k3, a, k)
        r = r + h * v + h * h / 6.0 * (k1 + k2 + k3)
        v = v + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
        rs.append(r)
        vs.append(v)
    return np.linspace(0.0, tau_end, n_steps + 1), np.array(rs), np.array(vs)


def _drag_positions(p: np.ndarray, d: int, tau: np.ndarray) -> np.ndarray:
    """Positions at ``tau`` (all one sign): RK4 on a grid + cubic Hermite interpolation."""
    tau_end = float(tau[np.argmax(np.abs(tau))])
    n_steps = max(1, math.ceil(abs(tau_end) / _RK4_MAX_STEP))
    nodes, R, V = _rk4(p, d, tau_end, n_steps)
    h = tau_end / n_steps
    j = np.clip(np.floor(tau / h).astype(int), 0, n_steps - 1)
    s = ((tau - nodes[j]) / h)[:, None]
    h00, h10 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s
    h01, h11 = -2 * s**3 + 3 * s**2, s**3 - s**2
    return h00 * R[j] + h10 * h * V[j] + h01 * R[j + 1] + h11 * h * V[j + 1]


def _fit_drag(source: str, tau: np.ndarray, pos: np.ndarray, start: _Segment) -> _Segment:
    """Least squares fit of (r0, v0, a, k) at tau = 0, from the constant-acceleration fit."""
    d = pos.shape[1]
    quad = start.params.reshape(d, 3)
    p0 = np.concatenate([quad[:, 0], quad[:, 1], 2 * quad[:, 2], [0.0]])
    res = least_squares(lambda p: (_drag_positions(p, d, tau) - pos).ravel(), p0, method="lm",
                        x_scale="jac", xtol=1e-12, ftol=1e-12, gtol=1e-12)
    dof = pos.size - p0.size
    scale = np.linalg.norm(res.jac, axis=0)  # column scaling: r0, v0, a, k differ in units
    jtj = (res.jac / scale).T @ (res.jac / scale) if np.all(scale > 0) else None
    if not res.success or dof < 1 or jtj is None or np.linalg.cond(jtj) > 1e14:
        raise TrajectoryError(source, f"the quadratic-drag fit failed ({res.message}); fit "
                                      "without drag or give longer free-flight segments",
                              reason="bad fit")
    rss = float(2 * res.cost)
    cov = rss / dof * np.linalg.inv(jtj) / np.outer(scale, scale)
    return _Segment(index=start.index, params=res.x, cov=cov,
                    rss=rss, n_resid=pos.size,
                    acceleration=tuple(float(a) for a in res.x[2 * d:3 * d]),
                    drag_k=float(res.x[3 * d]))


def _drag_model(d: int, n_params: int, tau_guess: float) -> Callable[[np.ndarray], np.ndarray]:
    """theta (both segments' r0, v0, a, k) -> observables + [tau_i, vy_in, vy_out]."""
    def state(p: np.ndarray, tau: float) -> tuple[np.ndarray, np.ndarray]:
        _, R, V = _rk4(p, d, tau, 8)
        return R[-1], V[-1]

    def model(theta: np.ndarray) -> np.ndarray:
        pre, post = theta[:n_params], theta[n_params:]
        tau = tau_guess
        for _ in range(30):  # Newton on y_pre(tau) - y_post(tau)
            (r1, v1), (r2, v2) = state(pre, tau), state(post, tau)
            step = (r1[1] - r2[1]) / (v1[1] - v2[1])
            tau -= step
            if abs(step) < 1e-15:
                break
        (_, v_in), (_, v_out) = state(pre, tau), state(post, tau)
        return np.array([*_observables(v_in, v_out), tau, v_in[1], v_out[1]])
    return model


# ------------------------------------------------------------------------------- batch + I/O

@dataclass(frozen=True)
class FolderKinematics:
    """Kinematics of every usable file of a folder, in file-name order, and why others failed.

    ``failures``: ``(path, message)`` pairs; the message names the file, the line where known,
    the reason and the remedy.
    """

    results: tuple[Kinematics, ...]
    failures: tuple[tuple[str, str], ...]

    def summary(self) -> str:
        """One line per failure under a count, for a log or the command line."""
        n = len(self.results) + len(self.failures)
        head = f"{len(self.results)} of {n} trajectory files gave kinematics"
        return "\n".join([head, *(f"  skipped: {message}" for _, message in self.failures)])


def kinematics_from_folder(folder: str | os.PathLike, *,
                           pattern: str | Sequence[str] = ("*.csv", "*.txt"),
                           rotation_deg: float = 0.0, length_unit: LengthUnit = "m",
                           **fit_kwargs) -> FolderKinematics:
    """Read and fit every file in ``folder`` matching ``pattern`` (not recursive).

    Files are taken in natural file-name order (``b2`` before ``b10``). A file that cannot be
    read or fitted (:class:`InputFileError`, including :class:`TrajectoryError`) is listed in
    ``failures`` and the others are still processed. ``rotation_deg`` and ``length_unit`` go to
    :func:`read_trajectory`, ``fit_kwargs`` (``min_points``, ``contact_guard``, ``drag``) to
    :func:`fit_kinematics`; they are checked once, before any file is read.

    Raises:
        InputFileError: ``folder`` is not a folder or holds no matching file.
    """
    check_scalar("rotation_deg", rotation_deg, unit="deg")
    check_choice("length_unit", length_unit, LENGTH_UNITS)
    _check_fit_options(**{"min_points": 5, "contact_guard": 1, "drag": None, **fit_kwargs})
    files = _matching_files(folder, (pattern,) if isinstance(pattern, str) else tuple(pattern))
    results, failures = [], []
    for path in files:
        try:
            traj = read_trajectory(path, rotation_deg=rotation_deg, length_unit=length_unit)
            results.append(fit_kinematics(traj, **fit_kwargs))
        except InputFileError as exc:
            failures.append((os.fspath(path), str(exc)))
    return FolderKinematics(results=tuple(results), failures=tuple(failures))


def _matching_files(folder: str | os.PathLike, patterns: tuple[str, ...]) -> list[Path]:
    root = Path(folder)
    if not root.is_dir():
        raise InputFileError(root, "no such folder" if not root.exists() else
                             "is a file; expected a folder of trajectory files")
    files = {p for pat in patterns for p in root.glob(pat) if p.is_file()}
    if not files:
        raise InputFileError(root, f"no file matches {', '.join(patterns)}; give `pattern` for "
                                   "other names")
    return sorted(files, key=_natural_key)


def _natural_key(path: Path) -> list:
    return [(0, int(s), "") if s.isdigit() else (1, 0, s.lower())
            for s in re.split(r"(\d+)", path.name)]


def write_trial_table(path: str | os.PathLike, results: Iterable[Kinematics]) -> Path:
    """Write the trial table (header ``file, incidence_speed, ..., rebound_angle_se``, one row
    per bounce, full float precision) atomically; ``bouncebayes.data.load_trials`` reads it."""
    rows = [k.to_row() for k in results]
    with atomic_path(path) as tmp, open(tmp, "w", newline="", encoding="utf-8") as fh:
        writer = csv.DictWriter(fh, fieldnames=TRIAL_TABLE_COLUMNS, lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)
    return Path(path)


def refer_to_contact(results: Sequence[Kinematics], experiment) -> tuple[Kinematics, ...]:
    """Move each incidence to the first contact and each rebound to the separation.

    The two fitted free flights meet inside the contact, about half a contact time after the
    first touch; the forward model's incidence is at first contact and its rebound at
    separation, and the velocities differ by what the flight acceleration (gravity) adds in
    between: about ``g t_c / 2``, 0.01 m/s for the paper's ball, a bias of about half a
    standard error per bounce that would add up over a campaign. This simulates every bounce at
    nominal contact parameters (the experiment's fixed values, or the medians of the priors of
    inferred ones), finds where the model's own incoming and outgoing flights cross, and moves
    each fitted velocity along its fitted parabola by those times. What remains depends on the
    unknown parameters only through the contact time (about 10 % over the paper's prior, i.e.
    ~1e-3 m/s). Standard errors are kept (the shift adds the acceleration's uncertainty times
    ~1 ms, negligible).
    """
    from .model import simulate

    if not results:
        return ()
    nominal = {name: (experiment.priors[name].ppf(0.5) if name in experiment.priors
                      else experiment.fixed_value(name))
               for name in ("mu", "eta", "youngs_modulus", "spin")}
    v_in = np.array([_velocity(k.incidence_speed, k.incidence_angle, -1.0) for k in results])
    v_out = np.array([_velocity(k.rebound_speed, k.rebound_angle, 1.0) for k in results])
    a_in = np.array([k.acceleration_before[:2] for k in results])
    a_out = np.array([k.acceleration_after[:2] for k in results])
    v0, v_sep = v_in, v_out
    gy = experiment.gravity * np.cos(np.radians(experiment.inclination))
    for _ in range(3):  # fixed point: the contact instants depend weakly on the incidence
        b = simulate(experiment.ball, mu=nominal["mu"], eta=nominal["eta"],
                     speed=np.hypot(v0[:, 0], v0[:, 1]),
                     angle=np.degrees(np.arctan2(v0[:, 0], -v0[:, 1])), spin=nominal["spin"],
                     youngs_modulus=nominal["youngs_modulus"],
                     inclination=experiment.inclination, normal_law=experiment.normal_law,
                     gravity=experiment.gravity, errors="flag")
        tc = np.where(b.ok, b.contact_time, 0.0)
        vs = np.where(b.ok, b.rebound_normal_velocity, v_out[:, 1])
        d_sep = np.where(b.ok, b.separation_overlap, 0.0)
        # the model's flights y_in = r + v0y t - gy t^2/2 and y_out = r - d_sep + vs (t - tc)
        # - gy (t - tc)^2/2 differ linearly in t: they cross at t_x
        t_x = (d_sep + vs * tc + 0.5 * gy * tc**2) / (vs + gy * tc - v0[:, 1])
        v0 = v_in - a_in * t_x[:, None]
        v_sep = v_out + a_out * (tc - t_x)[:, None]
    return tuple(replace(k, incidence_speed=float(np.hypot(*v0[i])),
                         incidence_angle=float(np.degrees(np.arctan2(v0[i, 0], -v0[i, 1]))),
                         rebound_speed=float(np.hypot(*v_sep[i])),
                         rebound_angle=float(np.degrees(np.arctan2(v_sep[i, 0], v_sep[i, 1]))),
                         instants="contact")
                 for i, k in enumerate(results))


def _velocity(speed: float, angle_deg: float, normal_sign: float) -> tuple[float, float]:
    a = math.radians(angle_deg)
    return speed * math.sin(a), normal_sign * speed * math.cos(a)
