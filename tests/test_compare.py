"""Model comparison (docs/comparison.md): evidence, PSIS-LOO, Bayes factors in words, verdict.

The synthetic campaigns use the Kharaz ball (5 mm alumina, Hertz with Tsuji's dashpot at
restitution 0.98, no gravity) and two candidates that differ only in the tangential contact: a
Mindlin spring at its no-slip stiffness, and the rigid contact. Below about 33 deg a bounce grips
and the two predict different rebounds (docs/validation.md §5); above it the ball slides
throughout and both predict the same (the tangential impulse is then mu times the normal one,
whatever the spring): there the data cannot tell them apart.
"""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest

import bouncebayes as bb
from bouncebayes.compare import (bayes_factors, compare_models, evidence_words, grid_evidence,
                                 nested_evidence, plan_for, verdict)
from bouncebayes.data import parse_experiment
from bouncebayes.inference import infer, sampler_config

KHARAZ = bb.data.demo_campaign("kharaz")
MU = 0.092
SE_SPEED, SE_ANGLE = 0.005, 0.2  # m/s, deg
FAST = {"grid_points": 32, "draws": 400}  # small grids: the tests' budget, not the defaults'


def _experiment() -> bb.Experiment:
    doc = tomllib.loads(KHARAZ.experiment.read_text(encoding="utf-8"))
    doc["model"]["tangential"] = "none"
    del doc["parameters"]["tangential_stiffness_ratio"]
    doc["models"] = {"spring": {"tangential": "mindlin"}, "rigid": {}}
    return parse_experiment(doc, source="synthetic.toml")


EXPERIMENT = _experiment()


def _campaign(tmp_path, tangential: str, angles, seed: int) -> bb.Trials:
    """Rebounds of the model ``tangential`` at mu = 0.092 with Gaussian noise of the stated
    standard errors (incidence exact)."""
    e = EXPERIMENT
    b = bb.simulate(e.ball, mu=MU, speed=3.9, angle=np.asarray(angles, dtype=float),
                    normal_law="hertz-tsuji", restitution=e.contact["restitution"],
                    tangential=tangential, gravity=0.0)
    rng = np.random.default_rng(seed)
    speed = b.rebound_speed + rng.normal(0.0, SE_SPEED, b.rebound_speed.shape)
    angle = b.rebound_angle + rng.normal(0.0, SE_ANGLE, b.rebound_angle.shape)
    rows = ["trial,rebound_speed,rebound_angle,incidence_angle,rebound_speed_se,"
            "rebound_angle_se,incidence_angle_se"]
    rows += [f"t{i},{float(s)!r},{float(a)!r},{float(x)!r},{SE_SPEED},{SE_ANGLE},0"
             for i, (s, a, x) in enumerate(zip(speed, angle, angles, strict=True))]
    path = tmp_path / f"{tangential}-{seed}.csv"
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    return bb.load_trials(path, e)


GRIP = np.linspace(8.0, 32.0, 7)  # deg: the spring changes the rebound
SLIDE = np.linspace(50.0, 85.0, 7)  # deg: it does not


@pytest.mark.parametrize("truth", ["mindlin", "none"])
def test_comparison_picks_the_generating_model(tmp_path, truth):
    """Campaigns in the grip range made with each model: the evidence picks the generating
    model decisively, LOO agrees, and the other model fails the adequacy check (the rigid
    contact leaves rolling with u'/u = 5/7 where the spring reverses the contact point)."""
    trials = _campaign(tmp_path, truth, GRIP, seed=3)
    c = compare_models(EXPERIMENT, trials, seed=1, **FAST)
    right, wrong = ("spring", "rigid") if truth == "mindlin" else ("rigid", "spring")
    v = c.verdict
    assert v["preferred"] == right and v["strength"] == "decisive", v["text"]
    assert v["loo_preferred"] == right, v["text"]
    assert c.models[right]["adequate"] and not c.models[wrong]["adequate"]
    assert v["misfitting"] == [wrong]
    assert f"The evidence prefers `{right}`" in v["text"]
    mu = c.models[right]["parameters"]["mu"]
    if truth == "mindlin":  # the spring's grip depends on mu: identified (within 3 sd)
        assert abs(mu["mean"] - MU) < 3 * mu["sd"] and mu["sd"] < 0.01
    else:  # every rigid bounce leaves rolling: only a lower bound (docs/model.md §7.3)
        assert mu["result"].startswith("mu >")


