"""Model adequacy: does the fitted model reproduce the data within the stated errors?

Three checks after every inference, each at ``ALPHA / 3`` so that a well-specified model is
flagged in at most ``ALPHA`` of campaigns (Bonferroni):

1. **Residuals.** Each trial's standardised residual ``(observed - model) / sd``, and their
   chi-square with its degrees of freedom and p-value. For the likelihoods that compare each
   trial with the model (gaussian), the model and its covariance are those of the likelihood
   (stated errors, propagated incidence uncertainty, inferred noise or discrepancy, the shared
   scale factor) at the best-fitting posterior draw, so that a well-specified model gives a
   chi-square with ``2 n - d`` degrees of freedom (``d``: inferred parameters). For the
   likelihoods that compare distributions (kde, consistent), each trial is standardised by the
   mean and covariance of the posterior predictive distribution at the nominal incidence, with
   ``2 n`` degrees of freedom.
2. **The worst trial.** Per-trial posterior predictive p-values (Gelman, Meng & Stern 1996,
   Statistica Sinica 6, 733): the probability that a replicated measurement lies farther from
   the model than the observed one, in the Mahalanobis distance of the trial's covariance,
   averaged over posterior draws in closed form (normal residuals: ``exp(-D / 2)``; Student-t:
   ``(1 + D / nu)^(-nu / 2)``). The smallest, times the number of trials, is compared with the
   level.
3. **Distributions.** Two-sample Kolmogorov-Smirnov test and Hellinger distance between the
   observed rebounds and the pooled posterior predictive replicates, per observable.

The verdict in words never says the model reproduces the data when a check fails: it says by how
much the residuals exceed their errors, which trials are worst, and what to do.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from scipy import integrate, stats

from ._memory import DEFAULT_MEMORY_BUDGET, batch_rows

ALPHA = 0.01  #: overall false-alarm level of the verdict on a well-specified model
N_CHECKS = 3  #: residual chi-square, worst trial, distributions (each at ALPHA / N_CHECKS)
PPP_DRAWS = 400  #: posterior draws the per-trial p-values average over (fewer for big tables)
PPP_BOUNCES = 2_000_000  #: bounces simulated for the per-trial p-values at most
N_WORST = 5  #: trials named in the verdict
PER_TRIAL = ("residual_speed", "residual_angle", "ppp")  #: posterior.nc's ``adequacy`` group
PREDICTIVE_SAMPLE = 50_000  #: predictive values the distribution check compares at most
HELLINGER_SAMPLE = 20_000  #: values of each sample the Hellinger distance's KDEs use at most
BYTES_PER_TRIAL_CHECK = 256  #: per draw and trial: covariances, distances, p-values


@dataclass(frozen=True)
class Adequacy:
    """The checks' numbers and the verdict (see the module docstring).

    Per trial (arrays in table order): ``labels``, ``residual_speed`` and ``residual_angle``
    (standardised, dimensionless), ``ppp`` (posterior predictive p-value). ``basis`` says what
    the residuals are standardised by.
    """

    labels: tuple[str, ...]
    residual_speed: np.ndarray
    residual_angle: np.ndarray
    ppp: np.ndarray
    chi2: float
    dof: int
    p_value: float
    distribution: dict
    basis: str
    trends: dict = field(default_factory=dict)
    verdict: str = ""
    adequate: bool = True

    @property
    def rms(self) -> dict[str, float]:
        """Root mean square of the standardised residuals per observable (1 expected)."""
        return {k: _rms(v) for k, v in (("rebound_speed", self.residual_speed),
                                        ("rebound_angle", self.residual_angle))}

    @property
    def worst_p_value(self) -> float:
        """The smallest per-trial p-value, Bonferroni-corrected for the number of trials."""
        p = self.ppp[np.isfinite(self.ppp)]
        return float(min(1.0, p.min() * p.size)) if p.size else float("nan")

    def worst(self, k: int = N_WORST) -> list[dict[str, Any]]:
        """The ``k`` trials with the smallest p-values."""
        order = np.argsort(np.nan_to_num(self.ppp, nan=2.0))[:k]
        return [{"trial": self.labels[i], "residual_speed": _float(self.residual_speed[i]),
                 "residual_angle": _float(self.residual_angle[i]), "ppp": _float(self.ppp[i])}
                for i in order]

    def to_dict(self) -> dict[str, Any]:
        """The ``adequacy`` object of summary.json (the per-trial arrays go to posterior.nc)."""
        return {"adequate": self.adequate, "verdict": self.verdict, "basis": self.basis,
                "level": ALPHA, "chi2": self.chi2, "dof": self.dof,
                "chi2_per_dof": self.chi2 / self.dof if self.dof > 0 else None,
                "chi2_p_value": self.p_value, "rms_standardised_residual": self.rms,
                "n_trials": len(self.labels),
                "smallest_trial_p_value": _float(np.nanmin(self.ppp)) if self.ppp.size else None,
                "smallest_trial_p_value_corrected": self.worst_p_value,
                "worst_trials": self.worst(), "distribution": self.distribution,
                "trends": self.trends}

    def per_trial(self) -> dict[str, np.ndarray]:
        """The per-trial arrays, for posterior.nc's ``adequacy`` group."""
        return {k: getattr(self, k) for k in PER_TRIAL}

    @classmethod
    def from_saved(cls, record: dict, labels: tuple[str, ...],
                   arrays: dict[str, np.ndarray]) -> Adequacy:
        """Rebuild from summary.json's record and posterior.nc's per-trial arrays."""
        return cls(labels, arrays["residual_speed"], arrays["residual_angle"], arrays["ppp"],
                   record["chi2"], record["dof"], record["chi2_p_value"],
                   record["distribution"], record["basis"], record.get("trends", {}),
                   record["verdict"], record["adequate"])


