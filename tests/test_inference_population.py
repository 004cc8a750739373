"""The population (hierarchical) likelihood: exact quadrature, recovery, honesty, outputs.

Where the expected values come from:

- the hat-function weights against an independent quadrature (``scipy.integrate.quad``) of the
  piecewise-linear interpolant times ``scipy.stats.truncnorm`` / ``scipy.stats.lognorm``
  densities, and against ``numpy.interp`` at zero spread (the closed form's limit);
- each trial's marginal likelihood against an independent Monte Carlo integral: parameters
  drawn from ``scipy.stats.truncnorm``, the gaussian likelihood evaluated by the model directly
  at each draw (no grid), averaged;
- synthetic campaigns with known truth: the demo campaign (no bounce-to-bounce spread: the
  spread's posterior must pile at zero and the mean agree with the gaussian likelihood's
  posterior within their sds), and a campaign with spread but no measurement noise (the
  population's spread must cover the sample sd of the true per-bounce parameters);
- the rolling threshold of the rigid-body limit (docs/model.md): at 30 deg incidence a bounce
  with mu above (2/7) tan(30 deg) / (1 + e) ~ 0.09 leaves rolling, so mu is only bounded.

Runs are kept short (reduced draws, a few trials where the sampler does not matter).
"""

from __future__ import annotations

import dataclasses
import json
import math
import tomllib

import numpy as np
import pytest
from scipy import integrate, stats

from bouncebayes.cli import main
from bouncebayes.data import demo_campaign, load_trials, make_trials, parse_experiment, synthesize
from bouncebayes.inference import MemoryBudgetError, MHConfig, infer, write_outputs
from bouncebayes.inference._likelihood import make_likelihood
from bouncebayes.inference._population import hat_weights, make_population
from bouncebayes.report import load_result
from demo_experiment import experiment

DEMO = demo_campaign()
FAST = MHConfig(draws=3000, chains=4, burn_in=1500, thin=2)


@pytest.fixture(scope="module")
def demo():
    e = experiment()
    return e, load_trials(DEMO.trials, e)


@pytest.fixture(scope="module")
def demo_population(demo):
    e, t = demo
    return infer(e, t, likelihood="population", sampler="mh", config=FAST, seed=3)


@pytest.mark.parametrize("family", ["normal", "lognormal"])
@pytest.mark.parametrize("mean,sd", [(0.16, 0.02), (0.03, 0.05), (0.33, 0.3), (0.2, 0.0)])
def test_hat_weights_integrate_the_interpolant_exactly(family, mean, sd):
    nodes = np.linspace(0.05, 0.4, 36)
    values = np.sin(20 * nodes) + 2
    w = hat_weights(nodes, (0.0, 0.5), np.array([mean]), np.array([sd]), family)[0]
    if sd == 0:  # a point mass: the interpolant at the mean
        assert w @ values == pytest.approx(np.interp(mean, nodes, values), abs=1e-12)
        return
    if family == "normal":
        dist = stats.truncnorm(-mean / sd, (0.5 - mean) / sd, loc=mean, scale=sd)
        pdf = dist.pdf
    else:
        s2 = math.log1p((sd / mean) ** 2)
        base = stats.lognorm(math.sqrt(s2), scale=mean * math.exp(-0.5 * s2))
        mass = base.cdf(0.5) - base.cdf(0.0)

        def pdf(x):
            return base.pdf(x) / mass
    want = sum(integrate.quad(lambda x: np.interp(x, nodes, values) * pdf(x), a, b,
                              epsabs=1e-13, epsrel=1e-12)[0]
               for a, b in zip(nodes[:-1], nodes[1:], strict=True))
    assert w @ values == pytest.approx(want, abs=1e-9)


def test_trial_marginal_likelihood_matches_monte_carlo(demo):
    """Each trial's likelihood integrated against the population, by the grid, against plain
    Monte Carlo over the population with the model evaluated at every draw."""
    e, t = demo
    pick = np.arange(0, t.n, 9)
    sub = dataclasses.replace(t, **{k: getattr(t, k)[pick] for k in (
        "rebound_speed", "rebound_angle", "incidence_speed", "incidence_angle",
        "incidence_spin", "scale_rel_sd")}, labels=tuple(t.labels[i] for i in pick),
        se={k: np.asarray(v)[pick] for k, v in t.se.items()})
    like = make_population(e, sub, ("mu", "eta"))
    hyper = np.array([[0.155, 0.012, 1.3, 0.3]])
    got = like.pointwise(hyper)[0]
    gauss = make_likelihood("gaussian", e, sub, ("mu", "eta"), rng=np.random.default_rng(0),
                            noise="given")
    rng = np.random.default_rng(7)
    n = 40_000
    mu = stats.truncnorm.rvs(-0.155 / 0.012, (0.5 - 0.155) / 0.012, loc=0.155, scale=0.012,
                             size=n, random_state=rng)
    eta = stats.truncnorm.rvs(-1.3 / 0.3, (5 - 1.3) / 0.3, loc=1.3, scale=0.3, size=n,
                              random_state=rng)
    terms = gauss.pointwise(np.column_stack([mu, eta])).terms  # (n, trials)
    peak = terms.max(axis=0)
    ratio = np.exp(terms - peak)
    want = peak + np.log(ratio.mean(axis=0))
    se = ratio.std(axis=0) / math.sqrt(n) / ratio.mean(axis=0)  # relative MC error
    assert np.all(np.abs(got - want) < 4 * se + 0.01), (got - want, se)


