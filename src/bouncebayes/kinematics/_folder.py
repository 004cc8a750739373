"""A folder of trajectory files -> kinematics of every bounce -> the trial table."""

from __future__ import annotations

import hashlib
import math
import os
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from .._errors import InputFileError
from .._validate import check_choice, check_scalar
from .._version import __version__
from ..data import make_trials, write_trials
from ._config import FitConfig
from ._contact import refer_to_contact
from ._fit import find_bounces, fit_bounces
from ._gravity import gravity_scale
from ._read import LENGTH_UNITS, LengthUnit, read_trajectory
from ._result import Kinematics, TrajectoryError
from ._spin import SPIN_FILE, SpinRow, check_spin_names, read_spin_table, spin_for

# The drag coefficient k = rho C_d pi r^2 / (2 m) of a ball in air: expected with air at
# 20 degC (1.2 kg/m^3) and a sphere's C_d = 0.47 (Reynolds numbers 1e3-2e5); at most its value
# for dense air (1.3 kg/m^3, 0 degC at sea level) and C_d = 1 (reached near Re = 100, below any
# ball of >= 1 cm moving at >= 0.2 m/s). F.M. White, Fluid Mechanics, 7th ed., 2011, fig. 7.16.
AIR_DENSITY = 1.2  # kg/m^3
SPHERE_DRAG_COEFFICIENT = 0.47
AIR_DENSITY_MAX = 1.3  # kg/m^3
DRAG_COEFFICIENT_MAX = 1.0


def ball_drag(ball) -> tuple[float, float]:
    """Expected and largest drag coefficient ``k = rho C_d pi r^2 / (2 m)`` of a ball (1/m)."""
    area_per_mass = math.pi * ball.radius**2 / (2 * ball.mass)
    return (AIR_DENSITY * SPHERE_DRAG_COEFFICIENT * area_per_mass,
            AIR_DENSITY_MAX * DRAG_COEFFICIENT_MAX * area_per_mass)


@dataclass(frozen=True)
class FolderKinematics:
    """Kinematics of every usable bounce of a folder, in file-name order, and why others failed.

    ``failures``: ``(name, message)`` pairs, ``name`` a file or ``<file>#<k>``; the message names
    the file, the line where known, the reason and the remedy. ``notes``: ``(file, message)``
    pairs about files that were used (rows merged or left out, drag fallbacks).
    ``n_files``: files read.
    """

    results: tuple[Kinematics, ...]
    failures: tuple[tuple[str, str], ...]
    notes: tuple[tuple[str, str], ...] = ()
    n_files: int = 0

    def summary(self) -> str:
        """A count, then one line per note and per failure, for a log or the command line."""
        used = {k.source for k in self.results}
        n = max(self.n_files, len(used) + len(self.failures))
        head = f"{len(used)} of {n} trajectory files gave kinematics ({len(self.results)} trials)"
        return "\n".join([head, *(f"  note: {name}: {message}" for name, message in self.notes),
                          *(f"  skipped: {message}" for _, message in self.failures)])


