"""Hostile input: the mistakes a careless or unlucky user makes, on every command.

The cases are generated from tables: bad values per option, bad files per file kind, damaged run
folders, output paths that cannot be written, and interruptions at several moments of a run.
Each case asserts what the README promises:

- exit status 2 (130 / 143 when stopped by Ctrl-C / SIGTERM);
- exactly one error line on stderr, ``bouncebayes CMD: error: ...``, naming the culprit (the
  option, the file) and no traceback, no raw Python warning, no "unexpected" (the command line's
  word for a bug);
- nothing written: the folder holding the inputs and outputs is byte-for-byte as before, with no
  temporary file;
- a time budget (in-process cases: pytest-timeout; cases that may hang inside compiled code run
  in a subprocess with a timeout).
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from bouncebayes.cli import main

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "paper.toml"
DEMO = ROOT / "src" / "bouncebayes" / "demo"
READ_ONLY = "/sys/bouncebayes-hostile"  # nothing can be made here, not even by root

pytestmark = pytest.mark.timeout(300)


# --------------------------------------------------------------------------- the world

EXPERIMENT_TEXT = EXAMPLE.read_text(encoding="utf-8")


def _edit(pattern: str, new: str) -> str:
    """The example experiment with the first line matching ``pattern`` replaced."""
    text, n = re.subn(pattern, new, EXPERIMENT_TEXT, count=1, flags=re.M)
    assert n == 1, pattern
    return text


BAD_EXPERIMENTS = {
    "missing": None,
    "empty": "",
    "binary": b"\x00\xff\xfe\x00",
    "not_toml": "[[[ this is not TOML",
    "unknown_section": EXPERIMENT_TEXT + "\n[camera]\nmodel = 'x'\n",
    "unknown_key": _edit(r"^\[ball\]$", "[ball]\ncolour = 'red'"),
    "string_mass": _edit(r"^mass_kg = .*$", 'mass_kg = "heavy"'),
    "negative_mass": _edit(r"^mass_kg = .*$", "mass_kg = -0.0095"),
    "zero_modulus": _edit(r"^youngs_modulus_Pa = .*$", "youngs_modulus_Pa = 0.0"),
    "unknown_prior": _edit(r'^prior = "uniform"$', 'prior = "cauchy"'),
    "inverted_prior": _edit(r"^low = 0.0\nhigh = 0.5$", "low = 0.5\nhigh = 0.1"),
    "bad_normal_law": _edit(r"^normal = .*$", 'normal = "spring"'),
    "angle_90": _edit(r"^angle_deg = 60.0 .*$", "angle_deg = 90.0"),
    "folder": "<folder>",
}
TABLE_HEADER = "rebound_speed,rebound_angle\n"
BAD_TABLES = {
    "missing": None,
    "empty": "",
    "header_only": TABLE_HEADER,
    "unknown_column": "speed,angle\n2.5,50\n",
    "text_cell": TABLE_HEADER + "2.5,fifty\n",
    "negative_speed": TABLE_HEADER + "-2.5,50\n",
    "nan_cell": TABLE_HEADER + "nan,50\n",
    "inf_cell": TABLE_HEADER + "inf,50\n",
    "angle_95": TABLE_HEADER + "2.5,95\n",
    "ragged": TABLE_HEADER + "2.5\n",
    "duplicate_column": "rebound_speed,rebound_speed,rebound_angle\n1,1,2\n",
    "binary": b"\x00\xff\xfe\x00",
    "latin1": (TABLE_HEADER + "2.5,50 \xe9\n").encode("latin-1"),
    "folder": "<folder>",
}
BAD_TRAJECTORY_FOLDERS = {
    "missing": None,
    "empty": "<folder>",
    "a_file": "t,x,y\n0,0,0\n",
    "junk": {"junk.csv": "hello\nworld\n", "short.csv": "t,x,y\n0,0,0.1\n0.001,0,0.1\n"},
}


class World:
    """Files in a temporary folder, made on demand from the tables above."""

    def __init__(self, root: Path):
        self.root = root
        (root / "in").mkdir()
        self.values = {"exp": self._copy(EXAMPLE, "exp.toml"),
                       "trials": self._copy(DEMO / "trials.csv", "trials.csv"),
                       "file": self._write("in/plain.txt", "not a folder"),
                       "dir": self._folder("in/emptydir"),
                       "out": str(root / "out"), "ro": READ_ONLY}
        self.values["under"] = self.values["file"] + "/sub"
        traj = root / "in" / "traj"
        traj.mkdir()
        for p in sorted((DEMO / "trajectories").glob("*.csv"))[:6]:
            shutil.copy(p, traj / p.name)
        self.values["traj"] = str(traj)

    def _copy(self, src: Path, name: str) -> str:
        shutil.copy(src, self.root / "in" / name)
        return str(self.root / "in" / name)

    def _write(self, name: str, content) -> str:
        path = self.root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        if isinstance(content, bytes):
            path.write_bytes(content)
        else:
            path.write_text(content, encoding="utf-8")
        return str(path)

    def _folder(self, name: str, files: dict | None = None) -> str:
        path = self.root / name
        path.mkdir(parents=True, exist_ok=True)
        for f, text in (files or {}).items():
            (path / f).write_text(text)
        return str(path)

    def bad(self, table: dict, kind: str, name: str) -> str:
        content = table[kind]
        if content is None:
            return str(self.root / "in" / name)
        if content == "<folder>":
            return self._folder(f"in/{name}")
        if isinstance(content, dict):
            return self._folder(f"in/{name}", content)
        return self._write(f"in/{name}", content)

    def resolve(self, text: str) -> str:
        def one(m: re.Match) -> str:
            key, kind = m[1], m[2]
            if kind is None:
                return self.values[key]
            if key == "manifest":
                return self._write(f"in/manifest-{kind}.toml", BAD_MANIFESTS[kind][0])
            table, suffix = {"exp": ({**BAD_EXPERIMENTS, **OTHERS_EXPERIMENTS}, ".toml"),
                             "table": ({**BAD_TABLES, **OTHERS_TABLES}, ".csv"),
                             "trajdir": ({**BAD_TRAJECTORY_FOLDERS, **OTHERS_TRAJECTORIES},
                                         "")}[key]
            return self.bad(table, kind, f"{key}-{kind}{suffix}")
        return re.sub(r"\{(\w+)(?::(\w+))?\}", one, text)


def snapshot(folder: Path) -> dict:
    return {p.relative_to(folder).as_posix(): (hashlib.sha256(p.read_bytes()).hexdigest()
                                               if p.is_file() else "dir")
            for p in sorted(folder.rglob("*"))}


def run_main(argv: list[str]) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main(argv)
        except SystemExit as exc:  # argparse's usage errors
            code = exc.code
    return code, out.getvalue(), err.getvalue()


def assert_one_clean_error(code, err: str, command: str | None, culprit: str) -> str:
    assert code == 2, f"exit status {code}; stderr: {err}"
    assert "Traceback" not in err and '  File "' not in err, err
    assert not re.search(r"^\S+:\d+: \w*Warning: ", err, re.M), f"raw warning: {err}"
    errors = [line for line in err.splitlines() if ": error: " in line]
    assert len(errors) == 1 and err.rstrip().splitlines()[-1] == errors[0], err
    line = errors[0]
    # usage errors the main parser finds (an unknown option) come without the command
    assert line.startswith((f"bouncebayes {command}: error: ", "bouncebayes: error: ")), line
    assert "unexpected " not in line, f"a bug, not a clean error: {line}"
    assert culprit in line, f"{culprit!r} not named in: {line}"
    return line


# --------------------------------------------------------------------------- case tables

def _cases():
    """(id, argv, culprit, marks): argv and culprit may hold {placeholders} of World."""
    yield from _option_cases()
    yield from _file_cases()
    yield from _output_cases()
    yield from _track_cases()
    yield from _global_cases()
    yield from _others_cases()
    yield from _study_cases()
    yield from _compare_cases()


NOT_A_NUMBER = ("abc", "nan", "inf", "-inf", "1,5", "")
SIMULATE_NUMBERS = ("--mu", "--eta", "--speed", "--angle", "--spin", "--diameter", "--mass",
                    "--modulus", "--poisson", "--inertia-factor", "--inclination", "--gravity")
# option, value, the name the library gives it
SIMULATE_OUT_OF_RANGE = (
    ("--mu", "-0.1", "mu"), ("--eta", "-1", "eta"), ("--speed", "0", "speed"),
    ("--speed", "-3", "speed"), ("--angle", "90", "angle"), ("--angle", "-1", "angle"),
    ("--diameter", "0", "diameter"), ("--diameter", "-0.02", "diameter"),
    ("--mass", "0", "mass"), ("--mass", "-1", "mass"), ("--modulus", "0", "modulus"),
    ("--poisson", "0.6", "poisson"), ("--poisson", "-1", "poisson"),
    ("--inertia-factor", "0", "inertia"), ("--inertia-factor", "1.5", "inertia"),
    ("--inclination", "90", "inclination"), ("--inclination", "-90", "inclination"),
    ("--gravity", "-9.8", "gravity"),
)
INT_OPTIONS = {  # option -> bad values (all named by the flag)
    "--draws": ("abc", "1.5", "-5", "10"), "--chains": ("0", "abc"), "--burn-in": ("-1", "x"),
    "--thin": ("0", "2.5"), "--walkers": ("abc", "1"), "--grid-points": ("0", "abc"),
    "--seed": ("-1", "abc", "1e3", "1.5"), "--likelihood": ("poisson",),
    "--sampler": ("hmc",), "--noise": ("loud",),
}
SAMPLE = {"infer": ["infer", "{exp}", "{trials}", "--out", "{out}"],
          "run": ["run", "{exp}", "{trials}", "--out", "{out}"],
          "demo": ["demo", "--out", "{out}"]}


def _option_cases():
    for option in SIMULATE_NUMBERS:
        for value in NOT_A_NUMBER:
            yield (f"simulate{option}={value!r}", ["simulate", option, value],
                   f"argument {option}", ())
    for option, value, name in SIMULATE_OUT_OF_RANGE:
        yield f"simulate{option}={value}", ["simulate", option, value], name, ()
    yield "simulate--normal-law", ["simulate", "--normal-law", "spring"], "--normal-law", ()
    for command, base in SAMPLE.items():
        for option, values in INT_OPTIONS.items():
            for value in values if command == "infer" else values[:1]:
                yield f"{command}{option}={value}", [*base, option, value], option, ()
    if True:  # the ensemble sampler's own settings, under the same flags
        base = [*SAMPLE["infer"], "--sampler", "ensemble"]
        yield "infer-ensemble--burn-in=-1", [*base, "--burn-in", "-1"], "--burn-in", ()
        yield "infer-ensemble--thin=0", [*base, "--thin", "0"], "--thin", ()
        yield "infer-grid--grid-points=3", [*SAMPLE["infer"], "--sampler", "grid",
                                            "--grid-points", "3"], "--grid-points", ()
    synth = ["synth", "{exp}", "--out", "{out}"]
    for option, values in {"--n": ("0", "-1", "abc", "2.5"), "--seed": ("-1", "x")}.items():
        for value in values:
            yield f"synth{option}={value}", [*synth, option, value], option, ()
    kin = ["kinematics", "{traj}", "--experiment", "{exp}", "--out", "{out}/t.csv"]
    for option, values in {"--min-points": ("0", "abc", "1.5"),
                           "--contact-guard": ("-1", "abc")}.items():
        for value in values:
            yield f"kinematics{option}={value}", [*kin, option, value], option, ()
    for value in ("abc", "0", "-30"):
        yield (f"run--fps={value}", ["run", "{exp}", "{trials}", "--out", "{out}", "--fps",
                                     value], "--fps", ())


def _file_cases():
    for kind in BAD_EXPERIMENTS:
        culprit = f"exp-{kind}.toml"
        for command, argv in {
            "infer": ["infer", "{exp:%s}", "{trials}", "--out", "{out}"],
            "synth": ["synth", "{exp:%s}", "--out", "{out}"],
            "kinematics": ["kinematics", "{traj}", "--experiment", "{exp:%s}", "--out",
                           "{out}/t.csv"],
            "run": ["run", "{exp:%s}", "{trials}", "--out", "{out}"],
        }.items():
            yield (f"{command}-experiment-{kind}", [a.replace("%s", kind) for a in argv],
                   culprit, ())
    for kind in BAD_TABLES:
        culprit = f"table-{kind}.csv"
        yield f"infer-table-{kind}", ["infer", "{exp}", "{table:%s}" % kind, "--out", "{out}"], \
            culprit, ()
        yield f"run-table-{kind}", ["run", "{exp}", "{table:%s}" % kind, "--out", "{out}"], \
            culprit, ()
    for kind in BAD_TRAJECTORY_FOLDERS:
        culprit = f"trajdir-{kind}"
        yield (f"kinematics-folder-{kind}", ["kinematics", "{trajdir:%s}" % kind, "--experiment",
                                             "{exp}", "--out", "{out}/t.csv"], culprit, ())
        yield (f"run-folder-{kind}", ["run", "{exp}", "{trajdir:%s}" % kind, "--out", "{out}"],
               culprit, ())


def _output_cases():
    outputs = {"synth": ["synth", "{exp}", "--out", "%s"],
               "infer": ["infer", "{exp}", "{trials}", "--out", "%s"],
               "run": ["run", "{exp}", "{trials}", "--out", "%s"],
               "demo": ["demo", "--out", "%s"],
               "track": ["track", "{file}", "--out", "%s"]}
    for command, argv in outputs.items():
        for where, path in {"a_file": "{file}", "under_a_file": "{under}",
                            "read_only": "{ro}/out"}.items():
            yield (f"{command}-out-{where}", [a.replace("%s", path) for a in argv], "--out", ())
    kin = ["kinematics", "{traj}", "--experiment", "{exp}", "--out"]
    for where, path in {"a_folder": "{dir}", "under_a_file": "{under}/t.csv",
                        "read_only": "{ro}/t.csv"}.items():
        yield f"kinematics-out-{where}", [*kin, path], "--out", ()
    for where, path in {"a_folder": "{dir}", "under_a_file": "{under}/f.png",
                        "read_only": "{ro}/f.png", "wrong_suffix": "{out}/f.txt"}.items():
        yield f"simulate-plot-{where}", ["simulate", "--plot", path], "--plot", ()
    yield ("run-out-not-a-run-folder", ["run", "{exp}", "{trials}", "--out", "{root}/in"],
           "not a bouncebayes run folder", ())


def _track_cases():
    base = ["track", "{root}/in/video.avi", "--out", "{out}"]
    options = {"--fps": ("0", "-1", "nan", "abc"),
               "--reference": ("1,2,3", "a,b,c,d,e", "1,2,3,4,nan", "1,2,3,4,0", "0,0,3,4,1,-1"),
               "--surface": ("1,2", "x", "1,2,1,2"), "--ball-diameter": ("0", "-1", "abc"),
               "--polarity": ("sideways",), "--min-contrast": ("abc", "nan", "-5"),
               "--threshold-sigma": ("abc", "-1")}
    for option, values in options.items():
        for value in values:
            yield f"track{option}={value}", [*base, option, value], option, ()
    yield "track-missing-video", ["track", "{root}/in/none.avi", "--out", "{out}"], "none.avi", ()
    yield "track-junk-video", ["track", "{file}", "--out", "{out}"], "plain.txt", ()
    yield "track-empty-frame-folder", ["track", "{dir}", "--out", "{out}"], "emptydir", ()
    yield ("track-same-names", ["track", "{root}/a/v.avi", "{root}/b/v.mp4", "--out", "{out}"],
           "would write the same", ())


def _global_cases():
    yield "no-command", [], "COMMAND", ()
    yield "unknown-command", ["simulat"], "simulat", ()
    yield "unknown-option", ["--nope"], "COMMAND", ()
    yield "simulate-unknown-option", ["simulate", "--nope"], "--nope", ()
    yield "simulate-extra-word", ["simulate", "extra"], "extra", ()
    yield "warmup-extra-word", ["warmup", "now"], "now", ()
    yield "infer-missing-arguments", ["infer", "{exp}"], "TRIALS.csv", ()
    yield "run-missing-out", ["run", "{exp}", "{trials}"], "--out", ()
    yield "report-missing-folder", ["report", "{root}/nothing"], "nothing", ()
    yield "report-a-file", ["report", "{file}"], "plain.txt", ()
    yield "report-empty-folder", ["report", "{dir}"], "emptydir", ()




def _others_cases():
    """Behaviour other parts of the package own; on with their branches."""
    for option, value in (("--diameter", "1e-300"), ("--diameter", "1e300"),
                          ("--modulus", "1e300"), ("--mass", "1e-300")):
        yield f"simulate{option}={value}", ["simulate", option, value], option[2:], ()
    # 1e5 m/s is outside the speeds the model is defined for (the overlap would be 3.9 m)
    yield "simulate-speed-beyond-domain", ["simulate", "--speed", "1e5"], "speed", ()
    mark = ()
    yield ("infer-modulus-prior-from-zero",
           ["infer", "{exp:modulus_prior}", "{trials}", "--out", "{out}"],
           "exp-modulus_prior.toml", mark)
    yield ("infer-prior-to-1e300", ["infer", "{exp:huge_prior}", "{trials}", "--out", "{out}"],
           "exp-huge_prior.toml", mark)
    yield ("infer-kde-identical-rows",
           ["infer", "{exp}", "{table:identical}", "--out", "{out}", "--likelihood", "kde"],
           "table-identical.csv", ())
    yield ("infer-rebound-faster-than-incidence",
           ["infer", "{exp}", "{table:faster}", "--out", "{out}", "--draws", "400"],
           "table-faster.csv",
           ())
    for kind in ("in_mm", "in_ms"):
        yield (f"kinematics-trajectories-{kind}",
               ["kinematics", "{trajdir:%s}" % kind, "--experiment", "{exp}", "--out",
                "{out}/t.csv"], f"trajdir-{kind}", ())


# the study commands: every case fails before a cluster starts (--scheduler serial where the
# check needs the experiment), so none costs more than reading the inputs
DESIGN_OPTIONS = {"--angles": ("abc", "95", "0", "10:5:1"), "--speeds": ("-1", "0", "x"),
                  "--memory-budget": ("abc", "-1"),
                  "--bounces": ("0", "1.5"), "--frame-rates": ("0", "-100"),
                  "--position-noise": ("-1", "0"), "--campaigns": ("0", "1", "x"),
                  "--target": ("mu=abc", "nope=0.1", "mu"), "--seed": ("-1", "x"),
                  "--scheduler": ("foo",), "--workers": ("0", "x")}
SBC_OPTIONS = {"--campaigns": ("0", "x"), "--draws": ("10", "-1"), "--n-trials": ("0",),
               "--memory-budget": ("abc", "1"),
               "--grid-points": ("3", "x"), "--seed": ("-1",), "--scheduler": ("udp://x",),
               "--workers": ("0",)}
_RUN = '[[run]]\nexperiment = "exp.toml"\ndata = "trials.csv"\nout = "o"\n'
BAD_MANIFESTS = {  # name -> (manifest text, the key the error names)
    "empty": ("", "`run`"), "not_toml": ("[[run", "not valid TOML"),
    "unknown_top_key": ("colour = 1\n" + _RUN, "`colour`"),
    "negative_seed": ("seed = -1\n" + _RUN, "`seed`"),
    "run_not_tables": ("run = 3\n", "`run`"),
    "missing_out": (_RUN.replace('out = "o"\n', ""), "run[0].out"),
    "missing_experiment_file": (_RUN.replace("exp.toml", "nope.toml"), "run[0].experiment"),
    "missing_data": (_RUN.replace("trials.csv", "nope.csv"), "run[0].data"),
    "unknown_run_key": (_RUN + "colour = 1\n", "run[0].colour"),
    "bad_likelihood": (_RUN + 'likelihood = "poisson"\n', "run[0].likelihood"),
    "bad_sampler": (_RUN + 'sampler = "hmc"\n', "run[0].sampler"),
    "text_seed": (_RUN + 'seed = "x"\n', "run[0].seed"),
    "negative_run_seed": (_RUN + "seed = -3\n", "run[0].seed"),
    "few_draws": (_RUN + "draws = 5\n", "run[0].draws"),
    "out_is_a_file": (_RUN.replace('out = "o"', 'out = "exp.toml"'), "run[0].out"),
    "out_not_a_run_folder": (_RUN.replace('out = "o"', 'out = "."'), "run[0].out"),
    "same_out_twice": (_RUN + _RUN, "run.out"),
}


def _study_cases():
    design = ["design", "{exp}", "--out", "{out}", "--scheduler", "serial"]
    for option, values in DESIGN_OPTIONS.items():
        for value in values:
            base = design[:4] if option == "--scheduler" else design
            yield f"design{option}={value}", [*base, option, value], option, ()
    for kind in ("missing", "not_toml", "unknown_key", "negative_mass", "folder"):
        yield (f"design-experiment-{kind}", ["design", "{exp:%s}" % kind, "--out", "{out}"],
               f"exp-{kind}.toml", ())
    for where, path in {"a_file": "{file}", "under_a_file": "{under}",
                        "read_only": "{ro}/out"}.items():
        yield f"design-out-{where}", ["design", "{exp}", "--out", path], "--out", ()
        yield f"sbc-out-{where}", ["sbc", "--out", path], "--out", ()
    for option, values in SBC_OPTIONS.items():
        for value in values:
            yield f"sbc{option}={value}", ["sbc", "--out", "{out}", option, value], option, ()
    for kind, (_, culprit) in BAD_MANIFESTS.items():
        yield (f"batch-manifest-{kind}", ["batch", "{manifest:%s}" % kind, "--scheduler",
                                          "serial"], culprit, ())
    yield "batch-missing-manifest", ["batch", "{root}/in/none.toml"], "none.toml", ()
    yield "batch-manifest-a-folder", ["batch", "{dir}"], "emptydir", ()
    yield "batch--workers=0", ["batch", "{manifest:empty}", "--workers", "0"], "--workers", ()
    # requests that cannot fit the memory budget: refused before any task starts
    yield ("sbc-grid-beyond-memory", ["sbc", "--out", "{out}", "--grid-points", "100000"],
           "--grid-points", ())
    yield ("design-bounces-beyond-memory", ["design", "{exp}", "--out", "{out}", "--bounces",
                                            "50000000", "--scheduler", "serial"], "--bounces", ())
    yield from _predict_cases()


def _predict_cases():
    predict = ["predict", "{run}", "{trials}", "--out", "{out}/p.csv"]
    for value in ("abc", "5", "-1", "1.5"):
        yield f"predict--draws={value}", [*predict, "--draws", value], "--draws", ()
    yield "predict--seed=-1", [*predict, "--seed", "-1"], "--seed", ()
    for where, path in {"a_folder": "{dir}", "under_a_file": "{under}/p.csv",
                        "read_only": "{ro}/p.csv", "wrong_suffix": "{out}/p.txt"}.items():
        yield f"predict-out-{where}", [*predict[:4], path], "--out", ()
    for where, path in {"missing": "{root}/nothing", "a_file": "{file}",
                        "not_a_run": "{dir}"}.items():
        yield (f"predict-run-folder-{where}", ["predict", path, "{trials}", "--out",
                                               "{out}/p.csv"], path.strip("{}").split("/")[-1]
               if where == "missing" else ("plain.txt" if where == "a_file" else "emptydir"),
               ())
    for kind in ("missing", "empty", "unknown_column", "text_cell", "angle_95", "ragged",
                 "binary", "folder"):
        yield (f"predict-table-{kind}", ["predict", "{run}", "{table:%s}" % kind, "--out",
                                         "{out}/p.csv"], f"table-{kind}.csv", ())


def _compare_cases():
    """``compare``: every case fails before the first model is inferred."""
    base = ["compare", "{exp:with_models}", "{trials}", "--out", "{out}"]
    yield "compare-no-models", ["compare", "{exp}", "{trials}", "--out", "{out}"], "exp.toml", ()
    for value, culprit in (("nope", "--models"), ("kv", "--models"), ("kv,kv", "--models"),
                           (",", "argument --models")):
        yield f"compare--models={value}", [*base, "--models", value], culprit, ()
    for option, values in {"--evidence": ("exact",), "--grid-points": ("3", "abc"),
                           "--draws": ("10", "x"), "--live-points": ("5", "abc"),
                           "--seed": ("-1",)}.items():
        for value in values:
            yield f"compare{option}={value}", [*base, option, value], option, ()
    yield ("compare--evidence=grid-beyond-3", ["compare", "{exp:four_parameters}", "{trials}",
                                               "--out", "{out}", "--evidence", "grid"],
           "--evidence", ())
    for kind in ("missing", "not_toml", "unknown_key", "folder"):
        yield (f"compare-experiment-{kind}", ["compare", "{exp:%s}" % kind, "{trials}", "--out",
                                              "{out}"], f"exp-{kind}.toml", ())
    yield ("compare-experiment-bad-candidate", ["compare", "{exp:bad_candidate}", "{trials}",
                                                "--out", "{out}"], "models.hc.normal", ())
    for kind in ("missing", "empty", "text_cell", "angle_95", "binary"):
        yield (f"compare-table-{kind}", ["compare", "{exp:with_models}", "{table:%s}" % kind,
                                         "--out", "{out}"], f"table-{kind}.csv", ())
    yield "compare-data-a-folder", ["compare", "{exp:with_models}", "{dir}", "--out", "{out}"], \
        "emptydir", ()
    for where, path in {"a_file": "{file}", "under_a_file": "{under}",
                        "read_only": "{ro}/out"}.items():
        yield (f"compare-out-{where}", ["compare", "{exp:with_models}", "{trials}", "--out",
                                        path], "--out", ())
    yield ("compare-out-not-a-comparison", ["compare", "{exp:with_models}", "{trials}", "--out",
                                            "{root}/in"], "not a bouncebayes comparison", ())


_MODELS = ("\n[models.kv]\n\n[models.hc]\nnormal = \"hunt-crossley\"\n"
           "[models.hc.parameters.eta]\nlow = 0.0\nhigh = 0.2\n")
# inputs of the cases other branches own (not in the tables every command is tried with)
OTHERS_EXPERIMENTS = {
    "modulus_prior": EXPERIMENT_TEXT + (
        "\n[parameters.youngs_modulus]\nprior = \"uniform\"\nlow = 0.0\nhigh = 1e7\n"),
    "huge_prior": _edit(r"^high = 5.0$", "high = 1e300"),
    "with_models": EXPERIMENT_TEXT + _MODELS,
    "bad_candidate": EXPERIMENT_TEXT + _MODELS.replace('"hunt-crossley"', '"hertz"'),
    "four_parameters": EXPERIMENT_TEXT + _MODELS + (
        "[models.kv.parameters.youngs_modulus]\nprior = \"lognormal\"\nmedian = 5e6\n"
        "sd_log = 0.3\n[models.kv.parameters.spin]\nlow = -10.0\nhigh = 10.0\n")}
_rows = (DEMO / "trials.csv").read_text().splitlines()
_head = next(i for i, r in enumerate(_rows) if not r.startswith("#"))
OTHERS_TABLES = {
    "identical": "\n".join([_rows[_head], *[_rows[_head + 1]] * 30]) + "\n",
    "faster": "incidence_speed,incidence_angle,rebound_speed,rebound_angle\n" + "".join(
        f"3.0,60,{4.5 + 0.01 * i},50\n" for i in range(20))}


def _scaled_trajectories(scale_t: float, scale_xy: float, outlier: bool = False) -> dict:
    files = {}
    for p in sorted((DEMO / "trajectories").glob("*.csv"))[:3]:
        lines = p.read_text().splitlines()
        rows = [[float(v) for v in line.split(",")] for line in lines[1:]]
        if outlier:
            rows[len(rows) // 3][1] = 1e300
        files[p.name] = "t,x,y\n" + "".join(
            f"{t * scale_t!r},{x * scale_xy!r},{y * scale_xy!r}\n" for t, x, y in rows)
    return files


OTHERS_TRAJECTORIES = {"in_mm": _scaled_trajectories(1.0, 1000.0),
                       "in_ms": _scaled_trajectories(1000.0, 1.0),
                       "outlier": _scaled_trajectories(1.0, 1.0, outlier=True)}

CASES = list(_cases())


def test_the_suite_is_large_and_covers_every_command():
    from bouncebayes.cli._app import COMMANDS

    assert len(CASES) + len(REPORT_DAMAGE) >= 150
    covered = {argv[0] for _, argv, _, _ in CASES if argv} | {"report"}
    assert covered >= {c.name for c in COMMANDS}
    assert len({case[0] for case in CASES}) == len(CASES)  # ids unique


@pytest.mark.parametrize("argv, culprit", [pytest.param(argv, culprit, id=name, marks=marks)
                                           for name, argv, culprit, marks in CASES])
def test_bad_input_is_one_clean_line_and_writes_nothing(tmp_path, argv, culprit, request):
    world = World(tmp_path)
    world.values["root"] = str(tmp_path)
    if any("{run}" in a for a in argv):  # a finished run folder (built once per session)
        world.values["run"] = str(request.getfixturevalue("small_run").folder)
    argv = [world.resolve(a) for a in argv]
    culprit = world.resolve(culprit)
    before = snapshot(tmp_path)
    run_before = snapshot(Path(world.values["run"])) if "run" in world.values else None
    code, _, err = run_main(argv)
    assert_one_clean_error(code, err, argv[0] if argv else None, culprit)
    assert snapshot(tmp_path) == before
    if run_before is not None:
        assert snapshot(Path(world.values["run"])) == run_before


# --------------------------------------------------------------------------- damaged run folders

def _truncate(path: Path) -> None:
    data = path.read_bytes()
    path.write_bytes(data[:len(data) // 2])


def _replace_key(key: str, value: str):
    def damage(path: Path) -> None:
        text = path.read_text()
        path.write_text(re.sub(rf'"{key}": [^,\n]+', f'"{key}": {value}', text, count=1))
    return damage


REPORT_DAMAGE = {  # name -> (file, damage)
    "summary-empty-object": ("summary.json", lambda p: p.write_text("{}")),
    "summary-truncated": ("summary.json", _truncate),
    "summary-empty": ("summary.json", lambda p: p.write_text("")),
    "summary-a-list": ("summary.json", lambda p: p.write_text("[1, 2]")),
    "summary-seed-text": ("summary.json", _replace_key("seed", '"zero"')),
    "summary-binary": ("summary.json", lambda p: p.write_bytes(b"\xff\xfe\x00")),
    "posterior-empty": ("posterior.nc", lambda p: p.write_bytes(b"")),
    "posterior-truncated": ("posterior.nc", _truncate),
    "posterior-garbage": ("posterior.nc", lambda p: p.write_bytes(os.urandom(4096))),
    "posterior-missing": ("posterior.nc", lambda p: p.unlink()),
    "summary-missing": ("summary.json", lambda p: p.unlink()),
    "experiment-broken": ("experiment.toml", lambda p: p.write_text("[[[")),
    "experiment-missing": ("experiment.toml", lambda p: p.unlink()),
    "trials-broken": ("trials.csv", lambda p: p.write_text("speed\n1\n")),
    "trials-missing": ("trials.csv", lambda p: p.unlink()),
    "propagation-arrays-garbage": ("propagation.npz", lambda p: p.write_bytes(b"PK\x03\x04xx")),
    "propagation-summary-truncated": ("propagation.json", _truncate),
    "grid-garbage": ("grid.npz", lambda p: p.write_bytes(b"not an archive")),
    "truth-garbage": ("truth.json", lambda p: p.write_text('{"population": "high"}')),
}


@pytest.mark.parametrize("name", list(REPORT_DAMAGE))
def test_report_on_a_damaged_run_folder_names_the_damaged_file(small_run, tmp_path, name):
    folder = tmp_path / "run"
    shutil.copytree(small_run.folder, folder)
    file, damage = REPORT_DAMAGE[name]
    damage(folder / file)
    before = snapshot(tmp_path)
    code, _, err = run_main(["report", str(folder)])
    assert_one_clean_error(code, err, "report", file)
    assert snapshot(tmp_path) == before


# --------------------------------------------------------------------------- subprocesses

ENV = {**os.environ, "PYTHONPATH": str(ROOT / "src"), "PYTHONWARNINGS": "default"}


def cli(*argv: str, timeout: float = 120, limit_memory: int | None = None):
    """``bouncebayes ARGV`` in a fresh process; a hang is killed at ``timeout``."""
    def limit():
        import resource

        resource.setrlimit(resource.RLIMIT_AS, (limit_memory, limit_memory))

    return subprocess.run([sys.executable, "-m", "bouncebayes.cli", *argv], env=ENV,
                          capture_output=True, text=True, timeout=timeout,
                          preexec_fn=limit if limit_memory else None)


def test_a_ball_of_1e300_kg_does_not_hang():
    proc = cli("simulate", "--mass", "1e300", timeout=30)
    assert_one_clean_error(proc.returncode, proc.stderr, "simulate", "mass")


def test_a_grid_too_large_for_memory_is_refused_up_front(tmp_path):
    proc = cli("infer", str(EXAMPLE), str(DEMO / "trials.csv"), "--out", str(tmp_path / "o"),
               "--sampler", "grid", "--grid-points", "100000", timeout=120,
               limit_memory=6 << 30)
    assert_one_clean_error(proc.returncode, proc.stderr, "infer", "--grid-points")
    assert "GiB" in proc.stderr or "GB" in proc.stderr


# --------------------------------------------------------------------------- interrupted runs

def _earlier_run(folder: Path) -> Path:
    """An earlier run folder (what matters: it must come out byte-for-byte the same)."""
    folder.mkdir()
    (folder / "summary.json").write_text('{"seed": 1}')
    (folder / "report.html").write_text("<p>the earlier run, seed 1</p>")
    (folder / "figures").mkdir()
    (folder / "figures" / "marginals.png").write_bytes(b"\x89PNG earlier")
    (folder / "notes.txt").write_text("the user's own notes")
    return folder


def _start_run(out: Path) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "bouncebayes.cli", "run", str(EXAMPLE), str(DEMO / "trials.csv"),
         "--out", str(out), "--draws", "2000", "--chains", "2", "--seed", "5"],
        env=ENV, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _interrupt(out: Path, marker: str, sig: int, delay: float = 0.0
               ) -> tuple[subprocess.Popen, str]:
    """Start a run into ``out``, wait for ``marker`` on its stderr, wait ``delay`` s, send
    ``sig``; returns the process (finished) and its whole stderr."""
    proc = _start_run(out)
    seen = []
    assert proc.stderr is not None
    for line in proc.stderr:
        seen.append(line)
        if marker in line:
            break
    time.sleep(delay)
    proc.send_signal(sig)
    rest_out, rest_err = proc.communicate(timeout=120)
    return proc, "".join(seen) + rest_err


STAGE_MARKS = ("[1/5]", "[2/5]", "[3/5]", "[4/5]", "[5/5]")


@pytest.mark.parametrize("sig, marker", [
    (signal.SIGTERM, "[2/5]"), (signal.SIGINT, "[1/5]"),
    *[pytest.param(signal.SIGTERM, m, marks=pytest.mark.slow) for m in ("[1/5]", "[3/5]",
                                                                        "[4/5]")],
    pytest.param(signal.SIGINT, "[4/5]", marks=pytest.mark.slow),
])
def test_a_stopped_run_says_so_and_leaves_the_earlier_results_exactly(tmp_path, sig, marker):
    out = _earlier_run(tmp_path / "out")
    before = snapshot(tmp_path)
    proc, err = _interrupt(out, marker, sig, delay=0.3)
    expected = 143 if sig == signal.SIGTERM else 130
    assert proc.returncode == expected, err
    assert "Traceback" not in err, err
    assert err.rstrip().splitlines()[-1] == (f"bouncebayes run: stopped; earlier results in "
                                            f"{out} are intact")
    assert snapshot(tmp_path) == before  # no temporary file either


@pytest.mark.parametrize("marker, delay", [
    ("[3/5]", 0.0),
    *[pytest.param(m, d, marks=pytest.mark.slow)
      for m, d in (("[1/5]", 0.0), ("[2/5]", 0.5), ("[4/5]", 0.0), ("[4/5]", 2.0),
                   ("[5/5]", 0.0))],
])
def test_a_killed_run_leaves_the_earlier_results_and_the_next_run_cleans_up(
        tmp_path, marker, delay, demo, monkeypatch):
    import bouncebayes.pipeline
    import bouncebayes.report
    from bouncebayes.inference import MHConfig

    out = _earlier_run(tmp_path / "out")
    before = snapshot(tmp_path)
    proc, err = _interrupt(out, marker, signal.SIGKILL, delay=delay)
    assert proc.returncode == -signal.SIGKILL
    after = snapshot(tmp_path)
    leftovers = {k for k in after if k.startswith(".out.staging-")}
    if after.get("out/report.html") != before["out/report.html"]:  # finished before the kill
        assert marker == "[5/5]" and not leftovers
        return
    assert {k: v for k, v in after.items() if k not in leftovers} == before
    # the next run into the same folder removes what the killed one left
    monkeypatch.setattr(bouncebayes.report, "make_figures", lambda *a, **k: [])
    bouncebayes.pipeline.run(demo.experiment, demo.trials, out, log=lambda m: None,
                             config=MHConfig(draws=400, chains=2))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]
    assert (out / "notes.txt").read_text() == "the user's own notes"


def test_an_outlier_position_is_left_out_with_its_line(tmp_path, capsys):
    """One position of 1e300 m: the row is left out and named, the bounce is still measured
    (plausible speeds, not 1e300 m/s)."""
    from bouncebayes.cli import main
    from bouncebayes.data import load_experiment, load_trials

    folder = tmp_path / "traj"
    folder.mkdir()
    for name, text in OTHERS_TRAJECTORIES["outlier"].items():
        (folder / name).write_text(text)
    exp = DEMO / "experiment.toml"
    status = main(["kinematics", str(folder), "--experiment", str(exp), "--out",
                   str(tmp_path / "t.csv")])
    out = capsys.readouterr().out
    assert status == 0
    assert out.count("outlier position(s) left out (line 29") == 3
    trials = load_trials(tmp_path / "t.csv", load_experiment(exp))
    # the demo campaign's bounces: incidence ~3 m/s, rebound ~2.5 m/s (truth.json)
    assert 2.0 < trials.rebound_speed.min() and trials.rebound_speed.max() < 3.0


def test_an_overlap_beyond_hertz_validity_is_flagged(capsys):
    """20 m/s head-on: the maximum overlap, 7.2 mm (Hertz closed form, docs/model.md §7.1, gives
    (15 m V^2 / (16 E* sqrt(r)))^(2/5) = 7.4 mm without damping), exceeds 10 % of the 12.8 mm
    radius: the result is printed with a one-line warning that says so."""
    from bouncebayes.cli import main

    assert main(["simulate", "--speed", "20", "--angle", "0"]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "exceeds 10% of the ball's radius" in err[0]


def test_an_error_raised_in_a_worker_process_reaches_the_caller_whole(tmp_path):
    import pickle
    from concurrent.futures import ProcessPoolExecutor

    from bouncebayes._errors import InputFileError
    from bouncebayes.inference._memory import MemoryBudgetError
    from bouncebayes.kinematics import TrajectoryError, read_trajectory
    from bouncebayes.model._history import BounceFailed

    # A process pool (or Dask's workers) sends a worker's exception back pickled. Python
    # rebuilds an exception by calling its class with its message alone, which these classes'
    # own arguments refused: the caller got "TypeError: InputFileError.__init__() missing 1
    # required positional argument" instead of the error (found by a benchmark's pool).
    # Expected: each comes back with the same message and attributes
    for error in (InputFileError("a.csv", "bad", line=3, field="t"),
                  TrajectoryError("b.csv#1", "no crossing", reason="no_crossing"),
                  BounceFailed(2, "did not separate"),
                  MemoryBudgetError("the grid", 5e9, 2e9, "use fewer points")):
        back = pickle.loads(pickle.dumps(error))
        assert type(back) is type(error) and str(back) == str(error)
        assert back.__dict__ == error.__dict__
    bad = tmp_path / "bad.csv"
    bad.write_text("t,x,y\n0,0,zero\n")
    with ProcessPoolExecutor(1) as pool:
        with pytest.raises(InputFileError, match=r"bad\.csv"):
            pool.submit(read_trajectory, bad).result()
