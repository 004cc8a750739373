"""The whole job: data (trial table, trajectories or videos) -> kinematics -> inference ->
propagation -> figures -> report, every result in one run folder.

A run folder changes all at once: every stage writes into a staging folder beside it, and the
staging folder replaces the run folder only when every stage has succeeded (see
:func:`bouncebayes._io.staged_output`). A run that fails or is stopped leaves the earlier results
exactly as they were; files of the user's own in an earlier run folder are kept.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import shutil
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ._errors import InputFileError
from ._io import is_temporary, link_or_copy, staged_output
from ._provenance import provenance, read_provenance, stamp, stamp_tree

TRAJECTORY_SUFFIXES = (".csv", ".txt")
EXPERIMENT_FILE, TRIALS_FILE, TRUTH_FILE = "experiment.toml", "trials.csv", "truth.json"
# what `report` needs of a run folder
RUN_FILES = ("posterior.nc", "summary.json", EXPERIMENT_FILE, TRIALS_FILE)
# what a run writes; anything else found in an earlier run folder is the user's, and kept
RUN_ENTRIES = frozenset({*RUN_FILES, "report.html", "grid.npz", "propagation.json",
                         "propagation.npz", "figures", "tracking", "trajectories", TRUTH_FILE})
STAGES = ("data", "inference", "propagation", "figures", "report")
RUN_ENTRIES |= {"derived.json"}  # the DEM-ready quantities (propagation.derive), a run's too


@dataclass(frozen=True)
class RunOutcome:
    """Where a run put its results, and its printed summary."""

    folder: Path
    report: Path
    table: str
    verdict: str
    stage_seconds: dict
    result: Any = None  #: the InferenceResult (``bouncebayes compare`` reads its evidence)


def video_inputs(folder: Path) -> list[Path]:
    """The videos of a folder: video files, and sub-folders of image frames."""
    from .tracking import IMAGE_SUFFIXES, VIDEO_SUFFIXES

    return sorted(p for p in folder.iterdir()
                  if (p.is_file() and p.suffix.lower() in VIDEO_SUFFIXES)
                  or (p.is_dir() and any(f.suffix.lower() in IMAGE_SUFFIXES
                                         for f in p.iterdir())))


def data_kind(data: Path) -> str:
    """``"table"`` (a CSV file), ``"trajectories"`` or ``"videos"`` (a folder)."""
    data = Path(data)
    if data.is_file():
        return "table"
    if not data.is_dir():
        raise InputFileError(data, "no such file or folder (expected a trial table, or a folder "
                                   "of trajectory files or videos)")
    try:
        if video_inputs(data):
            return "videos"
        if any(p.is_file() and p.suffix.lower() in TRAJECTORY_SUFFIXES for p in data.iterdir()):
            return "trajectories"
    except OSError as exc:
        raise InputFileError(data, f"cannot read the folder ({exc.strerror})") from None
    raise InputFileError(data, "holds neither trajectory files (*.csv, *.txt) nor videos")


def trial_table(folder: Path, experiment, out: Path, *, log: Callable[[str], None] = print,
                progress: bool = False, **fit_kwargs):
    """The trial table of a folder of trajectories, written to ``out``
    (:func:`bouncebayes.kinematics.trial_table_from_folder`, with a progress bar if asked)."""
    from .kinematics import trial_table_from_folder

    return trial_table_from_folder(folder, experiment, out, log=log, progress=progress,
                                   **fit_kwargs)


EACH_VIDEO = ("frames", "lens", "surface", "depth")  # `run` says these for each video


def _warnings(video, record: Path) -> dict[str, str | None]:
    """What the tracking of one video warns of (None: nothing): the scale (the record's
    ``ball.warning``), the compression, the tone curve and the flights' fall against the scale
    (``record``: its ``<name>.track.json``; e.g. a file whose frame rate is wrong), which `run`
    says once for all the videos; lost or repeated frames, a lens that bends lines, a surface
    edge that lies on its line along little of the frame and a ball that moves along the
    camera's axis, which it says for each (``EACH_VIDEO``)."""
    from .tracking import (compression_warning, depth_warning, lens_warning, radius_warning,
                           surface_warning, timing_warning, tone_curve_warning)

    check = json.loads(record.read_text(encoding="utf-8"))["gravity"]
    fell = None if check is None or check["agrees"] else \
        check["summary"].replace("\n  warning: ", ": ")
    return {"scale": radius_warning(video.track), "compression": compression_warning(video.source),
            "tone curve": tone_curve_warning(video), "frames": timing_warning(video.track),
            "lens": lens_warning(video), "surface": surface_warning(video),
            "depth": depth_warning(video.track), "fall": fell}


