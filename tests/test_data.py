"""Experiment files, priors, trial tables and synthetic campaigns."""

import json
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

import bouncebayes as bb
from bouncebayes._errors import InputFileError
from bouncebayes.data import (LogNormal, Normal, Uniform, load_experiment, load_trials,
                              parse_experiment, synthesize, write_campaign, write_trials)

ROOT = Path(__file__).resolve().parents[1]
PAPER_TOML = ROOT / "examples" / "paper.toml"
MINIMAL = """
[ball]
diameter_m = 0.0256
mass_kg = 0.0095
youngs_modulus_Pa = 5.0e6
poisson_ratio = 0.49
inertia_factor = 0.4
[surface]
inclination_deg = 0.0
[incidence]
speed_m_s = 3.0
angle_deg = 60.0
spin_rad_s = 0.0
[model]
normal = "kelvin-voigt"
[parameters.mu]
prior = "uniform"
low = 0.0
high = 0.5
[parameters.eta]
prior = "uniform"
low = 0.0
high = 5.0
"""


def parse(text: str):
    return parse_experiment(tomllib.loads(text), source="exp.toml")


def test_the_issue_example_parses_as_written():
    e = parse(MINIMAL)
    assert e.ball == bb.Ball(radius=0.0128, mass=0.0095, youngs_modulus=5e6, poisson_ratio=0.49)
    assert e.parameter_names == ("mu", "eta")
    assert e.priors["mu"] == Uniform(0.0, 0.5)
    assert e.incidence.speed == 3.0 and e.incidence.angle == 60.0
    assert e.normal_law == "kelvin-voigt" and e.gravity == bb.model.STANDARD_GRAVITY
    assert e.unit("eta") == "kg/s"
    # youngs_modulus and spin are not inferred: fixed at the file's values
    assert e.fixed_value("youngs_modulus") == 5e6 and e.fixed_value("spin") == 0.0


def test_paper_example_file_loads():
    e = load_experiment(PAPER_TOML)
    assert e.contact["mu"] == 0.16 and e.contact["eta"] == 1.35  # the paper's eq. (8)
    assert e.ball.diameter == pytest.approx(0.0256)
    assert len(e.text_sha256) == 64


def test_radius_and_density_alternatives():
    text = MINIMAL.replace("diameter_m = 0.0256", "radius_m = 0.0128").replace(
        "mass_kg = 0.0095", "density_kg_m3 = 1000.0")
    e = parse(text)
    # closed form: m = rho (4/3) pi r^3
    assert e.ball.mass == pytest.approx(1000.0 * 4 / 3 * math.pi * 0.0128**3, rel=1e-14)


