"""Propagation of the posterior: bounce summaries, histories, predictive check, failures."""

import numpy as np
import pytest

import bouncebayes as bb
from bouncebayes.propagation import compare, hellinger, load_propagation, propagate
from bouncebayes.report import load_result


@pytest.fixture(scope="module")
def result(small_run):
    return load_result(small_run.folder)


def test_propagation_summary_and_files(small_run):
    import json

    s = json.loads((small_run.folder / "propagation.json").read_text())
    at = s["at_nominal_incidence"]
    for key, unit in (("rebound_speed", "m/s"), ("contact_time", "s"),
                      ("peak_normal_force", "N"), ("peak_friction_force", "N")):
        assert at[key]["unit"] == unit and at[key]["ci90"][0] <= at[key]["mean"]
    assert s["n_failed"] == 0
    assert s["posterior_predictive_match"]["reproduces_data"] is True
    prop = load_propagation(small_run.folder)
    assert prop.histories["x"].shape[0] == 100
    assert np.isfinite(prop.predicted_speed).all()


def test_propagated_bounces_are_the_model_at_the_draws(result):
    """The propagated rebound of each draw is bb.simulate at that draw (same model)."""
    prop = propagate(result, n_draws=50, n_histories=3)
    e = result.experiment
    again = bb.simulate(e.ball, mu=prop.theta["mu"], eta=prop.theta["eta"],
                        speed=e.incidence.speed, angle=e.incidence.angle)
    np.testing.assert_array_equal(prop.bounces.rebound_speed, again.rebound_speed)
    assert prop.histories["normal_force"].shape[0] == 3
    # the same seed gives the same subset
    assert np.array_equal(propagate(result, n_draws=50, n_histories=0).theta["mu"],
                          prop.theta["mu"])


def test_failures_are_counted_not_fatal(result):
    """Draws that cannot bounce (damping that stops the ball) are counted and reported."""
    from dataclasses import replace

    samples = result.draws.samples.copy()
    samples[..., result.names.index("eta")] = 5000.0  # far beyond critical: no separation
    broken = replace(result, draws=replace(result.draws, samples=samples))
    prop = propagate(broken, n_draws=20, n_histories=2)
    assert prop.n_failed == 20 + 20 + 2
    assert "NO_SEPARATION" in prop.failures


def test_hellinger_closed_form_and_compare_verdicts():
    """Hellinger distance of two normals N(0,1), N(d,1): sqrt(1 - exp(-d^2/8)) (closed form);
    the KDE estimate from large samples is within 0.03."""
    rng = np.random.default_rng(3)
    a, b = rng.normal(0, 1, 20000), rng.normal(1.0, 1, 20000)
    assert hellinger(a, b) == pytest.approx(np.sqrt(1 - np.exp(-1 / 8)), abs=0.03)
    assert hellinger(a, rng.normal(0, 1, 20000)) < 0.05
    trials = bb.data.make_trials(bb.load_experiment(bb.data.demo_campaign().experiment),
                                 rebound_speed=rng.normal(2.5, 0.05, 55),
                                 rebound_angle=rng.normal(58, 1.0, 55))
    good = compare(trials, rng.normal(2.5, 0.05, 2000), rng.normal(58, 1.0, 2000))
    assert good["reproduces_data"] and "reproduces" in good["verdict"]
    bad = compare(trials, rng.normal(2.3, 0.05, 2000), rng.normal(58, 1.0, 2000))
    assert not bad["reproduces_data"]
    assert "does not reproduce the measured rebound speed" in bad["verdict"]