def test_comparison_says_when_the_data_cannot_tell(tmp_path):
    """Sliding throughout, the spring changes nothing: both models fit, their evidences agree
    to within 2 ln B < 2 (same likelihood, same prior on mu), and the verdict says the data do
    not choose; comparison.json, the figure and the report say so too."""
    import json

    from bouncebayes.compare import write_comparison

    trials = _campaign(tmp_path, "mindlin", SLIDE, seed=5)
    c = compare_models(EXPERIMENT, trials, seed=1, **FAST)
    v = c.verdict
    assert v["preferred"] is None and v["strength"] == "cannot tell apart", v["text"]
    assert "cannot tell `" in v["text"] and "do not choose" in v["text"]
    assert abs(c.models["spring"]["log_evidence"] - c.models["rigid"]["log_evidence"]) < 0.5
    assert v["loo_preferred"] is None
    assert all(m["adequate"] for m in c.models.values())
    page = write_comparison(c, tmp_path / "out", provenance={"seed": 1}).read_text()
    saved = json.loads((tmp_path / "out" / "comparison.json").read_text())
    assert saved["verdict"]["text"] == v["text"] and saved["provenance"] == {"seed": 1}
    assert set(saved["models"]["rigid"]) >= {"log_evidence", "log_evidence_se", "elpd_loo",
                                             "elpd_loo_se"}
    assert "cannot tell" in page and "data:image/png;base64," in page
    assert (tmp_path / "out" / "figures" / "comparison.png").read_bytes()[:4] == b"\x89PNG"


def test_grid_and_nested_evidence_agree(tmp_path):
    """Two independent integrations of the same evidence: grid quadrature and dynesty's nested
    sampling agree within their stated uncertainties (3 sigma of the combined)."""
    trials = _campaign(tmp_path, "none", SLIDE, seed=7)
    e = EXPERIMENT.models["rigid"].experiment
    r = infer(e, trials, sampler="grid", config=sampler_config("grid", points=256, draws=300),
              likelihood="gaussian", discrepancy="none", seed=2)
    grid, nested = grid_evidence(r), nested_evidence(r, seed=2, live_points=100)
    assert nested.se > 0 and grid.se < 0.05
    assert abs(grid.log_evidence - nested.log_evidence) < 3 * math.hypot(grid.se, nested.se) \
        + 0.05


def test_psis_loo_agrees_with_exact_leave_one_out(tmp_path):
    """PSIS-LOO (ArviZ) against leave-one-out done exactly: elpd_i = ln p(y_i | y_-i) =
    ln Z(all trials) - ln Z(all but trial i), both evidences by grid quadrature."""
    trials = _campaign(tmp_path, "none", SLIDE, seed=9)
    e = EXPERIMENT.models["rigid"].experiment
    settings = {"sampler": "grid", "likelihood": "gaussian", "discrepancy": "none", "seed": 2}
    c = compare_models(parse_experiment_with(e), trials, seed=2, grid_points=1024,
                       draws=4000)
    full = c.results["rigid"].draws.info.log_evidence
    exact = []
    for i in range(trials.n):
        keep = [j for j in range(trials.n) if j != i]
        sub = bb.data.make_trials(e, **_columns(trials, keep))
        r = infer(e, sub, config=sampler_config("grid", points=1024, draws=200), **settings)
        exact.append(full - r.draws.info.log_evidence)
    assert c.models["rigid"]["elpd_loo"] == pytest.approx(sum(exact), abs=0.15)


def parse_experiment_with(e: bb.Experiment) -> bb.Experiment:
    """``e`` with two candidates that are ``e`` itself (a comparison needs two)."""
    doc = tomllib.loads(KHARAZ.experiment.read_text(encoding="utf-8"))
    doc["model"]["tangential"] = "none"
    del doc["parameters"]["tangential_stiffness_ratio"]
    doc["models"] = {"rigid": {}, "same": {}}
    return parse_experiment(doc, source="synthetic.toml")


def _columns(trials: bb.Trials, keep: list[int]) -> dict:
    return {"rebound_speed": trials.rebound_speed[keep],
            "rebound_angle": trials.rebound_angle[keep],
            "incidence_angle": trials.incidence_angle[keep],
            "se": {k: np.asarray(trials.se[k])[keep]
                   for k in ("rebound_speed", "rebound_angle", "incidence_angle")},
            "labels": [trials.labels[j] for j in keep]}


# ------------------------------------------------------------------ the words and the verdict