def _track_videos(data: Path, experiment, stage: Path, log, video: dict,
                  progress: bool) -> Path:
    """Track every video (or image-sequence folder) of ``data`` into ``stage/trajectories``,
    with an overlay image per video in ``stage/tracking``; unusable videos are listed.
    ``video``: ``fps``, ``surface`` (``"X1,Y1,X2,Y2"`` or None: detected), ``tone_curve`` and
    ``readout``, as :func:`run`."""
    from .tracking import (Surface, TrackerConfig, camera_message, cast_message,
                           tone_curve_label, track_video, write_track_files)

    fps = video["fps"]
    surface = None if video["surface"] is None else Surface.from_text(video["surface"])
    config = TrackerConfig(tone_curve=video.get("tone_curve"))

    inputs = video_inputs(data)
    folder = stage / "trajectories"
    tracked = 0
    said: dict[str, list[tuple[str, str]]] = {}  # kind -> (video, its warning) (_warnings)
    for path in _bar(inputs, progress, "videos"):
        try:
            tracked_video = track_video(path, fps=fps, ball_diameter=experiment.ball.diameter,
                                        surface=surface, config=config,
                                        readout=video.get("readout", 0.0))
        except InputFileError as exc:
            log(f"  skipped: {exc}")
            continue
        # the same files as `bouncebayes track`; <name>.track.json beside <name>.csv, where
        # the kinematics read its calibration uncertainty
        files = write_track_files(tracked_video, folder, overlay_folder=stage / "tracking",
                                  settings={"fps": fps,
                                            "ball_diameter_m": experiment.ball.diameter,
                                            "surface": video["surface"], "polarity": "auto",
                                            "tone_curve": tone_curve_label(config.tone_curve),
                                            "readout_s": video.get("readout", 0.0),
                                            "background": "per-pixel median of frames"})
        for note in (camera_message(tracked_video.track), cast_message(tracked_video.track),
                     tracked_video.source.channel_note):
            if note:  # each video's own
                log(f"  note: {path.name}: {note}")
        for kind, warning in _warnings(tracked_video, files["record"]).items():
            if warning is not None and kind in EACH_VIDEO:  # its own frames, its own lens
                log(f"  warning: {path.name}: {warning}")
            elif warning is not None:
                said.setdefault(kind, []).append((path.name, warning))
        tracked += 1
    for kind in ("scale", "compression", "tone curve", "fall"):  # one line, not one a video:
        if kind in said:                                           # one camera
            first, words = said[kind][0]
            log(f"  warning, {len(said[kind])} of {tracked} videos (first {first}): {words}")
    if not tracked:
        raise InputFileError(data, "no video could be tracked (each is listed above with the "
                                   "reason)")
    log(f"tracked {tracked} of {len(inputs)} videos")
    return folder


def _bar(items: list, show: bool, desc: str):
    if not show or len(items) < 2:
        return items
    from tqdm.auto import tqdm

    return tqdm(items, desc=desc, leave=False)


def check_run_folder(out: Path) -> None:
    """``out`` may be a run folder: missing, empty, or holding an earlier run."""
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise ValueError(f"`out` {out}: is a file; expected a run folder")
    if out.is_dir():
        entries = [p.name for p in out.iterdir() if not p.name.startswith(".")]
        if entries and not {"summary.json", "report.html"} & set(entries):
            raise ValueError(f"`out` {out}: holds {len(entries)} entries (e.g. {entries[0]!r}) "
                             f"and is not a bouncebayes run folder (no summary.json); give a "
                             f"new or empty folder, or an earlier run folder")


def carry_over(old: Path, stage: Path, log: Callable[[str], None]) -> list[str]:
    """Hard-link (or copy) into ``stage`` the entries of the earlier run folder ``old`` that
    no run writes: the user's own files survive the swap. Returns their names."""
    if not old.is_dir():
        return []
    kept = []
    for entry in sorted(old.iterdir()):
        if entry.name in RUN_ENTRIES or (stage / entry.name).exists() or entry == stage \
                or is_temporary(entry.name):
            continue
        if entry.is_dir() and not entry.is_symlink():
            shutil.copytree(entry, stage / entry.name, copy_function=link_or_copy,
                            symlinks=True)
        else:
            link_or_copy(entry, stage / entry.name)
        kept.append(entry.name)
    if kept:
        log(f"kept {len(kept)} of your entries in {old}: {', '.join(kept)}")
    return kept