@pytest.mark.parametrize(("edit", "match"), [
    (("youngs_modulus_Pa = 5.0e6\n", ""),
     r"exp.toml, `ball.youngs_modulus_Pa`: missing; required: a finite number > 0 Pa"),
    (("mass_kg = 0.0095", "mas_kg = 0.0095"),
     r"`ball.mas_kg`: unknown key \(did you mean `mass_kg`\?\); allowed keys in \[ball\]"),
    (("speed_m_s = 3.0", 'speed_m_s = "3"'),
     r"`incidence.speed_m_s`: must be a number \(in m/s\); got the string '3'"),
    (("poisson_ratio = 0.49", "poisson_ratio = 0.7"),
     r"`ball.poisson_ratio`: must be a finite number in \(-1, 0.5\] \(Poisson ratio\); "
     r"got 0.7"),
    (("angle_deg = 60.0", "angle_deg = 90.0"), r"`incidence.angle_deg`: must be .* got 90.0"),
    (("mass_kg = 0.0095", "mass_kg = -1.0"), r"`ball.mass_kg`: must be a finite number > 0"),
    (("mass_kg = 0.0095", "mass_kg = true"), r"`ball.mass_kg`: must be a number .* boolean"),
    (('normal = "kelvin-voigt"', 'normal = "maxwell"'),
     r"`model.normal`: must be one of 'kelvin-voigt', 'hunt-crossley', 'linear-dashpot', "
     r"'hertz-tsuji'; got 'maxwell'"),
    (("low = 0.0\nhigh = 0.5", "low = 0.5\nhigh = 0.1"),
     r"`parameters.mu`: `low` \(0.5\) must be less than `high` \(0.1\)"),
    (("[parameters.mu]", "[parameters.friction]"),
     r"`parameters.friction`: unknown parameter( \(did you mean `\w+`\?\))?; allowed "
     r"parameters in \[parameters\]: "
     r"eta, mu, normal_stiffness, restitution, spin, tangential_stiffness_ratio, "
     r"youngs_modulus"),
    (('prior = "uniform"\nlow = 0.0\nhigh = 0.5', 'prior = "beta"'),
     r"`parameters.mu.prior`: must be one of 'uniform', 'normal', 'lognormal'; got 'beta'"),
    (('prior = "uniform"\nlow = 0.0\nhigh = 0.5', 'prior = "normal"\nmean = 0.2\nsd = 0.1'),
     r"`parameters.mu`: the prior \(normal\(mean 0.2, sd 0.1\)\) puts mass below 0, where "
     r"`mu` is not physical; truncate it with `low = 0`"),
    (("low = 0.0\nhigh = 0.5", "low = -0.1\nhigh = 0.5"),
     r"puts mass below 0, where `mu` is not physical; set `low` >= 0"),
    (("low = 0.0\nhigh = 0.5", "low = 0.0\nhigh = 0.5\nmean = 1.0"),
     r"`parameters.mu.mean`: unknown key"),
    (("[surface]", "[surfaces]"), r"`surfaces`: unknown section \(did you mean `surface`\?\)"),
    (("mass_kg = 0.0095", "mass_kg = 0.0095\ndensity_kg_m3 = 1000.0"),
     r"`ball.mass_kg`: give exactly one of `ball.mass_kg` and `ball.density_kg_m3`; got both"),
    (("diameter_m = 0.0256\n", ""),
     r"give exactly one of `ball.diameter_m` and `ball.radius_m`; got neither"),
])
def test_every_mistake_names_the_key(edit, match):
    old, new = edit
    assert old in MINIMAL
    with pytest.raises(InputFileError, match=match):
        parse(MINIMAL.replace(old, new, 1))


def test_missing_section_and_bad_files(tmp_path):
    with pytest.raises(InputFileError, match=r"missing section \[incidence\]"):
        parse(MINIMAL.split("[incidence]")[0])
    bad = tmp_path / "bad.toml"
    bad.write_text("[ball\nx = 1\n")
    with pytest.raises(InputFileError, match=r"bad.toml: not valid TOML: .*line 1"):
        load_experiment(bad)
    with pytest.raises(InputFileError, match=r"nope.toml: cannot read the experiment file"):
        load_experiment(tmp_path / "nope.toml")


def test_fixed_parameter_without_value_is_reported():
    e = parse(MINIMAL.replace("[parameters.mu]\nprior = \"uniform\"\nlow = 0.0\nhigh = 0.5\n",
                              ""))
    assert e.parameter_names == ("eta",)
    with pytest.raises(InputFileError, match=r"`contact.mu`: missing; `mu` is not inferred"):
        e.fixed_value("mu")


def test_priors_match_scipy_and_sample_with_explicit_rng():
    """Expected values: scipy.stats distributions with the same parameters."""
    x = np.linspace(0.01, 0.6, 7)
    np.testing.assert_allclose(Uniform(0.0, 0.5).logpdf(x),
                               stats.uniform(0, 0.5).logpdf(x))
    tn = Normal(0.2, 0.1, 0.0, np.inf)
    np.testing.assert_allclose(tn.logpdf(x), stats.truncnorm(-2, np.inf, 0.2, 0.1).logpdf(x))
    ln = LogNormal(1.0, 0.5)
    np.testing.assert_allclose(ln.logpdf(x), stats.lognorm(0.5, scale=1.0).logpdf(x))
    assert tn.support == (0.0, math.inf)
    low, high = ln.box(1e-6)
    assert stats.lognorm(0.5).cdf(high) == pytest.approx(1 - 5e-7)
    a = Uniform(0, 1).sample(np.random.default_rng(5), 3)
    b = Uniform(0, 1).sample(np.random.default_rng(5), 3)
    assert np.array_equal(a, b)


def test_normal_prior_from_file():
    e = parse(MINIMAL.replace('prior = "uniform"\nlow = 0.0\nhigh = 0.5',
                              'prior = "normal"\nmean = 0.2\nsd = 0.05\nlow = 0.0'))
    assert e.priors["mu"] == Normal(0.2, 0.05, 0.0, math.inf)


# --- trial tables -------------------------------------------------------------------------

