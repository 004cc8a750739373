"""The three likelihoods of MODEL.md §5, each a callable ``loglike(theta) -> (n,)``.

- ``kde`` (the paper's): the experimental density of the rebounds (product of marginal KDEs, or
  a joint KDE when speed and angle are correlated) evaluated at the simulated rebound for the
  nominal incidence. It treats the scatter of the bounces as scatter of the parameters.
- ``gaussian`` (a measurement model): each trial is the simulated rebound for its own incidence
  plus Gaussian noise, with the standard errors of the table (or noise levels inferred as extra
  parameters); the incidence's own uncertainty is propagated through the model (linearised).
- ``consistent`` (data-consistent inversion, Butler, Jakeman & Wildey, SIAM J. Sci. Comput. 40,
  A984, 2018): prior times observed density over the prior's push-forward density, so that the
  push-forward of the result reproduces the observed distribution of rebounds.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal, get_args

import numpy as np
from scipy.stats import qmc

from ..data import Experiment, LogUniform, Prior, Trials
from ..density import ReboundDensity, rebound_density
from ._forward import Forward

LikelihoodName = Literal["kde", "gaussian", "consistent"]
LIKELIHOODS: tuple[str, ...] = get_args(LikelihoodName)

MEANINGS = {
    "kde": "the paper's likelihood: the density of the measured rebounds (kernel density "
           "estimate) at the rebound simulated for the nominal incidence. The scatter of the "
           "bounces is read as scatter of the parameters, so the posterior width reflects that "
           "scatter and does not shrink with more bounces.",
    "gaussian": "a measurement model: every bounce is the rebound simulated for its own "
                "incidence plus Gaussian measurement noise. The posterior is the uncertainty "
                "of one true parameter value and narrows like 1/sqrt(number of bounces).",
    "consistent": "data-consistent inversion: the distribution of parameters whose push-forward "
                  "through the model reproduces the observed distribution of rebounds (prior "
                  "times observed density over the prior's predicted density). It describes "
                  "bounce-to-bounce variability of the parameters, not the uncertainty of one "
                  "value.",
}
NOISE_PARAMETERS = ("sigma_speed", "sigma_angle")
NOISE_UNITS = {"sigma_speed": "m/s", "sigma_angle": "deg"}


def _nominal(experiment: Experiment):
    """The experiment's nominal incidence as one condition (speed, angle, spin arrays)."""
    inc = experiment.incidence
    return np.array([inc.speed]), np.array([inc.angle]), np.array([inc.spin])


@dataclass(frozen=True)
class KDELikelihood:
    """``log rho_exp(h(Theta))`` at the nominal incidence."""

    forward: Forward
    density: ReboundDensity
    name: str = "kde"

    def __call__(self, theta: np.ndarray) -> np.ndarray:
        r = self.forward(theta)
        ll = self.density.logpdf(r.speed[:, 0], r.angle[:, 0])
        return np.where(r.ok[:, 0], ll, -np.inf)

    def describe(self) -> dict:
        return {"density": self.density.to_dict(), "incidence": "nominal"}


@dataclass(frozen=True)
class ConsistentLikelihood:
    """``log rho_obs(Q(Theta)) - log pi_pred(Q(Theta))`` at the nominal incidence."""

    forward: Forward
    observed: ReboundDensity
    predicted: ReboundDensity
    n_predicted: int
    ratio_mean: float  #: E_prior[rho_obs / pi_pred]; ~1 when the observations are predictable
    name: str = "consistent"

    def __call__(self, theta: np.ndarray) -> np.ndarray:
        r = self.forward(theta)
        q_speed, q_angle = r.speed[:, 0], r.angle[:, 0]
        ll = self.observed.logpdf(q_speed, q_angle) - self.predicted.logpdf(q_speed, q_angle)
        return np.where(r.ok[:, 0], ll, -np.inf)

    def describe(self) -> dict:
        return {"observed_density": self.observed.to_dict(),
                "predicted_density": self.predicted.to_dict(),
                "n_prior_samples": self.n_predicted,
                "mean_ratio_under_prior": self.ratio_mean, "incidence": "nominal"}


