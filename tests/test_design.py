"""Experiment design: standard errors from the camera, the sliding/rolling boundary, predicted
posterior widths against widths obtained on fresh campaigns, and the ``design`` command."""

import json
import math
import tomllib

import numpy as np
import pytest

import bouncebayes as bb
from bouncebayes.cli import main
from bouncebayes.data import make_trials, parse_experiment, synthesize
from bouncebayes.design import (DesignSpace, information_gain, kinematics_errors,
                                p_mu_identified, run_design, sliding_boundary)
from bouncebayes.inference import GridConfig, infer
from bouncebayes.kinematics import fit_kinematics, trajectory_from_arrays

PAPER = "examples/paper.toml"


def paper_doc(**priors):
    with open(PAPER, "rb") as f:
        doc = tomllib.load(f)
    for name, (low, high) in priors.items():
        doc["parameters"][name] = {"prior": "uniform", "low": low, "high": high}
    return doc


def fitted(campaign):
    """Kinematics of every trajectory of a synthetic campaign, by the kinematics stage."""
    return [fit_kinematics(trajectory_from_arrays(*t.T)) for t in campaign.trajectories]


def test_camera_errors_match_the_scatter_of_fitted_kinematics():
    # expected value: the empirical scatter of the fitted incidence and rebound speeds and
    # angles around the simulated truth over 60 independent trajectories (an independent
    # estimate of the same standard errors; its own sampling error is about 9 %)
    exp = parse_experiment(paper_doc(), source="test")
    se = kinematics_errors(exp, seed=3, n=16)
    campaign = synthesize(exp, seed=4, n=60)
    truth = campaign.truth["per_bounce"]
    ks = fitted(campaign)
    for column in ("incidence_speed", "incidence_angle", "rebound_speed", "rebound_angle"):
        errors = np.array([getattr(k, column) for k in ks]) - np.array(truth[column])
        assert se[column] == pytest.approx(np.std(errors, ddof=1), rel=0.3), column
    # position noise scales the errors linearly (the delta method on a linear fit)
    doc = paper_doc()
    doc["synth"]["position_noise_m"] *= 4
    se4 = kinematics_errors(parse_experiment(doc, source="test"), seed=3, n=16)
    assert se4["rebound_speed"] / se["rebound_speed"] == pytest.approx(4.0, rel=0.15)


def test_sliding_boundary_matches_the_rigid_body_condition():
    # closed form (impulse balance of a solid sphere, inertia factor 2/5): a bounce slides
    # throughout when mu J_n < (2/7) m u, u = V sin(theta) the incident tangential speed and
    # J_n = m (v_n (1 + e) + g t_c) the surface's normal impulse (restitution e of that bounce,
    # gravity over the contact time t_c); so tan(theta*) = 3.5 mu (1 + e + g t_c / v_n)
    exp = parse_experiment(paper_doc(), source="test")
    angle = sliding_boundary(exp, 0.16, 1.35, 3.0)
    r = bb.simulate(exp.ball, mu=0.16, eta=1.35, speed=3.0, angle=angle)
    vn_in = 3.0 * math.cos(math.radians(angle))
    e = float(r.rebound_speed * np.cos(np.radians(r.rebound_angle))) / vn_in
    gravity = exp.gravity * float(r.contact_time) / vn_in
    assert math.tan(math.radians(angle)) == pytest.approx(3.5 * 0.16 * (1 + e + gravity),
                                                          rel=1e-4)
    # below the boundary mu cannot be identified from bounces at the nominal incidence
    p = p_mu_identified(exp, (angle - 10, 3.0, 1000.0, 2e-4), (10,), seed=1)
    assert p[10] < p_mu_identified(exp, (angle + 30, 3.0, 1000.0, 2e-4), (10,), seed=1)[10]


def test_information_gain_of_a_gaussian_posterior():
    # closed form: KL(N(m, s^2) || U(a, b)) = log((b - a) / (s sqrt(2 pi e)))
    from bouncebayes.data import Uniform
    from bouncebayes.inference import GridDensity

    c = np.linspace(0.4, 0.6, 2001)
    s = 0.01
    density = np.exp(-0.5 * ((c - 0.5) / s) ** 2) / (s * math.sqrt(2 * math.pi))
    grid = GridDensity((c,), density, (density,))
    expected = math.log(1.0 / (s * math.sqrt(2 * math.pi * math.e)))
    assert information_gain(grid, (Uniform(0.0, 1.0),)) == pytest.approx(expected, rel=1e-4)


