"""Figures, the report, and the run/report/demo commands."""

import json
import os
import re
import shutil
from pathlib import Path

import pytest

from bouncebayes._provenance import read_provenance
from bouncebayes.cli import main
from bouncebayes.pipeline import data_kind

FIGURES = ("data", "joint_posterior", "marginals", "trajectories", "predictive", "forces",
           "contact_time", "residuals", "derived", "diagnostics")


def test_run_writes_every_output(small_run):
    f = small_run.folder
    for name in ("posterior.nc", "summary.json", "propagation.json", "propagation.npz",
                 "derived.json", "report.html", "experiment.toml", "trials.csv", "truth.json"):
        assert (f / name).is_file(), name
    for key in FIGURES:
        png = f / "figures" / f"{key}.png"
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert not (f / "figures" / f"{key}.svg").exists()  # SVG only on request
    assert set(small_run.stage_seconds) == {"data", "inference", "propagation", "figures",
                                            "report"}


def test_figures_in_svg_on_request(small_run, tmp_path):
    """SVG (and PDF) beside the PNG when asked for; asking for fewer formats later removes the
    files of the others, so that no figure is left over from an earlier run."""
    from bouncebayes.propagation import load_propagation
    from bouncebayes.report import load_result, load_truth, make_figures

    result, prop = load_result(small_run.folder), load_propagation(small_run.folder)
    shutil.copy(small_run.folder / "derived.json", tmp_path)  # figures read it where drawn
    written = make_figures(result, prop, tmp_path, load_truth(small_run.folder),
                           formats=("png", "svg"))
    assert [k for k, _ in written] == list(FIGURES)
    for key, png in written:
        assert png == tmp_path / "figures" / f"{key}.png"
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        svg = tmp_path / "figures" / f"{key}.svg"
        assert svg.read_text().lstrip().startswith("<?xml")
    make_figures(result, prop, tmp_path, formats=())
    assert not list((tmp_path / "figures").glob("*.svg"))
    assert len(list((tmp_path / "figures").glob("*.png"))) == len(FIGURES)


def test_figures_rendered_in_parallel_are_the_same_files(small_run, tmp_path):
    """Rendering in forked processes (the default on Linux with several cores) writes the same
    PNG bytes as rendering in this process (the expected files: workers=1)."""
    from bouncebayes.propagation import load_propagation
    from bouncebayes.report import load_result, load_truth, make_figures

    result, prop = load_result(small_run.folder), load_propagation(small_run.folder)
    shutil.copy(small_run.folder / "derived.json", tmp_path)
    pngs, children = {}, {}
    for workers in (1, 3):
        out = tmp_path / f"w{workers}"
        shutil.copytree(tmp_path, out, ignore=shutil.ignore_patterns("w*"))
        before = os.times()
        written = make_figures(result, prop, out, load_truth(small_run.folder),
                               workers=workers)
        after = os.times()
        children[workers] = after.children_user - before.children_user
        pngs[workers] = {key: png.read_bytes() for key, png in written}
    assert list(pngs[3]) == list(FIGURES)
    assert pngs[1] == pngs[3]
    assert children[1] == 0 and children[3] > 0  # the forked copies did render


def test_figure_formats():
    from bouncebayes.report import figure_formats

    assert figure_formats(()) == ("png",)
    assert figure_formats("svg") == ("png", "svg")
    assert figure_formats(["SVG", ".pdf", "png", "svg"]) == ("png", "svg", "pdf")
    with pytest.raises(ValueError, match="figure format 'jpg' is not one of png, svg, pdf"):
        figure_formats(["jpg"])


