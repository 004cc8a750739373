"""The run folder: staged outputs that change all at once, provenance on every file, and the
pipeline's handling of earlier results (kept intact on failure, the user's files carried over).
"""

import dataclasses
import hashlib
import json
import os
import struct
import subprocess
import sys
import zlib
from pathlib import Path

import numpy as np
import pytest

import bouncebayes as bb
from bouncebayes import _io
from bouncebayes._provenance import (file_sha256, provenance, read_provenance, stamp,
                                     stamp_tree, tree_sha256)
from bouncebayes.data import load_experiment, load_trials
from bouncebayes.inference import MHConfig


def snapshot(folder: Path) -> dict:
    """Every path under ``folder`` (hidden ones included) with its bytes' hash."""
    return {p.relative_to(folder).as_posix(): (hashlib.sha256(p.read_bytes()).hexdigest()
                                               if p.is_file() else "dir")
            for p in sorted(folder.rglob("*"))}


def make_folder(path: Path, files: dict) -> Path:
    for name, text in files.items():
        (path / name).parent.mkdir(parents=True, exist_ok=True)
        (path / name).write_text(text)
    return path


def dead_pid() -> int:
    """The id of a process that has finished."""
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


# --------------------------------------------------------------------------- staging

@pytest.mark.parametrize("mode", ["folder", "entries"])
def test_a_failed_staged_output_leaves_the_target_exactly_as_it_was(tmp_path, mode):
    target = make_folder(tmp_path / "out", {"summary.json": "{}", "figures/a.png": "x"})
    before = snapshot(tmp_path)
    for error in (RuntimeError("stage 4 failed"), KeyboardInterrupt()):
        with pytest.raises(type(error)):
            with _io.staged_output(target, mode) as stage:
                (stage / "summary.json").write_text('{"new": 1}')
                raise error
        assert snapshot(tmp_path) == before  # no temporary file either


def test_a_staged_run_folder_replaces_the_old_one_whole(tmp_path):
    target = make_folder(tmp_path / "out", {"summary.json": "old", "grid.npz": "stale"})
    with _io.staged_output(target, "folder") as stage:
        (stage / "summary.json").write_text("new")
        assert stage.parent == tmp_path and stage.name.startswith(".out.staging-")
    assert snapshot(tmp_path) == {"out": "dir",
                                  "out/summary.json": hashlib.sha256(b"new").hexdigest()}


def test_a_new_output_folder_is_removed_again_when_the_command_fails(tmp_path):
    with pytest.raises(RuntimeError):
        with _io.staged_output(tmp_path / "a" / "b" / "out", "entries") as stage:
            (stage / "x.csv").write_text("1")
            raise RuntimeError
    assert list(tmp_path.iterdir()) == []


def test_entries_replace_their_namesakes_and_owned_stale_ones_go(tmp_path):
    target = make_folder(tmp_path / "out", {"mine.txt": "user", "summary.json": "old",
                                            "grid.npz": "old grid", "trajectories/b1.csv": "1",
                                            "trajectories/b2.csv": "2"})
    with _io.staged_output(target, "entries", owned=("summary.json", "grid.npz",
                                                     "trajectories")) as stage:
        make_folder(stage, {"summary.json": "new", "trajectories/b1.csv": "new 1"})
    assert snapshot(target) == snapshot(make_folder(tmp_path / "expect", {
        "mine.txt": "user", "summary.json": "new", "trajectories/b1.csv": "new 1"}))


def test_a_file_output_is_replaced_at_once(tmp_path):
    target = tmp_path / "trials.csv"
    target.write_text("old")
    with _io.staged_output(target, "file") as stage:
        (stage / "trials.csv").write_text("new")
    assert target.read_text() == "new" and [p.name for p in tmp_path.iterdir()] == ["trials.csv"]


def test_a_run_folder_holding_the_working_directory_is_replaced_entry_by_entry(tmp_path,
                                                                              monkeypatch):
    target = make_folder(tmp_path / "out", {"summary.json": "old", "figures/a.png": "old"})
    monkeypatch.chdir(target)
    with _io.staged_output(target, "folder") as stage:
        assert stage.parent == target  # not beside: the user's shell stays in a live folder
        make_folder(stage, {"summary.json": "new"})
    assert os.path.samefile(Path.cwd(), target)
    assert snapshot(target) == {"summary.json": hashlib.sha256(b"new").hexdigest()}


