"""Kernel density estimates of the measured rebounds (bouncebayes.density, docs/likelihoods.md, `kde`).

References: scipy.stats.gaussian_kde (1-D and 2-D), scipy.stats.multivariate_normal, closed-form
bandwidth rules written out here, scipy.integrate.quad, scipy.special.logsumexp, and the MATLAB
Answers thread "ksdensity default bandwidth value" (x = [1 3 2 5] -> bw = 1.1901).
"""

import dataclasses
import json

import numpy as np
import pytest
from scipy import integrate, special, stats

from bouncebayes.density import (
    KDE1D,
    bandwidth,
    kde1d,
    pearson,
    rebound_density,
    summarize,
)

SEED = 20261121


@pytest.fixture
def rng():
    return np.random.default_rng(SEED)


@pytest.fixture
def bounces(rng):
    """55 independent rebounds like the paper's: speed ~ 2 m/s, angle ~ 40 deg."""
    return rng.normal(2.0, 0.1, 55), rng.normal(40.0, 3.0, 55)


@pytest.fixture
def correlated(rng):
    """55 rebounds whose angle follows the speed (r ~ 0.9): the product assumption fails."""
    v = rng.normal(2.0, 0.1, 55)
    return v, 40.0 + 25.0 * (v - 2.0) + rng.normal(0.0, 1.0, 55)


# --- bandwidth rules --------------------------------------------------------------------------

def test_normal_reference_matlab_hand_example():
    # MATLAB Answers "ksdensity default bandwidth value": [f,xi,bw] = ksdensity([1 3 2 5]) has
    # bw = 1.1901. By hand: median 2.5, |x - 2.5| = [1.5 .5 .5 2.5], MAD = 1.0,
    # sigma = 1/0.6745, h = sigma (4/(3*4))^(1/5) = 1.19013.
    assert bandwidth([1.0, 3.0, 2.0, 5.0]) == pytest.approx((1 / 0.6745) * (1 / 3) ** 0.2,
                                                              rel=1e-15)
    assert bandwidth([1.0, 3.0, 2.0, 5.0]) == pytest.approx(1.1901, abs=5e-5)


def test_bandwidth_rules_closed_forms(rng):
    x = rng.gamma(2.0, 1.0, 40)
    n, sd = x.size, np.std(x, ddof=1)
    mad = np.median(np.abs(x - np.median(x)))  # MATLAB mad(x, 1)
    # Closed forms: MATLAB ksdensity doc (normal reference), Scott (1992), Silverman (1986) 3.31.
    assert bandwidth(x, "normal-reference") == pytest.approx(mad / 0.6745 * (4 / (3 * n)) ** 0.2,
                                                             rel=1e-14)
    assert bandwidth(x, "scott") == pytest.approx(sd * n ** -0.2, rel=1e-14)
    assert bandwidth(x, "silverman") == pytest.approx(sd * (4 / (3 * n)) ** 0.2, rel=1e-14)
    assert bandwidth(x, 0.3) == 0.3  # a positive float passes through


@pytest.mark.parametrize("rule", ["scott", "silverman"])
def test_bandwidth_matches_scipy_factor(rng, rule):
    # scipy.stats.gaussian_kde: kernel sd in 1-D = factor * std(ddof=1).
    x = rng.normal(0.0, 2.0, 30)
    scipy_h = stats.gaussian_kde(x, bw_method=rule).factor * np.std(x, ddof=1)
    assert bandwidth(x, rule) == pytest.approx(scipy_h, rel=1e-14)


def test_normal_reference_close_to_silverman_on_gaussian_data(rng):
    # For normal data MAD/0.6745 and std both estimate sigma (MAD's relative s.e. ~1.17/sqrt(n)
    # = 2.6 % at n = 2000), so the two rules agree to within ~4 standard errors.
    x = rng.normal(5.0, 0.7, 2000)
    assert bandwidth(x) == pytest.approx(bandwidth(x, "silverman"), rel=0.1)


# --- 1-D KDE ----------------------------------------------------------------------------------

@pytest.mark.parametrize("rule", ["normal-reference", "scott", "silverman"])
def test_kde_matches_scipy_gaussian_kde(bounces, rule):
    v = bounces[0]
    kde = kde1d(v, rule)
    # scipy's bw_method is a factor on std(ddof=1): same kernel sd h.
    ref = stats.gaussian_kde(v, bw_method=kde.bandwidth / np.std(v, ddof=1))
    x = np.linspace(v.min() - 5 * kde.bandwidth, v.max() + 5 * kde.bandwidth, 401)
    np.testing.assert_allclose(kde.pdf(x), ref(x), rtol=1e-12, atol=0)
    # Absolute 1e-12 on log f is relative 1e-12 on f.
    np.testing.assert_allclose(kde.logpdf(x), ref.logpdf(x), rtol=0, atol=1e-12)
    assert kde.rule == rule