def _float(x) -> float | None:
    x = float(x)
    return x if math.isfinite(x) else None


def _rms(r: np.ndarray) -> float:
    r = r[np.isfinite(r)]
    return float(np.sqrt(np.mean(r**2))) if r.size else float("nan")


# ------------------------------------------------------------------ residuals and p-values


def _survival(d2: np.ndarray, nu: float) -> np.ndarray:
    """P(D > d2) for a bivariate residual's squared Mahalanobis length: chi-square with 2
    degrees of freedom (normal), or 2 F(2, nu) (Student-t)."""
    if math.isinf(nu):
        return np.exp(-0.5 * d2)
    return (1.0 + d2 / nu) ** (-0.5 * nu)


def _mahalanobis(ds: np.ndarray, da: np.ndarray, cov: np.ndarray) -> np.ndarray:
    """Squared Mahalanobis length of residuals (..., n) under covariances (..., n, 2, 2)."""
    c00, c01, c11 = cov[..., 0, 0], cov[..., 0, 1], cov[..., 1, 1]
    det = c00 * c11 - c01**2
    with np.errstate(invalid="ignore", divide="ignore"):
        return (c11 * ds * ds - 2.0 * c01 * ds * da + c00 * da * da) / det


def measurement_residuals(like, samples: np.ndarray, lp: np.ndarray, y: np.ndarray,
                          work: float = DEFAULT_MEMORY_BUDGET):
    """Standardised residuals (n, 2), chi-square and per-trial p-values of a likelihood that
    compares each trial with the model (``like.covariances``; ``y``: (n, 2) observations);
    model evaluations in batches within ``work`` bytes."""
    flat = samples.reshape(-1, samples.shape[-1])
    best = flat[int(np.argmax(np.where(np.isfinite(lp), lp, -np.inf).ravel()))][None, :]
    h = like.pointwise(best).rebounds
    d = np.stack([h.speed[0] - y[:, 0], h.angle[0] - y[:, 1]], axis=-1)
    d[~h.ok[0]] = np.nan
    cov = like.covariances(best)[0]
    z = -d / np.sqrt(np.stack([cov[:, 0, 0], cov[:, 1, 1]], axis=-1))
    chi2 = _joint_chi2(like, best, d)
    return z, chi2, _ppp(like, flat, y, work)


def _joint_chi2(like, best: np.ndarray, d: np.ndarray) -> float:
    """Sum of the squared Mahalanobis lengths, with the shared scale factor (rank-one
    covariance across trials) taken out exactly (Sherman-Morrison)."""
    g = like.scale
    own = like.covariances(best)[0]
    if g is not None:
        own = own - g[:, :, None] * g[:, None, :]
    ok = np.all(np.isfinite(d), axis=1)
    q = _mahalanobis(d[ok, 0], d[ok, 1], own[ok])
    total = float(np.sum(q))
    if g is not None:
        inv = np.linalg.inv(own[ok])
        wg = np.einsum("nij,nj->ni", inv, g[ok])
        a, b = float(np.sum(wg * g[ok])), float(np.sum(wg * d[ok]))
        total -= b * b / (1.0 + a)
    return total


