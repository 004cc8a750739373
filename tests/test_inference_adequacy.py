"""Model adequacy, model discrepancy and the shared scale factor (``bouncebayes.inference``).

Where the expected values come from:
- the likelihood's joint density with a shared scale factor is checked against an independent
  dense computation: ``scipy.stats.multivariate_normal`` on the full (2N x 2N) covariance, and
  for Student-t residuals ``scipy.integrate.quad`` over the scale error of products of
  ``scipy.stats.multivariate_t`` densities;
- per-trial Student-t terms against ``scipy.stats.multivariate_t``;
- campaigns are synthesised by ``bouncebayes.data.synthesize`` from known parameters; the
  misspecified ones use physics the fitted model does not have (another normal law over a range
  of incidence speeds, spin scatter the table does not mention at incidences that leave rolling,
  corrupted trials), and the check must fire; the well-specified ones must pass;
- a wrong ball mass is absorbed exactly by the damping (the damping number
  ``eta / (m^(3/5) k^(2/5) V^(1/5))``, docs/model.md §4.2): the check must pass and ``eta`` must
  come out as ``eta_true (m / m_true)^(3/5)``, a closed form.
"""

from __future__ import annotations

import copy
import math
import tomllib

import numpy as np
import pytest
from scipy import integrate, stats

from bouncebayes.data import demo_campaign, make_trials, parse_experiment, synthesize
from bouncebayes.inference import (GridConfig, MHConfig, STUDENT_T_DOF, adequacy_failures,
                                   infer)

DEMO = demo_campaign()
DOC = tomllib.loads(DEMO.experiment.read_text(encoding="utf-8"))
GRID = GridConfig(draws=2000, points=128)


def experiment(**edits):
    """The demo's experiment over a range of incidences (45 +- 12 deg, 3 +- 1 m/s), with
    ``section__key`` edits."""
    doc = copy.deepcopy(DOC)
    doc["incidence"].update(speed_sd_m_s=1.0, angle_sd_deg=12.0, angle_deg=45.0)
    for key, value in edits.items():
        section, name = key.split("__")
        doc[section][name] = value
    return parse_experiment(doc)


def fit(exp, trials, **kw):
    kw.setdefault("sampler", "grid")
    kw.setdefault("config", GRID)
    kw.setdefault("discrepancy", "none")
    return infer(exp, trials, seed=3, **kw)


# --------------------------------------------------------------------------- the likelihood


def _likelihood(discrepancy="none", n=6, scale=0.02):
    exp = experiment()
    c = synthesize(exp, seed=2, n=n)
    t = c.trials
    trials = make_trials(exp, rebound_speed=t.rebound_speed, rebound_angle=t.rebound_angle,
                         incidence_speed=t.incidence_speed, incidence_angle=t.incidence_angle,
                         se={k: v for k, v in t.se.items() if np.all(np.isfinite(v))},
                         scale_rel_sd=np.full(n, scale))
    from bouncebayes.inference._likelihood import make_likelihood

    return make_likelihood("gaussian", exp, trials, ("mu", "eta"), rng=np.random.default_rng(0),
                           noise="given", discrepancy=discrepancy), trials


def _dense(like, theta):
    """Residuals (2N,) ordered (speed_1, angle_1, ...) and the full covariance (2N, 2N)."""
    h = like.pointwise(theta[None, :]).rebounds
    r = np.column_stack([like.speed - h.speed[0], like.angle - h.angle[0]]).ravel()
    own = like.covariances(theta[None, :])[0] - like.scale[:, :, None] * like.scale[:, None, :]
    n = like.speed.size
    cov = np.zeros((2 * n, 2 * n))
    for i in range(n):
        cov[2 * i:2 * i + 2, 2 * i:2 * i + 2] = own[i]
    g = like.scale.ravel()
    return r, cov, g


def test_the_shared_scale_is_marginalised_exactly_for_normal_residuals():
    like, _ = _likelihood("normal")
    assert like.scale is not None and np.all(np.abs(like.scale[:, 0]) > 0)
    theta = np.array([0.16, 1.35, 0.03, 0.4])  # mu, eta, discrepancy speed and angle
    r, cov, g = _dense(like, theta)
    expected = stats.multivariate_normal(np.zeros(r.size), cov + np.outer(g, g)).logpdf(r)
    assert like(theta[None, :])[0] == pytest.approx(expected, rel=1e-10, abs=1e-8)


