"""Propagation of the posterior: bounce summaries, histories, predictive check, failures."""

import numpy as np
import pytest

import bouncebayes as bb
from bouncebayes.inference import distribution_check, hellinger
from bouncebayes.propagation import load_propagation, propagate
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
    assert prop.n_failed == 20 + 2  # the bounces and the histories (the predictive is reused)
    assert "NO_SEPARATION" in prop.failures


def test_hellinger_quadrature_grid_is_as_fine_as_the_kdes_need():
    """The quadrature grid follows the smaller bandwidth (steps of h / 4): the distance equals
    the one on a grid of 20,000 points (the expected value, by the same KDEs) to 1e-9, for
    samples of similar and of very different widths."""
    from scipy import integrate, stats

    rng = np.random.default_rng(4)
    for a, b in ((rng.normal(0, 1, 5000), rng.normal(0.5, 1, 55)),
                 (rng.gamma(2.0, 1.0, 5000), rng.normal(3.0, 0.02, 55))):
        lo, hi = min(a.min(), b.min()), max(a.max(), b.max())
        pad = 0.25 * (hi - lo)
        x = np.linspace(lo - pad, hi + pad, 20_000)
        bc = integrate.trapezoid(np.sqrt(stats.gaussian_kde(a)(x) * stats.gaussian_kde(b)(x)), x)
        assert hellinger(a, b) == pytest.approx(np.sqrt(1 - min(bc, 1.0)), abs=1e-9)


def test_hellinger_closed_form_and_distribution_check():
    """Hellinger distance of two normals N(0,1), N(d,1): sqrt(1 - exp(-d^2/8)) (closed form);
    the KDE estimate from large samples is within 0.03. The KS test of the distribution check
    tells a shift of 4 sd of the mean of 55 values from none."""
    rng = np.random.default_rng(3)
    a, b = rng.normal(0, 1, 20000), rng.normal(1.0, 1, 20000)
    assert hellinger(a, b) == pytest.approx(np.sqrt(1 - np.exp(-1 / 8)), abs=0.03)
    assert hellinger(a, rng.normal(0, 1, 20000)) < 0.05
    observed = {"rebound_speed": rng.normal(2.5, 0.05, 55),
                "rebound_angle": rng.normal(58, 1.0, 55)}
    good = distribution_check(observed, {"rebound_speed": rng.normal(2.5, 0.05, 2000),
                                         "rebound_angle": rng.normal(58, 1.0, 2000)})
    assert good["rebound_speed"]["ks_p_value"] > 0.01
    bad = distribution_check(observed, {"rebound_speed": rng.normal(2.3, 0.05, 2000),
                                        "rebound_angle": rng.normal(58, 1.0, 2000)})
    assert bad["rebound_speed"]["ks_p_value"] < 1e-6
    assert bad["rebound_speed"]["predicted_mean"] == pytest.approx(2.3, abs=0.01)


def test_the_predictive_is_the_inferences_replicates(result):
    """Propagation reuses the replicated rebounds of posterior.nc (pooled), and its verdict is
    the inference's adequacy verdict."""
    from bouncebayes.propagation import predictive

    speed, _ = predictive(result)
    assert speed.size == result.replicates.rebound_speed.size
    prop = propagate(result, n_draws=20, n_histories=0)
    assert prop.match["verdict"] == result.adequacy.verdict


def test_predictions_of_the_runs_own_bounces_are_calibrated(result, tmp_path):
    """Predicting the campaign's own bounces at their incidences: the PIT values of the
    measured rebounds are uniform for a calibrated predictive (Dawid 1984; KS test against
    U(0, 1)); the model's spin at each draw is ``bb.simulate`` at that draw (same model, an
    independent call)."""
    from scipy import stats

    from bouncebayes.propagation import predict_bounces, write_predictions

    pred = predict_bounces(result, result.trials, n_draws=400)
    cols = pred.columns
    for name in ("rebound_speed", "rebound_angle"):
        pit = cols[f"{name}_pit"]
        assert stats.kstest(pit, "uniform").pvalue > 1e-3
        assert np.all(cols[f"{name}_q05"] <= cols[f"{name}_q50"])
        assert np.all(cols[f"{name}_q50"] <= cols[f"{name}_q95"])
    assert np.all(cols["contact_time_mean"] > 0) and np.all(cols["share_rolling"] == 0)
    assert "each row's stated standard errors" in pred.includes
    path = write_predictions(pred, tmp_path / "p.csv", {"bouncebayes_version": "x"})
    lines = path.read_text().splitlines()
    assert lines[0].startswith("# provenance: ") and lines[1].startswith("trial,incidence_speed")
    assert len(lines) == 2 + result.trials.n


def test_predictions_without_measured_rebounds_and_the_spread_of_the_draws(result):
    """Rows with an incidence only: no PIT columns. Without noise terms (no standard errors,
    no inferred noise or discrepancy) the spin's quantiles are those of the model at the
    draws."""
    from bouncebayes.data import make_trials
    from bouncebayes.propagation import draw_subset, predict_bounces

    e = result.experiment
    rows = make_trials(e, rebound_speed=np.full(2, np.nan), rebound_angle=np.full(2, np.nan),
                       incidence_speed=[2.0, 4.0], incidence_angle=[30.0, 70.0])
    pred = predict_bounces(result, rows, n_draws=300, seed=5)
    assert "rebound_speed_pit" not in pred.columns
    theta = draw_subset(result, 300, np.random.default_rng([5, 2]).spawn(2)[0])
    again = bb.simulate(e.ball, mu=theta["mu"], eta=theta["eta"], speed=4.0, angle=70.0)
    assert pred.columns["rebound_spin_q50"][1] == pytest.approx(
        np.median(again.rebound_spin), rel=1e-9)
    # the faster, more oblique bounce rebounds faster
    assert pred.columns["rebound_speed_mean"][1] > pred.columns["rebound_speed_mean"][0]
