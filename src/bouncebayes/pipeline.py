"""The whole job: data (trial table, trajectories or videos) -> kinematics -> inference ->
propagation -> figures -> report, every result in one run folder."""

from __future__ import annotations

import shutil
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from ._errors import InputFileError
from ._io import write_text
from .data import load_experiment, load_trials
from .inference import SamplerConfig, format_table, infer, write_outputs
from .propagation import propagate, write_propagation
from .report import EXPERIMENT_FILE, TRIALS_FILE, load_truth, make_figures, render_report

TRAJECTORY_SUFFIXES = (".csv", ".txt")


@dataclass(frozen=True)
class RunOutcome:
    """Where a run put its results, and its printed summary."""

    folder: Path
    report: Path
    table: str
    verdict: str
    stage_seconds: dict


def _video_inputs(folder: Path) -> list[Path]:
    """The videos of a folder: video files, and sub-folders of image frames."""
    from .tracking import IMAGE_SUFFIXES, VIDEO_SUFFIXES

    return sorted(p for p in folder.iterdir()
                  if (p.is_file() and p.suffix.lower() in VIDEO_SUFFIXES)
                  or (p.is_dir() and any(f.suffix.lower() in IMAGE_SUFFIXES
                                         for f in p.iterdir())))


def data_kind(data: Path) -> str:
    """``"table"`` (a CSV file), ``"trajectories"`` or ``"videos"`` (a folder)."""
    if data.is_file():
        return "table"
    if not data.is_dir():
        raise InputFileError(data, "no such file or folder (expected a trial table, or a folder "
                                   "of trajectory files or videos)")
    if _video_inputs(data):
        return "videos"
    if any(p.is_file() and p.suffix.lower() in TRAJECTORY_SUFFIXES for p in data.iterdir()):
        return "trajectories"
    raise InputFileError(data, "holds neither trajectory files (*.csv, *.txt) nor videos")


def _trials_from_data(data: Path, kind: str, experiment, out: Path, log,
                      fps: float | None = None) -> Path:
    """The trial table of the run folder, made from the data as needed."""
    from .kinematics import trial_table_from_folder

    table = out / TRIALS_FILE
    if kind == "table":
        write_text(table, data.read_text(encoding="utf-8"))
        return table
    folder = data
    if kind == "videos":
        folder = _track_videos(data, experiment, out, log, fps)
    trial_table_from_folder(folder, experiment, table, log=log)
    return table


def _track_videos(data: Path, experiment, out: Path, log, fps: float | None) -> Path:
    """Track every video (or image-sequence folder) of ``data`` into ``out/trajectories``,
    with an overlay image per video in ``out/tracking``; unusable videos are listed."""
    from .tracking import overlay_image, track_video, write_trajectory_csv

    inputs = _video_inputs(data)
    folder = out / "trajectories"
    tracked_any = False
    for path in inputs:
        try:
            tracked = track_video(path, fps=fps, ball_diameter=experiment.ball.diameter)
        except InputFileError as exc:
            log(f"  skipped: {exc}")
            continue
        name = tracked.source.name
        write_trajectory_csv(folder / f"{name}.csv", *tracked.trajectory)
        overlay_image(tracked.source.frames, tracked.track,
                      out / "tracking" / f"{name}.overlay.png",
                      calibration=tracked.calibration, surface=tracked.surface, title=name)
        tracked_any = True
    if not tracked_any:
        raise InputFileError(data, "no video could be tracked (each is listed above with the "
                                   "reason)")
    log(f"tracked {len(list(folder.glob('*.csv')))} of {len(inputs)} videos")
    return folder


def run(experiment_path: str | Path, data: str | Path, out: str | Path, *,
        likelihood: str = "gaussian", sampler: str = "mh", seed: int = 0,
        config: SamplerConfig | None = None, progress: bool = False,
        log: Callable[[str], None] = print, truth: Path | None = None,
        fps: float | None = None) -> RunOutcome:
    """Run every stage; each writes its results atomically into ``out``. ``fps``: the frame
    rate of videos (required for image-sequence folders; overrides a video file's)."""
    out, data = Path(out), Path(data)
    experiment_path = Path(experiment_path)
    times = {}

    def stage(k, name):
        log(f"[{k}/5] {name} ...")
        return time.perf_counter()

    start = stage(1, "data and kinematics")
    experiment = load_experiment(experiment_path)
    kind = data_kind(data)
    table = _trials_from_data(data, kind, experiment, out, log, fps)
    write_text(out / EXPERIMENT_FILE, experiment_path.read_text(encoding="utf-8"))
    if truth is not None:
        shutil.copyfile(truth, out / "truth.json")
    experiment = load_experiment(out / EXPERIMENT_FILE)
    trials = load_trials(table, experiment)
    times["data"] = time.perf_counter() - start

    start = stage(2, f"inference ({likelihood} likelihood, {sampler} sampler)")
    result = infer(experiment, trials, likelihood=likelihood, sampler=sampler, seed=seed,
                   config=config, progress=progress)
    write_outputs(result, out)
    times["inference"] = time.perf_counter() - start

    start = stage(3, "propagation of the posterior")
    prop = propagate(result)
    write_propagation(prop, out)
    times["propagation"] = time.perf_counter() - start

    start = stage(4, "figures")
    truth_values = load_truth(out)
    figures = make_figures(result, prop, out, truth_values)
    times["figures"] = time.perf_counter() - start

    start = stage(5, "report")
    report = render_report(result, prop.summary(), figures, out, truth_values)
    times["report"] = time.perf_counter() - start
    return RunOutcome(out, report, format_table(result), prop.match["verdict"], times)


def report_folder(folder: str | Path) -> Path:
    """Redraw the figures and rewrite ``report.html`` of a run folder from its files
    (propagating the posterior first if the folder has no propagation yet)."""
    from .propagation import load_propagation
    from .report import load_result

    folder = Path(folder)
    result = load_result(folder)
    if (folder / "propagation.json").is_file() and (folder / "propagation.npz").is_file():
        prop = load_propagation(folder)
    else:
        prop = propagate(result)
        write_propagation(prop, folder)
    truth = load_truth(folder)
    figures = make_figures(result, prop, folder, truth)
    return render_report(result, prop.summary(), figures, folder, truth)