def test_leftovers_of_killed_writers_are_cleaned_and_a_half_swap_is_undone(tmp_path):
    pid = dead_pid()
    make_folder(tmp_path, {f".out.staging-{pid}-ab12cd34/summary.json": "partial",
                           f".trials.csv.{pid}.k2j4h5g6.part.csv": "partial",
                           f".run.old-{pid}-0011aabb/summary.json": "previous run",
                           f".out.staging-{os.getpid()}-00000000/x": "a live writer's",
                           "out/summary.json": "current"})
    removed = _io.remove_stale(tmp_path)
    assert len(removed) == 2
    # killed between its two renames: the previous run is moved back where it was
    assert snapshot(tmp_path) == {
        f".out.staging-{os.getpid()}-00000000": "dir",
        f".out.staging-{os.getpid()}-00000000/x": hashlib.sha256(b"a live writer's").hexdigest(),
        "out": "dir", "out/summary.json": hashlib.sha256(b"current").hexdigest(),
        "run": "dir", "run/summary.json": hashlib.sha256(b"previous run").hexdigest()}


def test_the_next_staged_output_cleans_what_a_killed_one_left(tmp_path):
    pid = dead_pid()
    make_folder(tmp_path, {f".out.staging-{pid}-ab12cd34/posterior.nc": "partial",
                           "out/summary.json": "old"})
    with _io.staged_output(tmp_path / "out", "folder") as stage:
        (stage / "summary.json").write_text("new")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


# --------------------------------------------------------------------------- provenance

def test_provenance_records_what_made_a_file(tmp_path):
    data = make_folder(tmp_path / "traj", {"b1.csv": "t,x,y\n", "sub/b2.csv": "2",
                                           ".hidden": "skipped"})
    config = MHConfig(draws=500)
    p = provenance(inputs={"experiment": EXAMPLE, "data": data, "none": None}, seed=7,
                   config=config, argv=["bouncebayes", "run", "my file.toml"])
    assert p["bouncebayes_version"] == bb.__version__ and p["seed"] == 7
    assert p["command"] == "bouncebayes run 'my file.toml'"
    # independent: hashlib over the bytes, and the documented listing of a folder
    assert p["inputs"]["experiment"]["sha256"] == hashlib.sha256(EXAMPLE.read_bytes()).hexdigest()
    listing = (f"b1.csv {hashlib.sha256(b't,x,y' + chr(10).encode()).hexdigest()}\n"
               f"sub/b2.csv {hashlib.sha256(b'2').hexdigest()}\n")
    assert p["inputs"]["data"] == {"path": str(data.resolve()), "files": 2,
                                   "sha256": hashlib.sha256(listing.encode()).hexdigest()}
    assert "none" not in p["inputs"] and p["config"]["draws"] == 500
    assert p["python_version"].count(".") == 2 and p["numpy_version"] == np.__version__
    assert p["created_utc"].endswith("+00:00")
    json.dumps(p)  # JSON-ready
    assert tree_sha256(data)[1] == 2 and file_sha256(EXAMPLE) == p["inputs"]["experiment"][
        "sha256"]


EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "paper.toml"


def _png(width: int = 2, height: int = 1) -> bytes:
    """A minimal grey PNG built by hand (PNG specification, ISO/IEC 15948)."""
    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(
            ">I", zlib.crc32(kind + data))
    raw = b"".join(b"\0" + bytes(range(width)) for _ in range(height))
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 0, 0,
                                                             0, 0))
            + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


def test_every_format_carries_the_stamp_and_stays_readable(tmp_path, demo):
    import h5netcdf
    import matplotlib.image

    record = provenance(inputs={"x": EXAMPLE}, seed=3, argv=["bouncebayes", "x -- y"])
    files = {"a.json": lambda p: p.write_text('{"k": 1}'),
             "trials.csv": lambda p: p.write_bytes(demo.trials.read_bytes()),
             "experiment.toml": lambda p: p.write_bytes(EXAMPLE.read_bytes()),
             "a.npz": lambda p: np.savez(p, x=np.arange(3)),
             "a.png": lambda p: p.write_bytes(_png()),
             "a.svg": lambda p: p.write_text('<?xml version="1.0"?>\n<svg></svg>\n')}
    for name, make in files.items():
        make(tmp_path / name)
    with h5netcdf.File(tmp_path / "a.nc", "w") as f:
        f.dimensions = {"n": 3}
        f.create_variable("v", ("n",), data=np.arange(3.0))
    for name in [*files, "a.nc"]:
        path = tmp_path / name
        assert stamp(path, record) and stamp(path, record)  # twice: replaced, not repeated
        assert read_provenance(path) == json.loads(json.dumps(record)), name
    assert (tmp_path / "trials.csv").read_text().count("# provenance:") == 1
    assert "--" not in (tmp_path / "a.svg").read_text().split("<!--")[1].split("-->")[0]
    # still what they were
    experiment = load_experiment(tmp_path / "experiment.toml")
    assert load_trials(tmp_path / "trials.csv", experiment).n == 55
    assert np.load(tmp_path / "a.npz")["x"].tolist() == [0, 1, 2]
    assert matplotlib.image.imread(tmp_path / "a.png").shape == (1, 2)
    assert json.loads((tmp_path / "a.json").read_text())["k"] == 1
    with h5netcdf.File(tmp_path / "a.nc", "r") as f:
        assert f.variables["v"][:].tolist() == [0.0, 1.0, 2.0]
    assert not stamp(tmp_path / "report.html", record)


