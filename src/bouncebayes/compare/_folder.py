"""``bouncebayes compare``: every candidate's run folder, then the comparison, in one folder
that changes all at once (like a run folder, :func:`bouncebayes._io.staged_output`)."""

from __future__ import annotations

import shutil
import tempfile
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from .._errors import InputFileError
from .._io import staged_output
from .._provenance import provenance, stamp
from ._compare import compare_results, plan_for, select_candidates
from ._evidence import LIVE_POINTS
from ._report import COMPARISON_FILE, write_comparison

MODELS_FOLDER = "models"


@dataclass(frozen=True)
class CompareOutcome:
    """Where the comparison went, and its verdict."""

    folder: Path
    report: Path
    verdict: str
    comparison: object


def check_compare_folder(out: Path) -> None:
    """``out`` may be a comparison folder: missing, empty, or holding an earlier comparison."""
    if out.exists() and not out.is_dir():
        raise ValueError(f"`out` {out}: is a file; expected a comparison folder")
    if out.is_dir():
        entries = [p.name for p in out.iterdir() if not p.name.startswith(".")]
        if entries and COMPARISON_FILE not in entries:
            raise ValueError(f"`out` {out}: holds {len(entries)} entries (e.g. {entries[0]!r}) "
                             f"and is not a bouncebayes comparison folder (no "
                             f"{COMPARISON_FILE}); give a new or empty folder, or an earlier "
                             f"comparison folder")


def _trial_table(data: Path) -> Path:
    if data.is_dir():
        raise InputFileError(data, "compare reads a trial table, the same for every candidate; "
                                   "make one from trajectories with `bouncebayes kinematics "
                                   "FOLDER --experiment EXPERIMENT.toml --out trials.csv`")
    if not data.is_file():
        raise InputFileError(data, "no such file (expected a trial table)")
    return data


def compare_folder(experiment_path: str | Path, data: str | Path, out: str | Path,
                   models: Sequence[str] | None = None, *, seed: int = 0,
                   evidence: str = "auto", grid_points: int | None = None,
                   draws: int | None = None, live_points: int = LIVE_POINTS,
                   progress: bool = False, log: Callable[[str], None] = print,
                   argv: Sequence[str] | None = None,
                   figure_formats: Sequence[str] = ("png",)) -> CompareOutcome:
    """Run every candidate of the experiment's [models] (``models``: names, default all) on
    the trial table ``data`` into ``out/models/NAME``, then write ``out/comparison.json``, the
    figure and ``out/report.html``."""
    from ..data import load_experiment, load_trials
    from ..pipeline import run

    out, data, experiment_path = Path(out), _trial_table(Path(data)), Path(experiment_path)
    experiment = load_experiment(experiment_path)
    candidates = select_candidates(experiment, models)
    trials = load_trials(data, experiment)
    plans = {n: plan_for(n, c.experiment, trials, evidence=evidence, grid_points=grid_points,
                         draws=draws) for n, c in candidates.items()}
    check_compare_folder(out)
    record = provenance(inputs={"experiment": experiment_path, "data": data}, seed=seed,
                        argv=argv, config={"models": list(candidates), "evidence": evidence,
                                           "live_points": live_points,
                                           "plans": {n: p.settings() for n, p in plans.items()}})
    results = {}
    with staged_output(out, "folder") as stage, tempfile.TemporaryDirectory() as tmp:
        shutil.copyfile(experiment_path, stage / "experiment.toml")
        for k, (name, candidate) in enumerate(candidates.items(), start=1):
            p = plans[name]
            log(f"model {k}/{len(candidates)}: {name} ({p.sampler} sampler, evidence by "
                f"{p.evidence})")
            toml = Path(tmp) / f"{name}.toml"
            toml.write_text(candidate.toml(), encoding="utf-8")
            results[name] = run(toml, data, stage / MODELS_FOLDER / name, sampler=p.sampler,
                                seed=seed, config=p.config, noise=p.noise, progress=progress,
                                log=lambda m: log(f"  {m}"), argv=argv,
                                figure_formats=figure_formats,
                                likelihood="gaussian", discrepancy="none").result
        log("comparison: evidence, leave-one-out, verdict ...")
        comparison = compare_results(results, plans, seed=seed, live_points=live_points,
                                     progress=progress)
        report = write_comparison(comparison, stage, provenance=record, formats=figure_formats,
                                  seed=seed, run_reports={n: f"{MODELS_FOLDER}/{n}/report.html"
                                                          for n in candidates})
        for path in (stage / "figures").iterdir():
            stamp(path, record)
        stamp(stage / "experiment.toml", record)
    return CompareOutcome(out, out / report.name, comparison.verdict["text"], comparison)
