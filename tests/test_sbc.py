"""Simulation-based calibration of the gaussian likelihood (slow: ``make test-slow``).

The study lives in ``benchmarks/sbc.py`` (also runnable on its own); this test runs it with its
defaults (300 campaigns drawn from the prior, grid quadrature, 999 posterior draws each), writes
``benchmarks/results/sbc.json`` and checks the two calibration criteria of Talts et al. (2018):
ranks of the truth uniform (chi-square on 20 bins, p > 0.01) and 90 % intervals covering the
truth at a rate inside the central 99 % binomial interval around 0.9, and the adequacy check
raising at most its nominal 1 % of false alarms on these well-specified campaigns.
"""

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import sbc  # noqa: E402

pytestmark = pytest.mark.slow


def test_rank_test_flags_a_miscalibrated_posterior():
    # negative control of the statistic itself: ranks of an over-confident posterior (truth
    # often outside all draws) pile into the end bins and fail; uniform ranks pass
    rng = np.random.default_rng(1804)
    uniform = rng.integers(0, 1000, size=300)
    overconfident = np.where(rng.uniform(size=300) < 0.3, rng.choice([0, 999], size=300),
                             uniform)
    assert sbc.rank_test(uniform, 999, 20)["chi2_p_value"] > 0.01
    assert sbc.rank_test(overconfident, 999, 20)["chi2_p_value"] < 1e-6
    with pytest.raises(ValueError, match=r"`draws` \+ 1 \(1000\) must be a multiple of `bins`"):
        sbc.rank_test(uniform, 999, 7)


def test_gaussian_likelihood_is_calibrated():
    result = sbc.run_sbc()
    assert sbc.RESULTS.exists()
    n = result["settings"]["campaigns"]
    assert n >= 200
    assert result["campaigns_with_rolling_bounces"] == 0
    lo, hi = result["coverage_bounds_99"]
    for name, p in result["parameters"].items():
        assert sum(p["rank_histogram"]) == n
        assert p["chi2_p_value"] > 0.01, (name, p["rank_histogram"])
        assert lo <= p["coverage90"] <= hi, (name, p["coverage90"], (lo, hi))
    # the adequacy check on these well-specified campaigns: false alarms at most its nominal
    # level (1 %), within the one-sided 99 % binomial bound of that level's count
    adequacy = result["adequacy"]
    assert adequacy["campaigns"] == n
    assert adequacy["at_most_level_within_binomial"], adequacy