def test_trajectory_files_are_stamped_and_still_read(tmp_path):
    from bouncebayes.data import read_trajectory_table

    make_folder(tmp_path, {"trajectories/b1.csv": "t,x,y\n0,0,0\n0.001,1,1\n",
                           "summary.json": "{}"})
    record = provenance(inputs={}, seed=5)
    stamped = stamp_tree(tmp_path, record)
    assert sorted(p.name for p in stamped) == ["b1.csv", "summary.json"]
    traj = tmp_path / "trajectories" / "b1.csv"
    assert read_provenance(traj) == record
    assert read_trajectory_table(traj).columns["t"].tolist() == [0.0, 0.001]


def test_every_file_of_a_run_carries_the_run_provenance(small_run):
    folder = small_run.folder
    summary = json.loads((folder / "summary.json").read_text())
    record = summary["provenance"]
    assert record["seed"] == 11 and record["inputs"]["data"]["sha256"] == hashlib.sha256(
        (Path(bb.data.demo_campaign().trials)).read_bytes()).hexdigest()
    assert record["config"]["sampler_config"]["draws"] == 2000
    exempt = {"report.html"}
    for path in folder.rglob("*"):
        if path.is_file() and path.name not in exempt:
            assert read_provenance(path) == record, path
    page = (folder / "report.html").read_text()
    assert record["created_utc"] in page and record["inputs"]["data"]["sha256"] in page
    # nothing in the results points into the staging folder
    assert ".staging-" not in (folder / "summary.json").read_text()


# --------------------------------------------------------------------------- the pipeline

def _earlier_run(folder: Path) -> Path:
    return make_folder(folder, {"summary.json": '{"seed": 1}', "report.html": "<p>seed 1</p>",
                                "grid.npz": "stale", "notes.txt": "my notes",
                                "extra/plan.md": "mine too"})


def test_a_run_that_fails_at_the_figures_stage_changes_nothing(tmp_path, demo, monkeypatch):
    import bouncebayes.report

    out = _earlier_run(tmp_path / "out")
    before = snapshot(tmp_path)

    def broken(*args, **kwargs):
        raise ValueError("cannot draw")

    monkeypatch.setattr(bouncebayes.report, "make_figures", broken)
    with pytest.raises(ValueError, match="cannot draw"):
        bb.pipeline.run(demo.experiment, demo.trials, out, config=MHConfig(draws=400),
                        log=lambda m: None)
    assert snapshot(tmp_path) == before


def test_a_run_keeps_the_users_files_of_an_earlier_run_folder(tmp_path, demo, monkeypatch):
    import bouncebayes.report

    out = _earlier_run(tmp_path / "out")
    monkeypatch.setattr(bouncebayes.report, "make_figures", lambda *a, **k: [])
    messages = []
    bb.pipeline.run(demo.experiment, demo.trials, out, config=MHConfig(draws=400),
                    log=messages.append, seed=2)
    assert (out / "notes.txt").read_text() == "my notes"
    assert (out / "extra" / "plan.md").read_text() == "mine too"
    assert not (out / "grid.npz").exists()  # the earlier run's: not part of this one
    assert json.loads((out / "summary.json").read_text())["seed"] == 2
    assert "kept 2 of your entries" in "\n".join(messages)
    assert [p.name for p in tmp_path.iterdir()] == ["out"]