def test_student_t_terms_and_the_shared_scale_by_quadrature():
    like, _ = _likelihood("student-t")
    theta = np.array([0.16, 1.35, 0.03, 0.4])
    r, cov, g = _dense(like, theta)
    n = like.speed.size
    dists = [stats.multivariate_t(np.zeros(2), cov[2 * i:2 * i + 2, 2 * i:2 * i + 2],
                                  df=STUDENT_T_DOF) for i in range(n)]

    def integrand(eps):
        shifted = (r - eps * g).reshape(n, 2)
        return math.exp(sum(d.logpdf(x) for d, x in zip(dists, shifted, strict=True))
                        + stats.norm.logpdf(eps))

    expected = math.log(integrate.quad(integrand, -8, 8, epsabs=0, epsrel=1e-10)[0])
    assert like(theta[None, :])[0] == pytest.approx(expected, rel=1e-8)
    # each trial on its own: a bivariate t with the shared scale's variance added
    own = like.pointwise(theta[None, :]).terms[0]
    full = like.covariances(theta[None, :])[0]
    alone = [stats.multivariate_t(np.zeros(2), full[i], df=STUDENT_T_DOF).logpdf(
        r.reshape(n, 2)[i]) for i in range(n)]
    np.testing.assert_allclose(own, alone, rtol=1e-10)


def test_discrepancy_needs_standard_errors_and_names_the_conflict():
    exp = experiment()
    t = synthesize(exp, seed=1, n=10).trials
    bare = make_trials(exp, rebound_speed=t.rebound_speed, rebound_angle=t.rebound_angle,
                       source="bare.csv")
    with pytest.raises(ValueError, match=r"^bare.csv: `discrepancy` \('normal'\) adds a model "
                                         r"error to each trial's standard errors"):
        infer(exp, bare, discrepancy="normal")
    with pytest.raises(ValueError, match=r"`discrepancy` must be one of"):
        infer(exp, t, discrepancy="huge")
    with pytest.raises(ValueError, match=r"applies to the gaussian likelihood"):
        infer(exp, t, likelihood="kde", discrepancy="student-t")


# --------------------------------------------------------------------------- the check


def test_a_well_specified_campaign_passes():
    exp = experiment()
    result = fit(exp, synthesize(exp, seed=4, n=55).trials)
    a = result.adequacy
    assert a.adequate and not adequacy_failures(a)
    assert 0.6 < a.chi2 / a.dof < 1.5 and a.dof == 2 * 55 - 2
    assert a.verdict.startswith("The model reproduces the measured rebounds")
    assert all(p.misfit == "" and "±" in p.paper_form() for p in result.parameters)


def test_another_normal_law_over_a_range_of_speeds_fails_and_says_what_to_do():
    truth = experiment(model__normal="hunt-crossley", contact__eta=0.3)
    result = fit(experiment(), synthesize(truth, seed=3, n=55).trials)
    a = result.adequacy
    assert not a.adequate and "residuals" in adequacy_failures(a)
    assert a.chi2 / a.dof > 5
    assert "times their standard errors" in a.verdict and "`discrepancy`" in a.verdict
    assert result.warnings[0] == a.verdict
    # no interval is printed for a model that misfits
    assert all("no interval" in p.paper_form() and "±" not in p.paper_form()
               for p in result.parameters)


def test_spin_scatter_the_table_does_not_mention_fails_where_bounces_roll():
    # at 20 deg the bounces leave rolling, where the rebound depends on the incident spin
    truth = experiment(incidence__angle_deg=20.0, incidence__spin_sd_rad_s=100.0)
    result = fit(experiment(incidence__angle_deg=20.0), synthesize(truth, seed=3, n=55).trials)
    assert not result.adequacy.adequate
    assert result.adequacy.rms["rebound_angle"] > 3


def test_a_wrong_mass_is_absorbed_by_the_damping_exactly():
    m = DOC["ball"]["mass_kg"]
    truth = experiment(ball__mass_kg=1.3 * m)
    result = fit(experiment(), synthesize(truth, seed=3, n=55).trials)
    assert result.adequacy.adequate
    eta = result.parameters[result.names.index("eta")]
    expected = DOC["contact"]["eta"] * 1.3 ** -0.6  # same damping number (docs/model.md §4.2)
    assert eta.ci90[0] < expected < eta.ci90[1]


def test_outlying_trials_are_named_and_student_t_recommended():
    exp = experiment()
    t = synthesize(exp, seed=5, n=55).trials
    speed = np.array(t.rebound_speed)
    speed[[7, 30]] += 12 * t.se["rebound_speed"][[7, 30]]
    bad = make_trials(exp, rebound_speed=speed, rebound_angle=t.rebound_angle,
                      incidence_speed=t.incidence_speed, incidence_angle=t.incidence_angle,
                      se={k: v for k, v in t.se.items() if np.all(np.isfinite(v))},
                      labels=t.labels)
    a = fit(exp, bad).adequacy
    assert "trials" in adequacy_failures(a)
    named = a.verdict.split("Worst trials: ")[1]
    assert named.startswith((t.labels[7], t.labels[30]))
    assert t.labels[7] in named and t.labels[30] in named
    assert "student-t" in a.verdict