@pytest.mark.parametrize("hyper", [[0.155, 0.02, 1.4, 0.4], [0.16, 0.004, 1.3, 0.05]])
def test_trial_marginal_likelihood_matches_fine_quadrature(demo, hyper):
    """One trial's likelihood integrated against the population, by the package's grid (129
    nodes per parameter), against an independent trapezoid rule on 1201 x 1201 points of the
    gaussian likelihood times scipy.stats.truncnorm densities: equal within the grid's stated
    error (hundredths of a nat at most)."""
    e, t = demo
    one = make_trials(e, rebound_speed=t.rebound_speed[:1], rebound_angle=t.rebound_angle[:1],
                      incidence_speed=t.incidence_speed[:1], incidence_angle=t.incidence_angle[:1],
                      se={k: np.asarray(t.se[k])[:1] for k in ("rebound_speed", "rebound_angle",
                                                              "incidence_speed",
                                                              "incidence_angle")})
    got = make_population(e, one, ("mu", "eta")).pointwise(np.array([hyper]))[0, 0]
    gauss = make_likelihood("gaussian", e, one, ("mu", "eta"), rng=np.random.default_rng(0),
                            noise="given")
    m0, s0, m1, s1 = hyper
    mu = np.linspace(max(0.0, m0 - 8 * s0), m0 + 8 * s0, 1201)
    eta = np.linspace(max(0.0, m1 - 8 * s1), m1 + 8 * s1, 1201)
    grid_mu, grid_eta = np.meshgrid(mu, eta, indexing="ij")
    ll = gauss.pointwise(np.column_stack([grid_mu.ravel(), grid_eta.ravel()])).terms[:, 0]
    ll = ll.reshape(grid_mu.shape)
    p_mu = stats.truncnorm.pdf(mu, -m0 / s0, (0.5 - m0) / s0, loc=m0, scale=s0)
    p_eta = stats.truncnorm.pdf(eta, -m1 / s1, (5 - m1) / s1, loc=m1, scale=s1)
    peak = ll.max()
    inner = integrate.trapezoid(np.exp(ll - peak) * p_eta[None, :], eta, axis=1)
    want = peak + math.log(integrate.trapezoid(inner * p_mu, mu))
    assert got == pytest.approx(want, abs=0.005)  # found: 5e-4 and 3e-4 nat


def test_zero_spread_campaign_piles_the_spread_at_zero(demo, demo_population):
    """The demo campaign has no bounce-to-bounce spread: each spread is an upper bound, and
    the population mean agrees with the gaussian likelihood's single value."""
    e, t = demo
    r = demo_population
    p = {s.name: s for s in r.parameters}
    assert p["mu_sd"].bound is not None and p["mu_sd"].bound["side"] == "upper"
    assert "<" in p["mu_sd"].paper_form()
    gauss = infer(e, t, likelihood="gaussian", sampler="grid", seed=3)
    g = {s.name: s for s in gauss.parameters}
    for name in ("mu", "eta"):
        m = p[f"{name}_mean"]
        assert abs(m.mean - g[name].mean) < 1.5 * max(m.sd, g[name].sd), name
    # what a DEM user samples from: centred on the truth, narrow
    pred = r.population.record["predictive"]["mu"]
    assert pred["quantiles"]["5%"] < 0.16 < pred["quantiles"]["95%"]
    assert r.adequacy.adequate