def _ppp(like, flat: np.ndarray, y: np.ndarray, work: float) -> np.ndarray:
    """Per-trial posterior predictive p-values, averaged in closed form over evenly spaced
    draws (as many as PPP_BOUNCES bounces allow, at most PPP_DRAWS)."""
    n = y.shape[0]
    k = int(max(20, min(PPP_DRAWS, PPP_BOUNCES // max(n, 1), flat.shape[0])))
    pick = np.unique(np.linspace(0, flat.shape[0] - 1, k).round().astype(int))
    # per row: the model's working memory and the covariances, distances, p-values per trial
    rows = batch_rows(0.5 * work, like.bytes_per_row + BYTES_PER_TRIAL_CHECK * n)
    total, count = np.zeros(n), np.zeros(n)
    for s in range(0, pick.size, rows):
        theta = flat[pick[s:s + rows]]
        h = like.pointwise(theta).rebounds
        d2 = _mahalanobis(h.speed - y[:, 0], h.angle - y[:, 1], like.covariances(theta))
        p = _survival(d2, like.nu)
        good = h.ok & np.isfinite(p)
        total += np.where(good, p, 0.0).sum(axis=0)
        count += good.sum(axis=0)
    with np.errstate(invalid="ignore"):
        return np.where(count > 0, total / np.maximum(count, 1), np.nan)


def predictive_residuals(replicates, y: np.ndarray):
    """Residuals, chi-square and per-trial p-values against the pooled posterior predictive
    distribution (mean and covariance of the replicates), for likelihoods of distributions."""
    pool = np.column_stack([replicates.rebound_speed.ravel(),
                            replicates.rebound_angle.ravel()])
    pool = pool[np.all(np.isfinite(pool), axis=1)]
    if pool.shape[0] < 10:
        nan = np.full(y.shape[0], np.nan)
        return np.column_stack([nan, nan]), float("nan"), nan
    mean, cov = pool.mean(axis=0), np.cov(pool, rowvar=False)
    d = y - mean
    z = d / np.sqrt(np.diag(cov))
    d2 = _mahalanobis(d[:, 0], d[:, 1], np.broadcast_to(cov, (y.shape[0], 2, 2)))
    return z, float(np.sum(d2)), _survival(d2, math.inf)


# ------------------------------------------------------------------ distributions


def hellinger(a: np.ndarray, b: np.ndarray) -> float:
    """Hellinger distance between Gaussian KDEs (Scott bandwidth) of two samples, by quadrature
    on a grid spanning both: 0 for identical, 1 for disjoint distributions. Samples larger
    than HELLINGER_SAMPLE are thinned evenly (the KDE's cost and memory grow with them; the
    distance changes far less than its own sampling error)."""
    a, b = _thin(np.asarray(a)), _thin(np.asarray(b))
    lo, hi = min(a.min(), b.min()), max(a.max(), b.max())
    pad = 0.25 * (hi - lo) + 1e-12
    ka, kb = stats.gaussian_kde(a), stats.gaussian_kde(b)
    # the integrand is a sum of Gaussians no narrower than the smaller bandwidth h: the
    # trapezoid rule with steps of h / 4 is exact to ~exp(-8 pi) ~ 1e-11 (it converges
    # exponentially for such functions), so the grid needs no more points than that (the
    # KDEs' cost is points x grid); at most 2048 points, as always
    h = math.sqrt(min(float(ka.covariance[0, 0]), float(kb.covariance[0, 0])))
    n = int(min(2048, max(256, math.ceil((hi - lo + 2 * pad) / (0.25 * h)) + 1)))
    x = np.linspace(lo - pad, hi + pad, n)
    fa, fb = ka(x), kb(x)
    bc = integrate.trapezoid(np.sqrt(fa * fb), x)
    return float(math.sqrt(max(0.0, 1.0 - min(bc, 1.0))))


def _thin(x: np.ndarray) -> np.ndarray:
    return x[::max(1, -(-x.size // HELLINGER_SAMPLE))]


def distribution_check(observed: dict[str, np.ndarray],
                       predicted: dict[str, np.ndarray]) -> dict[str, Any]:
    """Per observable: two-sample KS statistic and p-value, Hellinger distance, means and sds
    of the observed and predicted rebounds (``None`` where a sample is too small)."""
    out: dict[str, Any] = {}
    for name, unit in (("rebound_speed", "m/s"), ("rebound_angle", "deg")):
        obs = np.asarray(observed[name], dtype=float)
        pred = np.asarray(predicted[name], dtype=float)
        obs, pred = obs[np.isfinite(obs)], pred[np.isfinite(pred)]
        # the pooled replicates stand for the predictive distribution: an even thinning to
        # PREDICTIVE_SAMPLE values keeps the test's power (set by the observations) and bounds
        # its memory on big tables
        pred = pred[::max(1, -(-pred.size // PREDICTIVE_SAMPLE))]
        if pred.size < 10 or obs.size < 3 or np.ptp(obs) == 0 or np.ptp(pred) == 0:
            out[name] = {"ks_statistic": None, "ks_p_value": None, "hellinger": None,
                         "unit": unit}
            continue
        ks = stats.ks_2samp(pred, obs)
        out[name] = {"ks_statistic": float(ks.statistic), "ks_p_value": float(ks.pvalue),
                     "hellinger": hellinger(pred, obs),
                     "predicted_mean": float(np.mean(pred)), "observed_mean": float(np.mean(obs)),
                     "predicted_sd": float(np.std(pred, ddof=1)),
                     "observed_sd": float(np.std(obs, ddof=1)), "unit": unit}
    return out


def _trends(z: np.ndarray, trials) -> dict[str, Any]:
    """Spearman rank correlations of the residuals with the measured incidence."""
    out: dict[str, Any] = {}
    for column in ("incidence_angle", "incidence_speed"):
        x = np.asarray(trials.column(column), dtype=float)
        if column not in trials.measured or np.ptp(x) == 0 or trials.n < 8:
            continue
        for j, name in enumerate(("rebound_speed", "rebound_angle")):
            ok = np.isfinite(z[:, j])
            if ok.sum() < 8:
                continue
            rho, p = stats.spearmanr(x[ok], z[ok, j])
            out[f"{name}_vs_{column}"] = {"spearman_rho": float(rho), "p_value": float(p)}
    return out


# ------------------------------------------------------------------ the whole assessment


def assess(like, samples: np.ndarray, lp: np.ndarray, replicates, trials,
           work: float = DEFAULT_MEMORY_BUDGET) -> Adequacy:
    """The three checks and the verdict for an inference's likelihood, draws (chains, draws,
    d) with their log densities, and posterior predictive replicates; model evaluations in
    batches within ``work`` bytes."""
    y = np.column_stack([trials.rebound_speed, trials.rebound_angle]).astype(float)
    if like.compares == "trials":
        z, chi2, ppp = measurement_residuals(like, samples, lp, y, work)
        dof = 2 * int(np.all(np.isfinite(z), axis=1).sum()) - samples.shape[-1]
        basis = ("each trial's stated errors and the model's other variance terms, at the "
                 "best-fitting posterior draw")
    else:
        z, chi2, ppp = predictive_residuals(replicates, y)
        dof = 2 * trials.n
        basis = ("the posterior predictive distribution at the nominal incidence (its mean and "
                 "covariance)")
    p = float(stats.chi2.sf(chi2, dof)) if dof > 0 and math.isfinite(chi2) else float("nan")
    dist = distribution_check(
        {"rebound_speed": y[:, 0], "rebound_angle": y[:, 1]},
        {"rebound_speed": replicates.rebound_speed.ravel(),
         "rebound_angle": replicates.rebound_angle.ravel()})
    a = Adequacy(tuple(trials.labels), z[:, 0], z[:, 1], ppp, float(chi2), int(dof), p, dist,
                 basis, _trends(z, trials))
    failed = failures(a)
    return _with_verdict(a, failed)


def failures(a: Adequacy) -> list[str]:
    """Which checks fail at ``ALPHA / N_CHECKS`` each: "residuals", "trials", "distributions"."""
    level = ALPHA / N_CHECKS
    out = []
    if math.isfinite(a.p_value) and a.p_value < level:
        out.append("residuals")
    if math.isfinite(a.worst_p_value) and a.worst_p_value < level:
        out.append("trials")
    ks = [v["ks_p_value"] for v in a.distribution.values() if v.get("ks_p_value") is not None]
    if any(p < level / len(ks) for p in ks):
        out.append("distributions")
    return out


def _with_verdict(a: Adequacy, failed: list[str]) -> Adequacy:
    from ._verdict import verdict_text

    return replace(a, verdict=verdict_text(a, failed), adequate=not failed)