def test_auto_refits_with_a_discrepancy_and_keeps_the_first_fit():
    truth = experiment(model__normal="hunt-crossley", contact__eta=0.3)
    trials = synthesize(truth, seed=3, n=55).trials
    result = infer(experiment(), trials, seed=3, discrepancy="auto", sampler="grid",
                   config=GRID)
    assert result.discrepancy == "normal" and result.sampler == "mh"
    assert result.names[-2:] == ("discrepancy_speed", "discrepancy_angle")
    first = result.first_fit
    assert first is not None and not first["adequacy"]["adequate"]
    assert any("with `discrepancy` = auto the posterior was computed again" in w
               for w in result.warnings)
    s = result.summary()
    assert s["discrepancy"] == "normal" and s["fit_without_discrepancy"] == first
    # the model error is of the size of the misfit, far above the stated noise
    tau = result.parameters[result.names.index("discrepancy_speed")]
    assert tau.median > 3 * np.median(trials.se["rebound_speed"])
    # mu's truth (the friction law is right) is inside the honest interval
    mu = result.parameters[0]
    assert mu.ci90[0] < 0.16 < mu.ci90[1]


def test_the_kde_likelihood_is_judged_against_its_predictive_distribution():
    exp = parse_experiment(copy.deepcopy(DOC))
    from bouncebayes.data import load_trials

    result = infer(exp, load_trials(DEMO.trials, exp), likelihood="kde", seed=1,
                   config=MHConfig(draws=2000))
    a = result.adequacy
    assert a.adequate and a.dof == 2 * 55
    assert "posterior predictive distribution at the nominal incidence" in a.basis


@pytest.mark.slow
def test_kfold_predictions_cover_with_a_discrepancy_and_not_without():
    """5-fold cross-validation of the 90 % posterior predictive intervals of held-out bounces
    on three campaigns made with another normal law (Hunt-Crossley data, Kelvin-Voigt fit):
    with an inferred discrepancy they cover 85-95 % of the 330 held-out rebounds (binomial sd
    at 90 %: 1.7 %), without it far fewer, and the adequacy check flags every fold."""
    from bouncebayes.studies import kfold_coverage, scenario_campaign

    with_term, without, flagged = [], [], 0
    for seed in (1, 2, 3):
        exp, trials, _ = scenario_campaign("another normal law", seed, 55)
        a = kfold_coverage(exp, trials, folds=5, seed=seed, discrepancy="normal")
        b = kfold_coverage(exp, trials, folds=5, seed=seed, discrepancy="none")
        with_term += [a["rebound_speed"], a["rebound_angle"]]
        without += [b["rebound_speed"], b["rebound_angle"]]
        flagged += b["folds_flagged"]
    assert 0.85 <= np.mean(with_term) <= 0.95
    assert np.mean(without) < 0.6
    assert flagged == 15


def test_a_measured_spin_reaches_every_likelihood():
    """A table's incidence_spin column: each trial's own in the measurement model, its mean at
    the nominal incidence of kde and consistent (the experiment file's spin is 0)."""
    from bouncebayes.data import load_trials
    from bouncebayes.inference._likelihood import make_likelihood

    exp = parse_experiment(copy.deepcopy(DOC))
    t = load_trials(DEMO.trials, exp)
    spin = np.linspace(100.0, 200.0, t.n)
    trials = make_trials(exp, rebound_speed=t.rebound_speed, rebound_angle=t.rebound_angle,
                         incidence_speed=t.incidence_speed, incidence_angle=t.incidence_angle,
                         incidence_spin=spin,
                         se={k: v for k, v in t.se.items() if np.all(np.isfinite(v))})
    rng = np.random.default_rng(0)
    for name in ("kde", "consistent"):
        like = make_likelihood(name, exp, trials, ("mu", "eta"), rng=rng)
        assert float(np.ravel(like.forward.model.values["spin"])[0]) == pytest.approx(150.0)
    gauss = make_likelihood("gaussian", exp, trials, ("mu", "eta"), rng=rng)
    np.testing.assert_array_equal(np.ravel(gauss.forward.model.values["spin"]), spin)


def test_a_shared_scale_error_is_covered_when_the_table_states_it():
    """Every rebound speed 3 % high (one calibration error for the campaign; the incidence
    speed is the experiment's nominal one, not measured with the camera): a model that knows
    nothing of it misses the true mu and eta with confident intervals (and no check can see
    it: the error is absorbed), while the stated 2 % scale uncertainty, marginalised as one
    shared factor, gives intervals that hold the truth (0.16, 1.35 kg/s)."""
    exp = parse_experiment(copy.deepcopy(DOC))
    t = synthesize(exp, seed=8, n=55).trials
    se = {k: v for k, v in t.se.items() if k.startswith("rebound")}

    def fitted(scale_sd):
        trials = make_trials(exp, rebound_speed=np.asarray(t.rebound_speed) * 1.03,
                             rebound_angle=t.rebound_angle, se=se, scale_rel_sd=scale_sd)
        return {p.name: p.ci90 for p in fit(exp, trials).parameters}

    blind, honest = fitted(None), fitted(np.full(55, 0.02))
    assert not blind["mu"][0] <= 0.16 <= blind["mu"][1]
    assert not blind["eta"][0] <= 1.35 <= blind["eta"][1]
    assert honest["mu"][0] <= 0.16 <= honest["mu"][1]
    assert honest["eta"][0] <= 1.35 <= honest["eta"][1]
