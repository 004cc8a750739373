"""A folder of trajectory files -> kinematics and the trial table; referring them to the contact."""

from __future__ import annotations

import csv
import math
import os
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from .._errors import InputFileError
from .._io import atomic_path
from .._validate import check_choice, check_scalar
from ._fit import _check_fit_options, fit_kinematics
from ._read import LENGTH_UNITS, LengthUnit, read_trajectory
from ._result import TRIAL_TABLE_COLUMNS, Kinematics


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
    from ..model import simulate

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


def trial_table_from_folder(folder: str | os.PathLike, experiment, out: str | os.PathLike,
                            *, log=print, **fit_kwargs
                            ) -> tuple[FolderKinematics, tuple[Kinematics, ...]]:
    """The experiment's trial table from a folder of trajectories: every file fitted with the
    experiment's ``[trajectories]`` settings (rotation, length unit, drag), the results referred
    to the contact instants (:func:`refer_to_contact`) and written to ``out``; ``log`` gets the
    summary of which files were used and why others were not. Returns the folder's fits and
    the referred kinematics that were written.

    Raises:
        InputFileError: no file of the folder gave kinematics (nothing is written).
    """
    s = experiment.trajectories
    found = kinematics_from_folder(folder, rotation_deg=s["rotation_deg"],
                                   length_unit=s["length_unit"], drag=s["drag"], **fit_kwargs)
    log(found.summary())
    if not found.results:
        raise InputFileError(folder, "no usable trajectory file: nothing written")
    results = refer_to_contact(found.results, experiment)
    write_trial_table(out, results)
    return found, results