def test_a_run_refuses_a_folder_that_is_not_a_run_folder(tmp_path, demo):
    make_folder(tmp_path / "data", {"thesis.tex": "years of work"})
    with pytest.raises(ValueError, match=r"is not a bouncebayes run folder"):
        bb.pipeline.run(demo.experiment, demo.trials, tmp_path / "data", log=lambda m: None)
    assert (tmp_path / "data" / "thesis.tex").read_text() == "years of work"


def test_run_passes_progress_to_the_sampler(tmp_path, demo, monkeypatch):
    import bouncebayes.inference

    seen = {}

    def spy(*args, **kwargs):
        seen.update(kwargs)
        raise KeyboardInterrupt

    monkeypatch.setattr(bouncebayes.inference, "infer", spy)
    with pytest.raises(KeyboardInterrupt):
        bb.pipeline.run(demo.experiment, demo.trials, tmp_path / "o", progress=True,
                        log=lambda m: None)
    assert seen["progress"] is True
    assert list(tmp_path.iterdir()) == []


def test_run_passes_progress_to_propagation_and_figures(tmp_path, demo, monkeypatch):
    """The long stages after the sampler show a progress bar too when asked (and only then:
    the CLI asks on a terminal only)."""
    import bouncebayes.propagation
    import bouncebayes.report

    seen = {}
    real = bouncebayes.propagation.propagate

    def spy_propagate(*args, **kwargs):
        seen["propagate"] = kwargs.get("progress")
        return real(*args, **kwargs | {"n_histories": 2})

    def spy_figures(*args, **kwargs):
        seen["figures"] = kwargs.get("progress")
        raise KeyboardInterrupt

    monkeypatch.setattr(bouncebayes.propagation, "propagate", spy_propagate)
    monkeypatch.setattr(bouncebayes.report, "make_figures", spy_figures)
    with pytest.raises(KeyboardInterrupt):
        bb.pipeline.run(demo.experiment, demo.trials, tmp_path / "o", progress=True,
                        config=bb.inference.GridConfig(draws=200, points=64), sampler="grid",
                        log=lambda m: None)
    assert seen == {"propagate": True, "figures": True}


def test_grid_run_draws_its_joint_posterior_from_the_grid_with_a_spare_core(
        demo, tmp_path, monkeypatch):
    """With a spare core the posterior's files (grid.npz included) are written by a forked
    copy while the run goes on: the joint-posterior figure still shows the grid's exact
    density (from the run's own grid, not a KDE of the draws)."""
    import bouncebayes._background
    import bouncebayes.plots._posterior as post

    monkeypatch.setattr(bouncebayes._background, "spare_core", lambda: True)
    sources = []
    real = post.joint_density

    def spy(result, grid_file=None):
        out = real(result, grid_file)
        sources.append(out[-1])
        return out

    monkeypatch.setattr(post, "joint_density", spy)
    out = tmp_path / "o"
    bb.pipeline.run(demo.experiment, demo.trials, out, sampler="grid",
                    config=bb.inference.GridConfig(draws=200, points=64), log=lambda m: None)
    assert sources == ["grid quadrature"]
    assert {"grid.npz", "posterior.nc", "summary.json"} <= {p.name for p in out.iterdir()}