def kinematics_from_folder(folder: str | os.PathLike, *,
                           pattern: str | Sequence[str] = ("*.csv", "*.txt"),
                           rotation_deg: float = 0.0, length_unit: LengthUnit = "m",
                           ball=None, spin_bound: float = 0.0, config: FitConfig | None = None,
                           progress: bool = False, **options) -> FolderKinematics:
    """Read and fit every file in ``folder`` matching ``pattern`` (not recursive).

    Files are taken in natural file-name order (``b2`` before ``b10``); ``spin.csv`` is not a
    trajectory but the measured spins (module ``_spin``: ``file,incidence_spin[,_se]``). A file
    with several bounces gives one trial per bounce (``<file>#<k>``). A file or bounce that
    cannot be used (:class:`InputFileError`, including :class:`TrajectoryError`) is listed in
    ``failures`` and the others are still processed. ``rotation_deg`` and ``length_unit`` go to
    :func:`read_trajectory`; ``config`` and ``options`` (``min_points``, ``contact_guard``,
    ``drag``, ...: :class:`FitConfig`) to :func:`fit_bounces`; they are checked once, before any
    file is read. ``ball`` (radius, inertia_factor) and the spins allow for spin energy in the
    energy gate: a rebound may gain ``kappa r^2 w^2`` in ``v^2`` with ``w`` the measured
    ``|spin| + 3 se``, or ``spin_bound`` (rad/s) where not measured; without ``ball``, none.
    ``progress`` shows a progress bar over the files (tqdm).

    Raises:
        InputFileError: ``folder`` is not a folder or holds no matching file; a bad spin table.
    """
    check_scalar("rotation_deg", rotation_deg, unit="deg")
    check_choice("length_unit", length_unit, LENGTH_UNITS)
    bound = check_scalar("spin_bound", spin_bound, unit="rad/s", low=0.0)
    cfg = FitConfig.from_options(config, **options)
    files = _matching_files(folder, (pattern,) if isinstance(pattern, str) else tuple(pattern))
    spin_path = Path(folder) / SPIN_FILE
    spins = read_spin_table(spin_path) if spin_path.is_file() else None
    if spins is not None:
        check_spin_names(spin_path, spins, (p.name for p in files))
    results: list[Kinematics] = []
    failures: list[tuple[str, str]] = []
    notes: list[tuple[str, str]] = []
    for path in _bar(files, progress):
        try:
            traj = read_trajectory(path, rotation_deg=rotation_deg, length_unit=length_unit)
            n = find_bounces(traj).size
            rows: list[SpinRow | None] = (spin_for(spin_path, spins, path.name, n)
                                          if spins is not None else [None] * n)
            fits = fit_bounces(traj, config=cfg,
                               energy_allowance=[_allowance(ball, r, bound) for r in rows])
        except InputFileError as exc:
            if spins is not None and exc.path == os.fspath(spin_path):
                raise  # the spin table is wrong, not this file
            failures.append((os.fspath(path), str(exc)))
            continue
        notes += [(path.name, note) for note in traj.notes]
        _collect(fits, rows, spins is not None, results, failures)
    return FolderKinematics(tuple(results), tuple(failures), tuple(notes), len(files))


def _bar(files: list[Path], show: bool):
    """The files, behind a tqdm progress bar if asked (and there is more than one)."""
    if not show or len(files) < 2:
        return files
    from tqdm.auto import tqdm

    return tqdm(files, desc="trajectories", unit="file", leave=False)


def _collect(fits, rows: list[SpinRow | None], with_spin: bool, results: list[Kinematics],
             failures: list[tuple[str, str]]) -> None:
    """Add one file's bounces: results with their spins, failures with their messages."""
    for fit, row in zip(fits, rows, strict=True):
        if isinstance(fit, TrajectoryError):
            failures.append((fit.path, str(fit)))
        elif with_spin and row is None:
            failures.append((fit.label, str(TrajectoryError(
                fit.label, f"{SPIN_FILE} has no row for this trial; add `{fit.label},<spin>` "
                           "or remove the file", reason="no spin"))))
        else:
            results.append(fit if row is None else replace(
                fit, incidence_spin=row.spin, incidence_spin_se=row.se))


def _allowance(ball, row: SpinRow | None, bound: float) -> float:
    """What spin energy could add to the rebound's v^2: kappa r^2 w^2 (m^2/s^2)."""
    if ball is None:
        return 0.0
    w = abs(row.spin) + 3 * (row.se or 0.0) if row is not None else bound
    return float(ball.inertia_factor * ball.radius**2 * w * w)


def _matching_files(folder: str | os.PathLike, patterns: tuple[str, ...]) -> list[Path]:
    root = Path(folder)
    if not root.is_dir():
        raise InputFileError(root, "no such folder" if not root.exists() else
                             "is a file; expected a folder of trajectory files")
    files = {p for pat in patterns for p in root.glob(pat) if p.is_file() and p.name != SPIN_FILE}
    if not files:
        raise InputFileError(root, f"no file matches {', '.join(patterns)}; give `pattern` for "
                                   "other names")
    return sorted(files, key=_natural_key)


def _natural_key(path: Path) -> list:
    return [(0, int(s), "") if s.isdigit() else (1, 0, s.lower())
            for s in re.split(r"(\d+)", path.name)]


# ------------------------------------------------------------------------------ trial table

