"""The adequacy verdict in words: what was checked, by how much the model misses, which trials
are worst, and what to do. It never says the model reproduces the data when a check fails."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from ._adequacy import Adequacy

NAMES = {"rebound_speed": "rebound speed", "rebound_angle": "rebound angle"}
TREND_P = 1e-3  #: p-value of a rank correlation of residuals with the incidence worth a remedy
OUTLIER_SHARE = 0.5  #: share of the chi-square from the worst tenth of trials: outliers


def verdict_text(a: Adequacy, failed: list[str]) -> str:
    """One paragraph: the checks' outcome, and for a misfit its size, worst trials, remedies."""
    if not failed:
        return _passed(a)
    worst = [w for w in a.worst() if w["ppp"] is not None and w["ppp"] < 0.01]
    if "residuals" in failed:
        opening = f"{_sizes(a)}; {_chi2(a)}"
    elif "trials" in failed:
        opening = (f"{sum(p < 0.01 for p in a.ppp if p == p)} trials lie outside their "
                   f"predictive distribution (the worst at corrected p = "
                   f"{a.worst_p_value:.2g}), although the residuals as a whole are of the "
                   f"expected size ({_chi2(a)})")
    else:
        opening = "the distribution of the rebounds differs from the predicted one"
    parts = [f"The model does not reproduce the measured rebounds within their stated errors: "
             f"{opening}."]
    if worst:
        parts.append("Worst trials: " + "; ".join(_trial(w) for w in worst) + ".")
    if "distributions" in failed:
        parts.append(_distributions(a) + ".")
    parts.append("The intervals assume the model and the stated errors are right, so they are "
                 "too narrow.")
    parts.append("What to do: " + "; ".join(_remedies(a)) + ".")
    return " ".join(parts)


def _passed(a: Adequacy) -> str:
    ks = [f"{v['ks_p_value']:.2g} for {NAMES[k].split()[1]}" for k, v in a.distribution.items()
          if v.get("ks_p_value") is not None]
    dist = f"; observed and predicted distributions agree (KS p = {', '.join(ks)})" if ks else ""
    worst = a.worst_p_value
    trials = (f"; no trial lies outside its predictive distribution (smallest per-trial "
              f"p-value {np.nanmin(a.ppp):.2g}, {worst:.2g} after correcting for "
              f"{len(a.labels)} trials)" if math.isfinite(worst) else "")
    return (f"The model reproduces the measured rebounds within their stated errors: "
            f"{_chi2(a)}{trials}{dist}. Residuals are standardised by {a.basis}.")


def _chi2(a: Adequacy) -> str:
    if a.dof <= 0 or not math.isfinite(a.chi2):
        return "no chi-square (too few trials)"
    p = f"p = {a.p_value:.2g}" if a.p_value > 1e-300 else "p < 1e-300"
    return f"chi-square per degree of freedom {a.chi2 / a.dof:.3g} over {a.dof} ({p})"


def _sizes(a: Adequacy) -> str:
    words = [f"{NAMES[name]} residuals are {rms:.3g} times their standard errors"
             for name, rms in a.rms.items() if math.isfinite(rms)]
    if not words:
        return "the residuals could not be computed"
    return ", ".join(words) + " (rms of the standardised residuals; about 1 expected)"


def _trial(w: dict) -> str:
    zs, za = w["residual_speed"], w["residual_angle"]
    z = ", ".join(f"{n} {v:+.3g} sd" for n, v in (("speed", zs), ("angle", za))
                  if v is not None)
    return f"{w['trial']} ({z}; p = {w['ppp']:.2g})"


def _distributions(a: Adequacy) -> str:
    out = []
    for name, v in a.distribution.items():
        if v.get("ks_p_value") is None:
            continue
        out.append(f"{NAMES[name]}: predicted {v['predicted_mean']:.4g} +- "
                   f"{v['predicted_sd']:.2g} {v['unit']}, observed {v['observed_mean']:.4g} +- "
                   f"{v['observed_sd']:.2g} {v['unit']} (KS p = {v['ks_p_value']:.2g})")
    return "The predicted and observed distributions differ: " + "; ".join(out)


def _outliers(a: Adequacy) -> bool:
    """A few trials carry most of the misfit: the worst tenth holds over half the chi-square."""
    q = a.residual_speed**2 + a.residual_angle**2
    q = np.sort(q[np.isfinite(q)])[::-1]
    k = max(1, q.size // 10)
    return bool(q.size >= 10 and q[:k].sum() > OUTLIER_SHARE * q.sum())


def _remedies(a: Adequacy) -> list[str]:
    out = []
    if _outliers(a):
        out.append("check the worst trials (tracking, a second bounce in the flight, a "
                   "deflected ball), or rerun with `discrepancy` = student-t, whose heavy tails "
                   "let outlying trials count less")
    else:
        out.append("rerun with `discrepancy` = normal (an inferred model error per observable, "
                   "added in quadrature to the stated errors; the intervals then include it)")
    trends = [f"{NAMES[key.split('_vs_')[0]]} with {key.split('_vs_')[1].replace('_', ' ')} "
              f"(Spearman rho {t['spearman_rho']:+.2f})"
              for key, t in sorted(a.trends.items()) if t["p_value"] < TREND_P]
    if trends:
        out.append("the residuals trend with the incidence (" + ", ".join(trends) + "): the "
                   "contact law misses how the rebound changes with it; try another normal law "
                   "or tangential compliance in [model]")
    out.append("check that the standard errors of the table are not understated and that the "
               "incident spin is right (an incidence_spin column)"
               + ("" if trends else "; consider another normal law or tangential compliance "
                                    "in [model]"))
    return out