def test_report_is_self_contained_and_complete(small_run):
    page = (small_run.folder / "report.html").read_text()
    assert len(re.findall(r'<img src="data:image/png;base64,', page)) == len(FIGURES)
    assert not re.search(r'(src|href)="(?!data:)', page), "no external resources"
    summary = json.loads((small_run.folder / "summary.json").read_text())
    for p in summary["parameters"].values():
        assert p["paper_form"] in page
    for text in ("Likelihood gaussian", "Sampler mh", "Provenance", "sha256", "true value",
                 "Diagnostics and warnings", "What the posterior predicts", "Figure 8.",
                 "Standardised residuals", "not dropped", "DEM-ready quantities",
                 "Where these transfer", "linear normal stiffness"):
        assert text in page, text
    # the subtitle says what this report fitted, not only the experiment file's own words
    # (the same whatever trial table the file is run on): the trial table's data rows
    rows = [ln for ln in (small_run.folder / "trials.csv").read_text().splitlines()
            if ln.strip() and not ln.startswith("#")][1:]
    assert f"This report: {len(rows)} trials from " in page


def test_report_command_rebuilds_from_the_files(small_run, tmp_path):
    copy = tmp_path / "copy"
    shutil.copytree(small_run.folder, copy)
    (copy / "report.html").unlink()
    shutil.rmtree(copy / "figures")
    (copy / "propagation.json").unlink()  # missing propagation: computed again
    (copy / "derived.json").unlink()  # a run folder from before derived.json: computed
    assert main(["report", str(copy)]) == 0
    assert (copy / "report.html").is_file() and (copy / "figures" / "forces.png").is_file()
    assert (copy / "propagation.json").is_file() and (copy / "figures" / "derived.png").is_file()
    again = json.loads((copy / "derived.json").read_text())
    assert again["quantities"] == json.loads(
        (small_run.folder / "derived.json").read_text())["quantities"]  # same seed, same draws
    assert "provenance" in again


def test_report_of_a_folder_that_is_not_a_run(tmp_path, capsys):
    assert main(["report", str(tmp_path)]) == 2
    assert "not a bouncebayes run folder: posterior.nc is missing" in capsys.readouterr().err


def test_data_kinds(demo, tmp_path):
    assert data_kind(demo.trials) == "table"
    assert data_kind(demo.trajectories) == "trajectories"
    (tmp_path / "a.mp4").write_bytes(b"")
    assert data_kind(tmp_path) == "videos"
    with pytest.raises(ValueError, match="no such file or folder"):
        data_kind(tmp_path / "nope")


def _chromium() -> str | None:
    return shutil.which("chromium") or shutil.which("chromium-browser")


@pytest.mark.skipif(_chromium() is None and not os.environ.get("BOUNCEBAYES_REQUIRE_BROWSER"),
                    reason="Chromium not installed (CI installs it and sets "
                           "BOUNCEBAYES_REQUIRE_BROWSER)")
def test_report_in_a_headless_browser(small_run):
    """The report opens offline in Debian's Chromium with no console errors, and every figure
    is decoded (naturalWidth > 0)."""
    from playwright.sync_api import sync_playwright

    errors = []
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=_chromium(), headless=True, args=[
            "--no-sandbox", "--disable-gpu", "--disable-background-networking",
            "--disable-component-update", "--disable-sync", "--no-first-run"])
        page = browser.new_page()
        page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.goto((small_run.folder / "report.html").as_uri())
        page.wait_for_load_state("load")
        widths = page.eval_on_selector_all("img", "imgs => imgs.map(i => i.naturalWidth)")
        title = page.title()
        browser.close()
    assert errors == []
    assert len(widths) == len(FIGURES) and all(w > 0 for w in widths)
    assert title.startswith("bouncebayes:")


@pytest.mark.parametrize("command", ["run", "report", "demo", "infer", "kinematics", "synth",
                                     "track"])
def test_every_command_has_help_with_units(command, capsys):
    with pytest.raises(SystemExit) as info:
        main([command, "--help"])
    assert info.value.code == 0
    out = capsys.readouterr().out
    assert "usage: bouncebayes " + command in out
    assert "(default:" in out or command == "report"


