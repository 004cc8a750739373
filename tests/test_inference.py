"""Bayesian calibration (``bouncebayes.inference``): recovery, determinism, honesty, outputs.

Where the expected values come from:

- the truth of synthetic campaigns (``bouncebayes.data.synthesize`` with the ``[contact]`` values
  of the experiment: the paper's mu = 0.16, eta = 1.35 kg/s at 3 m/s and 60 deg, and a second
  point mu = 0.10, eta = 2.5 kg/s at 45 deg), and the realised noise of the campaign
  (``truth["per_bounce"]`` against the measured table);
- the exact grid posterior (quadrature of the normalised density) as the reference for the
  Monte Carlo samplers;
- the rolling threshold of mu, found by bisection on ``bouncebayes.simulate``;
- the kernel density estimate's own moments (sample variance + bandwidth^2) for the
  push-forward of the data-consistent posterior (Butler, Jakeman & Wildey 2018: the push-forward
  of the updated density is the observed density);
- ``1/sqrt(N)`` narrowing of a measurement-model posterior;
- SHA-256 of the input file computed here with ``hashlib``.

Runs are kept short (grid quadrature wherever the sampler does not matter, reduced draws
elsewhere); module-scoped fixtures share them between tests.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import tomllib

import numpy as np
import pytest
from scipy.special import logsumexp

import bouncebayes as bb
import bouncebayes.inference._outputs as outputs_module
from bouncebayes._errors import InputFileError
from bouncebayes.cli import main
from bouncebayes.data import demo_campaign, load_trials, make_trials, parse_experiment, synthesize
from bouncebayes.inference import (EnsembleConfig, GridConfig, LogPosterior, MemoryBudgetError,
                                   MHConfig, format_table, infer, sampler_config, write_outputs)
from bouncebayes.inference._forward import Forward
from bouncebayes.inference._grid_kernel import gaussian_grid
from bouncebayes.inference._likelihood import make_likelihood
from bouncebayes.inference._summary import (diagnostics, marginal_modes,
                                            summarize_parameter, warnings_for)
from demo_experiment import experiment

DEMO = demo_campaign()
PAPER_TRUTH = {"mu": 0.16, "eta": 1.35}
SECOND_TRUTH = {"mu": 0.10, "eta": 2.5}


def campaign(exp, seed: int, n: int = 55):
    c = synthesize(exp, seed=seed, n=n)
    assert c.truth["share_rolling"] in (0.0, 1.0)  # the tests below pick clean regimes
    return c


def covers(summary, value: float) -> bool:
    return summary.ci90[0] <= value <= summary.ci90[1]


def by_name(result, name):
    return result.parameters[result.names.index(name)]


def grid_moments(result):
    """Exact mean and sd of each parameter from the normalised grid density (no Monte Carlo)."""
    grid = result.draws.info.grid
    density = grid.density
    centres = [np.asarray(c) for c in grid.centres]
    cell = float(np.prod([c[1] - c[0] for c in centres]))
    out = {}
    for i, name in enumerate(result.names):
        axes = tuple(k for k in range(density.ndim) if k != i)
        marginal = density.sum(axis=axes) * cell  # probabilities of the cells along axis i
        mean = float(np.sum(marginal * centres[i]))
        out[name] = (mean, float(np.sqrt(np.sum(marginal * (centres[i] - mean) ** 2))))
    return out


# --------------------------------------------------------------------------- shared runs

@pytest.fixture(scope="module")
def paper():
    """A fresh 55-bounce campaign of the paper's setup (not the demo table) and its experiment."""
    exp = experiment()
    return exp, campaign(exp, seed=20161)


@pytest.fixture(scope="module")
def paper_grid(paper):
    exp, c = paper
    return infer(exp, c.trials, sampler="grid", seed=1, config=GridConfig(draws=4000))


# --------------------------------------------------------------------------- recovery

@pytest.mark.parametrize("truth, angle, seed", [(PAPER_TRUTH, 60.0, 20161),
                                                (SECOND_TRUTH, 45.0, 4502)])
def test_gaussian_interval_covers_the_truth_in_the_sliding_regime(truth, angle, seed):
    exp = experiment(contact__mu=truth["mu"], contact__eta=truth["eta"],
                     incidence__angle_deg=angle)
    c = campaign(exp, seed)
    assert c.truth["share_rolling"] == 0.0
    result = infer(exp, c.trials, sampler="grid", seed=2, config=GridConfig(draws=4000))
    for name, value in truth.items():
        p = by_name(result, name)
        assert covers(p, value), (name, p.ci90, value)
        assert p.identifiable
    assert result.regimes["share_rolling"] == 0.0
    assert result.warnings == ()


def test_gaussian_posterior_narrows_like_one_over_sqrt_n():
    # measurement model (docs/likelihoods.md, `gaussian`): 4x the bounces halve the posterior sd. The sd of a
    # 55-bounce posterior varies with the campaign by ~ 1/sqrt(2 * 55) ~ 10 %; 25 % allowed.
    exp = experiment()
    sd = {}
    for n in (40, 160):
        r = infer(exp, campaign(exp, seed=7, n=n).trials, sampler="grid",
                  config=GridConfig(draws=500, points=384))
        sd[n] = grid_moments(r)
    for name in ("mu", "eta"):
        assert sd[40][name][1] / sd[160][name][1] == pytest.approx(2.0, rel=0.25)


@pytest.fixture(scope="module")
def spread_results():
    """kde and consistent posteriors (grid) and the gaussian one, on the demo table."""
    exp = experiment()
    trials = load_trials(DEMO.trials, exp)
    config = GridConfig(draws=4000, points=256)
    return {lk: infer(exp, trials, likelihood=lk, sampler="grid", seed=3, config=config)
            for lk in ("kde", "consistent", "gaussian")}