@pytest.mark.parametrize(("two_ln_b", "words"), [(0.0, "cannot tell apart"),
                                                 (1.99, "cannot tell apart"),
                                                 (2.0, "positive"), (5.9, "positive"),
                                                 (6.0, "strong"), (9.9, "strong"),
                                                 (10.0, "decisive"), (150.0, "decisive")])
def test_kass_raftery_scale(two_ln_b, words):
    """The category boundaries of Kass & Raftery (1995), Table, on 2 ln B."""
    assert evidence_words(two_ln_b) == words


def _model(log_z, se=0.01, adequate=True):
    return {"log_evidence": log_z, "log_evidence_se": se, "adequate": adequate}


def test_a_difference_within_the_numerical_uncertainty_is_not_a_preference():
    """2 ln B = 8 would be strong, but not when the evidences are uncertain by 3 each."""
    f = bayes_factors({"a": _model(10.0, 3.0), "b": _model(6.0, 3.0)}, "a")
    assert f["b"]["words"].startswith("cannot tell apart (within")


def test_verdict_names_misfits_even_of_the_best():
    loo = {"a": {"rank": 0, "elpd_diff": 0.0, "elpd_diff_se": 0.0},
           "b": {"rank": 1, "elpd_diff": 30.0, "elpd_diff_se": 5.0}}
    v = verdict({"a": _model(-5.0, adequate=False), "b": _model(-40.0, adequate=False)}, loo)
    assert v["preferred"] == "a" and v["misfitting"] == ["a", "b"]
    assert "No candidate reproduces the data" in v["text"]


def test_plan_uses_the_grid_where_it_can():
    """Closed-form laws: the grid up to 3 parameters; a spring: up to 2; beyond: nested."""
    trials = bb.load_trials(KHARAZ.trials, bb.load_experiment(KHARAZ.experiment))
    rigid = EXPERIMENT.models["rigid"].experiment
    assert plan_for("r", rigid, trials).evidence == "grid"
    assert plan_for("r", rigid, trials).config.points == 2048
    spring = bb.load_experiment(KHARAZ.experiment).models["spring"].experiment
    p = plan_for("s", spring, trials)
    assert (p.evidence, p.config.points, p.noise) == ("grid", 96, "given")
    assert plan_for("s", spring, trials, evidence="nested").sampler == "mh"
    with pytest.raises(ValueError, match="`evidence`"):
        plan_for("s", spring, trials, evidence="loud")


# ------------------------------------------------------------------ the known answer


@pytest.fixture(scope="module")
def kharaz():
    """The bundled Kharaz campaign: the spring (stiffness ratio inferred) against the rigid
    contact, on coarse grids."""
    e = bb.load_experiment(KHARAZ.experiment)
    trials = bb.load_trials(KHARAZ.trials, e)
    return compare_models(e, trials, ["spring", "rigid"], seed=0, grid_points=32, draws=800)


def test_kharaz_spring_recovers_the_dem_friction(kharaz):
    """With the compliant model over the whole range (2-85 deg) mu lies between 0.08 and 0.10
    (the DEM community's 0.092: Chung & Ooi 2011, Test 4), and the model reproduces the data."""
    m = kharaz.models["spring"]
    mu = m["parameters"]["mu"]
    assert 0.08 < mu["ci90"][0] and mu["ci90"][1] < 0.10
    assert mu["ci90"][0] < 0.092 < mu["ci90"][1]
    assert m["adequate"], m["adequacy_verdict"]


def test_kharaz_rigid_contact_is_flagged_and_loses(kharaz):
    """The rigid contact cannot leave with u'/u below 5/7, which the experiment shows at
    10-30 deg: the adequacy check fails (naming the 20 deg trial) and the evidence decides
    against it (2 ln B far beyond 10)."""
    m = kharaz.models["rigid"]
    assert not m["adequate"] and "theta_20.1" in m["adequacy_verdict"]
    v = kharaz.verdict
    assert v["preferred"] == "spring" and v["strength"] == "decisive", v["text"]
    assert v["bayes_factors"]["rigid"]["two_ln_b"] > 50
    assert v["misfitting"] == ["rigid"]


# ------------------------------------------------------------------ the command


