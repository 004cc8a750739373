"""The bundled Kharaz et al. (2001) campaign and the candidate models of [models.NAME]."""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

import bouncebayes as bb
from bouncebayes._errors import InputFileError
from bouncebayes.data import parse_experiment
from bouncebayes.data._kharaz import (DIGITIZED, NORMAL_RESTITUTION, SPEED, kharaz_rows,
                                      read_digitized, table_text, tangential_rebound)

DATA = Path(__file__).parent / "data" / "external"

KHARAZ = bb.data.demo_campaign("kharaz")


def test_bundled_digitized_file_is_the_validation_copy():
    """The campaign ships the same digitized file the validation tests read (one source)."""
    bundled = (KHARAZ.folder / DIGITIZED).read_bytes()
    assert bundled == (DATA / "kharaz2001-digitized" / DIGITIZED).read_bytes()


def test_bundled_trial_table_is_its_derivation():
    """trials.csv is exactly what bouncebayes.data._kharaz derives from the digitized file."""
    rows, model = kharaz_rows(KHARAZ.folder / DIGITIZED)
    assert KHARAZ.trials.read_text(encoding="utf-8") == table_text(rows, model)


def test_trial_table_reproduces_the_measured_tangential_restitution():
    """Going back from the table's rebound (speed, angle) with v'_n = 0.98 V cos(theta) gives the
    digitized e_t figure: the mean of the Kratos and Lethe readings at each angle (SOURCE.md),
    to the table's rounding; the errors grow towards grazing in speed and fall in angle, as the
    propagation of one error in u' through (speed, angle) must."""
    experiment = bb.load_experiment(KHARAZ.experiment)
    trials = bb.load_trials(KHARAZ.trials, experiment)
    assert trials.n == 11
    a = np.radians(trials.incidence_angle)
    u_out = trials.rebound_speed * np.sin(np.radians(trials.rebound_angle))
    v_out = trials.rebound_speed * np.cos(np.radians(trials.rebound_angle))
    np.testing.assert_allclose(v_out, NORMAL_RESTITUTION * SPEED * np.cos(a), atol=1e-4)  # rounding
    e_t = u_out / (SPEED * np.sin(a))
    readings = [r for r in read_digitized(KHARAZ.folder / DIGITIZED)
                if r.quantity == "tangential_COR_et"]
    at_20 = [r.value for r in readings if abs(r.angle - 20.0) < 1.0]  # 0.5988 and 0.5969
    assert e_t[3] == pytest.approx(np.mean(at_20), abs=2e-4)
    assert np.all(np.diff(trials.se["rebound_speed"]) > 0)
    assert trials.se["rebound_angle"][-1] < trials.se["rebound_angle"][0]


def test_error_model_from_the_spread_of_the_figures():
    """The experiment's scatter in u' is about 0.012 m/s: the spin figure alone disagrees with
    the e_t figure by up to 49 rad/s (docs/validation.md §3), kappa r = 1e-3 m, i.e. 0.049 m/s at
    worst; spread over two figures and 34 differences it is a centimetre per second. The incidence
    readings of one point spread by 0.4 deg across figures (the spin figure's x axis sits about
    a degree to the right of the e_t figure's)."""
    _, model = kharaz_rows(KHARAZ.folder / DIGITIZED)
    assert 0.008 < model.scatter < 0.02
    assert 0.2 < model.angle_sd < 0.8
    assert model.n_differences == 34


def test_tangential_rebound_of_each_figure():
    """Closed forms: at 30 deg, e_t 0.69 gives u' = 0.69 * 3.9 * 0.5; a spin of 600 rad/s takes
    kappa r w = 0.6 m/s off u = 1.95 m/s; a centre-of-mass angle g gives v'_n tan(g)."""
    assert tangential_rebound("tangential_COR_et", 30.0, 0.69) == pytest.approx(1.3455)
    assert tangential_rebound("angular_velocity_after", 30.0, -600.0) == pytest.approx(1.35)
    vn = 0.98 * 3.9 * math.cos(math.radians(30.0))
    assert tangential_rebound("rebound_angle_centre_of_mass", 30.0, 20.0) == pytest.approx(
        vn * math.tan(math.radians(20.0)))