def test_threaded_path_for_many_points_matches_scipy(correlated):
    # >= 4096 points go through the parallel kernel; same reference as above (scipy).
    v, t = correlated
    x = np.linspace(1.5, 2.5, 5000)
    kde = kde1d(v)
    ref = stats.gaussian_kde(v, bw_method=kde.bandwidth / np.std(v, ddof=1))
    # Absolute 1e-12 on log f is relative 1e-12 on f (log f crosses 0 here).
    np.testing.assert_allclose(kde.logpdf(x), ref.logpdf(x), rtol=0, atol=1e-12)
    rho, ref2 = rebound_density(v, t, bandwidth="scott"), stats.gaussian_kde(np.vstack([v, t]))
    pts = np.vstack([x, np.linspace(30.0, 50.0, 5000)])
    np.testing.assert_allclose(rho.logpdf(*pts), ref2.logpdf(pts), rtol=0, atol=1e-12)


def test_kde_integrates_to_one(bounces):
    kde = kde1d(bounces[1])
    # Outside 12 bandwidths of the data the mass is below Phi(-12) ~ 2e-33.
    lo, hi = kde.data.min() - 12 * kde.bandwidth, kde.data.max() + 12 * kde.bandwidth
    mass, err = integrate.quad(kde.pdf, lo, hi, limit=200, epsabs=1e-13)
    assert mass == pytest.approx(1.0, abs=1e-10)


def test_logpdf_is_log_pdf_and_finite_in_far_tails(bounces):
    kde = kde1d(bounces[0])
    x = np.linspace(1.0, 3.0, 101)
    np.testing.assert_allclose(kde.logpdf(x), np.log(kde.pdf(x)), rtol=1e-13)
    far = np.array([-1e3, 50.0, 1e4])  # pdf underflows to 0 here; logpdf must not be -inf
    assert np.all(kde.pdf(far) == 0.0)
    z = (far[:, None] - kde.data[None, :]) / kde.bandwidth
    ref = special.logsumexp(-0.5 * z**2, axis=1) - np.log(kde.data.size * kde.bandwidth
                                                          * np.sqrt(2 * np.pi))
    np.testing.assert_allclose(kde.logpdf(far), ref, rtol=1e-13)


def test_logpdf_broadcasts_any_shape_and_handles_non_finite(bounces):
    kde = kde1d(bounces[0])
    x = np.linspace(1.5, 2.5, 60).reshape(3, 4, 5)
    out = kde.logpdf(x)
    assert out.shape == (3, 4, 5)
    np.testing.assert_array_equal(out.ravel(), kde.logpdf(x.ravel()))
    assert np.ndim(kde.logpdf(2.0)) == 0 and kde.logpdf(2.0) == kde.logpdf([2.0])[0]
    special_values = kde.logpdf([np.nan, np.inf, -np.inf])
    assert np.isnan(special_values[0]) and np.all(special_values[1:] == -np.inf)


def test_kde_is_immutable_and_copies_its_data(bounces):
    v = bounces[0].copy()
    kde = kde1d(v)
    v[0] = 100.0  # the caller's array is not the stored one
    assert kde.data[0] != 100.0
    with pytest.raises(ValueError, match="read-only"):
        kde.data[0] = 1.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        kde.bandwidth = 1.0


# --- correlation and the 2-D density ---------------------------------------------------------

def test_pearson_matches_scipy(bounces):
    v, t = bounces
    corr = pearson(v, t)
    ref = stats.pearsonr(v, t)
    assert (corr.r, corr.p_value, corr.n) == (pytest.approx(ref.statistic, rel=1e-14),
                                              pytest.approx(ref.pvalue, rel=1e-14), 55)
    assert corr.r == pytest.approx(np.corrcoef(v, t)[0, 1], rel=1e-12)  # definition
    with pytest.raises(ValueError, match=r"`y` is constant \(1.0\), so its correlation"):
        pearson(v, np.ones_like(v))


