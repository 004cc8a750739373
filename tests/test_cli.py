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
    assert err.strip() == ("bouncebayes simulate: error: `angle` must be a finite number in "
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
