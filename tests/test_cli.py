"""The command line, run in-process (``main(argv)``) as a user would type it."""

import json

import pytest

import bouncebayes as bb
from bouncebayes.cli import main


def test_simulate_json_has_the_documented_keys_and_matches_the_library(capsys):
    assert main(["simulate", "--mu", "0.2", "--eta", "1.0", "--speed", "2.5", "--angle", "50",
                 "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert set(out) == {"rebound_speed", "rebound_angle", "rebound_spin", "contact_time",
                        "peak_normal_force", "peak_friction_force", "regime"}
    lib = bb.simulate(mu=0.2, eta=1.0, speed=2.5, angle=50.0)
    assert out["rebound_speed"] == float(lib.rebound_speed)
    assert out["regime"] in ("slip", "roll")


def test_simulate_table_names_units(capsys):
    assert main(["simulate"]) == 0
    out = capsys.readouterr().out
    for text in ("rebound speed", "m/s", "deg", "rad/s", "contact time", "ms", "N"):
        assert text in out


def test_simulate_ball_options_reach_the_model(capsys):
    main(["simulate", "--diameter", "0.05", "--mass", "0.05", "--modulus", "2e7", "--poisson",
          "0.45", "--inertia-factor", "0.6667", "--inclination", "10", "--normal-law",
          "hunt-crossley", "--eta", "0.1", "--gravity", "9.8", "--json"])
    out = json.loads(capsys.readouterr().out)
    ball = bb.Ball(radius=0.025, mass=0.05, youngs_modulus=2e7, poisson_ratio=0.45,
                   inertia_factor=0.6667)
    lib = bb.simulate(ball, mu=0.16, eta=0.1, speed=3.0, angle=60.0, inclination=10.0,
                      normal_law="hunt-crossley", gravity=9.8)
    assert out["contact_time"] == float(lib.contact_time)


def test_simulate_bad_input_is_one_clear_line(capsys):
    assert main(["simulate", "--angle", "95"]) == 2
    err = capsys.readouterr().err
    assert err.strip() == ("bouncebayes simulate: error: `--angle` must be a finite number in "
                           "[0, 90) deg; got 95.0")


def test_simulate_unsolvable_bounce_is_an_error(capsys):
    assert main(["simulate", "--eta", "500", "--speed", "0.1"]) == 2
    assert "NO_SEPARATION" in capsys.readouterr().err


def test_simulate_plot_writes_a_figure(tmp_path, capsys):
    path = tmp_path / "fig" / "bounce.png"
    assert main(["simulate", "--plot", str(path)]) == 0
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert main(["simulate", "--plot", str(tmp_path / "bounce.txt")]) == 2
    assert "must end in one of .png, .svg, .pdf" in capsys.readouterr().err


@pytest.mark.parametrize("command", [[], ["simulate"], ["demo"]])
def test_help_describes_every_option(command, capsys):
    with pytest.raises(SystemExit) as info:
        main([*command, "--help"])
    assert info.value.code == 0
    out = capsys.readouterr().out
    assert "usage: bouncebayes" in out
    if command == ["simulate"]:
        for option in ("--mu", "--eta", "--speed", "--angle", "--spin", "--diameter", "--mass",
                       "--modulus", "--poisson", "--inertia-factor", "--inclination",
                       "--normal-law", "--json", "--plot"):
            assert option in out
        for unit in ("m/s", "deg", "rad/s", "kg/s", "Pa"):
            assert unit in out


EXAMPLE = __import__("pathlib").Path(__file__).resolve().parents[1] / "examples" / "paper.toml"


def test_synth_then_kinematics(tmp_path, capsys):
    out = tmp_path / "campaign"
    assert main(["synth", str(EXAMPLE), "--n", "8", "--seed", "3", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "8 bounces, seed 3" in printed and "truth mu = 0.16" in printed
    assert len(list((out / "trajectories").glob("*.csv"))) == 8
    (out / "trajectories" / "broken.csv").write_text("t,x,y\n0,0,0\n")
    table = tmp_path / "kin.csv"
    code = main(["kinematics", str(out / "trajectories"), "--experiment", str(EXAMPLE),
                 "--out", str(table)])
    printed = capsys.readouterr().out
    assert code == 1  # one file skipped: the exit status says so
    assert "8 of 9 trajectory files gave kinematics" in printed
    assert "broken.csv" in printed and "Pearson" in printed
    trials = bb.load_trials(table, bb.load_experiment(EXAMPLE))
    assert trials.n == 8 and trials.measured == {"incidence_speed", "incidence_angle"}


def test_kinematics_on_an_empty_folder_is_an_error(tmp_path, capsys):
    assert main(["kinematics", str(tmp_path), "--experiment", str(EXAMPLE), "--out",
                 str(tmp_path / "t.csv")]) == 2
    assert "bouncebayes kinematics: error:" in capsys.readouterr().err


# --------------------------------------------------------------------------- start-up and API

import os  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402

SRC = str(Path(__file__).resolve().parents[1] / "src")
HEAVY = ("cv2", "arviz", "matplotlib", "xarray", "emcee", "h5py")


def _modules_after(code: str) -> set[str]:
    """The modules a fresh interpreter has loaded after running ``code``."""
    code += "\nimport sys\nprint(' '.join(sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300,
                         env={"PYTHONPATH": SRC, "PATH": "/usr/bin:/bin"})
    assert out.returncode == 0, out.stderr
    return set(out.stdout.split())


def test_help_and_simulate_do_not_import_the_heavy_libraries():
    help_modules = _modules_after("import contextlib, io\nfrom bouncebayes.cli import main\n"
                                  "with contextlib.suppress(SystemExit), "
                                  "contextlib.redirect_stdout(io.StringIO()):\n"
                                  "    main(['--help'])")
    assert not help_modules & {*HEAVY, "numba", "numpy", "scipy"}
    simulate = _modules_after("import contextlib, io\nfrom bouncebayes.cli import main\n"
                              "with contextlib.redirect_stdout(io.StringIO()):\n"
                              "    assert main(['simulate']) == 0")
    assert not simulate & set(HEAVY)


def test_importing_the_package_is_light_and_its_names_load_on_use():
    modules = _modules_after("import bouncebayes")
    assert not modules & {*HEAVY, "numba", "numpy", "scipy"}
    modules = _modules_after("import bouncebayes as bb\nbb.Ball")
    assert "numba" in modules and not modules & set(HEAVY)


def test_the_public_api_is_curated_at_every_level():
    import importlib

    assert "infer" in bb.__all__ and bb.infer is importlib.import_module(
        "bouncebayes.inference").infer
    for name in bb.__all__:
        assert getattr(bb, name) is not None, name
    for package in ("model", "data", "inference", "kinematics", "tracking", "cli"):
        module = importlib.import_module(f"bouncebayes.{package}")
        public = {n for n, v in vars(module).items() if not n.startswith("_")
                  and getattr(v, "__module__", module.__name__) != "builtins"
                  and not isinstance(v, type(module))}
        assert set(module.__all__) == public, (package, public ^ set(module.__all__))
        for name in module.__all__:
            getattr(module, name)
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        bb.nope  # noqa: B018


def test_every_sampling_command_has_the_same_sampler_flags():
    from bouncebayes.cli import build_parser
    from bouncebayes.cli._common import SAMPLER_FLAGS

    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command").choices
    flags = {name: {s for a in sub[name]._actions for s in a.option_strings}
             for name in ("infer", "run", "demo")}
    wanted = {*SAMPLER_FLAGS.values(), "--likelihood", "--sampler", "--seed", "--noise",
              "--quiet", "--memory-budget"}
    for name, options in flags.items():
        assert wanted <= options, (name, wanted - options)


def test_the_memory_budget_flag_reaches_the_library_and_its_message(tmp_path, capsys):
    from bouncebayes.cli._common import byte_size

    # binary units, as the library's messages print them
    assert byte_size("4G") == 4 * 2**30 and byte_size("512MiB") == 512 * 2**20
    assert byte_size("100000") == 100000
    demo = bb.data.demo_campaign()
    out = tmp_path / "run"
    assert main(["infer", str(demo.experiment), str(demo.trials), "--out", str(out),
                 "--sampler", "grid", "--grid-points", "3000", "--memory-budget", "16M"]) == 2
    err = capsys.readouterr().err.strip()
    # a 3000 x 3000 grid needs hundreds of MiB: refused before it starts, in the flags' names
    assert err.count("\n") == 0 and "`--memory-budget` = 16.0 MiB" in err
    assert "`--grid-points`" in err and not out.exists()
    with pytest.raises(SystemExit) as stop:  # argparse's own usage error
        main(["infer", str(demo.experiment), str(demo.trials), "--out", str(out),
              "--memory-budget", "lots"])
    assert stop.value.code == 2 and "--memory-budget" in capsys.readouterr().err


def test_figure_formats_flag_lists_the_files_each_figure_gets():
    from bouncebayes.cli import build_parser

    parser = build_parser()
    args = parser.parse_args(["report", "somewhere", "--figure-formats", "svg,PDF"])
    assert args.figure_formats == ("svg", "pdf")
    assert parser.parse_args(["demo"]).figure_formats == ("png",)
    with pytest.raises(SystemExit):
        parser.parse_args(["run", "e.toml", "d", "--out", "o", "--figure-formats", "gif"])


def test_library_argument_names_become_flags_in_messages():
    from bouncebayes.cli._common import flag_names

    assert flag_names("`burn_in` must be >= 0; raise `points` or `draws`") == (
        "`--burn-in` must be >= 0; raise `--grid-points` or `--draws`")
    assert flag_names("`thin` must be >= 1") == "`--thin` must be >= 1"
    assert flag_names("`min_points` and `youngs_modulus`", frozenset({"--min-points"})) == (
        "`--min-points` and `youngs_modulus`")


def test_progress_bars_only_on_a_terminal(monkeypatch):
    import argparse

    from bouncebayes.cli._common import show_progress

    monkeypatch.setattr(sys.stderr, "isatty", lambda: True, raising=False)
    assert show_progress(argparse.Namespace(quiet=False))
    assert not show_progress(argparse.Namespace(quiet=True))
    monkeypatch.setattr(sys.stderr, "isatty", lambda: False, raising=False)
    assert not show_progress(argparse.Namespace(quiet=False))


def test_infer_asks_for_progress_bars_on_a_terminal_only(monkeypatch, tmp_path, capsys):
    import bouncebayes.inference

    seen = []

    def spy(*args, progress, **kwargs):
        seen.append(progress)
        raise ValueError("stop here")

    monkeypatch.setattr(bouncebayes.inference, "infer", spy)
    demo = bb.data.demo_campaign()
    argv = ["infer", str(demo.experiment), str(demo.trials), "--out", str(tmp_path / "o")]
    assert main(argv) == 2
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True, raising=False)
    assert main(argv) == 2 and main([*argv, "--quiet"]) == 2
    assert seen == [False, True, False]


def _command_raising(monkeypatch, exc: BaseException) -> None:
    import bouncebayes.cli._simulate

    def run(args):
        raise exc

    monkeypatch.setattr(bouncebayes.cli._simulate, "run", run)


@pytest.mark.parametrize("exc, status, line", [
    (KeyboardInterrupt(), 130, "bouncebayes simulate: stopped; nothing was written"),
    (MemoryError(), 2, "bouncebayes simulate: error: out of memory; ask for less (fewer draws "
                       "or grid points, a smaller table) or free memory"),
    (PermissionError(13, "Permission denied", "/x/y.csv"), 2,
     "bouncebayes simulate: error: /x/y.csv: Permission denied"),
    (KeyError("mu"), 2, "bouncebayes simulate: error: unexpected KeyError: 'mu'; this is a bug: "
                        "please report it with the output of the same command with --traceback"),
    (ValueError("line one\nline two"), 2, "bouncebayes simulate: error: line one line two"),
])
def test_every_failure_is_one_line(monkeypatch, capsys, exc, status, line):
    _command_raising(monkeypatch, exc)
    assert main(["simulate"]) == status
    assert capsys.readouterr().err == line + "\n"


def test_traceback_flag_keeps_the_traceback(monkeypatch):
    _command_raising(monkeypatch, KeyError("mu"))
    with pytest.raises(KeyError):
        main(["--traceback", "simulate"])


def test_a_stopped_command_names_the_output_it_left_intact(monkeypatch, capsys, tmp_path):
    import bouncebayes.cli._synth

    def run(args):
        raise KeyboardInterrupt

    monkeypatch.setattr(bouncebayes.cli._synth, "run", run)
    assert main(["synth", str(EXAMPLE), "--out", str(tmp_path)]) == 130
    assert capsys.readouterr().err == (f"bouncebayes synth: stopped; earlier results in "
                                       f"{tmp_path} are intact\n")


def test_warnings_reach_the_user_as_one_line(monkeypatch, capsys):
    import warnings

    import bouncebayes.cli._simulate

    def run(args):
        warnings.warn("draws pile against `burn_in`\nsecond line", UserWarning, stacklevel=1)
        return 0

    monkeypatch.setattr(bouncebayes.cli._simulate, "run", run)
    with warnings.catch_warnings():
        warnings.simplefilter("default")
        assert main(["simulate"]) == 0
    assert capsys.readouterr().err == ("bouncebayes simulate: warning: draws pile against "
                                       "`--burn-in` second line\n")


def test_version(capsys):
    with pytest.raises(SystemExit) as info:
        main(["--version"])
    assert info.value.code == 0 and capsys.readouterr().out == f"bouncebayes {bb.__version__}\n"


def test_version_of_a_source_tree_that_was_never_installed(tmp_path):
    """Run from ``PYTHONPATH=src`` with no package metadata: the version says so, rather than
    every command failing on the missing metadata (met on a machine without the install)."""
    import subprocess
    import sys
    from pathlib import Path

    src = Path(bb.__file__).resolve().parent.parent
    code = ("import importlib.metadata as m, sys\n"
            "real = m.version\n"
            "def version(name):\n"
            "    if name == 'bouncebayes':\n"
            "        raise m.PackageNotFoundError(name)\n"
            "    return real(name)\n"
            "m.version = version\n"
            f"sys.path.insert(0, {str(src)!r})\n"
            "import bouncebayes\n"
            "print(bouncebayes.__version__)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=tmp_path, check=True)
    assert out.stdout == "0+unknown.source-tree\n", out.stderr


def test_the_program_ends_without_teardown_but_does_what_teardown_does(tmp_path):
    """The program (``main()`` reading ``sys.argv``) ends the process itself, skipping the
    interpreter's teardown: its output still arrives whole through a pipe, its exit handlers
    still run (temporary folders' removal is one), its status is the command's, and nothing
    after ``main()`` runs. Expected values: the simulate command's own output and exit
    statuses (0; 2 for a bad option), as called in-process."""
    def program(*argv: str) -> subprocess.CompletedProcess:
        marker = tmp_path / f"atexit-{len(argv)}"
        code = ("import atexit, sys\n"
                "from bouncebayes.cli import main\n"
                f"atexit.register(lambda: open({str(marker)!r}, 'w').write('ran'))\n"
                f"sys.argv = ['bouncebayes', *{list(argv)!r}]\n"
                "main()\n"
                "print('after main')\n")
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                             timeout=300, env=os.environ | {"PYTHONPATH": SRC})
        assert marker.read_text() == "ran"
        assert "after main" not in out.stdout
        return out

    good = program("simulate", "--mu", "0.2", "--json")
    assert good.returncode == 0, good.stderr
    assert good.stdout == _in_process(["simulate", "--mu", "0.2", "--json"])
    bad = program("simulate", "--mu", "-1", "--angle", "60")
    assert bad.returncode == 2
    assert bad.stderr.strip().startswith("bouncebayes simulate: error: `--mu`")


def _in_process(argv: list[str]) -> str:
    import contextlib
    import io

    buffer = io.StringIO()
    with contextlib.redirect_stdout(buffer):
        assert main(argv) == 0
    return buffer.getvalue()


# --------------------------------------------------------------------------- outputs

def test_outputs_carry_the_command_line_that_made_them(tmp_path, capsys):
    from bouncebayes._provenance import read_provenance

    out = tmp_path / "campaign"
    argv = ["synth", str(EXAMPLE), "--n", "6", "--seed", "4", "--out", str(out)]
    assert main(argv) == 0
    trajectory = next((out / "trajectories").glob("*.csv"))
    for path in (out / "trials.csv", out / "truth.json", trajectory):
        record = read_provenance(path)
        assert record["command"] == "bouncebayes " + " ".join(argv) and record["seed"] == 4
    table = tmp_path / "kin.csv"
    assert main(["kinematics", str(out / "trajectories"), "--experiment", str(EXAMPLE),
                 "--out", str(table)]) == 0
    assert read_provenance(table)["inputs"]["trajectories"]["files"] == 6
    assert bb.load_trials(table, bb.load_experiment(EXAMPLE)).n == 6


def test_infer_replaces_its_outputs_together_and_stamps_them(tmp_path, capsys):
    from bouncebayes._provenance import read_provenance

    demo = bb.data.demo_campaign()
    out = tmp_path / "out"
    out.mkdir()
    for stale in ("propagation.json", "report.html", "grid.npz"):  # of an earlier posterior
        (out / stale).write_text("old")
    (out / "mine.txt").write_text("kept")
    argv = ["infer", str(demo.experiment), str(demo.trials), "--out", str(out), "--draws",
            "400", "--chains", "2", "--seed", "3"]
    assert main(argv) == 0
    assert sorted(p.name for p in out.iterdir()) == ["mine.txt", "posterior.nc", "summary.json"]
    for name in ("posterior.nc", "summary.json"):
        record = read_provenance(out / name)
        assert record["seed"] == 3 and record["config"]["sampler_config"]["draws"] == 400
        assert record["inputs"]["trials"]["sha256"] == bb.load_trials(
            demo.trials, bb.load_experiment(demo.experiment)).sha256
    assert f"summary: {out / 'summary.json'}" in capsys.readouterr().out


def test_predict_writes_the_predictions_of_new_incidences(small_run, tmp_path, capsys):
    rows = tmp_path / "new.csv"
    rows.write_text("trial,incidence_speed,incidence_angle\nslow,2.0,40\nfast,4.0,70\n")
    out = tmp_path / "pred.csv"
    assert main(["predict", str(small_run.folder), str(rows), "--out", str(out), "--draws",
                 "200"]) == 0
    assert f"predictions: {out} (2 rows, 200 draws each" in capsys.readouterr().out
    lines = out.read_text().splitlines()
    header = lines[1].split(",")
    assert lines[0].startswith("# provenance: ") and '"seed":11' in lines[0]
    for name in ("rebound_speed", "rebound_angle", "rebound_spin", "contact_time"):
        assert {f"{name}_mean", f"{name}_q05", f"{name}_q50", f"{name}_q95"} <= set(header)
    assert [line.split(",")[0] for line in lines[2:]] == ["slow", "fast"]