@pytest.mark.parametrize("likelihood", ["kde", "consistent"])
def test_spread_likelihoods_contain_the_truth_and_stay_wide(spread_results, likelihood):
    # kde and consistent describe bounce-to-bounce scatter read as scatter of the parameters:
    # the truth (mu = 0.16, eta = 1.35 kg/s for every bounce of the demo) must lie inside, and
    # the interval is far wider than the measurement model's (which shrinks like 1/sqrt(N)).
    result, gauss = spread_results[likelihood], spread_results["gaussian"]
    for name, value in PAPER_TRUTH.items():
        p, g = by_name(result, name), by_name(gauss, name)
        assert covers(p, value), (name, p.ci90)
        assert (p.ci90[1] - p.ci90[0]) > 5 * (g.ci90[1] - g.ci90[0])
    assert result.summary()["likelihood_meaning"] == bb.inference.MEANINGS[likelihood]


def test_consistent_push_forward_reproduces_the_observed_density(spread_results):
    # Butler et al. (2018): the push-forward of the data-consistent posterior through the model
    # (nominal incidence) is the observed density, here a KDE whose variance per variable is
    # the sample variance plus the squared bandwidth.
    result = spread_results["consistent"]
    exp = experiment()
    trials = load_trials(DEMO.trials, exp)
    density = result.likelihood_info["observed_density"]
    inc = exp.incidence
    fwd = Forward(exp, result.names, speed=np.array([inc.speed]), angle=np.array([inc.angle]))
    r = fwd(result.draws.samples.reshape(-1, 2))
    for pushed, observed, h in ((r.speed[:, 0], trials.rebound_speed,
                                 density["bandwidth_speed_m_s"]),
                                (r.angle[:, 0], trials.rebound_angle,
                                 density["bandwidth_angle_deg"])):
        kde_sd = math.sqrt(np.var(observed, ddof=1) + h**2)
        # the means agree to ~0.07 sd here: the prior's push-forward density is itself a KDE
        # of 4000 prior draws, whose smoothing bias shifts the ratio; 0.2 sd allowed
        assert np.mean(pushed) == pytest.approx(np.mean(observed), abs=0.2 * kde_sd)
        assert np.std(pushed) == pytest.approx(kde_sd, rel=0.1)


def test_mh_ensemble_and_grid_means_agree(paper, paper_grid):
    # reference: the grid quadrature (exact up to the grid spacing, no Monte Carlo error).
    # Monte Carlo error of a mean with ESS >= 1000 is <= 0.03 sd, so 0.1 sd is > 3 sigma.
    exp, c = paper
    exact = grid_moments(paper_grid)
    mh = infer(exp, c.trials, sampler="mh", seed=4, config=MHConfig(draws=6000))
    ens = infer(exp, c.trials, sampler="ensemble", seed=4,
                config=EnsembleConfig(draws=20000, walkers=32, burn_in=200, thin=1))
    for result in (mh, ens, paper_grid):
        for name, (mean, sd) in exact.items():
            x = result.samples(name)
            assert abs(np.mean(x) - mean) < 0.1 * sd, (result.sampler, name)
            assert np.std(x) == pytest.approx(sd, rel=0.1), (result.sampler, name)
        assert by_name(result, "mu").mean == pytest.approx(np.mean(result.samples("mu")))


# --------------------------------------------------------------------------- determinism

@pytest.fixture(scope="module")
def small_table():
    """The first 12 bounces of the demo: enough for a posterior, cheap to evaluate."""
    exp = experiment()
    t = load_trials(DEMO.trials, exp)
    keep = slice(0, 12)
    return exp, make_trials(exp, rebound_speed=t.rebound_speed[keep],
                            rebound_angle=t.rebound_angle[keep],
                            incidence_speed=t.incidence_speed[keep],
                            incidence_angle=t.incidence_angle[keep],
                            se={k: v[keep] for k, v in t.se.items()
                                if np.all(np.isfinite(v))})


SMALL = {"mh": MHConfig(draws=400, burn_in=50),
         "ensemble": EnsembleConfig(draws=400, walkers=8, burn_in=50),
         "grid": GridConfig(draws=400, points=64)}


def _numbers(result) -> dict:
    out = result.summary()
    del out["seconds"]
    return out


@pytest.mark.parametrize("sampler", ["mh", "ensemble", "grid"])
def test_same_seed_same_draws_other_seed_other_draws(small_table, sampler):
    exp, trials = small_table
    a, b, other = (infer(exp, trials, sampler=sampler, seed=s, config=SMALL[sampler])
                   for s in (7, 7, 8))
    assert np.array_equal(a.draws.samples, b.draws.samples)
    assert json.dumps(_numbers(a)) == json.dumps(_numbers(b))
    assert not np.array_equal(a.draws.samples, other.draws.samples)
    assert _numbers(a)["parameters"] != _numbers(other)["parameters"]


# --------------------------------------------------------------------------- identifiability

def _rolling_threshold(angle: float, eta: float) -> float:
    """Smallest mu for which the nominal bounce leaves rolling (bisection on the model)."""
    lo, hi = 0.0, 0.5
    for _ in range(30):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if bool(bb.simulate(mu=mid, eta=eta, speed=3.0, angle=angle).rolling) \
            else (mid, hi)
    return hi