def test_run_on_videos_of_small_balls_says_once_that_the_scale_is_uncertain(tmp_path):
    """A campaign filmed like the paper's (224 x 64 px, a ball of radius 5 px): the scale from
    the ball's radius is uncertain by more than 2 % (~2.6 % from the small-ball fit,
    docs/tracking.md §2-3), which each tracking record says (``ball.warning``) and `run` says
    once for all the videos, with their count."""
    from bouncebayes.pipeline import _track_videos
    from bouncebayes.tracking import Surface

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from video_helpers import Bounce, Scene, render, write_video

    videos = tmp_path / "videos"
    videos.mkdir()
    for i in range(2):
        scene = Scene(width=224, height=64, radius_px=5.0, n_frames=160,
                      surface_point=(0.0, 52.0), inclination=3.0, exposure=0.5,
                      noise_sigma=3.0, seed=2025 + i)
        write_video(render(scene, Bounce(speed_in=2.0, angle_in=35.0, t_contact=0.08,
                                         x_contact=0.05)), videos / f"b{i}.avi", scene.fps)
    experiment = load_experiment(Path(__file__).resolve().parents[1] / "examples" / "paper.toml")
    lines: list[str] = []
    stage = tmp_path / "stage"
    folder = _track_videos(videos, experiment, stage, lines.append,
                           {"fps": 1000.0, "surface": None, "tone_curve": None}, False)
    warnings = [line for line in lines if "warning" in line]
    assert len(warnings) == 2, lines
    assert warnings[0].startswith("  warning, 2 of 2 videos (first b0.avi): the ball is ")
    assert "give --reference" in warnings[0]
    # MJPEG files, their tone curve not given (tracking.tone_curve_warning): said once too
    assert warnings[1].startswith("  warning, 2 of 2 videos (first b0.avi): the frames were "
                                  "taken as linear in light (no --tone-curve given)")
    for name in ("b0", "b1"):
        record = json.loads((folder / f"{name}.track.json").read_text(encoding="utf-8"))
        assert record["calibration"]["relative_sd"] > 0.02
        assert "give --reference" in record["ball"]["warning"]
        assert record["surface"]["source"] == "detected"
    # `run --surface --tone-curve linear`: the same line for every video, and the curve,
    # recorded in each record's settings; the curve given, no warning of it
    points = ",".join(f"{v:g}" for v in scene.surface_points())
    lines.clear()
    folder = _track_videos(videos, experiment, tmp_path / "stage2", lines.append,
                           {"fps": 1000.0, "surface": points, "tone_curve": "linear",
                            "readout": 0.0005}, False)
    assert not any("tone curve" in line for line in lines), lines
    for name in ("b0", "b1"):
        record = json.loads((folder / f"{name}.track.json").read_text(encoding="utf-8"))
        assert record["surface"]["source"] == "points"
        assert record["settings"]["surface"] == points
        assert record["settings"]["tone_curve"] == record["tone_curve"] == "linear"
        # `run --readout`: each centre timed by its row, k / fps + readout v / 64
        assert record["settings"]["readout_s"] == 0.0005
        pf = record["per_frame"]
        found = np.flatnonzero(~np.isnan(np.array(pf["v_px"], dtype=float)))
        rows = np.loadtxt(folder / f"{name}.csv", delimiter=",", comments="#", skiprows=1,
                          usecols=0, ndmin=1)
        expected = found / 1000.0 + 0.0005 * np.array(pf["v_px"], dtype=float)[found] / 64
        assert np.abs(rows[:, None] - expected[None, :]).min(axis=1).max() < 1e-6
        assert record["surface"]["angle_deg"] == pytest.approx(
            Surface.from_text(points).angle, abs=1e-9)


def test_scale_gravity_on_a_trial_table_is_said_to_do_nothing(tmp_path, demo):
    """A trial table holds no flights, so `scale = "gravity"` cannot act on it: `run` says so
    in one line and takes the table's speeds as they are."""
    import dataclasses

    from bouncebayes.pipeline import _trials

    experiment = load_experiment(demo.experiment)
    settings = dict(experiment.trajectories) | {"scale": "gravity"}
    experiment = dataclasses.replace(experiment, trajectories=settings)
    lines: list[str] = []
    trials = _trials(demo.trials, experiment, tmp_path, tmp_path / "out", lines.append,
                     {"fps": None, "surface": None, "tone_curve": None}, False)
    assert lines == ["  note: `scale = \"gravity\"` in [trajectories] needs the flights, which a "
                     "trial table does not hold: its speeds are taken as they are"]
    np.testing.assert_array_equal(trials.rebound_speed,
                                  load_trials(demo.trials, experiment).rebound_speed)


def test_run_on_videos_names_the_one_whose_fall_disagrees_with_its_scale(tmp_path):
    """Three videos of one set-up, one of them stamped with half its frame rate (a file whose
    playback rate is not the camera's): without --fps each is read at its file's rate, and that
    one's flights fall at g / 4 (closed form: every time twice as long), which `run` says once,
    naming it and the rate at which the fall would be g (about 2 times the one used)."""
    import re

    from bouncebayes.pipeline import _track_videos

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from video_helpers import Bounce, Scene, render, write_video

    videos = tmp_path / "videos"
    videos.mkdir()
    for i, fps in enumerate((1000.0, 500.0, 1000.0)):
        scene = Scene(width=224, height=64, radius_px=5.0, n_frames=160,
                      surface_point=(0.0, 52.0), inclination=3.0, exposure=0.5,
                      noise_sigma=3.0, seed=2030 + i)
        write_video(render(scene, Bounce(speed_in=2.0, angle_in=35.0, t_contact=0.08,
                                         x_contact=0.05)), videos / f"b{i}.avi", fps)
    experiment = load_experiment(Path(__file__).resolve().parents[1] / "examples" / "paper.toml")
    lines: list[str] = []
    points = ",".join(f"{v:g}" for v in scene.surface_points())
    folder = _track_videos(videos, experiment, tmp_path / "stage", lines.append,
                           {"fps": None, "surface": points, "tone_curve": None}, False)
    fell = [line for line in lines if "free flights fall" in line]
    assert len(fell) == 1, lines
    assert fell[0].startswith("  warning, 1 of 3 videos (first b1.avi): ")
    rate = float(re.search(r"the fall is g at ([\d.]+) times the rate used", fell[0]).group(1))
    assert rate == pytest.approx(2.0, abs=0.1)
    record = json.loads((folder / "b1.track.json").read_text(encoding="utf-8"))
    # in the tracker's metres, whose scale is its own (the ball's radius: ~2 % here)
    scale = record["calibration"]["metres_per_pixel"] / scene.metres_per_px
    fall = record["gravity"]
    assert fall["fall_m_s2"] == pytest.approx(9.81 / 4 * scale, abs=3 * fall["fall_se_m_s2"])


