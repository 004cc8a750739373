"""Reading one tracked ball: a trajectory file (or arrays) -> a clean :class:`Trajectory` in the
plane-aligned frame, SI units."""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from .._errors import InputFileError
from .._validate import check_choice, check_scalar
from ..data import TrackSidecar, read_track_sidecar, read_trajectory_table
from ._clean import Rows, check_order, check_plausible, drop_outliers, merge_repeats

LengthUnit = Literal["m", "cm", "mm"]
LENGTH_UNITS: dict[str, float] = {"m": 1.0, "cm": 1e-2, "mm": 1e-3}
MIN_TRACKED_POINTS = 6  # fewer rows than this cannot hold two fitted free-flight segments


@dataclass(frozen=True, eq=False)
class Trajectory:
    """Tracked centre positions in the plane-aligned frame (read-only arrays, SI units).

    ``flipped_x``: the incident travel was towards -x in the file, so x (and z, keeping the axes
    right-handed: a half-turn about the normal) were negated. ``rotation_deg``: the camera-to-plane
    rotation that was applied. ``n_dropped``: rows left out as untracked (an empty or NaN cell).
    ``notes``: one line per condition met while reading (rows left out, merged; with lines).
    ``lines``: the file line of each sample (None for arrays). ``scale_rel_sd`` and
    ``surface_angle_sd_deg``: the tracker's stated calibration uncertainty (its sidecar file).
    ``quality``: the tracker's per-frame columns (``residual``, ``visible``) of the samples.
    ``position_sd``: the tracker's stated per-frame SD of its centres (m, per coordinate; its
    sidecar), a floor of the position noise in the flight fits (:func:`fit_bounces`).
    ``calibration_source``: what set the scale, as the sidecar says ("ball diameter": each
    video its own, "reference"); None without one.
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
    notes: tuple[str, ...] = ()
    lines: np.ndarray | None = None
    scale_rel_sd: float | None = None
    surface_angle_sd_deg: float | None = None
    quality: Mapping[str, np.ndarray] = field(default_factory=dict)
    position_sd: float | None = None
    provenance: Mapping[str, Any] | None = None
    calibration_source: str | None = None

    @property
    def n(self) -> int:
        """Number of samples."""
        return int(self.t.size)

    def positions(self) -> np.ndarray:
        """Positions as an ``(n, d)`` array, columns x, y (, z)."""
        cols = (self.x, self.y) if self.z is None else (self.x, self.y, self.z)
        return np.column_stack(cols)


def read_trajectory(path: str | os.PathLike, *, rotation_deg: float = 0.0,
                    length_unit: LengthUnit = "m") -> Trajectory:
    """Read one tracked ball from a trajectory file (``bouncebayes.data.read_trajectory_table``:
    CSV ``t,x,y[,z]`` with optional quality columns, or Tracker's data export).

    Rows as they come: untracked rows (an empty or NaN cell) and rows the tracker flagged are
    left out; rows repeating a time stamp are merged when their positions agree (within 4 noise
    SD) and rejected with the line when they do not; a row whose time goes back is rejected with
    the line; outlier positions (far from what both neighbouring pairs of samples predict) are
    left out; each of these is one line in ``notes``. A median sample interval outside
    1 us - 0.1 s or a median speed outside 0.01-300 m/s stops the file with a hint at the unit.
    A sidecar ``<name>.track.json`` gives the calibration uncertainty.

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
        InputFileError: what ``read_trajectory_table`` rejects, rows out of order or repeating a
            time with another position (line), too many outliers, implausible units, fewer than
            6 tracked rows, a bad sidecar.
        ValueError, TypeError: a bad ``rotation_deg`` or ``length_unit``.
    """
    rotation = check_scalar("rotation_deg", rotation_deg, unit="deg")
    check_choice("length_unit", length_unit, LENGTH_UNITS)
    table = read_trajectory_table(path)
    scale = LENGTH_UNITS[length_unit]
    names = [c for c in ("x", "y", "z") if c in table.columns]
    rows = Rows(table.source, table.columns["t"],
                np.column_stack([table.columns[c] * scale for c in names]),
                {k: table.columns[k] for k in ("residual", "visible") if k in table.columns},
                table.lines)
    sidecar = read_track_sidecar(path)
    return _build(rows, rotation, length_unit, table.n_untracked, table.notes, sidecar,
                  table.provenance)


def trajectory_from_arrays(t, x, y, z=None, *, rotation_deg: float = 0.0,
                           length_unit: LengthUnit = "m", source: str = "<arrays>",
                           scale_rel_sd: float | None = None,
                           surface_angle_sd_deg: float | None = None) -> Trajectory:
    """Build a :class:`Trajectory` from arrays, with the checks and transforms of
    :func:`read_trajectory` (problems are reported by 0-based index instead of line; every
    value must be finite)."""
    rotation = check_scalar("rotation_deg", rotation_deg, unit="deg")
    check_choice("length_unit", length_unit, LENGTH_UNITS)
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
    scale = LENGTH_UNITS[length_unit]
    pos = np.column_stack([columns[c] * scale for c in ("x", "y", "z") if c in columns])
    sidecar = TrackSidecar(source, scale_rel_sd, surface_angle_sd_deg)
    return _build(Rows(source, columns["t"], pos, {}, None), rotation, length_unit, 0, (),
                  sidecar, None)


def _build(rows: Rows, rotation_deg: float, length_unit: str, n_dropped: int,
           notes: tuple[str, ...], sidecar: TrackSidecar | None,
           provenance: Mapping[str, Any] | None) -> Trajectory:
    _check_count(rows, n_dropped)
    check_order(rows)
    rows, merged = merge_repeats(rows)
    rows, dropped = drop_outliers(rows)
    _check_count(rows, n_dropped)
    check_plausible(rows, length_unit, LENGTH_UNITS)
    x, y = _rotate(rows.pos[:, 0], rows.pos[:, 1], math.radians(rotation_deg))
    z = rows.pos[:, 2] if rows.pos.shape[1] > 2 else None
    flipped = _travels_backwards(x, y)
    if flipped:
        x, z = -x, (None if z is None else -z)
    return Trajectory(t=_frozen(rows.t), x=_frozen(x), y=_frozen(y),
                      z=None if z is None else _frozen(z), source=rows.source, flipped_x=flipped,
                      sample_rate_hz=float(np.median(1.0 / np.diff(rows.t))),
                      rotation_deg=rotation_deg, n_dropped=n_dropped,
                      notes=(*notes, *merged, *dropped), lines=rows.lines,
                      scale_rel_sd=sidecar.scale_rel_sd if sidecar else None,
                      surface_angle_sd_deg=sidecar.surface_angle_sd_deg if sidecar else None,
                      quality={k: _frozen(v) for k, v in rows.quality.items()},
                      position_sd=sidecar.position_sd if sidecar else None,
                      provenance=provenance,
                      calibration_source=sidecar.calibration_source if sidecar else None)


def _check_count(rows: Rows, n_dropped: int) -> None:
    if rows.t.size < MIN_TRACKED_POINTS:
        skipped = (f" ({n_dropped} row{'s' if n_dropped > 1 else ''} with an empty cell "
                   f"{'were' if n_dropped > 1 else 'was'} skipped)") if n_dropped else ""
        raise InputFileError(rows.source, f"only {rows.t.size} tracked rows{skipped}; need at "
                                          f"least {MIN_TRACKED_POINTS}")


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