def run(experiment_path: str | Path, data: str | Path, out: str | Path, *,
        likelihood: str | None = None, sampler: str | None = None, seed: int = 0, config=None,
        noise: str | None = None, discrepancy: str | None = None, progress: bool = False,
        log: Callable[[str], None] = print,
        truth: str | Path | None = None, fps: float | None = None,
        surface: str | None = None, tone_curve: str | float | None = None,
        readout: float = 0.0, argv: Sequence[str] | None = None,
        figure_formats: Sequence[str] = ("png",), memory_budget: int | None = None,
        population: str | None = None) -> RunOutcome:
    """Run every stage into the run folder ``out``, which changes only if all succeed.

    Arguments:
        experiment_path: the experiment file (TOML).
        data: a trial table (CSV), or a folder of trajectory files or of videos.
        out: the run folder: missing, empty, or an earlier run's.
        likelihood: as :func:`bouncebayes.inference.infer`.
        sampler: as :func:`bouncebayes.inference.infer`.
        seed: as :func:`bouncebayes.inference.infer`; recorded in every file.
        config: the sampler's configuration (:class:`bouncebayes.inference.MHConfig`,
            :class:`~bouncebayes.inference.EnsembleConfig` or :class:`~bouncebayes.inference.GridConfig`).
        noise: as :func:`bouncebayes.inference.infer`.
        discrepancy: as :func:`bouncebayes.inference.infer`.
        progress: progress bars for the long stages.
        log: receives one line per stage and the stages' messages.
        truth: a synthetic campaign's ``truth.json``, copied in and shown in the report.
        fps: the frame rate of videos (required for image-sequence folders; overrides a video
            file's).
        surface: videos: two pixel points on the surface line of every video,
            ``"X1,Y1,X2,Y2"`` (one camera set-up); None: detected in each.
        tone_curve: videos: how the camera stored light as grey levels
            (:class:`bouncebayes.tracking.TrackerConfig`; None: not given, taken as linear);
            the frames are decoded to light.
        readout: videos: a rolling shutter's readout time, s (0: a global shutter); each
            centre is timed by its row (:func:`bouncebayes.tracking.to_plane_frame`).
        argv: the command line, recorded in the provenance of every file.
        figure_formats: the files of each figure: PNG always, and "svg" or "pdf" if asked.
        memory_budget: as :func:`bouncebayes.inference.infer` (bytes; its default if None).
        population: as :func:`bouncebayes.inference.infer` (the population likelihood's
            family; the experiment's if None).
    """
    out, data, experiment_path = Path(out), Path(data), Path(experiment_path)
    check_run_folder(out)
    from ._validate import check_scalar
    from .tracking import TrackerConfig

    # the videos' settings, checked before any work
    tone_curve = TrackerConfig(tone_curve=tone_curve).tone_curve
    readout = check_scalar("readout", readout, unit="s", low=0.0)
    record = provenance(inputs={"experiment": experiment_path, "data": data, "truth": truth},
                        seed=seed, argv=argv, config={
                            "likelihood": likelihood, "sampler": sampler, "noise": noise,
                            "discrepancy": discrepancy, "sampler_config": config, "fps": fps,
                            "surface": surface, "tone_curve": tone_curve, "readout": readout,
                            "figure_formats": list(figure_formats),
                            "memory_budget": memory_budget})
    settings = dict(likelihood=likelihood, sampler=sampler, seed=seed, config=config,
                    noise=noise, discrepancy=discrepancy, progress=progress)
    if memory_budget is not None:
        settings["memory_budget"] = memory_budget
    if population is not None:
        settings["population"] = population
    times: dict[str, float] = {}
    with staged_output(out, "folder") as stage:
        with contextlib.ExitStack() as background:
            result, prop = _analyse(experiment_path, data, stage, out, settings, times, log,
                                    {"fps": fps, "surface": surface, "tone_curve": tone_curve,
                                     "readout": readout},
                                    truth, background)
            report = _draw(result, prop, stage, times, log, record, figure_formats, progress)
        # the trial table keeps what its kinematics recorded (settings, inputs, the scale's
        # check against the flights' fall), which `bouncebayes report` shows again
        kinematics = (read_provenance(stage / TRIALS_FILE) or {}).get("kinematics")
        stamp_tree(stage, record)
        if kinematics is not None:
            stamp(stage / TRIALS_FILE, dict(record) | {"kinematics": kinematics})
        carry_over(out, stage, log)
    from .inference import format_table

    return RunOutcome(out, out / report.name, format_table(result), prop.match["verdict"],
                      times, result)