def test_rolling_campaign_bounds_mu_from_below_and_still_identifies_eta():
    exp = experiment(contact__mu=0.4, incidence__angle_deg=20.0)
    c = campaign(exp, seed=31)
    assert c.truth["share_rolling"] == 1.0
    result = infer(exp, c.trials, sampler="grid", seed=5, config=GridConfig(draws=4000))
    mu, eta = by_name(result, "mu"), by_name(result, "eta")
    assert not mu.identifiable
    assert mu.bound["side"] == "lower" and mu.bound["level"] == 0.95
    assert mu.paper_form() == f"mu > {mu.bound['value']:.2f} at 95 %"
    # above the threshold the rebound does not depend on mu: the posterior is ~flat on
    # [threshold, 0.5], so its 5 % quantile lies near threshold + 0.05 (0.5 - threshold)
    threshold = _rolling_threshold(20.0, 1.35)
    assert threshold <= mu.bound["value"] <= threshold + 0.1 * (0.5 - threshold)
    assert result.regimes["share_rolling"] >= 0.95
    assert any(w.startswith("mu is not identified") for w in result.warnings)
    assert eta.identifiable and covers(eta, 1.35)
    assert "mu > " in format_table(result)


# --------------------------------------------------------------------------- the grid

def test_grid_density_is_normalised_and_the_evidence_converges():
    # 6 bounces: a broad posterior, so the midpoint rule converges visibly with the spacing
    exp = experiment()
    trials = campaign(exp, seed=61, n=6).trials
    runs = {n: infer(exp, trials, sampler="grid", config=GridConfig(draws=200, points=n))
            for n in (128, 256)}
    for n, r in runs.items():
        grid = r.draws.info.grid
        cell = np.prod([c[1] - c[0] for c in grid.centres])
        assert grid.density.shape == (n, n)
        assert grid.density.sum() * cell == pytest.approx(1.0, abs=1e-12)
        assert math.isfinite(r.draws.info.log_evidence)
    assert runs[128].draws.info.log_evidence == pytest.approx(
        runs[256].draws.info.log_evidence, abs=1e-3)


@pytest.mark.parametrize("order, eta_high", [(("mu", "eta"), 5.0), (("eta", "mu"), 5.0),
                                             (("mu", "eta"), 30.0)])
def test_structured_grid_equals_the_generic_posterior(order, eta_high, small_table):
    # the (mu, eta) kernel must give LogPosterior.__call__ on the same mesh: sliding and rolling
    # cells alike, for either parameter order in the experiment file, and (eta up to 30 kg/s)
    # with cells outside the kernel's normal-impact table handed over to the generic path
    exp, trials = small_table
    doc = tomllib.loads(DEMO.experiment.read_text(encoding="utf-8"))
    doc["parameters"]["eta"]["high"] = eta_high
    doc["parameters"] = {k: doc["parameters"][k] for k in order}
    exp = parse_experiment(doc)
    result = infer(exp, trials, sampler="grid", config=GridConfig(draws=200, points=24))
    assert result.names == order
    post = result.posterior
    centres = [np.asarray(c) for c in result.draws.info.grid.centres]
    mesh = np.stack(np.meshgrid(*centres, indexing="ij"), axis=-1).reshape(-1, 2)
    generic = post(mesh)
    density = np.exp(generic - logsumexp(generic)) / np.prod([c[1] - c[0] for c in centres])
    np.testing.assert_allclose(result.draws.info.grid.density.ravel(), density,
                               rtol=1e-9, atol=1e-12)
    # the kernel on the whole prior box (the sampler's grid is zoomed onto the posterior)
    box = post.box()
    full = [np.linspace(lo, hi, 26)[1:-1] for lo, hi in box]
    mu = full[order.index("mu")]
    eta = full[order.index("eta")]
    ll, bad = gaussian_grid(post.likelihood, mu, eta)
    assert bad.any() == (eta_high > 5.0)
    pairs = np.stack(np.meshgrid(mu, eta, indexing="ij"), axis=-1).reshape(-1, 2)
    theta = pairs if order == ("mu", "eta") else pairs[:, ::-1]
    rolling = post.likelihood.forward(theta).rolling.all(axis=1)
    assert rolling.any() and not rolling.all()  # both tangential outcomes are on this box
    reference = post.likelihood(theta).reshape(ll.shape)
    np.testing.assert_allclose(ll[~bad], reference[~bad], rtol=1e-12, atol=1e-10)


# --------------------------------------------------------------------------- warnings

def test_prior_bound_cutting_into_the_posterior_is_reported():
    # the demo's posterior of mu is 0.159 +- 0.0015; an upper bound at 0.157 cuts it
    exp = experiment(parameters__mu={"prior": "uniform", "low": 0.0, "high": 0.157})
    result = infer(exp, load_trials(DEMO.trials, exp), sampler="grid",
                   config=GridConfig(draws=4000))
    piles = [w for w in result.warnings if "piles against it" in w]
    assert len(piles) == 1
    assert piles[0].startswith("mu: ") and "upper bound (0.157)" in piles[0]
    # the reference run with the paper's prior has no such warning
    wide = infer(experiment(), load_trials(DEMO.trials, experiment()), sampler="grid",
                 config=GridConfig(draws=4000))
    assert not any("piles against it" in w for w in wide.warnings)


def test_a_tiny_mcmc_run_is_flagged(small_table):
    exp, trials = small_table
    result = infer(exp, trials, sampler="mh", seed=9,
                   config=MHConfig(draws=200, burn_in=0, thin=1))
    text = "\n".join(result.warnings)
    assert "effective draws (< 400)" in text  # 200 draws cannot hold 400 effective ones
    assert any("the chains disagree (R-hat" in w for w in result.warnings)
    for w in result.warnings:
        if "R-hat" in w:
            name = w.split(":")[0]
            assert by_name(result, name).r_hat > 1.01


def test_marginal_modes_finds_two_separated_peaks():
    rng = np.random.default_rng(2018)
    bimodal = np.concatenate([rng.normal(0.1, 0.01, 3000), rng.normal(0.3, 0.01, 7000)])
    modes = marginal_modes(bimodal, 0.0, 0.5)
    assert len(modes) == 2
    assert modes[0] == pytest.approx(0.3, abs=0.01)  # the higher peak first
    assert modes[1] == pytest.approx(0.1, abs=0.01)
    assert len(marginal_modes(rng.normal(0.2, 0.02, 10000), 0.0, 0.5)) == 1