def test_run_on_videos_says_for_each_where_frames_were_lost_or_the_ball_came_closer(tmp_path):
    """A video with every 10th frame lost (taken out by the test) beside one without: `run`
    says for the first which frames, and nothing of frames for the second; the trajectory's
    times step over the gaps (bouncebayes.tracking._timing). A third, whose ball comes closer
    to the camera (the renderer's approach: its picture 1.8 % larger over the clip), is said
    to, and only it (bouncebayes.tracking._edge.depth_change)."""
    from bouncebayes.pipeline import _track_videos

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from render_pbr import Shot, Throw, render
    from video_helpers import write_video

    shot = Shot(width=240, height=120, radius_px=12.0, n_frames=60, surface_v=100.0,
                slope_deg=2.0, sigma_px=0.7, exposure=0.3, supersample=2,
                throw=Throw(speed_in=2.4, angle_in=35.0, t_contact=0.04, x_contact=0.07))
    frames = render(shot)
    videos = tmp_path / "videos"
    videos.mkdir()
    write_video(frames[[k for k in range(60) if k % 10 != 9]], videos / "gaps.avi", 1000.0)
    write_video(frames, videos / "whole.avi", 1000.0)
    write_video(render(dataclasses.replace(shot, approach=0.3)), videos / "closer.avi", 1000.0)
    experiment = load_experiment(Path(__file__).resolve().parents[1] / "examples" / "paper.toml")
    lines: list[str] = []
    folder = _track_videos(videos, experiment, tmp_path / "stage", lines.append,
                           {"fps": 1000.0, "surface": None, "tone_curve": None}, False)
    told = [line for line in lines if "frame(s) lost" in line]
    assert len(told) == 1 and told[0].startswith("  warning: gaps.avi: frames: ")
    closer = [line for line in lines if "moves towards the camera" in line]
    assert len(closer) == 1 and closer[0].startswith("  warning: closer.avi: the ball's picture")
    t = np.loadtxt(folder / "gaps.csv", delimiter=",", skiprows=1, usecols=0)
    assert np.isclose(t[9] - t[8], 2e-3) and np.isclose(t[8] - t[7], 1e-3)


def test_a_runs_messages_about_its_tracks_name_the_videos_not_the_staging_folder(tmp_path):
    """`run` tracks videos into its staging folder, which is gone when the run fails: its
    messages named files there that no longer existed (".out.staging-.../trajectories/b1.csv:
    no crossing"). Expected (by hand): each such path becomes the video's, "<video>'s track",
    a bounce's "#k" kept; other paths and the words are left as they are."""
    from bouncebayes.pipeline import _as_videos

    videos = tmp_path / "videos"
    videos.mkdir()
    (videos / "b1.avi").write_bytes(b"")
    (videos / "frames").mkdir()
    (videos / "frames" / "0001.png").write_bytes(b"")
    tracks = tmp_path / ".out.staging-1-ab12cd34" / "trajectories"
    said = _as_videos(tracks, videos)
    assert said(f"{tracks / 'b1.csv'}: no crossing: the fitted flights do not cross") == \
        f"{videos / 'b1.avi'}'s track: no crossing: the fitted flights do not cross"
    assert said(f"{tracks / 'frames.csv'}#2: bad fit") == f"{videos / 'frames'}'s track#2: bad fit"
    other = f"{tmp_path / 'other.csv'}: too few rows"
    assert said(other) == other