@pytest.fixture
def experiment():
    return parse(MINIMAL)


def write(tmp_path, text, name="trials.csv"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_trial_table_with_and_without_incidence(tmp_path, experiment):
    t = load_trials(write(tmp_path, "# comment\nrebound_speed,rebound_angle,rebound_speed_se\n"
                                    "2.5,58.0,0.02\n2.6,59.0,0.03\n"), experiment)
    assert t.n == 2 and t.measured == frozenset()
    np.testing.assert_array_equal(t.incidence_speed, [3.0, 3.0])  # nominal from the file
    np.testing.assert_array_equal(t.se["rebound_speed"], [0.02, 0.03])
    assert np.isnan(t.se["rebound_angle"]).all()
    t2 = load_trials(write(tmp_path, "trial,rebound_speed,rebound_angle,incidence_angle\n"
                                     "a,2.5,58.0,61.0\nb,2.6,59.0,59.5\n"), experiment)
    assert t2.labels == ("a", "b") and t2.measured == {"incidence_angle"}
    np.testing.assert_array_equal(t2.incidence_angle, [61.0, 59.5])
    with pytest.raises(ValueError):
        t2.rebound_speed[0] = 1.0  # read-only after validation


@pytest.mark.parametrize(("text", "match"), [
    ("", r"trials.csv: empty: expected a header row"),
    ("rebound_speed\n2.5\n", r"trials.csv, line 1: missing required column\(s\) rebound_angle"),
    ("rebound_speed,rebound_angle,speed\n2.5,58,1\n",
     r"trials.csv, line 1: unknown column 'speed'; allowed columns: rebound_speed"),
    ("rebound_speed,rebound_angle\n", r"trials.csv, line 1: no data rows after the header"),
    ("rebound_speed,rebound_angle\n2.5,58\n2.5,abc\n",
     r"trials.csv, line 3, `rebound_angle`: 'abc' is not a number"),
    ("rebound_speed,rebound_angle\n-2.5,58\n",
     r"trials.csv, line 2, `rebound_speed`: must be a finite number > 0 m/s; got -2.5"),
    ("rebound_speed,rebound_angle\n2.5,58,3\n",
     r"trials.csv, line 2: has 3 cells, the header has 2"),
    ("rebound_speed,rebound_angle\n2.5,\n", r"line 2, `rebound_angle`: empty cell; this column "
                                            r"is required"),
    ("rebound_speed,rebound_angle,incidence_speed\n2.5,58,3\n2.5,58,\n",
     r"line 3, `incidence_speed`: empty cell in a column that has values elsewhere"),
    ("rebound_speed,rebound_angle,rebound_speed_se\n2.5,58,-1\n",
     r"`rebound_speed_se`: must be a finite number >= 0 m/s; got -1"),
    ("rebound_speed,rebound_angle,rebound_angle\n2.5,58,58\n", r"duplicate column"),
])
def test_trial_table_errors_name_file_line_and_column(tmp_path, experiment, text, match):
    with pytest.raises(InputFileError, match=match):
        load_trials(write(tmp_path, text), experiment)


def test_trial_table_round_trip(tmp_path, experiment):
    campaign = synthesize(with_contact(), seed=4, n=5)
    path = write_trials(tmp_path / "t.csv", campaign.trials)
    back = load_trials(path, experiment)
    for col in ("rebound_speed", "rebound_angle", "incidence_speed", "incidence_angle"):
        np.testing.assert_array_equal(back.column(col), campaign.trials.column(col))
        np.testing.assert_array_equal(back.se[col], campaign.trials.se[col])


# --- synthetic campaigns ------------------------------------------------------------------

def with_contact(text=MINIMAL, mu=0.16, eta=1.35, extra=""):
    return parse(text + f"\n[contact]\nmu = {mu}\neta = {eta}\n" + extra)


def test_synth_is_reproducible_and_its_truth_is_the_model(tmp_path):
    e = with_contact(extra="[synth]\nmu_sd = 0.01\neta_sd = 0.1\n")
    a, b = synthesize(e, seed=7, n=6), synthesize(e, seed=7, n=6)
    np.testing.assert_array_equal(a.trials.rebound_speed, b.trials.rebound_speed)
    assert all(np.array_equal(x, y) for x, y in zip(a.trajectories, b.trajectories, strict=True))
    assert not np.array_equal(a.trials.rebound_speed, synthesize(e, seed=8, n=6).trials
                              .rebound_speed)
    per = a.truth["per_bounce"]
    # the recorded truth is what the forward model gives for the recorded per-bounce inputs
    again = bb.simulate(e.ball, mu=per["mu"], eta=per["eta"], speed=per["incidence_speed"],
                        angle=per["incidence_angle"], spin=per["incidence_spin"])
    np.testing.assert_array_equal(again.rebound_speed, per["rebound_speed"])
    # measurement noise 0.01 m/s (the [synth] default): residuals of that size
    resid = a.trials.rebound_speed - np.array(per["rebound_speed"])
    assert np.all(np.abs(resid) < 5 * 0.01)
    paths = write_campaign(a, tmp_path / "c")
    truth = json.loads(paths["truth"].read_text())
    assert truth["seed"] == 7 and truth["population"] == {"mu": 0.16, "eta": 1.35}
    files = sorted(paths["trajectories"].glob("*.csv"))
    assert [f.stem for f in files] == list(a.trials.labels)
    text = files[0].read_text()  # the one trajectory writer: provenance comment, header, rows
    rows = [line for line in text.splitlines() if not line.startswith("#")]
    assert text.startswith("# provenance: ") and rows[0] == "t,x,y" and rows[1].startswith("0.0,")


def test_synth_trajectory_is_ballistic_with_the_recorded_incidence():
    """Noise-free trajectory: the incident flight is a parabola with acceleration -g (closed
    form), and its velocity at the first contact is the recorded incidence."""
    e = with_contact(extra="[synth]\nposition_noise_m = 0.0\n")
    c = synthesize(e, seed=2, n=1)
    t, x, y = c.trajectories[0].T
    before = y > e.ball.radius + 1e-3
    before &= np.arange(t.size) < np.argmin(y)
    cy = np.polyfit(t[before], y[before], 2)
    cx = np.polyfit(t[before], x[before], 1)
    assert 2 * cy[0] == pytest.approx(-bb.model.STANDARD_GRAVITY, rel=1e-6)
    t_hit = np.roots(cy - [0, 0, e.ball.radius]).real.min()
    speed = math.hypot(cx[0], np.polyval(np.polyder(cy), t_hit))
    assert speed == pytest.approx(c.truth["per_bounce"]["incidence_speed"][0], rel=1e-6)


def test_synth_reports_unsolvable_truth():
    e = with_contact(eta=5000.0)
    with pytest.raises(bb.data.SynthesisError, match="could not be simulated"):
        synthesize(e, seed=1, n=3)


def test_experiment_file_reference_is_generated_from_the_schema():
    """docs/experiment-file.md must be regenerated when the schema changes:
    python -c "from bouncebayes.data._schema import reference_markdown as r; \
open('docs/experiment-file.md', 'w').write(r())" """
    from bouncebayes.data._schema import reference_markdown

    assert (ROOT / "docs" / "experiment-file.md").read_text() == reference_markdown()


def test_demo_campaign_is_what_its_seed_gives_and_slides_throughout():
    """The shipped demo files are reproducible from the experiment file and the recorded seed,
    so its truth.json is the truth; every bounce slides throughout (mu and eta identifiable)."""
    from bouncebayes.data import demo_campaign
    from bouncebayes.data._demo import DEMO_SEED

    demo = demo_campaign()
    assert demo.experiment.read_text() == PAPER_TOML.read_text()
    e = load_experiment(demo.experiment)
    assert demo.truth["seed"] == DEMO_SEED and demo.truth["n"] == 55
    assert demo.truth["share_rolling"] == 0.0
    again = synthesize(e, seed=DEMO_SEED, n=55)
    shipped = load_trials(demo.trials, e)
    for col in ("rebound_speed", "rebound_angle", "incidence_speed", "incidence_angle"):
        np.testing.assert_allclose(shipped.column(col), again.trials.column(col), rtol=1e-12)
    assert len(list(demo.trajectories.glob("*.csv"))) == 55


@pytest.mark.parametrize("prior", [Uniform(0.1, 0.5), Normal(0.2, 0.1), Normal(0.2, 0.1, 0.0),
                                   Normal(1.0, 2.0, -1.0, 3.0), LogNormal(1.5, 0.4),
                                   bb.data.LogUniform(1e-3, 10.0)])
def test_closed_form_prior_densities_equal_scipy(prior):
    """The closed-form log densities (used by the samplers) against scipy.stats."""
    x = np.array([-2.0, -0.5, 0.0, 1e-4, 0.1, 0.3, 0.5, 1.0, 2.5, 20.0])
    with np.errstate(divide="ignore"):
        np.testing.assert_allclose(prior.logpdf(x), prior.dist.logpdf(x), rtol=1e-12)


# --- one trial-table format: schema, writer, reader ----------------------------------------

def test_trial_table_reference_is_generated_from_the_schema():
    """docs/trial-table.md must be regenerated when the schema changes:
    python -c "from bouncebayes.data import trial_table_reference as r; \
open('docs/trial-table.md', 'w').write(r())" """
    from bouncebayes.data import trial_table_reference

    assert (ROOT / "docs" / "trial-table.md").read_text() == trial_table_reference()


def test_trial_table_writer_stamps_provenance_and_round_trips_every_column(tmp_path, experiment):
    from bouncebayes.data import make_trials

    trials = make_trials(experiment, rebound_speed=[2.5, 2.6], rebound_angle=[58.0, -1.5],
                         incidence_speed=[3.0, 3.1], incidence_angle=[60.0, 0.0],
                         incidence_spin=[-12.5, 40.0],
                         se={"rebound_speed": [0.01, 0.02], "incidence_spin": [1.0, np.nan]},
                         scale_rel_sd=[0.004, 0.004], labels=["#1 a,b", "b.csv#2"])
    path = write_trials(tmp_path / "t.csv", trials, provenance={"seed": 3, "inputs": ["x"]})
    lines = path.read_text().splitlines()
    assert lines[0] == '# provenance: {"seed":3,"inputs":["x"]}'
    assert lines[1] == ("trial,rebound_speed,rebound_angle,incidence_speed,incidence_angle,"
                        "incidence_spin,rebound_speed_se,incidence_spin_se,scale_rel_sd")
    assert lines[2].startswith('"#1 a,b",2.5,58.0,')  # a label that would read as a comment
    back = load_trials(path, experiment)
    assert back.labels == ("#1 a,b", "b.csv#2") and back.provenance == {"seed": 3,
                                                                         "inputs": ["x"]}
    assert back.measured == {"incidence_speed", "incidence_angle", "incidence_spin"}
    for col in ("rebound_speed", "rebound_angle", "incidence_speed", "incidence_angle",
                "incidence_spin", "scale_rel_sd"):
        np.testing.assert_array_equal(back.column(col), trials.column(col))
    np.testing.assert_array_equal(back.se["incidence_spin"], [1.0, np.nan])  # empty cell
    assert np.isnan(back.se["rebound_angle"]).all()


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"rebound_speed": [2.5, np.nan]}, r"trial '2', `rebound_speed`: must be a finite number > 0"),
    ({"incidence_angle": [95.0, 60.0]}, r"trial '1', `incidence_angle`: must be a finite number "
                                        r"in \[0, 90\) deg; got 95.0"),
    ({"se": {"rebound_angle": [-0.1, 0.1]}}, r"trial '1', `rebound_angle_se`: must be a finite "
                                            r"number >= 0 deg"),
    ({"labels": ["a", 'b"c']}, r"trial 2: a label must be one line"),
])
def test_trial_table_writer_refuses_what_the_reader_rejects(tmp_path, experiment, kwargs,
                                                            match):
    from bouncebayes.data import make_trials

    args = {"rebound_speed": [2.5, 2.6], "rebound_angle": [58.0, 59.0],
            "incidence_angle": [60.0, 60.0]} | kwargs
    with pytest.raises(ValueError, match=match):
        write_trials(tmp_path / "t.csv", make_trials(experiment, **args))
    assert not (tmp_path / "t.csv").exists()