def test_a_bimodal_marginal_is_a_warning():
    rng = np.random.default_rng(5)
    x = np.concatenate([rng.normal(0.1, 0.01, 2000), rng.normal(0.3, 0.01, 2000)])
    samples = x.reshape(4, 1000, 1)  # four chains, each half in one mode: R-hat is fine
    prior = bb.data.Uniform(0.0, 0.5)
    s = summarize_parameter("mu", "", prior, x, diagnostics(samples, ("mu",))["mu"])
    text = warnings_for([s], samples, [prior])
    assert any("the posterior has 2 modes" in w for w in text)


# --------------------------------------------------------------------------- inferred noise

def test_noise_levels_are_inferred_without_standard_errors():
    # exact incidence (no incidence noise), rebound noise 0.02 m/s and 0.5 deg, no *_se columns
    exp = experiment(synth__incidence_speed_noise_m_s=0.0, synth__incidence_angle_noise_deg=0.0)
    c = campaign(exp, seed=11)
    t = c.trials
    trials = make_trials(exp, rebound_speed=t.rebound_speed, rebound_angle=t.rebound_angle,
                         incidence_speed=t.incidence_speed, incidence_angle=t.incidence_angle)
    result = infer(exp, trials, sampler="mh", seed=6, config=MHConfig(draws=3000))
    assert result.names == ("mu", "eta", "sigma_speed", "sigma_angle")
    assert result.likelihood_info["noise"] == "inferred"
    noise = c.truth["measurement_noise"]
    per = c.truth["per_bounce"]
    for name, column, generating in (("sigma_speed", "rebound_speed", noise["rebound_speed"]),
                                     ("sigma_angle", "rebound_angle", noise["rebound_angle"])):
        realised = float(np.sqrt(np.mean((t.column(column) - np.array(per[column])) ** 2)))
        p = by_name(result, name)
        assert covers(p, realised), (name, p.ci90, realised)  # what these 55 draws hold
        lo, hi = np.quantile(result.samples(name), [0.005, 0.995])
        assert lo <= generating <= hi, (name, lo, hi)
    for name, value in PAPER_TRUTH.items():
        assert covers(by_name(result, name), value)


# --------------------------------------------------------------------------- outputs

@pytest.fixture(scope="module")
def demo_grid():
    exp = experiment()
    trials = load_trials(DEMO.trials, exp)
    return infer(exp, trials, sampler="grid", seed=12,
                 config=GridConfig(draws=500, points=128))


def test_posterior_netcdf_holds_draws_data_and_provenance(tmp_path, demo_grid):
    import arviz_base
    import xarray as xr

    paths = write_outputs(demo_grid, tmp_path)
    assert set(paths) == {"posterior", "summary", "grid"}
    with xr.open_datatree(tmp_path / "posterior.nc") as opened:
        assert {"posterior", "sample_stats", "observed_data", "log_likelihood",
                "posterior_predictive"} <= set(opened.children)
    idata = arviz_base.convert_to_datatree(str(tmp_path / "posterior.nc"))
    np.testing.assert_array_equal(idata.posterior["mu"].values, demo_grid.draws.samples[..., 0])
    np.testing.assert_array_equal(idata.observed_data["rebound_speed"].values,
                                  demo_grid.trials.rebound_speed)
    assert "lp" in idata.sample_stats
    assert idata.log_likelihood["rebound"].shape == (1, 500, demo_grid.trials.n)
    assert idata.posterior_predictive["rebound_speed"].dims == ("chain", "draw", "trial")
    attrs = idata.attrs
    assert int(attrs["seed"]) == 12
    assert attrs["likelihood"] == "gaussian" and attrs["sampler"] == "grid"
    assert attrs["bouncebayes_version"] == bb.__version__
    assert attrs["data_sha256"] == hashlib.sha256(DEMO.trials.read_bytes()).hexdigest()
    assert json.loads(attrs["config"]) == {"draws": 500, "points": 128}
    # the package's one provenance record, also for a library user (no command line)
    from bouncebayes._provenance import read_provenance

    record = read_provenance(tmp_path / "posterior.nc")
    assert record["seed"] == 12 and record["command"] is None and record["created_utc"]
    assert record["inputs"]["trials"]["sha256"] == attrs["data_sha256"]
    assert set(idata["adequacy"].data_vars) == {"residual_speed", "residual_angle", "ppp"}
    with np.load(tmp_path / "grid.npz") as grid:
        cell = (grid["centres_0"][1] - grid["centres_0"][0]) * (grid["centres_1"][1]
                                                                - grid["centres_1"][0])
        assert grid["density"].sum() * cell == pytest.approx(1.0, abs=1e-12)


def test_pointwise_log_likelihood_is_each_trials_bivariate_normal(demo_grid):
    # reference: scipy.stats.multivariate_normal with the likelihood's covariance (table
    # standard errors + propagated incidence uncertainty), at the simulated rebound of each
    # trial; the pointwise terms of a draw also sum to the likelihood the sampler used
    from scipy import stats

    like = demo_grid.posterior.likelihood
    theta = demo_grid.draws.samples[0, :3]
    r = like.forward(theta)
    cov = like.propagated + np.einsum("ij,jk->ijk", like.rebound_var, np.eye(2))
    for j in range(3):
        expected = [stats.multivariate_normal(mean=[r.speed[j, k], r.angle[j, k]],
                                              cov=cov[k]).logpdf([like.speed[k], like.angle[k]])
                    for k in range(demo_grid.trials.n)]
        np.testing.assert_allclose(demo_grid.log_likelihood[0, j], expected, rtol=1e-10)
    np.testing.assert_allclose(demo_grid.log_likelihood[0, :3].sum(axis=1), like(theta),
                               rtol=1e-12)