def trials_from_kinematics(results: Sequence[Kinematics], experiment=None):
    """The :class:`bouncebayes.data.Trials` of fitted bounces: labels, incidence and rebound with
    standard errors, ``incidence_spin`` where measured, ``scale_rel_sd`` where stated.

    Raises:
        ValueError: some results have a spin (or a scale uncertainty) and others not.
    """
    def column(name: str) -> list[float] | None:
        values = [getattr(k, name) for k in results]
        if all(v is None for v in values):
            return None
        if any(v is None for v in values):
            missing = next(k.label for k in results if getattr(k, name) is None)
            raise ValueError(f"`{name}` is given for some trials but not for {missing!r}")
        return values

    spin_se = [math.nan if k.incidence_spin_se is None else k.incidence_spin_se for k in results]
    se = {q: [getattr(k, q + "_se") for k in results]
          for q in ("incidence_speed", "incidence_angle", "rebound_speed", "rebound_angle")}
    if column("incidence_spin") is not None:
        se["incidence_spin"] = spin_se
    return make_trials(experiment, rebound_speed=[k.rebound_speed for k in results],
                       rebound_angle=[k.rebound_angle for k in results],
                       incidence_speed=[k.incidence_speed for k in results],
                       incidence_angle=[k.incidence_angle for k in results],
                       incidence_spin=column("incidence_spin"), se=se,
                       scale_rel_sd=column("scale_rel_sd"),
                       labels=[k.label or Path(k.source).name for k in results],
                       source="kinematics")


def write_trial_table(path: str | os.PathLike, results: Sequence[Kinematics], *,
                      provenance: Mapping[str, Any] | None = None) -> Path:
    """Write the trial table of fitted bounces with ``bouncebayes.data.write_trials`` (the one
    writer; ``bouncebayes.data.load_trials`` reads it)."""
    return write_trials(path, trials_from_kinematics(list(results)), provenance=provenance)


def trial_table_from_folder(folder: str | os.PathLike, experiment, out: str | os.PathLike,
                            *, log=print, provenance: Mapping[str, Any] | None = None,
                            progress: bool = False, **options) -> tuple[FolderKinematics, tuple[Kinematics, ...]]:
    """The experiment's trial table from a folder of trajectories.

    Every file is fitted with the experiment's ``[trajectories]`` settings (rotation, length
    unit, drag) and what the experiment's ball implies (:func:`ball_drag`: the expected drag
    coefficient as the prior of the drag fit, or, without it, to check that ignoring drag
    biases nothing; its largest physical value as the bound), with the ball's spin energy
    allowed for in the energy gate, the
    results referred to the contact instants (:func:`refer_to_contact`) and written to ``out``
    with ``provenance`` plus what this step used (settings, input files and their SHA-256).
    ``log`` gets the summary of which files were used and why others were not; ``progress``
    shows a progress bar over the files. Returns the
    folder's fits and the referred kinematics that were written.

    Raises:
        InputFileError: no bounce of the folder gave kinematics (nothing is written).
    """
    if Path(out).is_dir():  # before the work, not after it
        raise InputFileError(out, "is a folder; expected the name of the trial table to "
                                  "write, e.g. trials.csv")
    s = experiment.trajectories
    ball = experiment.ball
    k, k_max = ball_drag(ball)
    options = {"drag": s["drag"], "drag_k": k, "drag_k_max": k_max} | options
    found = kinematics_from_folder(folder, rotation_deg=s["rotation_deg"],
                                   length_unit=s["length_unit"], ball=ball,
                                   spin_bound=_spin_bound(experiment), progress=progress,
                                   **options)
    log(found.summary())
    if not found.results:
        raise InputFileError(folder, "no usable trajectory file: nothing written")
    results = refer_to_contact(found.results, experiment)
    stated = sum(k.scale_rel_sd is not None for k in results)
    if 0 < stated < len(results):
        log(f"  note: the tracker stated a scale uncertainty for {stated} of {len(results)} "
            "trials; `scale_rel_sd` is left out of the table (it holds it for every trial "
            "or none)")
        results = tuple(replace(k, scale_rel_sd=None) for k in results)
    gravity = gravity_scale([k.fall for k in results if k.fall is not None],
                            experiment.gravity, [k.scale_rel_sd for k in results])
    record: dict[str, Any] = {"setting": s["scale"]}
    if gravity is not None:
        log(f"  {gravity.summary()}")
        record |= gravity.record()
        if s["scale"] == "gravity":
            results, applied, words = rescaled_by_fall(results, experiment.gravity)
            record |= {"applied": applied, "applied_words": words}
            log(f"  {words}")
    elif s["scale"] == "gravity":
        why = (f"the experiment's gravity_m_s2 is {experiment.gravity:g}"
               if not experiment.gravity > 0 else "no free flight gave an acceleration")
        raise InputFileError(experiment.source, "`scale = \"gravity\"` in [trajectories] "
                                                f"needs the flights' fall, but {why}: nothing "
                                                "written", field="trajectories.scale")
    stamp = {"bouncebayes_version": __version__} | dict(provenance or {}) | {
        "kinematics": {"folder": os.fspath(folder), "experiment": experiment.source,
                       "experiment_sha256": experiment.text_sha256,
                       "settings": {"rotation_deg": s["rotation_deg"],
                                    "length_unit": s["length_unit"]} | {
                           k: v for k, v in options.items()},
                       "gravity": record, "inputs": _hashes(folder)}}
    write_trial_table(out, results, provenance=stamp)
    return found, results