def test_trial_table_writer_and_reader_name_a_folder(tmp_path, experiment):
    campaign = synthesize(with_contact(), seed=4, n=2)
    with pytest.raises(InputFileError, match="is a folder; expected the name of the trial "
                                             "table to write"):
        write_trials(tmp_path, campaign.trials)
    with pytest.raises(InputFileError, match="is a folder; expected a trial table"):
        load_trials(tmp_path, experiment)
    with pytest.raises(TypeError, match="`provenance` must be JSON-serialisable"):
        write_trials(tmp_path / "t.csv", campaign.trials, provenance={"x": object()})


def test_old_tables_with_a_file_label_still_read(tmp_path, experiment):
    t = load_trials(write(tmp_path, "file,rebound_speed,rebound_angle\nb1.csv,2.5,58\n"),
                    experiment)
    assert t.labels == ("b1.csv",) and np.isnan(t.scale_rel_sd).all()


# --- one trajectory format: writer and reader ----------------------------------------------

def test_trajectory_writer_and_reader_round_trip_with_quality_and_provenance(tmp_path):
    from bouncebayes.data import read_trajectory_table, write_trajectory

    t = np.arange(6) * 1e-3
    x, y, z = 0.1 + t, 0.05 - t, np.full(6, 0.01)
    quality = {"residual": [1.5, 2.0, np.nan, 2.5, 3.0, 1.0],
               "visible": [1, 1, 1, 0.5, 1, 1], "flag": [0, 0, 0, 1, 0, 0]}
    path = write_trajectory(tmp_path / "a.csv", t, x, y, z, quality=quality,
                            provenance={"stage": "track"})
    text = path.read_text().splitlines()
    assert text[0] == '# provenance: {"stage":"track"}'
    assert text[1] == "t,x,y,z,residual,visible,flag"
    assert text[4].split(",")[4] == ""  # NaN residual: an empty cell
    table = read_trajectory_table(path)
    keep = [0, 1, 2, 4, 5]  # the flagged frame (line 6) is left out and said so
    np.testing.assert_array_equal(table.columns["x"], x[keep])  # exact: repr round-trips
    np.testing.assert_array_equal(table.columns["t"], t[keep])
    assert np.isnan(table.columns["residual"][2]) and table.n_flagged == 1
    assert table.notes == ("1 row(s) flagged by the tracker (flag = 1) left out (line 6)",)
    assert table.provenance == {"stage": "track"}
    assert list(table.lines) == [3, 4, 5, 7, 8]


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"x": [0.0, np.inf]}, r"`x` must be finite \(write tracked frames only\); got inf at "
                           r"index 1"),
    ({"y": [0.0]}, r"trajectory columns must be 1-D and of one length"),
    ({"quality": {"flag": [0, 2]}}, r"`quality\['flag'\]` must be 0 or 1; got 2.0 at index 1"),
    ({"quality": {"visible": [0.5, 1.5]}}, r"`quality\['visible'\]` must be in \[0, 1\]"),
    ({"quality": {"blur": [0, 0]}}, r"`quality` has an unknown column 'blur'; allowed: "
                                    r"residual, visible, flag"),
])
def test_trajectory_writer_refuses_bad_columns(tmp_path, kwargs, match):
    from bouncebayes.data import write_trajectory

    args = {"t": [0.0, 0.001], "x": [0.0, 0.001], "y": [0.1, 0.1]} | kwargs
    quality = args.pop("quality", None)
    with pytest.raises(ValueError, match=match):
        write_trajectory(tmp_path / "a.csv", quality=quality, **args)