@dataclass(frozen=True)
class GaussianLikelihood:
    """Bivariate normal per trial: residual covariance = measurement noise of the rebound plus
    J Sigma_inc J^T, the incidence uncertainty pushed through the model's Jacobian J."""

    forward: Forward
    speed: np.ndarray  #: observed rebound speeds, m/s
    angle: np.ndarray  #: observed rebound angles, deg
    noise: str  #: "given" (table standard errors) or "inferred" (extra parameters)
    rebound_var: np.ndarray  #: (n, 2) variances of the rebound measurement ("given")
    propagated: np.ndarray  #: (n, 2, 2) J Sigma_inc J^T
    jacobian_at: dict = field(default_factory=dict)
    name: str = "gaussian"

    def __call__(self, theta: np.ndarray) -> np.ndarray:
        theta = np.atleast_2d(theta)
        d = len(self.forward.names)
        r = self.forward(theta[:, :d])
        cov = np.broadcast_to(self.propagated, (theta.shape[0],) + self.propagated.shape).copy()
        if self.noise == "given":
            var = self.rebound_var
        else:
            var = theta[:, None, d:] ** 2 * np.ones((1, self.speed.size, 2))
        cov[..., 0, 0] += var[..., 0]
        cov[..., 1, 1] += var[..., 1]
        ds, da = r.speed - self.speed, r.angle - self.angle
        det = cov[..., 0, 0] * cov[..., 1, 1] - cov[..., 0, 1] ** 2
        quad = (cov[..., 1, 1] * ds**2 - 2 * cov[..., 0, 1] * ds * da
                + cov[..., 0, 0] * da**2) / det
        ll = -0.5 * (quad + np.log(det)) - np.log(2 * np.pi)
        ll = np.where(r.ok, ll, -np.inf).sum(axis=1)
        return np.where(np.isnan(ll), -np.inf, ll)

    def describe(self) -> dict:
        return {"noise": self.noise, "incidence": "per trial",
                "incidence_uncertainty": "propagated through the model's Jacobian at "
                                         + ", ".join(f"{k} = {v:.6g}" for k, v in
                                                     self.jacobian_at.items())}


def noise_priors(trials: Trials) -> dict[str, Prior]:
    """Log-uniform priors of the inferred noise levels: from 1e-3 to 10 times the spread of the
    observations (m/s and deg)."""
    out = {}
    for name, column in zip(NOISE_PARAMETERS, ("rebound_speed", "rebound_angle"), strict=True):
        spread = max(float(np.std(trials.column(column), ddof=1)), 1e-9)
        out[name] = LogUniform(1e-3 * spread, 10.0 * spread)
    return out


def make_likelihood(name: str, experiment: Experiment, trials: Trials, names: tuple[str, ...],
                    *, rng: np.random.Generator, noise: str = "auto", bandwidth="normal-reference",
                    density_kind: str = "auto", n_predicted: int = 4000):
    """Build the named likelihood for the inferred parameters ``names`` (model parameters)."""
    if name in ("kde", "consistent"):
        speed, angle, spin = _nominal(experiment)
        forward = Forward(experiment, names, speed=speed, angle=angle, spin=spin)
        observed = rebound_density(trials.rebound_speed, trials.rebound_angle,
                                   kind=density_kind, bandwidth=bandwidth)
        if name == "kde":
            return KDELikelihood(forward, observed)
        return _consistent(forward, observed, experiment, names, rng, n_predicted)
    return _gaussian(experiment, trials, names, noise)


def _consistent(forward, observed, experiment, names, rng, n):
    theta = np.column_stack([experiment.priors[k].sample(rng, n) for k in names])
    r = forward(theta)
    ok = r.ok[:, 0]
    if ok.sum() < 50:
        raise ValueError(f"only {int(ok.sum())} of {n} prior draws gave a bounce: the prior's "
                         "push-forward cannot be estimated; narrow the priors")
    predicted = rebound_density(r.speed[ok, 0], r.angle[ok, 0], kind="joint",
                                bandwidth="scott")
    ratio = np.exp(observed.logpdf(r.speed[ok, 0], r.angle[ok, 0])
                   - predicted.logpdf(r.speed[ok, 0], r.angle[ok, 0]))
    return ConsistentLikelihood(forward, observed, predicted, int(ok.sum()),
                                float(np.mean(ratio)))