def test_demo_command(tmp_path, capsys):
    """The demo prints intervals that cover the demo campaign's true values."""
    out = tmp_path / "demo"
    assert main(["demo", "--out", str(out), "--quiet"]) == 0
    printed = capsys.readouterr().out
    assert "report:" in printed and (out / "report.html").is_file()
    summary = json.loads((out / "summary.json").read_text())
    truth = json.loads((out / "truth.json").read_text())["population"]
    for name, value in truth.items():
        lo, hi = summary["parameters"][name]["ci90"]
        assert lo <= value <= hi, (name, lo, value, hi)


def test_run_on_a_missing_experiment(tmp_path, demo, capsys):
    assert main(["run", str(tmp_path / "x.toml"), str(demo.trials), "--out",
                 str(tmp_path / "o")]) == 2
    assert "cannot read the experiment file" in capsys.readouterr().err
    assert not (tmp_path / "o" / "report.html").exists()


def test_run_goes_from_a_folder_of_videos_to_a_report(tmp_path, capsys):
    """`bouncebayes run` accepts a folder of videos (synthetic 1000 fps renders of
    known bounces, tests/video_helpers.py) and goes from footage to report."""
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from video_helpers import Bounce, Scene, render, write_png_sequence, write_video

    videos = tmp_path / "videos"
    for i, ratio in enumerate((0.60, 0.62, 0.58)):
        scene = Scene(seed=i, noise_sigma=2.0, inclination=0.0)
        frames = render(scene, Bounce(normal_ratio=ratio))
        if i == 0:
            write_png_sequence(frames, videos / "bounce_a")  # an image-sequence folder
        else:
            write_video(frames, videos / f"bounce_{'bc'[i - 1]}.avi", scene.fps)
    experiment = Path(__file__).resolve().parents[1] / "examples" / "paper.toml"
    out = tmp_path / "out"
    code = main(["run", str(experiment), str(videos), "--out", str(out), "--quiet",
                 "--sampler", "grid", "--fps", "1000"])
    printed = capsys.readouterr()
    assert code == 0, printed.err
    assert sorted(p.name for p in (out / "trajectories").glob("*.csv")) == [
        "bounce_a.csv", "bounce_b.csv", "bounce_c.csv"]
    assert len(list((out / "tracking").glob("*.overlay.png"))) == 3
    # the same tracking record as `bouncebayes track`, beside each trajectory (docs/tracking.md)
    assert len(list((out / "trajectories").glob("*.track.json"))) == 3
    assert (out / "report.html").is_file()
    assert "3 of 3 trajectory files gave kinematics" in printed.err
    # the flights' fall checks the scale (the renders fall at 9.81 m/s^2), and the report says it
    assert re.search(r"gravity: the 6 free flights fall at .* consistent", printed.err)
    report = (out / "report.html").read_text()
    assert "<b>Length scale</b> (the free flights' fall against g): the 6 free flights" in report
    # the tracking: one row per video from its record, and the first video's overlay
    assert "<h2>Tracking</h2>" in report and "<p>3 videos tracked" in report
    for name in ("bounce_a", "bounce_b", "bounce_c"):
        assert f"<tr><td>{name}</td>" in report
    assert 'alt="tracked positions over the frames"' in report
    # the run's trial table keeps its kinematics' record, so a rebuilt report shows both again
    assert "gravity" in read_provenance(out / "trials.csv")["kinematics"]
    (out / "report.html").unlink()
    assert main(["report", str(out)]) == 0
    rebuilt = (out / "report.html").read_text()
    assert "<b>Length scale</b>" in rebuilt and "<h2>Tracking</h2>" in rebuilt
    # a 12 px ball: its edge gives the scale to ~1 %, nothing to warn about (see
    # test_pipeline.py for the warning of small balls) but the tone curve of the two MJPEG
    # files, not given (the PNG frames are lossless): said once, and in their report rows
    warned = [line for line in printed.err.splitlines() if "warning" in line]
    assert len(warned) == 1, warned
    assert warned[0].startswith("  warning, 2 of 3 videos (first bounce_b.avi): the frames were "
                                "taken as linear in light")
    assert report.count("the frames were taken as linear in light") == 2
