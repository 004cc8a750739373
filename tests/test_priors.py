"""Priors (``bouncebayes.data``): they check their arguments on construction and are proper.

Expected values: the densities are compared with scipy.stats (an independent implementation)
and integrated numerically with ``scipy.integrate.quad`` (a proper density integrates to 1).
"""

import math

import numpy as np
import pytest
from scipy import integrate, stats

from bouncebayes.data import LogNormal, LogUniform, Normal, Uniform


@pytest.mark.parametrize("make, message", [
    (lambda: Uniform(1.0, 0.0),
     r"`high` of a uniform prior must be greater than `low` \(1.0\); got 0.0"),
    (lambda: Uniform(0.5, 0.5),
     r"`high` of a uniform prior must be greater than `low` \(0.5\); got 0.5"),
    (lambda: Uniform(0.0, math.inf), r"`high` of a uniform prior must be a finite number; got inf"),
    (lambda: Uniform(math.nan, 1.0), r"`low` of a uniform prior must be a finite number; got nan"),
    (lambda: Uniform(-1e308, 1e308),
     r"the uniform prior on \[-1e\+308, 1e\+308\] is wider than the largest float"),
    (lambda: Normal(0.0, -1.0), r"`scale` of a normal prior must be a finite number > 0; got -1.0"),
    (lambda: Normal(0.0, 0.0), r"`scale` of a normal prior must be a finite number > 0; got 0.0"),
    (lambda: Normal(math.inf, 1.0), r"`loc` of a normal prior must be a finite number; got inf"),
    (lambda: Normal(0.0, 1.0, 1.0, 0.5),
     r"`high` of a normal prior must be greater than `low` \(1.0\); got 0.5"),
    (lambda: Normal(0.0, 1.0, math.inf),
     r"`low` of a normal prior must be a finite number \(or -inf: no bound\); got inf"),
    (lambda: Normal(0.0, 1.0, 100.0, 200.0),
     r"the truncation \[100, 200\] of the normal prior \(mean 0, sd 1\) holds no probability"),
    (lambda: LogNormal(-1.0, 0.5),
     r"`median` of a lognormal prior must be a finite number > 0; got -1.0"),
    (lambda: LogNormal(1.0, 0.0),
     r"`sd_log` of a lognormal prior must be a finite number > 0; got 0.0"),
    (lambda: LogUniform(0.0, 1.0),
     r"`low` of a loguniform prior must be a finite number > 0; got 0.0"),
    (lambda: LogUniform(2.0, 1.0),
     r"`high` of a loguniform prior must be greater than `low` \(2.0\); got 1.0"),
])
def test_a_bad_prior_is_refused_in_one_line(make, message):
    with pytest.raises(ValueError, match=message) as err:
        make()
    assert "\n" not in str(err.value)


@pytest.mark.parametrize("make", [lambda: Uniform("0", 1.0), lambda: Normal(0.0, None),
                                  lambda: LogNormal(True, 1.0), lambda: LogUniform(1.0, [2.0])])
def test_a_prior_argument_that_is_not_a_number_is_a_type_error(make):
    with pytest.raises(TypeError, match=r"prior must be a real number; got .* of type"):
        make()


def test_integer_arguments_are_stored_as_floats():
    prior = Uniform(0, 2)
    assert prior == Uniform(0.0, 2.0)
    assert isinstance(prior.low, float) and prior.describe() == "uniform on [0, 2]"


@pytest.mark.parametrize("prior, reference", [
    (Uniform(0.1, 0.5), stats.uniform(0.1, 0.4)),
    (Normal(0.2, 0.1), stats.norm(0.2, 0.1)),
    (Normal(0.2, 0.1, 0.0), stats.truncnorm(-2.0, np.inf, loc=0.2, scale=0.1)),
    # a truncation far in the upper tail: the mass comes from the survival function (the
    # difference of two cdf values near 1 would lose every digit)
    (Normal(0.0, 1.0, 8.0, 9.0), stats.truncnorm(8.0, 9.0)),
    (LogNormal(1.5, 0.4), stats.lognorm(s=0.4, scale=1.5)),
    (LogUniform(1e-3, 10.0), stats.loguniform(1e-3, 10.0)),
])
def test_each_prior_is_scipys_density_and_integrates_to_one(prior, reference):
    low, high = prior.box(1e-12)
    x = np.linspace(low, high, 101)[1:-1]
    np.testing.assert_allclose(prior.logpdf(x), reference.logpdf(x), rtol=1e-10)
    mass, _ = integrate.quad(lambda v: math.exp(prior.logpdf(v)), low, high, limit=200)
    assert mass == pytest.approx(1.0, abs=1e-8)
    outside = [low - 1.0] if math.isfinite(prior.support[0]) else []
    outside += [high + 1.0] if math.isfinite(prior.support[1]) else []
    assert np.all(np.isneginf(prior.logpdf(np.array(outside))))


def test_a_wide_prior_keeps_a_finite_density():
    # log(1e300) = 690.8: the width itself is representable, the density is 1e-300
    assert Uniform(0.0, 1e300).logpdf(1.0) == pytest.approx(-math.log(1e300), rel=1e-15)
    # log(high / low) would overflow (1e600); log(high) - log(low) does not
    assert LogUniform(1e-300, 1e300).logpdf(1.0) == pytest.approx(
        -math.log(math.log(1e300) - math.log(1e-300)), rel=1e-15)