def test_product_density_is_product_of_marginals(bounces):
    v, t = bounces
    rho = rebound_density(v, t, kind="product")
    kv, kt = kde1d(v), kde1d(t)  # the 1-D rule on each axis
    assert (rho.speed.bandwidth, rho.angle.bandwidth) == (kv.bandwidth, kt.bandwidth)
    vs, ts = np.linspace(1.7, 2.3, 7)[:, None], np.linspace(30, 50, 9)[None, :]
    out = rho.pdf(vs, ts)
    assert out.shape == (7, 9)
    np.testing.assert_allclose(out, kv.pdf(vs) * kt.pdf(ts), rtol=1e-13)


def test_joint_density_matches_scipy_2d_with_scott(correlated):
    v, t = correlated
    rho = rebound_density(v, t, kind="joint", bandwidth="scott")
    ref = stats.gaussian_kde(np.vstack([v, t]))  # scipy default: Scott, H = n^(-1/3) cov
    np.testing.assert_allclose(rho.bandwidth_matrix, ref.covariance, rtol=1e-12)
    pts = np.vstack([np.linspace(1.8, 2.2, 50), np.linspace(34.0, 46.0, 50)])
    np.testing.assert_allclose(rho.pdf(*pts), ref(pts), rtol=1e-12)
    np.testing.assert_allclose(rho.logpdf(*pts), ref.logpdf(pts), rtol=0, atol=1e-12)


def test_joint_normal_reference_is_mixture_of_normals(correlated):
    v, t = correlated
    rho = rebound_density(v, t, kind="joint")
    # Closed form of the documented choice: h_j = MAD_j/0.6745 n^(-1/6), H = D R D, R from r.
    h = np.array([np.median(np.abs(x - np.median(x))) / 0.6745 * 55 ** (-1 / 6) for x in (v, t)])
    r = np.corrcoef(v, t)[0, 1]
    cov = np.outer(h, h) * np.array([[1, r], [r, 1]])
    np.testing.assert_allclose(rho.bandwidth_matrix, cov, rtol=1e-12)
    p = np.array([2.03, 40.4])
    ref = np.mean([stats.multivariate_normal(c, cov).pdf(p) for c in zip(v, t, strict=True)])
    assert rho.pdf(*p) == pytest.approx(ref, rel=1e-12)
    # The marginals are exact: integrating out the angle leaves the speed KDE.
    mass, _ = integrate.quad(lambda a: rho.pdf(2.03, a), 0.0, 80.0, limit=200)
    assert mass == pytest.approx(float(rho.speed.pdf(2.03)), rel=1e-8)


def test_auto_picks_joint_when_correlated(correlated):
    rho = rebound_density(*correlated)
    # Built with r = 2.5/sqrt(2.5^2 + 1) = 0.93 (signal sd 25*0.1 deg, noise sd 1 deg).
    assert rho.correlation.r > 0.8 and rho.correlation.p_value < 0.05
    assert rho.kind == "joint" and "rejects zero correlation at alpha = 0.05" in rho.reason


def test_auto_picks_product_when_independent(bounces):
    rho = rebound_density(*bounces)
    assert rho.correlation.p_value > 0.05  # independent draws; this seed does not reject
    assert rho.kind == "product" and "as in the paper" in rho.reason
    record = rho.to_dict()
    assert record["kind"] == "product" and record["bandwidth_speed_m_s"] == rho.speed.bandwidth
    json.dumps(record)


# --- the data summary -------------------------------------------------------------------------

def test_summary_statistics_and_json(bounces):
    v, t = bounces
    s = summarize(v, t)
    assert (s.speed.n, s.speed.mean, s.speed.sd) == (55, pytest.approx(np.mean(v)),
                                                    pytest.approx(np.std(v, ddof=1)))
    assert (s.angle.min, s.angle.max) == (t.min(), t.max())
    np.testing.assert_array_equal(s.speed.bin_edges, np.histogram_bin_edges(v, bins="auto"))
    assert s.warnings == () and s.density_kind == "product"
    d = json.loads(json.dumps(s.to_dict()))
    assert d["rebound_speed_m_s"]["kde_bandwidth"] == bandwidth(v)
    assert d["rebound_angle_deg"]["bandwidth_rule"] == "normal-reference"
    assert d["correlation"]["n_bounces"] == 55


def test_summary_warns_on_correlation(correlated):
    s = summarize(*correlated)
    c = s.correlation
    assert s.density_kind == "joint" and len(s.warnings) == 1
    assert f"Pearson r = {c.r:.3f}, p = {c.p_value:.3g}, n = 55" in s.warnings[0]
    assert "product of marginal densities rho_1(v) rho_2(theta) is not supported" in s.warnings[0]
    assert "will use a joint 2-D KDE" in s.warnings[0]