def _gaussian(experiment: Experiment, trials: Trials, names, noise: str) -> GaussianLikelihood:
    se = np.column_stack([trials.se["rebound_speed"], trials.se["rebound_angle"]])
    if noise == "auto":
        noise = "given" if np.all(np.isfinite(se)) and np.all(se > 0) else "inferred"
    if noise == "given" and not (np.all(np.isfinite(se)) and np.all(se > 0)):
        raise ValueError(f"{trials.source}: noise='given' needs positive standard errors in "
                         "rebound_speed_se and rebound_angle_se for every trial; leave them out "
                         "to infer the noise levels instead")
    forward = Forward(experiment, names, speed=trials.incidence_speed,
                      angle=trials.incidence_angle, spin=trials.incidence_spin)
    at = _jacobian_point(experiment, trials, names, forward, se, noise)
    propagated = _propagated_covariance(experiment, trials, names, at)
    return GaussianLikelihood(forward, np.asarray(trials.rebound_speed),
                              np.asarray(trials.rebound_angle), noise,
                              se**2 if noise == "given" else np.zeros_like(se), propagated,
                              dict(zip(names, at, strict=True)))


def _incidence_variance(experiment: Experiment, trials: Trials) -> np.ndarray:
    """(n, 3) variances of incident speed, angle and spin: the table's standard errors where a
    column was measured, the experiment's bounce-to-bounce spread where it was not."""
    inc = experiment.incidence
    spread = {"incidence_speed": inc.speed_sd, "incidence_angle": inc.angle_sd,
              "incidence_spin": inc.spin_sd}
    out = []
    for column, sd in spread.items():
        if column in trials.measured:
            se = np.nan_to_num(trials.se[column], nan=0.0)
        else:
            se = np.full(trials.n, sd)
        out.append(se**2)
    return np.column_stack(out)


def _propagated_covariance(experiment, trials, names, at) -> np.ndarray:
    """J Sigma_inc J^T per trial, J by central differences of the model at ``at``."""
    var = _incidence_variance(experiment, trials)
    n = trials.n
    cov = np.zeros((n, 2, 2))
    if not np.any(var > 0):
        return cov
    steps = (1e-4 * np.asarray(trials.incidence_speed), np.full(n, 1e-3), np.full(n, 1e-2))
    base = [np.asarray(trials.incidence_speed, dtype=float),
            np.asarray(trials.incidence_angle, dtype=float),
            np.asarray(trials.incidence_spin, dtype=float)]
    theta = np.asarray(at, dtype=float)[None, :]
    for k in range(3):
        if not np.any(var[:, k] > 0):
            continue
        sides = []
        for sign in (1.0, -1.0):
            cond = [b.copy() for b in base]
            cond[k] = cond[k] + sign * steps[k]
            r = Forward(experiment, names, speed=cond[0], angle=cond[1], spin=cond[2])(theta)
            sides.append(np.column_stack([r.speed[0], r.angle[0]]))
        jac = (sides[0] - sides[1]) / (2 * steps[k][:, None])  # (n, 2)
        cov += var[:, k, None, None] * jac[:, :, None] * jac[:, None, :]
    return np.nan_to_num(cov)


def _jacobian_point(experiment, trials, names, forward, se, noise) -> np.ndarray:
    """Where to linearise: the best of a deterministic (Sobol) design over the prior box under
    the likelihood without the propagated term."""
    boxes = np.array([experiment.priors[k].box(1e-4) for k in names])
    design = qmc.Sobol(len(names), scramble=False).random(256)
    theta = boxes[:, 0] + design * (boxes[:, 1] - boxes[:, 0])
    r = forward(theta)
    scale = se if noise == "given" else np.column_stack(
        [np.full(trials.n, np.std(trials.rebound_speed, ddof=1)),
         np.full(trials.n, np.std(trials.rebound_angle, ddof=1))])
    chi2 = (((r.speed - trials.rebound_speed) / scale[:, 0]) ** 2
            + ((r.angle - trials.rebound_angle) / scale[:, 1]) ** 2)
    chi2 = np.where(r.ok, chi2, np.inf).sum(axis=1)
    return theta[int(np.argmin(chi2))]