def fresh_width(doc, angle, n, rng):
    """Posterior sd of a fresh campaign: truth from the prior, trajectories at the camera's
    rate and noise, the kinematics stage's own trial table and errors, the grid posterior."""
    d = json.loads(json.dumps(doc))
    d["incidence"]["angle_deg"] = angle
    prior = parse_experiment(d, source="test").priors
    d["contact"] |= {k: float(p.sample(rng, 1)[0]) for k, p in prior.items()}
    exp = parse_experiment(d, source="test")
    ks = fitted(synthesize(exp, seed=int(rng.integers(2**31)), n=n))
    cols = ("rebound_speed", "rebound_angle", "incidence_speed", "incidence_angle")
    trials = make_trials(exp, **{c: np.array([getattr(k, c) for k in ks]) for c in cols},
                         se={c: np.array([getattr(k, c + "_se") for k in ks]) for c in cols})
    r = infer(exp, trials, sampler="grid", seed=int(rng.integers(2**31)), noise="given",
              config=GridConfig(draws=100, points=64))
    return dict(zip(r.names, r.draws.info.exact_sd, strict=True))


def test_predicted_widths_agree_with_fresh_campaigns_at_three_designs():
    # expected value: the mean posterior sd over 8 fresh campaigns per design made with the
    # kinematics stage on simulated trajectories (not with the design's error model), truths
    # drawn afresh from the same prior; agreement required within 20 %. The three designs are
    # in the sliding regime on purpose: where bounces roll, the sd of mu is the spread of a
    # posterior flat up to the prior's bound (the design reports the probability that mu is
    # identified for that), and its mean over 8 campaigns is dominated by which truths roll,
    # not by the design's error model that this test checks
    doc = paper_doc(mu=(0.05, 0.2), eta=(0.5, 3.0))
    exp = parse_experiment(doc, source="test")
    space = DesignSpace.for_experiment(exp, angles_deg=(55.0, 65.0, 75.0), n_bounces=(20,),
                                       campaigns=8)
    result = run_design(doc, space, seed=5, scheduler="serial")
    rng = np.random.default_rng(20240501)
    for design in result["designs"]:
        fresh = [fresh_width(doc, design["angle_deg"], 20, rng) for _ in range(8)]
        for name in ("mu", "eta"):
            obtained = float(np.mean([f[name] for f in fresh]))
            assert design["expected_sd"][name] == pytest.approx(obtained, rel=0.2), (
                design["angle_deg"], name)
    assert result["method"].startswith("simulated campaigns")


def test_design_command_writes_json_figure_and_resumes(tmp_path, capsys):
    out = tmp_path / "design"
    argv = ["design", PAPER, "--out", str(out), "--angles", "40,75", "--bounces", "5,10",
            "--campaigns", "2", "--scheduler", "serial", "--target", "mu=0.02", "--quiet"]
    assert main(argv) == 0
    doc = json.loads((out / "design.json").read_text())
    assert len(doc["designs"]) == 4
    d = doc["designs"][0]
    for key in ("angle_deg", "speed_m_s", "n_bounces", "expected_sd", "p_mu_identified",
                "information_gain", "cost", "standard_errors"):
        assert key in d
    assert set(d["expected_sd"]) == {"mu", "eta"}
    # at 40 deg most prior draws of mu (0-0.5) roll; at 75 deg nearly all slide
    assert doc["designs"][0]["p_mu_identified"] < 0.5 < doc["designs"][-1]["p_mu_identified"]
    rec = doc["recommended"]["design"]
    assert rec is not None and rec["expected_sd"]["mu"] <= 0.02
    assert all(x["cost"] >= rec["cost"] for x in doc["designs"] if x["reaches_targets"])
    assert "Fisher" in doc["method"] and doc["provenance"]["seed"] == 0
    assert (out / "design.png").read_bytes()[:4] == b"\x89PNG" and (out / "design.svg").exists()
    stored = sorted(out.glob("campaigns-*/*.json"))
    assert len(stored) == 4
    mtimes = [p.stat().st_mtime_ns for p in stored]
    assert main(argv) == 0  # a rerun takes every campaign from the store
    assert [p.stat().st_mtime_ns for p in stored] == mtimes
    assert json.loads((out / "design.json").read_text())["designs"] == doc["designs"]
    capsys.readouterr()


def test_design_refuses_bad_input(tmp_path, capsys):
    assert main(["design", PAPER, "--out", str(tmp_path), "--target", "nu=0.1",
                 "--scheduler", "serial"]) == 2
    assert "`--target` names 'nu', which is not inferred" in capsys.readouterr().err
    assert main(["design", PAPER, "--out", str(tmp_path), "--angles", "95"]) == 2
    assert "`--angles` must be numbers in (0, 90); got 95.0" in capsys.readouterr().err