@pytest.mark.slow  # two whole runs with their figures: about a minute on the shared machine
def test_compare_command_writes_the_comparison_and_every_run(tmp_path, capsys):
    """`bouncebayes compare` on the demo table with two normal laws (closed forms: fast):
    comparison.json with every number the docs promise and its provenance, the figure, a
    report linking each model's run folder, which `bouncebayes report` can redraw."""
    import json

    from bouncebayes.cli import main

    exp = tmp_path / "exp.toml"
    exp.write_text(bb.data.demo_campaign().experiment.read_text(encoding="utf-8")
                   + "\n[models.kv]\n\n[models.hc]\nnormal = \"hunt-crossley\"\n"
                     "[models.hc.parameters.eta]\nlow = 0.0\nhigh = 0.2\n", encoding="utf-8")
    out = tmp_path / "cmp"
    assert main(["compare", str(exp), str(bb.data.demo_campaign().trials), "--out", str(out),
                 "--grid-points", "96", "--draws", "400"]) == 0
    printed = capsys.readouterr().out
    assert "log evidence" in printed and "report:" in printed
    c = json.loads((out / "comparison.json").read_text())
    for m in c["models"].values():
        for key in ("log_evidence", "log_evidence_se", "elpd_loo", "elpd_loo_se", "p_loo",
                    "pareto_k_max", "adequate", "evidence_method", "parameters"):
            assert key in m, key
        assert m["likelihood"] == "gaussian" and m["discrepancy"] == "none"
    assert c["verdict"]["text"] and set(c["verdict"]["ranking"]) == {"kv", "hc"}
    assert c["provenance"]["inputs"]["data"]["sha256"]
    page = (out / "report.html").read_text()
    assert 'href="models/kv/report.html"' in page and "Kass &amp; Raftery" in page
    assert (out / "figures" / "comparison.png").read_bytes()[:4] == b"\x89PNG"
    for name in ("kv", "hc"):
        run = out / "models" / name
        assert (run / "report.html").is_file() and (run / "derived.json").is_file()
        assert bb.load_experiment(run / "experiment.toml").normal_law == (
            "kelvin-voigt" if name == "kv" else "hunt-crossley")
    assert main(["report", str(out / "models" / "hc")]) == 0


@pytest.mark.slow  # the whole job with its figures on a spring model: half a minute
def test_demo_kharaz(tmp_path):
    """`bouncebayes demo --campaign kharaz`: the whole job on the bundled measurements (a
    coarse grid here) recovers mu between 0.08 and 0.10 with the spring model."""
    import json

    from bouncebayes.cli import main

    out = tmp_path / "k"
    assert main(["demo", "--campaign", "kharaz", "--out", str(out), "--sampler", "grid",
                 "--grid-points", "24", "--draws", "300"]) == 0
    s = json.loads((out / "summary.json").read_text())
    assert 0.08 < s["parameters"]["mu"]["mean"] < 0.10
    assert s["experiment"]["tangential"] == "mindlin"
    derived = json.loads((out / "derived.json").read_text())
    assert 0.08 < derived["quantities"]["friction_coefficient"]["median"] < 0.10


@pytest.mark.parametrize("method", ["grid", pytest.param("nested", marks=pytest.mark.slow)])
def test_evidence_charges_for_prior_volume(tmp_path, method):
    """Closed form: the same model with a uniform prior on mu twice as wide (both holding all
    the likelihood) has half the evidence, ln B = ln 2 = 0.693, whichever way the evidence is
    computed (nested: within 3 of its stated uncertainties; grid: to 1e-3)."""
    doc = tomllib.loads(KHARAZ.experiment.read_text(encoding="utf-8"))
    doc["model"]["tangential"] = "none"
    del doc["parameters"]["tangential_stiffness_ratio"]
    doc["models"] = {"narrow": {}, "wide": {"parameters": {"mu": {"low": 0.0, "high": 0.6}}}}
    e = parse_experiment(doc, source="volume.toml")
    trials = _campaign(tmp_path, "none", SLIDE, seed=11)
    c = compare_models(e, trials, seed=4, evidence=method, draws=1000, live_points=200)
    m = c.models
    ln_b = m["narrow"]["log_evidence"] - m["wide"]["log_evidence"]
    se = math.hypot(m["narrow"]["log_evidence_se"], m["wide"]["log_evidence_se"])
    assert m["narrow"]["evidence_method"].startswith(
        "grid" if method == "grid" else "nested sampling (dynesty")
    assert abs(ln_b - math.log(2.0)) < (1e-3 if method == "grid" else 3 * se), (ln_b, se)
    assert c.verdict["strength"].startswith("cannot tell apart")  # 2 ln B = 1.39 < 2