@pytest.mark.filterwarnings("ignore::DeprecationWarning", "ignore::FutureWarning")
def test_loo_and_compare_work_on_posterior_files(tmp_path, demo_grid):
    # PSIS-LOO (Vehtari, Gelman & Gabry 2017) over the 55 trials: elpd_loo is at most the
    # in-sample log predictive density (leaving a trial out cannot predict it better), and a
    # model compared with itself differs by 0
    import arviz_stats
    import xarray as xr

    write_outputs(demo_grid, tmp_path)
    tree = xr.open_datatree(tmp_path / "posterior.nc").load()
    loo = arviz_stats.loo(tree)
    lppd = float(np.sum(logsumexp(demo_grid.log_likelihood[0], axis=0)
                        - math.log(demo_grid.log_likelihood.shape[1])))
    assert loo.n_data_points == demo_grid.trials.n
    assert loo.elpd < lppd
    table = arviz_stats.compare({"a": tree, "b": tree})
    assert table["elpd_diff"].tolist() == [0.0, 0.0]


def test_kde_log_likelihood_is_one_campaign_term(tmp_path):
    # the kde likelihood is one density at one simulated rebound: one term per draw, stored
    # as the observation `campaign`, and equal to the likelihood the sampler used
    import xarray as xr

    exp = experiment()
    result = infer(exp, load_trials(DEMO.trials, exp), likelihood="kde", sampler="grid",
                   seed=1, config=GridConfig(draws=200, points=32))
    write_outputs(result, tmp_path)
    with xr.open_datatree(tmp_path / "posterior.nc") as tree:
        ll = tree["log_likelihood"]["rebound"]
        assert ll.dims == ("chain", "draw", "campaign") and ll.shape == (1, 200, 1)
        np.testing.assert_allclose(ll.values[0, :, 0], result.posterior.likelihood(
            result.draws.samples[0]), rtol=1e-12)
        assert "does not factor over trials" in tree.attrs["pointwise_log_likelihood"]
        assert tree["posterior_predictive"]["rebound_speed"].dims == ("chain", "draw",
                                                                      "campaign")


def test_summary_json_has_the_documented_shape(tmp_path, demo_grid):
    write_outputs(demo_grid, tmp_path)
    summary = json.loads((tmp_path / "summary.json").read_text(encoding="utf-8"))
    assert {"parameters", "likelihood", "sampler", "seed", "regimes", "warnings", "data",
            "bouncebayes_version"} <= set(summary)
    assert list(summary["parameters"]) == ["mu", "eta"]
    for name, p in summary["parameters"].items():
        assert {"mean", "sd", "ci90", "r_hat", "ess_bulk", "identifiable"} <= set(p)
        assert len(p["ci90"]) == 2 and p["ci90"][0] < p["mean"] < p["ci90"][1]
        assert p["mean"] == pytest.approx(float(np.mean(demo_grid.samples(name))), rel=1e-12)
    assert summary["likelihood"] == "gaussian" and summary["sampler"] == "grid"
    assert summary["seed"] == 12
    assert summary["data"]["sha256"] == hashlib.sha256(DEMO.trials.read_bytes()).hexdigest()


def _digests(folder) -> dict:
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in folder.iterdir()}


def test_a_failed_posterior_write_leaves_the_earlier_outputs(tmp_path, demo_grid, monkeypatch):
    write_outputs(demo_grid, tmp_path)
    before = _digests(tmp_path)

    def broken(result):
        raise OSError("disk full")

    monkeypatch.setattr(outputs_module, "inference_data", broken)
    with pytest.raises(OSError, match="disk full"):
        write_outputs(dataclasses.replace(demo_grid, seed=99), tmp_path)
    assert _digests(tmp_path) == before  # no partial file, nothing replaced, no temporaries


def test_a_failed_summary_write_leaves_the_earlier_outputs(tmp_path, demo_grid):
    write_outputs(demo_grid, tmp_path)
    before = _digests(tmp_path)
    broken = dataclasses.replace(demo_grid, seed=99, likelihood_info={"x": object()})
    with pytest.raises(TypeError, match="not JSON serializable"):
        write_outputs(broken, tmp_path)
    assert _digests(tmp_path) == before


# --------------------------------------------------------------------------- the CLI

def test_cli_infer_on_the_demo_matches_the_library(tmp_path, capsys):
    argv = ["infer", str(DEMO.experiment), str(DEMO.trials), "--out", str(tmp_path),
            "--sampler", "grid", "--grid-points", "128", "--draws", "500", "--seed", "12",
            "--quiet"]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "mu = " in out and "posterior.nc" in out
    summary = json.loads((tmp_path / "summary.json").read_text(encoding="utf-8"))
    exp = experiment()
    lib = infer(exp, load_trials(DEMO.trials, exp), sampler="grid", seed=12,
                config=GridConfig(draws=500, points=128))
    assert summary["parameters"]["mu"]["mean"] == by_name(lib, "mu").mean
    assert summary["parameters"]["eta"]["ci90"] == list(by_name(lib, "eta").ci90)


def test_cli_infer_mh_with_small_draws(tmp_path, capsys):
    argv = ["infer", str(DEMO.experiment), str(DEMO.trials), "--out", str(tmp_path),
            "--draws", "400", "--burn-in", "50", "--likelihood", "kde", "--seed", "3", "--quiet"]
    assert main(argv) == 0
    summary = json.loads((tmp_path / "summary.json").read_text(encoding="utf-8"))
    assert summary["sampler"] == "mh" and summary["likelihood"] == "kde"
    assert summary["n_draws"] == 400
    assert "likelihood kde, sampler mh, seed 3" in capsys.readouterr().out