def test_scatter_without_noise_recovers_the_population():
    """Bounces with real spread of mu and eta and no measurement noise: the population's spread
    covers the sample spread of the true per-bounce parameters."""
    e = experiment(synth__mu_sd=0.03, synth__eta_sd=0.3, synth__rebound_speed_noise_m_s=0.0,
                   synth__rebound_angle_noise_deg=0.0, synth__incidence_speed_noise_m_s=0.0,
                   synth__incidence_angle_noise_deg=0.0, incidence__angle_sd_deg=0.0,
                   incidence__speed_sd_m_s=0.0)
    c = synthesize(e, seed=11, n=40)
    t = c.trials
    se = {"rebound_speed": np.full(t.n, 0.004), "rebound_angle": np.full(t.n, 0.1)}
    t = make_trials(e, rebound_speed=t.rebound_speed, rebound_angle=t.rebound_angle,
                    incidence_speed=t.incidence_speed, incidence_angle=t.incidence_angle,
                    se=se, labels=t.labels)
    r = infer(e, t, likelihood="population", sampler="mh", config=FAST, seed=1)
    truth = c.truth["per_bounce"]
    for name in ("mu", "eta"):
        x = np.asarray(truth[name])
        s = next(p for p in r.parameters if p.name == f"{name}_sd")
        m = next(p for p in r.parameters if p.name == f"{name}_mean")
        assert s.ci90[0] < np.std(x, ddof=1) < s.ci90[1], (name, s.ci90, np.std(x, ddof=1))
        assert m.ci90[0] < np.mean(x) < m.ci90[1], (name, m.ci90, np.mean(x))
        assert s.bound is None
    # the population's predictive 90 % range covers most of the true per-bounce values
    pred = r.population.record["predictive"]["mu"]["quantiles"]
    mu = np.asarray(truth["mu"])
    inside = np.mean((mu >= pred["5%"]) & (mu <= pred["95%"]))
    assert inside > 0.75


def test_rolling_population_gives_a_bound_on_mu_in_words():
    """At 30 deg incidence the bounces of mu = 0.16 leave rolling: mu's population is bounded
    from below, not given as an interval, and the words say why."""
    e = experiment(incidence__angle_deg=30.0, synth__mu_sd=0.0, synth__eta_sd=0.0)
    t = synthesize(e, seed=4, n=30).trials
    r = infer(e, t, likelihood="population", sampler="mh", config=FAST, seed=2)
    p = {s.name: s for s in r.parameters}
    assert p["mu_mean"].bound is not None and p["mu_mean"].bound["side"] == "lower"
    assert ">" in p["mu_mean"].paper_form() and "±" not in p["mu_mean"].paper_form()
    assert not p["mu_sd"].identifiable
    words = r.population.record["predictive"]["mu"]["statement"]
    assert "rolling" in words and "from below" in words
    assert r.population.record["share_of_bounces_rolling"] > 0.95
    # eta is still measured
    assert p["eta_mean"].bound is None


def test_refusals_say_why(demo):
    e, t = demo
    with pytest.raises(ValueError, match="noise given"):
        infer(e, t, likelihood="population", noise="inferred")
    with pytest.raises(ValueError, match="discrepancy"):
        infer(e, t, likelihood="population", discrepancy="normal")
    e3 = experiment()
    doc = tomllib.loads(DEMO.experiment.read_text(encoding="utf-8"))
    doc["parameters"]["youngs_modulus"] = {"prior": "uniform", "low": 1e6, "high": 1e7}
    e3 = parse_experiment(doc)
    with pytest.raises(ValueError, match="1 or 2 inferred parameters"):
        infer(e3, load_trials(DEMO.trials, e3), likelihood="population")
    # 55 trials x 129 x 129 nodes x 25 bytes (likelihoods, factors, flags) = 21.8 MiB
    with pytest.raises(MemoryBudgetError, match="integration grid"):
        infer(e, t, likelihood="population", memory_budget=20_000_000)
    no_se = make_trials(e, rebound_speed=t.rebound_speed, rebound_angle=t.rebound_angle)
    with pytest.raises(ValueError, match="standard errors"):
        infer(e, no_se, likelihood="population")


def test_outputs_name_the_hyper_parameters_and_reload(demo_population, tmp_path):
    r = demo_population
    write_outputs(r, tmp_path)
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert set(summary["parameters"]) == {"mu_mean", "mu_sd", "eta_mean", "eta_sd"}
    assert summary["likelihood"] == "population"
    pop = summary["population"]
    assert set(pop["predictive"]) == {"mu", "eta"}
    assert pop["quadrature_error_log_likelihood"]["variation_over_draws"] < 0.1
    import xarray as xr

    with xr.open_datatree(tmp_path / "posterior.nc") as tree:
        assert {"mu", "eta"} <= set(tree["population_predictive"].data_vars)
        assert tree["bounces"]["mu_shrinkage"].shape == (r.trials.n,)
        assert tree["log_likelihood"]["rebound"].shape[-1] == r.trials.n
    # per-trial log-likelihood: leave-one-out applies (how well the population predicts a
    # bounce left out), one pointwise term per trial
    from bouncebayes.compare import loo_of

    loo = loo_of(r)
    assert loo.pareto_k.values.size == r.trials.n and np.isfinite(loo.elpd)
    back = load_result_from(tmp_path, r)
    assert back.population is not None
    np.testing.assert_array_equal(back.population.predictive, r.population.predictive)