def rescaled_by_fall(results: Sequence[Kinematics], gravity: float
                     ) -> tuple[tuple[Kinematics, ...], list[dict[str, Any]], str]:
    """``results`` with every speed (and its standard error) divided by the lengths' factor the
    flights' fall gives against ``gravity`` (m/s^2), and ``scale_rel_sd`` set to its relative
    SD; angles do not depend on the scale. A trial whose video was scaled by its own ball
    diameter (its tracker's sidecar) has its own calibration error, so each such video is
    corrected by its own flights' fall; the other trials share one calibration (a reference
    length, or none stated) and so one factor, from their flights together. Each factor is the
    fall's and the stated scale's by inverse variances where they agree
    (``GravityScale.combined``), the fall's alone where they do not or none was stated.
    Returns the trials, one record per group (trials, basis, factor, SD, agreement) and what
    was done in words."""
    own: dict[str, list[int]] = {}
    shared: list[int] = []
    for i, k in enumerate(results):
        if k.calibration_source == "ball diameter":
            own.setdefault(k.source, []).append(i)
        else:
            shared.append(i)
    groups = [("video", idx) for idx in own.values()] + ([("campaign", shared)] if shared else [])
    factor, sd = [1.0] * len(results), [math.nan] * len(results)
    records: list[dict[str, Any]] = []
    for basis, idx in groups:
        falls = [results[i].fall for i in idx]
        check = gravity_scale([f for f in falls if f is not None], gravity,
                              [results[i].scale_rel_sd for i in idx])
        if check is None:  # no usable fall: the stated scale stays
            continue
        value, rel = check.combined() if check.agrees else (check.scale, check.scale_sd)
        for i in idx:
            factor[i], sd[i] = value, rel
        records.append({"basis": basis, "trials": [results[i].label for i in idx],
                        "factor": value, "rel_sd": rel, "agrees": check.agrees,
                        "stated_rel_sd": check.stated})
    out = tuple(replace(k, incidence_speed=k.incidence_speed / f,
                        incidence_speed_se=k.incidence_speed_se / f,
                        rebound_speed=k.rebound_speed / f,
                        rebound_speed_se=k.rebound_speed_se / f,
                        scale_rel_sd=s if math.isfinite(s) else k.scale_rel_sd)
                for k, f, s in zip(results, factor, sd, strict=True))
    return out, records, _rescale_words(records)


def _rescale_words(records: list[dict[str, Any]]) -> str:
    """What :func:`rescaled_by_fall` did, one line."""
    if not records:
        return "scale = \"gravity\": no flight's fall could be used; the stated scale stays"
    parts = []
    for basis in ("video", "campaign"):
        group = [r for r in records if r["basis"] == basis]
        if not group:
            continue
        f = [r["factor"] for r in group]
        s = [100 * r["rel_sd"] for r in group]
        off = [r["trials"][0] for r in group if not r["agrees"] and r["stated_rel_sd"]]
        how = ("the fall's alone" if all(r["stated_rel_sd"] is None for r in group) else
               "the fall and the stated scale combined" + (
                   f"; the fall's alone where they disagree: {', '.join(off)}" if off else ""))
        if basis == "video":
            parts.append(f"each of {len(group)} videos with its own ball-diameter scale "
                         f"corrected by its own flights' fall ({how}): speeds divided by "
                         f"{min(f):.4f}-{max(f):.4f}, scale_rel_sd {min(s):.2f}-{max(s):.2f} %")
        else:
            parts.append(f"{len(group[0]['trials'])} trials sharing one calibration: every "
                         f"speed divided by {f[0]:.4f} ({how}); scale_rel_sd {s[0]:.2f} %")
    return "scale = \"gravity\": " + "; ".join(parts)


def _spin_bound(experiment) -> float:
    """Largest plausible |incident spin| where none was measured (rad/s)."""
    inc = experiment.incidence
    bound = abs(inc.spin) + 3 * inc.spin_sd
    if "spin" in experiment.priors:
        prior = experiment.priors["spin"]
        bound = max(bound, abs(float(prior.ppf(1e-3))), abs(float(prior.ppf(1 - 1e-3))))
    return bound


def _hashes(folder: str | os.PathLike) -> dict[str, str]:
    root = Path(folder)
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(root.iterdir(), key=_natural_key) if p.is_file()}