# ------------------------------------------------------------------ candidate models


def test_kharaz_candidates():
    """spring: the file's priors; mindlin: the ratio fixed at the [contact] value 0.870; rigid:
    no spring, so its prior of the ratio is left out."""
    models = bb.load_experiment(KHARAZ.experiment).models
    assert list(models) == ["spring", "mindlin", "rigid"]
    assert models["spring"].experiment.parameter_names == ("mu", "tangential_stiffness_ratio")
    mindlin = models["mindlin"].experiment
    assert mindlin.parameter_names == ("mu",)
    assert mindlin.fixed_value("tangential_stiffness_ratio") == 0.870
    assert models["rigid"].experiment.tangential == "none"
    assert models["rigid"].experiment.parameter_names == ("mu",)


def test_candidate_toml_reads_back_as_its_experiment(tmp_path):
    """A candidate's own file (what its run folder keeps) parses to the same experiment."""
    candidate = bb.load_experiment(KHARAZ.experiment).models["rigid"]
    path = tmp_path / "rigid.toml"
    path.write_text(candidate.toml(), encoding="utf-8")
    again = bb.load_experiment(path)
    assert again.tangential == "none" and dict(again.priors) == dict(
        candidate.experiment.priors)
    assert again.ball == candidate.experiment.ball and not again.models


def _doc(**models) -> dict:
    doc = tomllib.loads(bb.data.demo_campaign().experiment.read_text(encoding="utf-8"))
    doc["models"] = models
    return doc


def test_candidate_replaces_and_adds_priors():
    """[models.NAME.parameters.X] replaces the file's prior of X and adds new ones; the
    [model] keys and [models.NAME.contact] override the file's."""
    doc = _doc(hc={"normal": "hunt-crossley", "contact": {"eta": 0.05},
                   "parameters": {"eta": {"low": 0.0, "high": 0.2},
                                  "youngs_modulus": {"prior": "lognormal", "median": 5e6,
                                                     "sd_log": 0.3}}})
    hc = parse_experiment(doc).models["hc"].experiment
    assert hc.normal_law == "hunt-crossley" and hc.contact["eta"] == 0.05
    assert hc.priors["eta"].high == 0.2 and hc.priors["mu"].high == 0.5
    assert hc.parameter_names == ("mu", "eta", "youngs_modulus")


@pytest.mark.parametrize(("models", "where", "says"), [
    ({"a b": {}}, "models.a b", "letters, digits"),
    ({"x": 3}, "models.x", "must be a table"),
    ({"x": {"normal": "hertz"}}, "models.x.normal", "must be one of"),
    ({"x": {"tangental": "none"}}, "models.x.tangental", "did you mean `tangential`"),
    ({"x": {"contact": {"mu": -1.0}}}, "models.x.contact.mu", "must be"),
    ({"x": {"parameters": {"restitution": {"low": 0.5, "high": 1.0}}}},
     "models.x.parameters.restitution", "not a parameter of this candidate"),
    ({"x": {"parameters": {"mu": {"low": 0.5, "high": 0.1}}}}, "models.x.parameters.mu",
     "must be less than"),
    ({"x": {"fixed": ["spin"]}}, "models.x.fixed", "not inferred in [parameters]"),
    ({"x": {"fixed": "mu"}}, "models.x.fixed", "must be an array"),
    ({"x": {"fixed": ["mu", "eta"]}}, "models.x", "infers nothing"),
    ({"x": {"normal": "linear-dashpot", "fixed": ["mu"]}}, "models.x", "infers nothing"),
])
def test_candidate_mistakes_name_their_key(models, where, says):
    with pytest.raises(InputFileError) as info:
        parse_experiment(_doc(**models), source="exp.toml")
    assert info.value.field == where and says in str(info.value)


def test_candidate_needing_a_value_the_file_lacks_says_which_candidate():
    """A DEM law needs its restitution where it is not inferred: the message names the
    candidate whose law asks for it."""
    doc = _doc(dem={"normal": "hertz-tsuji", "contact": {"restitution": 1.5}})
    with pytest.raises(InputFileError, match=r"models\.dem\.contact\.restitution"):
        parse_experiment(doc, source="exp.toml")