def _one_error_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    return err[-1]


def test_cli_unknown_likelihood_is_a_usage_error(tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["infer", str(DEMO.experiment), str(DEMO.trials), "--out", str(tmp_path),
              "--likelihood", "poisson"])
    assert exc.value.code == 2
    line = _one_error_line(capsys)
    assert line.startswith("bouncebayes infer: error: argument --likelihood: invalid choice")
    assert "'poisson'" in line


def test_cli_missing_trial_table_is_one_line(tmp_path, capsys):
    missing = tmp_path / "nowhere.csv"
    assert main(["infer", str(DEMO.experiment), str(missing), "--out",
                 str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert err.startswith("bouncebayes infer: error: ") and str(missing) in err
    assert not (tmp_path / "out").exists()


def test_cli_experiment_without_parameters_is_one_line(tmp_path, capsys):
    text = DEMO.experiment.read_text(encoding="utf-8")
    start, end = text.index("[parameters.mu]"), text.index("[trajectories]")
    path = tmp_path / "fixed.toml"
    path.write_text(text[:start] + text[end:], encoding="utf-8")
    assert main(["infer", str(path), str(DEMO.trials), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "no [parameters.NAME] table: nothing to infer" in err


# --------------------------------------------------------------------------- error paths

@pytest.mark.parametrize("kwargs, message", [
    ({"sampler": "hmc"}, "`sampler` must be one of 'mh', 'ensemble', 'grid'; got 'hmc'"),
    ({"likelihood": "poisson"},
     "`likelihood` must be one of 'kde', 'gaussian', 'consistent', 'population'; got 'poisson'"),
    ({"noise": "estimated"}, "`noise` must be one of 'auto', 'given', 'inferred'; got 'estimated'"),
])
def test_bad_names_are_rejected(small_table, kwargs, message):
    exp, trials = small_table
    with pytest.raises(ValueError, match=message.replace("[", r"\[")):
        infer(exp, trials, **kwargs)


def test_grid_with_four_parameters_is_rejected(small_table):
    exp, trials = small_table
    with pytest.raises(ValueError, match="the grid sampler handles 1 to 3 parameters; this "
                                         "problem has 4: use `mh` or `ensemble`"):
        infer(exp, trials, sampler="grid", noise="inferred")


def test_given_noise_needs_standard_errors():
    exp = experiment()
    t = load_trials(DEMO.trials, exp)
    bare = make_trials(exp, rebound_speed=t.rebound_speed, rebound_angle=t.rebound_angle)
    with pytest.raises(ValueError, match="noise='given' needs positive standard errors in "
                                         "rebound_speed_se and rebound_angle_se"):
        infer(exp, bare, noise="given")


@pytest.mark.parametrize("field, value, message", [
    ("draws", 99, "`draws` must be an integer >= 100; got 99"),
    ("chains", 0, "`chains` must be an integer >= 1; got 0"),
    ("thin", 1.5, "`thin` must be an integer >= 1; got 1.5"),
])
def test_sampler_config_checks_itself(field, value, message):
    with pytest.raises(ValueError, match=message):
        MHConfig(**{field: value})


def test_likelihood_is_only_evaluated_inside_the_prior(small_table):
    # LogPosterior: -inf outside the support without calling the likelihood there
    exp, trials = small_table
    like = make_likelihood("gaussian", exp, trials, ("mu", "eta"),
                           rng=np.random.default_rng(0))
    calls = []

    def spy(theta):
        calls.append(theta.copy())
        return like(theta)

    post = LogPosterior(("mu", "eta"), (exp.priors["mu"], exp.priors["eta"]), ("", "kg/s"), spy)
    lp = post(np.array([[0.16, 1.35], [0.6, 1.35], [0.16, -1.0]]))
    assert np.isfinite(lp[0]) and np.all(np.isneginf(lp[1:]))
    assert len(calls) == 1 and np.array_equal(calls[0], [[0.16, 1.35]])


# --------------------------------------------------------------------------- configs

@pytest.mark.parametrize("make, error, message", [
    (lambda: EnsembleConfig(walkers=2), ValueError, "`walkers` must be an integer >= 4; got 2"),
    (lambda: GridConfig(points=7), ValueError, r"`points` must be an integer in \[8, 100000\]"),
    (lambda: sampler_config("grid", draws=500, chains=4), ValueError,
     "`chains` is not a setting of the grid sampler; GridConfig has draws, points"),
])
def test_each_sampler_config_checks_itself(make, error, message):
    with pytest.raises(error, match=message):
        make()


def test_the_config_names_the_sampler_and_a_mismatch_is_refused(small_table):
    exp, trials = small_table
    result = infer(exp, trials, config=GridConfig(draws=200, points=16))
    assert result.sampler == "grid" and result.config == GridConfig(draws=200, points=16)
    assert sampler_config("mh", draws=400, chains=None) == MHConfig(draws=400)
    with pytest.raises(TypeError, match="`config` must be a MHConfig for sampler='mh'; got "
                                        "GridConfig"):
        infer(exp, trials, sampler="mh", config=GridConfig())


# --------------------------------------------------------------------------- (init, step)

GAUSS_MEAN = np.array([1.0, -2.0])
GAUSS_COV = np.array([[1.0, 0.6], [0.6, 2.0]])


def gauss_logdensity(x):
    z = np.atleast_2d(x) - GAUSS_MEAN
    return -0.5 * np.einsum("ij,jk,ik->i", z, np.linalg.inv(GAUSS_COV), z)


def test_mh_step_is_pure_and_samples_a_known_gaussian():
    # target: a correlated bivariate normal (closed-form mean and covariance); 8 chains of
    # 6000 steps with the optimal scale: Monte Carlo error of the mean ~ 0.05, 0.15 allowed
    rng = np.random.default_rng(1)
    chol = np.linalg.cholesky(GAUSS_COV) * 2.38 / math.sqrt(2)
    state = bb.inference.mh_init(np.zeros((8, 2)), gauss_logdensity)
    increment, log_u = rng.standard_normal((8, 2)) @ chol.T, np.log(rng.uniform(size=8))
    before = [a.copy() for a in state]
    a, info_a = bb.inference.mh_step(state, gauss_logdensity, increment, log_u)
    b, info_b = bb.inference.mh_step(state, gauss_logdensity, increment, log_u)
    assert all(np.array_equal(x, y) for x, y in zip(state, before, strict=True))  # unchanged
    assert all(np.array_equal(x, y) for x, y in zip(a + info_a, b + info_b, strict=True))
    kept = []
    for _ in range(6000):
        state, info = bb.inference.mh_step(state, gauss_logdensity,
                                           rng.standard_normal((8, 2)) @ chol.T,
                                           np.log(rng.uniform(size=8)))
        kept.append(state.position)
    x = np.concatenate(kept[1000:])
    np.testing.assert_allclose(x.mean(axis=0), GAUSS_MEAN, atol=0.15)
    np.testing.assert_allclose(np.cov(x.T), GAUSS_COV, rtol=0.15, atol=0.1)


def test_ensemble_step_wraps_emcee_and_samples_a_known_gaussian():
    # emcee's stretch move on the same closed-form target; the generator state travels in the
    # state record, so a step repeated from the same state gives the same walkers
    state = bb.inference.ensemble_init(
        np.random.default_rng(2).normal(size=(16, 2)), gauss_logdensity, seed=3)
    before = state.position.copy()
    a, _ = bb.inference.ensemble_step(state, gauss_logdensity)
    b, _ = bb.inference.ensemble_step(state, gauss_logdensity)
    assert np.array_equal(state.position, before) and a.position is not b.position
    assert np.array_equal(a.position, b.position) and not np.array_equal(a.position, before)
    kept = []
    for _ in range(3000):
        state, info = bb.inference.ensemble_step(state, gauss_logdensity)
        kept.append(state.position)
    x = np.concatenate(kept[500:])
    np.testing.assert_allclose(x.mean(axis=0), GAUSS_MEAN, atol=0.15)
    np.testing.assert_allclose(np.cov(x.T), GAUSS_COV, rtol=0.15, atol=0.1)


# --------------------------------------------------------------------------- memory

def test_a_grid_that_cannot_fit_is_refused_up_front_with_the_estimate(small_table):
    # 1e10 cells x 48 bytes (log posterior, weights, density, kernel output, resampling)
    exp, trials = small_table
    with pytest.raises(MemoryBudgetError, match=r"a grid of 100000 points per parameter in 2 "
                                                r"parameters \(1e\+10 cells\) needs about "
                                                r"447.0 GiB") as err:
        infer(exp, trials, config=GridConfig(points=100000))
    assert err.value.needed == 1e10 * 48 and err.value.budget == bb.inference.DEFAULT_MEMORY_BUDGET
    with pytest.raises(MemoryBudgetError, match="lower `draws`"):
        infer(exp, trials, config=MHConfig(draws=10**9))
    with pytest.raises(ValueError, match=r"`memory_budget` must be at least 16777216 bytes"):
        infer(exp, trials, memory_budget=1000)


MEMORY_SCRIPT = """
import json, sys
import numpy as np
from bouncebayes.data import demo_campaign, load_experiment, load_trials, make_trials
from bouncebayes.inference import BYTES_PER_BOUNCE, MHConfig, infer
from bouncebayes.inference._likelihood import make_likelihood

def rss(key):
    with open("/proc/self/status") as fh:
        return next(int(l.split()[1]) * 1024 for l in fh if l.startswith(key))

demo = demo_campaign()
exp = load_experiment(demo.experiment)
t = load_trials(demo.trials, exp)
n, budget = int(sys.argv[1]), int(sys.argv[2])
reps = -(-n // t.n)
tile = lambda x: np.tile(x, reps)[:n]
big = make_trials(exp, rebound_speed=tile(t.rebound_speed), rebound_angle=tile(t.rebound_angle),
                  incidence_speed=tile(t.incidence_speed), incidence_angle=tile(t.incidence_angle),
                  se={k: tile(v) for k, v in t.se.items() if np.all(np.isfinite(v))})
config = MHConfig(draws=100, chains=2, burn_in=0, thin=1)
infer(exp, t, config=config)  # compiled code loaded before anything is measured
base = rss("VmRSS")  # the high-water mark only rises: the larger measurement last
# one posterior: the tiled table repeats 55 values, which the adequacy check's distribution test
# rightly finds unlike a continuous predictive, and discrepancy="auto" would then refit
result = infer(exp, big, config=config, memory_budget=budget, discrepancy="none")
growth = rss("VmHWM") - base
like = make_likelihood("gaussian", exp, t, ("mu", "eta"), rng=np.random.default_rng(0))
rows = 4 * max(1, growth // (BYTES_PER_BOUNCE * t.n))  # a call larger than the run's peak
theta = np.column_stack([np.full(rows, 0.16), np.linspace(1.0, 2.0, rows)])
like(theta[:10])
base = rss("VmRSS")
like(theta)
per_bounce = (rss("VmHWM") - base) / (rows * t.n)
print(json.dumps({"per_bounce": per_bounce, "planned": BYTES_PER_BOUNCE, "growth": growth,
                  "mu": result.parameters[0].mean,
                  "log_likelihood": list(result.log_likelihood.shape)}))
"""


def _memory_run(n: int, budget: int) -> dict:
    import subprocess
    import sys

    out = subprocess.run([sys.executable, "-c", MEMORY_SCRIPT, str(n), str(budget)],
                         capture_output=True, text=True, check=True, timeout=900)
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_a_large_table_runs_in_batches_within_the_memory_budget():
    # 10,000 trials under a 48 MiB budget: one likelihood row (all trials) is planned at
    # 10 MB, so the model is evaluated a row or two at a time. The resident-set growth of the
    # run stays within the budget, and the planning constant bounds the measured working
    # memory of one likelihood call (resident-set high-water mark of a call larger than the
    # run's own peak, so that the mark is the call's)
    run = _memory_run(10_000, 48 * 2**20)
    assert run["per_bounce"] < run["planned"]
    assert run["growth"] < 48 * 2**20
    assert run["log_likelihood"] == [2, 50, 10_000]
    assert run["mu"] == pytest.approx(0.159, abs=0.005)  # the demo's posterior mean


@pytest.mark.slow
def test_a_100000_row_table_runs_within_the_memory_budget():
    run = _memory_run(100_000, 512 * 2**20)
    assert run["growth"] < 512 * 2**20 * 1.1
    assert run["mu"] == pytest.approx(0.159, abs=0.005)


# --------------------------------------------------------------------------- what no sampler fixes

def test_identical_rows_with_kde_name_the_file_and_the_column():
    exp = experiment()
    same = make_trials(exp, rebound_speed=np.full(10, 2.0), rebound_angle=np.full(10, 40.0),
                       source="same.csv")
    with pytest.raises(ValueError, match=r"^same.csv: every rebound_speed is 2 m/s: the kde "
                                         r"likelihood estimates the density of the rebounds "
                                         r"from their spread"):
        infer(exp, same, likelihood="kde")


@pytest.mark.parametrize("name", ["eta", "mu"])
def test_an_absurdly_wide_prior_is_blamed_not_the_data(name):
    # refused where the experiment file is read (the model's domains, bouncebayes.model
    # PARAMETER_DOMAINS), naming the key, before any data are looked at
    with pytest.raises(InputFileError, match=f"`parameters.{name}`: the prior .* puts mass "
                                             f"above .* where `{name}` is not physical") as err:
        experiment(parameters__eta={"prior": "uniform", "low": 0.0, "high": 1e300}
                   if name == "eta" else {"prior": "uniform", "low": 0.0, "high": 5.0},
                   parameters__mu={"prior": "uniform", "low": 0.0, "high": 1e300}
                   if name == "mu" else {"prior": "uniform", "low": 0.0, "high": 0.5})
    assert "data" not in str(err.value)


def test_a_prior_where_the_ball_never_bounces_says_so(small_table):
    # eta of 200-1000 kg/s (inside the model's domain): the ball stops on the surface at every
    # point of the design (the ODE path finds no separation; checked with BounceModel)
    exp = experiment(parameters__eta={"prior": "uniform", "low": 200.0, "high": 1000.0})
    with pytest.raises(ValueError, match="the model gives no rebound for every bounce at any "
                                         "point of a 1024-point design") as err:
        infer(exp, small_table[1], config=MHConfig(draws=200))
    assert "narrow them to the physical range" in str(err.value)
    assert "reproduces the data" not in str(err.value)


def _faster(exp, trials, rows, by=1.0):
    speed = trials.rebound_speed.copy()
    speed[rows] += by
    return make_trials(exp, rebound_speed=speed, rebound_angle=trials.rebound_angle,
                       incidence_speed=trials.incidence_speed,
                       incidence_angle=trials.incidence_angle, source="faster.csv",
                       se={k: v for k, v in trials.se.items() if np.all(np.isfinite(v))})


def test_rebounds_faster_than_the_incidence_are_named_not_blamed_on_the_prior(small_table):
    # energy: a passive contact cannot return more kinetic energy than arrived, so a rebound
    # 1 m/s faster than a 3 m/s incidence is impossible for every parameter value
    exp, trials = small_table
    with pytest.raises(ValueError, match=r"^faster.csv: every bounce rebounds faster than it "
                                         r"arrived \(trial 1: "):
        infer(exp, _faster(exp, trials, slice(None)))
    result = infer(exp, _faster(exp, trials, [2, 7]), config=GridConfig(draws=400, points=32))
    assert result.warnings[0].startswith("2 of 12 bounces rebound faster than they arrived, "
                                         "beyond their measurement error (trials 3, 8;")
    assert not any("widen the prior" in w for w in result.warnings)
    clean = infer(exp, trials, config=GridConfig(draws=400, points=32))
    assert not any("faster than they arrived" in w for w in clean.warnings)


def test_a_result_whose_chains_disagree_or_that_has_modes_gets_no_interval():
    from bouncebayes.inference._summary import UNCONVERGED, ParameterSummary

    # the `run` table of three rendered bounces printed "mu = 0.069 ± 0.065" where R-hat was
    # 1.93 and the posterior had two modes, beside warnings saying both
    base = dict(name="mu", unit="", prior="uniform", mean=0.08, sd=0.08, median=0.07,
                ci90=(0.004, 0.133), r_hat=1.0, ess_bulk=900.0, ess_tail=900.0,
                identifiable=True, bound=None, modes=(0.07,))
    assert ParameterSummary(**base).paper_form() == "mu = 0.069 ± 0.065"
    stuck = ParameterSummary(**{**base, "r_hat": UNCONVERGED + 0.83})
    assert stuck.paper_form() == "mu ≈ 0.07 (no interval: the chains disagree, R-hat 1.93; " \
                                 "run longer)"
    two = ParameterSummary(**{**base, "modes": (0.0166, 0.09)})
    assert "±" not in two.paper_form() and "2 modes, at 0.0166, 0.09" in two.paper_form()