@pytest.mark.parametrize(("text", "match"), [
    ("t,x,y,flag\n0,0,0,2\n", r"a.csv, line 2, `flag`: must be 0 or 1; got '2'"),
    ("t,x,y,visible\n0,0,0,-0.1\n", r"a.csv, line 2, `visible`: must be in \[0, 1\]"),
])
def test_trajectory_reader_checks_the_quality_columns(tmp_path, text, match):
    from bouncebayes.data import read_trajectory_table

    (tmp_path / "a.csv").write_text(text)
    with pytest.raises(InputFileError, match=match):
        read_trajectory_table(tmp_path / "a.csv")


@pytest.mark.parametrize(("sidecar", "match"), [
    ("{not json", r"a.track.json: not a readable JSON file"),
    ('{"calibration": {"relative_sd": -1}}',
     r"a.track.json, `calibration.relative_sd`: must be a finite number >= 0; got -1"),
    ('{"surface": 3}', r"a.track.json, `surface`: must be a JSON object; got 3"),
])
def test_track_sidecar_errors_name_the_key(tmp_path, sidecar, match):
    from bouncebayes.data import read_track_sidecar

    (tmp_path / "a.track.json").write_text(sidecar)
    with pytest.raises(InputFileError, match=match):
        read_track_sidecar(tmp_path / "a.csv")
    (tmp_path / "a.track.json").write_text('{"surface": {"angle_sd_deg": 0.25}}')
    got = read_track_sidecar(tmp_path / "a.csv")
    assert got.surface_angle_sd_deg == 0.25 and got.scale_rel_sd is None