def _stage(k: int, name: str, log) -> float:
    log(f"[{k}/{len(STAGES)}] {name} ...")
    return time.perf_counter()


def _analyse(experiment_path: Path, data: Path, stage: Path, out: Path, settings: dict,
             times: dict, log, video: dict, truth, background: contextlib.ExitStack):
    """Stages 1-3: the trial table, the posterior, its propagation (written into ``stage``;
    the posterior's files perhaps by a forked copy that ``background`` waits for); ``video``:
    the videos' ``fps`` and ``surface`` (:func:`run`)."""
    from ._background import in_background
    from .data import load_experiment
    from .inference import infer, write_outputs
    from .propagation import derive, propagate, write_derived, write_propagation

    start = _stage(1, "data and kinematics", log)
    experiment = load_experiment(experiment_path)
    trials = _trials(data, experiment, stage, out, log, video, settings["progress"])
    shutil.copyfile(experiment_path, stage / EXPERIMENT_FILE)
    if truth is not None:
        shutil.copyfile(truth, stage / TRUTH_FILE)
    times["data"] = time.perf_counter() - start

    likelihood = settings["likelihood"] or experiment.inference["likelihood"]
    from .inference import resolve_sampler

    sampler = resolve_sampler(settings["sampler"], settings["config"], likelihood)
    start = _stage(2, f"inference ({likelihood} likelihood, {sampler} sampler)", log)
    result = infer(experiment, trials, **settings)
    times["inference"] = time.perf_counter() - start

    # posterior.nc, summary.json (and grid.npz) are read by no later stage, which has them in
    # memory: a spare core writes them (its import of the NetCDF stack included) while this
    # process goes on (``background`` waits for it before the run folder is stamped and
    # committed)
    background.enter_context(in_background(lambda: write_outputs(result, stage)))

    start = _stage(3, "propagation of the posterior", log)
    prop = propagate(result, progress=settings["progress"])
    write_propagation(prop, stage)
    write_derived(derive(result), stage)  # DEM-ready quantities (derived.json)
    times["propagation"] = time.perf_counter() - start
    return result, prop


def _trials(data: Path, experiment, stage: Path, out: Path, log, video: dict, progress):
    """The run's trials, and its copy of the trial table in ``stage``."""
    from ._provenance import file_sha256, read_provenance
    from .data import load_trials
    from .kinematics import trials_from_kinematics

    kind = data_kind(data)
    table = stage / TRIALS_FILE
    if kind == "table":
        if experiment.trajectories["scale"] == "gravity":
            log("  note: `scale = \"gravity\"` in [trajectories] needs the flights, which a "
                "trial table does not hold: its speeds are taken as they are")
        shutil.copyfile(data, table)
        return load_trials(data, experiment)
    if kind == "videos":
        folder = _track_videos(data, experiment, stage, log, video, progress)
        said = _as_videos(folder, data)
        try:
            _, results = trial_table(folder, experiment, table, log=lambda m: log(said(m)),
                                     progress=progress)
        except InputFileError as exc:  # about the staging folder or a file in it: the same
            # error (a TrajectoryError keeps its reason), naming the videos
            exc.args = (said(str(exc)).replace(str(folder), str(data)),)
            exc.path = str(data) if Path(exc.path) == folder else said(exc.path)
            raise
    else:
        _, results = trial_table(data, experiment, table, log=log, progress=progress)
    # the fitted kinematics go on as they are, not back through the file just written
    trials = trials_from_kinematics(results, experiment)
    return dataclasses.replace(trials, source=str(out / TRIALS_FILE),  # not the staging path
                               sha256=file_sha256(table), provenance=read_provenance(table))


def _as_videos(tracks: Path, videos: Path) -> Callable[[str], str]:
    """What names the trajectory files tracked into the staging folder ``tracks`` in a message
    names instead the videos of ``videos`` they came from (``<video>'s track``): the staging
    folder is gone when the run fails, and its files were never the user's."""
    import re

    names = {p.stem: p.name for p in video_inputs(videos)}
    pattern = re.compile(re.escape(str(tracks)) + r"[/\\]([^/\\:#]+)\.csv")

    def said(message: str) -> str:
        return pattern.sub(lambda m: f"{videos / names.get(m.group(1), m.group(1))}'s track",
                           message)

    return said