def test_summary_warns_on_small_n(bounces):
    s = summarize(bounces[0][:12], bounces[1][:12])
    assert any(w.startswith("Only 12 bounces: a kernel density estimate from fewer than 20")
               for w in s.warnings)


# --- error paths ------------------------------------------------------------------------------

@pytest.mark.parametrize(("data", "match"), [
    ([[1.0, 2.0], [3.0, 4.0]], r"`data` must be a 1-D array of measurements; got shape \(2, 2\)"),
    ([1.0], r"`data` needs at least 2 values for a density; got 1"),
    ([1.0, np.nan, 2.0], r"`data` must be a finite number; got nan at index \(1,\)"),
    ([1.0, 1.0, 1.0, 2.0], r"`data` has zero spread \(median absolute deviation 0"),
])
def test_bandwidth_rejects_degenerate_data(data, match):
    with pytest.raises(ValueError, match=match):
        bandwidth(data)


def test_bandwidth_rejects_bad_rules():
    with pytest.raises(ValueError, match=r"`rule` must be one of 'normal-reference', 'scott', "
                                         r"'silverman'; got 'iqr'"):
        bandwidth([1.0, 2.0, 4.0], "iqr")
    with pytest.raises(ValueError, match=r"`rule` must be a finite number > 0; got -0.1"):
        bandwidth([1.0, 2.0, 4.0], -0.1)
    with pytest.raises(ValueError, match=r"`bandwidth` must be a finite number > 0; got 0.0"):
        KDE1D([1.0, 2.0], 0.0)
    with pytest.raises(TypeError, match=r"`data` must be a real number or an array"):
        kde1d(["a", "b"])


@pytest.mark.parametrize(("kwargs", "match"), [
    (dict(speed=[2.0, 2.1, 1.9], angle=[40.0, 41.0]),
     r"`speed` and `angle` must have the same length \(one pair per bounce\); got 3 and 2"),
    (dict(speed=[2.0, -2.1, 1.9], angle=[40.0, 39.0, 41.5]),
     r"`speed` must be a finite number >= 0 m/s; got -2.1 at index \(1,\)"),
    (dict(speed=[2.0, 2.1, 1.9], angle=[40.0, 91.0, 39.0]),
     r"`angle` must be a finite number in \[-90, 90\] deg; got 91.0"),
    (dict(speed=[2.0, 2.1, 1.9], angle=[40.0, 39.0, 41.5], kind="both"),
     r"`kind` must be one of 'auto', 'product', 'joint'; got 'both'"),
    (dict(speed=[2.0, 2.1, 1.9], angle=[40.0, 39.0, 41.5], alpha=1.5),
     r"`alpha` must be a finite number in \(0, 1\); got 1.5"),
    (dict(speed=[2.0, 2.1, 1.9], angle=[40.0, 39.0, 41.5], bandwidth=0.1),
     r"`bandwidth` must be one of .* or a pair \(speed m/s, angle deg\); got 0.1"),
    (dict(speed=[2.0, 2.1, 1.9], angle=[40.0, 42.0, 38.0], kind="joint"),
     r"`speed` and `angle` lie on a line \(Pearson r = 1.000"),
    (dict(speed=[2.0, 2.0, 2.0], angle=[40.0, 42.0, 38.0]),
     r"`speed` is constant \(2.0\), so its correlation is undefined"),
])
def test_rebound_density_rejects_bad_input(kwargs, match):
    with pytest.raises(ValueError, match=match):
        rebound_density(**kwargs)


@pytest.mark.parametrize("kind", ["product", "joint"])
def test_density_rejects_shapes_that_do_not_broadcast(correlated, kind):
    rho = rebound_density(*correlated, kind=kind)
    with pytest.raises(ValueError, match=r"must broadcast to one shape; got `speed` \(3,\), "
                                         r"`angle` \(2,\)"):
        rho.logpdf([2.0, 2.1, 2.2], [40.0, 41.0])


def test_explicit_bandwidth_pair(bounces):
    rho = rebound_density(*bounces, bandwidth=(0.05, 1.5), kind="product")
    assert (rho.speed.bandwidth, rho.angle.bandwidth, rho.speed.rule) == (0.05, 1.5, "user")
    with pytest.raises(ValueError, match=r"`bandwidth` must be a finite number > 0; got -1.5"):
        summarize(*bounces, bandwidth=(0.05, -1.5))