def load_result_from(folder, r):
    from bouncebayes.inference import load_inference

    summary = json.loads((folder / "summary.json").read_text())
    return load_inference(folder / "posterior.nc", summary, r.experiment, r.trials)


def test_experiment_file_and_cli_choose_the_population(tmp_path, capsys):
    """``likelihood = "population"`` in the experiment file and ``--population lognormal`` on
    the command line reach the inference (a 12-trial table keeps it short)."""
    text = DEMO.experiment.read_text(encoding="utf-8").replace(
        'likelihood = "gaussian"', 'likelihood = "population"')
    exp = tmp_path / "experiment.toml"
    exp.write_text(text, encoding="utf-8")
    lines = DEMO.trials.read_text(encoding="utf-8").splitlines()
    table = tmp_path / "trials.csv"
    table.write_text("\n".join(lines[:13]) + "\n", encoding="utf-8")
    out = tmp_path / "out"
    code = main(["infer", str(exp), str(table), "--out", str(out), "--draws", "400",
                 "--population", "lognormal", "--quiet"])
    assert code == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["likelihood"] == "population"
    assert summary["population"]["family"] == "lognormal"
    # no --sampler: the population likelihood's default, the ensemble sampler
    assert summary["sampler"] == "ensemble"
    # bounces without spread: the population mean agrees with the gaussian likelihood's value
    e = experiment()
    gauss = infer(e, load_trials(table, e), likelihood="gaussian", sampler="grid", seed=1)
    g = gauss.parameters[gauss.names.index("mu")]
    m = summary["parameters"]["mu_mean"]
    assert abs(m["mean"] - g.mean) < 1.5 * max(m["sd"], g.sd)
    assert "mu_sd" in capsys.readouterr().out


def test_report_shows_the_population(tmp_path):
    from bouncebayes.pipeline import run

    out = tmp_path / "run"
    outcome = run(DEMO.experiment, DEMO.trials, out, likelihood="population",
                  config=MHConfig(draws=400, burn_in=2000), log=lambda s: None)
    html = (out / "report.html").read_text(encoding="utf-8")
    assert "population" in html.lower()
    assert (out / "figures" / "population.png").is_file()
    from bouncebayes.plots import plot_population

    fig = plot_population(outcome.result)
    for ax in fig.axes:  # units on the axes, a legend
        assert ax.get_xlabel() and "probability density" in ax.get_ylabel()
        assert ax.get_legend() is not None
    assert "(kg/s)" in fig.axes[1].get_xlabel()
    assert load_result(out).population is not None
    assert outcome.result.population is not None


def test_stored_sbc_study_is_calibrated():
    """benchmarks/results/population_sbc.json (``python benchmarks/population_sbc.py``, the
    default ensemble sampler): at least 200 campaigns; 90 % coverage inside the 99 % binomial
    band and rank histograms uniform (chi-square p > 0.01) for every hyper-parameter over all
    campaigns, and coverage inside its band over the first 200 too (their ranks for mu_mean sit
    at p = 0.010, on the test's edge: docs/likelihoods.md §6 gives every number)."""
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "benchmarks" / "results" / "population_sbc.json"
    result = json.loads(path.read_text(encoding="utf-8"))
    assert result["campaigns_done"] >= 200
    assert "ensemble" in result["settings"]["sampler"]
    lo, hi = result["coverage_bounds_99"]
    first = result["first_campaigns"]
    for name in ("mu_mean", "mu_sd", "eta_mean", "eta_sd"):
        assert lo <= result["parameters"][name]["coverage90"] <= hi, name
        assert result["parameters"][name]["chi2_p_value"] > 0.01, name
        assert first["parameters"][name]["coverage_ok"], name


def test_a_flag_of_another_sampler_names_the_likelihoods_default(tmp_path, capsys):
    """Without ``--sampler`` the population likelihood runs the ensemble sampler; an mh-only
    flag is refused naming that default and how to choose another."""
    code = main(["infer", str(DEMO.experiment), str(DEMO.trials), "--out", str(tmp_path / "o"),
                 "--likelihood", "population", "--chains", "3", "--quiet"])
    assert code == 2
    err = capsys.readouterr().err
    assert "`--chains` applies to the mh sampler" in err
    assert "the ensemble sampler (the likelihood's default" in err
    assert not (tmp_path / "o").exists()