def _draw(result, prop, stage: Path, times: dict, log, record: dict,
          formats: Sequence[str], progress: bool = False) -> Path:
    """Stages 4-5: figures and the report (written into ``stage``)."""
    from .report import load_truth, make_figures, render_report

    start = _stage(4, "figures", log)
    truth_values = load_truth(stage)
    figures = make_figures(result, prop, stage, truth_values, formats=formats,
                           progress=progress)
    times["figures"] = time.perf_counter() - start

    start = _stage(5, "report", log)
    report = render_report(result, prop.summary(), figures, stage, truth_values,
                           provenance=record)
    times["report"] = time.perf_counter() - start
    return report


def report_folder(folder: str | Path, *, argv: Sequence[str] | None = None,
                  log: Callable[[str], None] = lambda message: None,
                  progress: bool = False, figure_formats: Sequence[str] = ("png",)) -> Path:
    """Redraw the figures and rewrite ``report.html`` of a run folder from its files
    (propagating the posterior first if the folder has no propagation yet). Every file is
    checked first, and a damaged one is named; the folder changes only when all is done."""
    from .report import load_result, load_run_propagation, load_truth, make_figures, \
        render_report

    folder = Path(folder)
    result = load_result(folder)
    prop = load_run_propagation(folder)
    truth = load_truth(folder)
    record = provenance(inputs={"run_folder": folder}, argv=argv)
    shown = _run_provenance(folder) or record
    with staged_output(folder, "folder", start_from=folder) as stage:
        for name in ("figures", "report.html"):
            _remove(stage / name)
        written: list[Path] = []
        if prop is None:
            from .propagation import propagate, write_propagation

            log("propagating the posterior ...")
            prop = propagate(result, progress=progress)
            written += write_propagation(prop, stage).values()
        written += _derived_if_missing(result, stage, log)
        log("figures ...")
        figures = make_figures(result, prop, stage, truth, formats=figure_formats,
                               progress=progress)
        report = render_report(result, prop.summary(), figures, stage, truth,
                               provenance=shown)
        for path in [*written, *(stage / "figures").rglob("*")]:
            stamp(path, record)
    return folder / report.name


def _derived_if_missing(result, stage: Path, log) -> list[Path]:
    """``derived.json`` for a run folder that has none (written before it existed)."""
    from .propagation import derive, load_derived, write_derived

    if load_derived(stage) is not None:
        return []
    log("DEM-ready quantities ...")
    return [write_derived(derive(result), stage)]


def _run_provenance(folder: Path) -> dict | None:
    from ._provenance import read_provenance

    try:
        return read_provenance(folder / "summary.json")
    except (OSError, ValueError):
        return None


def _remove(path: Path) -> None:
    if path.is_dir():
        shutil.rmtree(path)
    elif path.exists():
        path.unlink()


def warmup(log: Callable[[str], None] = print) -> float:
    """Compile and cache every numba kernel a run uses, on a tiny problem; returns seconds.

    Numba caches compiled kernels on disk (``cache=True``); the first run after an install
    otherwise spends most of its time compiling."""
    from .data import demo_campaign
    from .inference import sampler_config

    start = time.perf_counter()
    demo = demo_campaign()
    configs = {"mh": sampler_config("mh", draws=200, chains=2, burn_in=20),
               "ensemble": sampler_config("ensemble", draws=200, walkers=8, burn_in=10),
               "grid": sampler_config("grid", draws=200, points=16)}
    with tempfile.TemporaryDirectory(prefix="bouncebayes-warmup-") as tmp:
        for likelihood, sampler in _WARMUP_CASES:
            log(f"compiling: {likelihood} likelihood, {sampler} sampler ...")
            _warm_once(demo, Path(tmp) / f"{likelihood}-{sampler}", likelihood, sampler,
                       configs[sampler])
    log("compiling: video tracking ...")
    from .tracking import warm_kernels

    warm_kernels()
    return time.perf_counter() - start


_WARMUP_CASES = (("gaussian", "mh"), ("kde", "mh"), ("consistent", "grid"),
                 ("gaussian", "ensemble"), ("population", "ensemble"))


def _warm_once(demo, out: Path, likelihood: str, sampler: str, config: Any) -> None:
    from .data import load_experiment, load_trials
    from .inference import infer
    from .propagation import propagate

    experiment = load_experiment(demo.experiment)
    out.mkdir(parents=True)
    if (likelihood, sampler) == _WARMUP_CASES[0]:  # kinematics and the ODE path once
        trial_table(demo.data, experiment, out / TRIALS_FILE, log=lambda m: None)
        trials = load_trials(out / TRIALS_FILE, experiment)
    else:
        trials = load_trials(demo.trials, experiment)
    result = infer(experiment, trials, likelihood=likelihood, sampler=sampler, config=config)
    if sampler == "mh":
        propagate(result, n_draws=50)
