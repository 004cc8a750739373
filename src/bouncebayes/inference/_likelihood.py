"""The three likelihoods (see ``docs/model.md``), each a callable ``loglike(theta) -> (n,)``.

- ``kde`` (the paper's): the experimental density of the rebounds (product of marginal KDEs, or
  a joint KDE when speed and angle are correlated) evaluated at the simulated rebound for the
  nominal incidence. It treats the scatter of the bounces as scatter of the parameters.
- ``gaussian`` (a measurement model): each trial is the simulated rebound for its own incidence
  plus Gaussian noise, with the standard errors of the table (or noise levels inferred as extra
  parameters); the incidence's own uncertainty is propagated through the model (linearised).
- ``consistent`` (data-consistent inversion, Butler, Jakeman & Wildey, SIAM J. Sci. Comput. 40,
  A984, 2018): prior times observed density over the prior's push-forward density, so that the
  push-forward of the result reproduces the observed distribution of rebounds.

Every likelihood has the same interface: ``__call__`` (the samplers' log-likelihood),
``pointwise`` (its terms, for the ``log_likelihood`` group of posterior.nc), ``predict`` (the
posterior predictive of the rebounds), ``structured_grid`` (a fast exact grid, or ``None``),
``extra_parameters`` (parameters it adds to the model's), ``bytes_per_row`` (its working
memory per parameter row, for the memory plan) and ``compares`` ("trials": each trial with the
model, with ``covariances``, ``scale`` and ``nu`` for the adequacy check; "distributions": the
rebounds' distribution at the nominal incidence).

What "pointwise" means: the gaussian likelihood is a product over trials, and its terms are the
log-densities of each trial's rebound (``arviz_stats.loo`` and ``compare`` apply). The kde and
consistent likelihoods are one density evaluated at one simulated rebound (the nominal
incidence); they do not factor over trials, so their single term per draw is stored as one
observation, ``campaign``, and leave-one-out cross-validation across trials is not defined for
them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any, NamedTuple

import numpy as np
from scipy.stats import qmc

from ..data import INFERENCE_CHOICES, Experiment, LogUniform, Prior, Trials
from ..density import ReboundDensity, rebound_density
from . import _kernels as _kernel_module
from ._forward import Forward
from ._memory import BYTES_PER_BOUNCE, DEFAULT_MEMORY_BUDGET, batch_rows

_kernels: Any = _kernel_module  # numba dispatchers: mypy cannot see their signatures
LIKELIHOODS: tuple[str, ...] = INFERENCE_CHOICES["likelihood"]

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
    "population": "a hierarchical model: every bounce has its own parameters, drawn from a "
                  "population (normal or lognormal, truncated to the prior's domain) whose "
                  "mean and spread (<parameter>_mean, <parameter>_sd) are inferred; each "
                  "bounce is the rebound simulated for its own incidence and parameters plus "
                  "Gaussian measurement noise. The spread is bounce-to-bounce variability, "
                  "separated from the noise; the population predictive is what a new bounce "
                  "looks like.",
}
DISCREPANCIES: tuple[str, ...] = INFERENCE_CHOICES["discrepancy"]
DISCREPANCY_PARAMETERS = ("discrepancy_speed", "discrepancy_angle")
DISCREPANCY_MEANINGS = {
    "none": "none: the model is taken as exact, residuals are measurement noise only",
    "normal": "inferred: a model error per observable (discrepancy_speed, discrepancy_angle), "
              "normal, added in quadrature to each trial's standard errors",
    "student-t": "inferred: a model error per observable (discrepancy_speed, "
                 "discrepancy_angle) added in quadrature to each trial's standard errors, with "
                 "Student-t residuals (4 degrees of freedom) that let outlying trials count "
                 "less",
}
#: the discrepancy prior's lower end in median standard errors: below about a fifth of the noise
#: 55 bounces cannot tell a model error from none, and a longer flat stretch of the posterior
#: in log(tau) only slows the samplers' random walk
DISCREPANCY_FLOOR = 0.02
STUDENT_T_DOF = 4.0  #: degrees of freedom of the heavy-tailed residuals (docs/likelihoods.md)
HERMITE_NODES = 20  #: Gauss-Hermite nodes over the shared scale with Student-t residuals
NOISE_PARAMETERS = ("sigma_speed", "sigma_angle")
NOISE_UNITS = {"sigma_speed": "m/s", "sigma_angle": "deg", "discrepancy_speed": "m/s",
               "discrepancy_angle": "deg"}
JACOBIAN_TRIALS = 2000  #: trials (evenly spaced) that choose where to linearise
POINTWISE_MEANING = {
    "gaussian": "per trial: the log-density of each trial's measured rebound",
    "kde": "one term per draw (observation `campaign`): the kde likelihood is one density "
           "evaluated at one simulated rebound and does not factor over trials, so "
           "leave-one-out cross-validation across trials is not defined for it",
    "consistent": "one term per draw (observation `campaign`): the consistent likelihood is "
                  "one density ratio at one simulated rebound and does not factor over "
                  "trials, so leave-one-out cross-validation across trials is not defined",
    "population": "per trial: the log of each trial's likelihood integrated over its own "
                  "parameters against the population",
}


class Pointwise(NamedTuple):
    """Log-likelihood terms (n, n_observations) and the rebounds they came from."""

    terms: np.ndarray
    rebounds: Any  #: ``Forward`` output, arrays (n, n_conditions)


def _nominal(experiment: Experiment, trials: Trials):
    """The nominal incidence as one condition (speed, angle, spin arrays): the experiment's,
    with the spin the table measured (its mean) where it has an ``incidence_spin`` column: a
    spin measured elsewhere is information the experiment file's default of 0 is not."""
    inc = experiment.incidence
    spin = (float(np.mean(trials.incidence_spin)) if "incidence_spin" in trials.measured
            else inc.spin)
    return np.array([inc.speed]), np.array([inc.angle]), np.array([spin])


@dataclass(frozen=True)
class _AtNominal:
    """Shared behaviour of the likelihoods evaluated at the nominal incidence."""

    forward: Forward

    extra_parameters = ()
    observations = ("campaign",)
    compares = "distributions"  #: the adequacy check standardises by the predictive (§10)

    @property
    def bytes_per_row(self) -> float:
        return float(BYTES_PER_BOUNCE)

    def __call__(self, theta: np.ndarray) -> np.ndarray:
        return self.pointwise(theta).terms[:, 0]

    def pointwise(self, theta: np.ndarray) -> Pointwise:
        r = self.forward(theta)
        ll = self._logdensity(r.speed[:, 0], r.angle[:, 0])
        return Pointwise(np.where(r.ok[:, 0], ll, -np.inf)[:, None], r)

    def _logdensity(self, speed: np.ndarray, angle: np.ndarray) -> np.ndarray:
        raise NotImplementedError  # pragma: no cover

    def predict(self, theta: np.ndarray, rebounds, rng: np.random.Generator):
        """The rebound of each draw at the nominal incidence, (n, 1) speed and angle: under
        this reading the parameters vary from bounce to bounce, and each draw is a bounce."""
        return rebounds.speed, rebounds.angle

    def structured_grid(self, names, axes) -> None:
        """No exact fast grid for this likelihood."""
        return None

    def subset(self, most: int):
        """Itself: the likelihood is evaluated at one incidence."""
        return self


@dataclass(frozen=True)
class KDELikelihood(_AtNominal):
    """``log rho_exp(h(Theta))`` at the nominal incidence."""

    density: ReboundDensity
    name: str = "kde"

    def _logdensity(self, speed, angle):
        return self.density.logpdf(speed, angle)

    def describe(self) -> dict:
        return {"density": self.density.to_dict(), "incidence": "nominal",
                "pointwise": POINTWISE_MEANING["kde"]}


@dataclass(frozen=True)
class ConsistentLikelihood(_AtNominal):
    """``log rho_obs(Q(Theta)) - log pi_pred(Q(Theta))`` at the nominal incidence."""

    observed: ReboundDensity
    predicted: ReboundDensity
    n_predicted: int
    ratio_mean: float  #: E_prior[rho_obs / pi_pred]; ~1 when the observations are predictable
    name: str = "consistent"

    def _logdensity(self, speed, angle):
        return self.observed.logpdf(speed, angle) - self.predicted.logpdf(speed, angle)

    def describe(self) -> dict:
        return {"observed_density": self.observed.to_dict(),
                "predicted_density": self.predicted.to_dict(),
                "n_prior_samples": self.n_predicted,
                "mean_ratio_under_prior": self.ratio_mean, "incidence": "nominal",
                "pointwise": POINTWISE_MEANING["consistent"]}


@dataclass(frozen=True)
class GaussianLikelihood:
    """Bivariate residual per trial: covariance = measurement noise of the rebound plus
    J Sigma_inc J^T (the incidence uncertainty pushed through the model's Jacobian J), plus an
    inferred model discrepancy in quadrature where asked (normal or Student-t residuals), with
    the campaign's shared scale factor marginalised where the table states its uncertainty
    (``docs/likelihoods.md``)."""

    forward: Forward
    speed: np.ndarray  #: observed rebound speeds, m/s
    angle: np.ndarray  #: observed rebound angles, deg
    noise: str  #: "given" (table standard errors) or "inferred" (extra parameters)
    rebound_var: np.ndarray  #: (n, 2) variances of the rebound measurement ("given")
    propagated: np.ndarray  #: (n, 2, 2) J Sigma_inc J^T
    jacobian_at: dict = field(default_factory=dict)
    observations: tuple[str, ...] = ()  #: trial labels
    extra_parameters: tuple[tuple[str, Prior, str], ...] = ()  #: (name, prior, unit)
    incidence: np.ndarray | None = None  #: (n, 3) incident speed, angle, spin per trial
    name: str = "gaussian"
    discrepancy: str = "none"  #: "none", "normal" or "student-t" (model error, inferred)
    scale: np.ndarray | None = None  #: (n, 2) rebound speed, angle per sd of the shared scale
    _terms: tuple[np.ndarray, ...] = field(init=False, repr=False, compare=False)
    _general: tuple[np.ndarray, ...] = field(init=False, repr=False, compare=False)
    compares = "trials"  #: each trial with the model: ``covariances`` and ``scale`` (§10)

    def __post_init__(self) -> None:
        """Precompute what every call needs: contiguous observations, the inverse covariances
        and normalisations (the plain case: given noise, nothing else), and the fixed
        covariance parts and shared-scale sensitivities (every other case)."""
        cov = self.fixed_covariance()
        c00, c01, c11 = (np.ascontiguousarray(cov[:, i, j]) for i, j in ((0, 0), (0, 1), (1, 1)))
        obs = (np.ascontiguousarray(self.speed, dtype=float),
               np.ascontiguousarray(self.angle, dtype=float))
        terms: tuple[np.ndarray, ...] = ()
        if self.simple:  # the covariances are fixed: invert them once
            det = c00 * c11 - c01**2
            terms = (c11 / det, -c01 / det, c00 / det, 0.5 * np.log(det) + _kernels.LOG_2PI)
        object.__setattr__(self, "_terms", obs + terms if self.simple else ())
        g = np.zeros((self.speed.size, 2)) if self.scale is None else self.scale
        nodes, log_w = _hermite(self.scale is not None and self.nu < math.inf)
        object.__setattr__(self, "_general", obs + (c00, c01, c11) + (
            np.ascontiguousarray(g[:, 0]), np.ascontiguousarray(g[:, 1])) + (nodes, log_w))

    @property
    def simple(self) -> bool:
        """Given noise, no discrepancy, no shared scale: the closed-form, compiled path."""
        return self.noise == "given" and self.discrepancy == "none" and self.scale is None

    @property
    def nu(self) -> float:
        """Degrees of freedom of the residuals (infinite: normal)."""
        return STUDENT_T_DOF if self.discrepancy == "student-t" else math.inf

    @property
    def bytes_per_row(self) -> float:
        return float(self.forward.n_conditions * BYTES_PER_BOUNCE)

    def fixed_covariance(self) -> np.ndarray:
        """(n, 2, 2): the propagated incidence uncertainty plus, with given noise, the
        measurement variances; the inferred noise or discrepancy add to it per row."""
        cov = self.propagated.copy()
        if self.noise == "given":
            cov[:, 0, 0] += self.rebound_var[:, 0]
            cov[:, 1, 1] += self.rebound_var[:, 1]
        return cov

    def _model(self, theta: np.ndarray):
        theta = np.asarray(theta, dtype=float)
        theta = theta[None, :] if theta.ndim == 1 else theta
        d = len(self.forward.names)
        return theta, self.forward(theta if theta.shape[1] == d else theta[:, :d])

    def extra_sd(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Per row: the sd added in quadrature to each trial's (inferred noise levels or
        model discrepancy; zeros where neither is inferred)."""
        d = len(self.forward.names)
        if theta.shape[1] < d + 2:
            zeros = np.zeros(theta.shape[0])
            return zeros, zeros
        return np.ascontiguousarray(theta[:, d]), np.ascontiguousarray(theta[:, d + 1])

    def __call__(self, theta: np.ndarray) -> np.ndarray:
        theta, r = self._model(theta)
        out = np.empty(theta.shape[0])
        if self.simple:
            _kernels.given_noise_sum(r.speed, r.angle, r.ok, *self._terms, out)
        else:
            g = self._general
            _kernels.measurement_sum(r.speed, r.angle, r.ok, *g[:7], *self.extra_sd(theta),
                                     self.nu, *g[7:], out)
        return out

    def pointwise(self, theta: np.ndarray) -> Pointwise:
        """Log-density of each trial's rebound, (n, trials): of each trial on its own (with
        the shared scale's variance) where a shared scale is marginalised."""
        theta, r = self._model(theta)
        out = np.empty(r.speed.shape)
        if self.simple:
            _kernels.given_noise_terms(r.speed, r.angle, r.ok, *self._terms, out)
        else:
            _kernels.measurement_terms(r.speed, r.angle, r.ok, *self._general[:7],
                                       *self.extra_sd(theta), self.nu, out)
        return Pointwise(out, r)

    def covariances(self, theta: np.ndarray) -> np.ndarray:
        """(rows, n, 2, 2): each trial's residual covariance on its own at each row (fixed part,
        inferred noise or discrepancy, shared scale)."""
        theta = np.atleast_2d(np.asarray(theta, dtype=float))
        cov = np.broadcast_to(self.fixed_covariance(), (theta.shape[0],) + self.propagated.shape)
        cov = cov.copy()
        es, ea = self.extra_sd(theta)
        cov[..., 0, 0] += es[:, None] ** 2
        cov[..., 1, 1] += ea[:, None] ** 2
        if self.scale is not None:
            cov += self.scale[None, :, :, None] * self.scale[None, :, None, :]
        return cov

    def predict(self, theta: np.ndarray, rebounds, rng: np.random.Generator):
        """Replicated measurements (n, trials): each trial's simulated rebound plus a draw of
        its measurement noise and discrepancy (normal, or Student-t), plus one shared scale
        error per row."""
        theta = np.atleast_2d(theta)
        cov = self.covariances(theta)
        if self.scale is not None:  # the shared part is drawn once per row below
            cov -= self.scale[None, :, :, None] * self.scale[None, :, None, :]
        l00 = np.sqrt(cov[..., 0, 0])
        l10 = np.divide(cov[..., 0, 1], l00, out=np.zeros_like(l00), where=l00 > 0)
        l11 = np.sqrt(np.maximum(cov[..., 1, 1] - l10**2, 0.0))
        z = rng.standard_normal((2,) + rebounds.speed.shape)
        if self.nu < math.inf:  # a bivariate t: the normal over sqrt(chi2_nu / nu)
            z /= np.sqrt(rng.chisquare(self.nu, size=rebounds.speed.shape) / self.nu)
        speed = rebounds.speed + l00 * z[0]
        angle = rebounds.angle + l10 * z[0] + l11 * z[1]
        if self.scale is not None:
            eps = rng.standard_normal((rebounds.speed.shape[0], 1))
            speed, angle = speed + eps * self.scale[:, 0], angle + eps * self.scale[:, 1]
        return speed, angle

    def subset(self, most: int) -> GaussianLikelihood:
        """The likelihood of at most ``most`` evenly spaced trials (itself when it has no
        more): a cheap stand-in where only the location of the mode matters."""
        n = self.speed.size
        if n <= most or self.incidence is None:
            return self
        pick = np.unique(np.linspace(0, n - 1, most).round().astype(int))
        inc = self.incidence[pick]
        forward = Forward(self.forward.experiment, self.forward.names, speed=inc[:, 0],
                          angle=inc[:, 1], spin=inc[:, 2])
        return replace(self, forward=forward, speed=self.speed[pick], angle=self.angle[pick],
                       rebound_var=self.rebound_var[pick], propagated=self.propagated[pick],
                       observations=tuple(self.observations[i] for i in pick), incidence=inc,
                       scale=None if self.scale is None else self.scale[pick])

    def structured_grid(self, names: tuple[str, ...], axes) -> tuple[np.ndarray,
                                                                      np.ndarray] | None:
        """Log-likelihood on the (mu, eta) mesh of ``axes`` (in ``names`` order) without
        repeating the normal impact for every mu, and the cells it could not do exactly;
        ``None`` unless the parameters are exactly mu and eta in the plain case."""
        if not self.simple or sorted(names) != ["eta", "mu"]:
            return None
        from ._grid_kernel import gaussian_grid

        i_mu, i_eta = names.index("mu"), names.index("eta")
        ll, bad = gaussian_grid(self, np.asarray(axes[i_mu]), np.asarray(axes[i_eta]))
        return (ll.T, bad.T) if i_mu == 1 else (ll, bad)

    def describe(self) -> dict:
        out: dict[str, Any] = {"noise": self.noise, "incidence": "per trial",
               "incidence_uncertainty": "propagated through the model's Jacobian at "
                                        + ", ".join(f"{k} = {v:.6g}" for k, v in
                                                    self.jacobian_at.items()),
               "discrepancy": DISCREPANCY_MEANINGS[self.discrepancy],
               "shared_scale": ("marginalised: one scale factor for the campaign, relative sd "
                                "from the table's scale_rel_sd" if self.scale is not None
                                else "none stated (no scale_rel_sd column)"),
               "pointwise": POINTWISE_MEANING["gaussian"]}
        if self.discrepancy == "student-t":
            out["student_t_dof"] = STUDENT_T_DOF
        return out


def _hermite(needed: bool) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Hermite nodes for eps ~ N(0, 1) and normalised log weights (one node at 0 where
    no quadrature is needed)."""
    if not needed:
        return np.zeros(1), np.zeros(1)
    x, w = np.polynomial.hermite_e.hermegauss(HERMITE_NODES)
    return x, np.log(w / w.sum())


Likelihood = KDELikelihood | ConsistentLikelihood | GaussianLikelihood


def noise_priors(trials: Trials) -> dict[str, Prior]:
    """Log-uniform priors of the inferred noise levels: from 1e-3 to 10 times the spread of the
    observations (m/s and deg)."""
    out: dict[str, Prior] = {}
    for name, column in zip(NOISE_PARAMETERS, ("rebound_speed", "rebound_angle"), strict=True):
        x = trials.column(column)
        spread = float(np.std(x, ddof=1)) if x.size > 1 else 0.0
        if not spread > 0:
            raise ValueError(f"{trials.source}: every {column} is {x[0]:g} "
                             f"{NOISE_UNITS[name]}: a noise level "
                             f"cannot be inferred from bounces without spread; give standard "
                             f"errors ({column}_se) and use noise='given'")
        out[name] = LogUniform(1e-3 * spread, 10.0 * spread)
    return out


def make_likelihood(name: str, experiment: Experiment, trials: Trials, names: tuple[str, ...],
                    *, rng: np.random.Generator, noise: str = "auto", discrepancy: str = "none",
                    bandwidth="normal-reference", density_kind: Any = "auto",
                    n_predicted: int = 4000,
                    memory_budget: float = DEFAULT_MEMORY_BUDGET) -> Likelihood:
    """Build the named likelihood for the inferred parameters ``names`` (model parameters);
    ``discrepancy`` ("none", "normal" or "student-t"; gaussian only) adds an inferred model
    error; ``memory_budget``: bytes its preparation may use for model evaluations at once.
    ``population`` builds the hierarchical likelihood of the hyper-parameters (normal
    population; ``_population.make_population`` for the other settings)."""
    if name == "population":
        from ._population import make_population

        return make_population(experiment, trials, names, noise=noise,  # type: ignore[return-value]
                               discrepancy=discrepancy, memory_budget=memory_budget)
    if name in ("kde", "consistent"):
        if discrepancy not in ("none", "auto"):
            raise ValueError(f"`discrepancy` ({discrepancy!r}) applies to the gaussian "
                             f"likelihood, which compares each trial with the model; the "
                             f"{name} likelihood compares distributions: use "
                             f"discrepancy='none'")
        _check_spread(trials, name)
        speed, angle, spin = _nominal(experiment, trials)
        forward = Forward(experiment, names, speed=speed, angle=angle, spin=spin)
        observed = rebound_density(trials.rebound_speed, trials.rebound_angle,
                                   kind=density_kind, bandwidth=bandwidth)
        if name == "kde":
            return KDELikelihood(forward, observed)
        return _consistent(forward, observed, experiment, names, rng, n_predicted)
    return _gaussian(experiment, trials, names, noise,
                     "none" if discrepancy == "auto" else discrepancy, memory_budget)


def discrepancy_priors(trials: Trials) -> dict[str, Prior]:
    """Log-uniform priors of the model discrepancy per observable: from DISCREPANCY_FLOOR times
    the median standard error (a model error far below the noise, indistinguishable from none)
    to the larger of 10 times the observations' spread and their mean size (a model error as
    large as the rebound itself)."""
    out: dict[str, Prior] = {}
    for name, column in zip(DISCREPANCY_PARAMETERS, ("rebound_speed", "rebound_angle"),
                            strict=True):
        x, se = trials.column(column), np.asarray(trials.se[column], dtype=float)
        floor = DISCREPANCY_FLOOR * float(np.median(se))
        top = max(10.0 * (float(np.std(x, ddof=1)) if x.size > 1 else 0.0),
                  float(np.mean(np.abs(x))), 1e3 * floor)
        out[name] = LogUniform(floor, top)
    return out


def _check_spread(trials: Trials, likelihood: str) -> None:
    """The kde and consistent likelihoods estimate a density from the rebounds' spread."""
    if trials.n < 2:
        raise ValueError(f"{trials.source}: the {likelihood} likelihood estimates the density "
                         f"of the rebounds from several bounces; the table has {trials.n}")
    for column, unit in (("rebound_speed", "m/s"), ("rebound_angle", "deg")):
        x = trials.column(column)
        if np.ptp(x) == 0:
            raise ValueError(f"{trials.source}: every {column} is {x[0]:g} {unit}: the "
                             f"{likelihood} likelihood estimates the density of the rebounds "
                             f"from their spread, and this column has none (kernel bandwidth "
                             f"0); check the table, or use likelihood='gaussian' with "
                             f"standard errors")


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


def _gaussian(experiment: Experiment, trials: Trials, names, noise: str, discrepancy: str,
              budget: float) -> GaussianLikelihood:
    se = np.column_stack([trials.se["rebound_speed"], trials.se["rebound_angle"]])
    have_se = bool(np.all(np.isfinite(se)) and np.all(se > 0))
    if noise == "auto":
        noise = "given" if have_se else "inferred"
    if noise == "given" and not have_se:
        raise ValueError(f"{trials.source}: noise='given' needs positive standard errors in "
                         "rebound_speed_se and rebound_angle_se for every trial; leave them out "
                         "to infer the noise levels instead")
    if discrepancy != "none" and noise != "given":
        raise ValueError(f"{trials.source}: `discrepancy` ({discrepancy!r}) adds a model error "
                         f"to each trial's standard errors, and this table has none "
                         f"(rebound_speed_se, rebound_angle_se), so the noise levels are "
                         f"inferred instead, which already absorbs a model error; give the "
                         f"standard errors, or use discrepancy='none'")
    extra: tuple = ()
    if noise == "inferred":
        priors = noise_priors(trials)
        extra = tuple((n, priors[n], NOISE_UNITS[n]) for n in NOISE_PARAMETERS)
    elif discrepancy != "none":
        priors = discrepancy_priors(trials)
        extra = tuple((n, priors[n], NOISE_UNITS[n]) for n in DISCREPANCY_PARAMETERS)
    forward = Forward(experiment, names, speed=trials.incidence_speed,
                      angle=trials.incidence_angle, spin=trials.incidence_spin)
    at = _jacobian_point(experiment, trials, names, se, noise, budget)
    sens = _incidence_sensitivity(experiment, trials, names, at, budget)
    return GaussianLikelihood(forward, np.asarray(trials.rebound_speed),
                              np.asarray(trials.rebound_angle), noise,
                              se**2 if noise == "given" else np.zeros_like(se),
                              sens.propagated(incidence_variance(experiment, trials)),
                              dict(zip(names, at.tolist(), strict=True)), trials.labels, extra,
                              np.column_stack([trials.incidence_speed, trials.incidence_angle,
                                               trials.incidence_spin]).astype(float),
                              discrepancy=discrepancy, scale=sens.shared_scale(trials))


def incidence_variance(experiment: Experiment, trials: Trials) -> np.ndarray:
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


@dataclass(frozen=True)
class _Sensitivity:
    """The model's rebound and its derivatives with respect to the incidence, per trial, at
    the linearisation point: ``rebound`` (n, 2) speed and angle, ``jacobian`` (n, 2, 3) with
    respect to incident speed, angle and spin (zero where not needed)."""

    rebound: np.ndarray
    jacobian: np.ndarray

    def propagated(self, var: np.ndarray) -> np.ndarray:
        """J Sigma_inc J^T per trial for the incidence variances ``var`` (n, 3)."""
        j = self.jacobian
        return np.nan_to_num(np.einsum("nik,nk,njk->nij", j, var, j))

    def shared_scale(self, trials: Trials) -> np.ndarray | None:
        """Each trial's rebound speed and angle per standard deviation of the campaign's shared
        scale factor (``None`` without a ``scale_rel_sd`` column): every length, so every speed
        of the table, is ``s`` times the true one, so the measured rebound speed is
        ``s h(v_in / s)``, which moves by ``(h - v_in dh/dv_in) (s - 1)`` to first order (the
        incidence term only where the incident speed was measured with the same camera), and
        the angle by ``-v_in dh_angle/dv_in (s - 1)``."""
        sd = np.asarray(trials.scale_rel_sd, dtype=float)
        if sd.size == 0 or not np.all(np.isfinite(sd)) or not np.any(sd > 0):
            return None
        v_in = np.asarray(trials.incidence_speed, dtype=float)
        measured = 1.0 if "incidence_speed" in trials.measured else 0.0
        g = np.column_stack([self.rebound[:, 0] - measured * v_in * self.jacobian[:, 0, 0],
                             -measured * v_in * self.jacobian[:, 1, 0]])
        return np.nan_to_num(g * sd[:, None])


def _incidence_sensitivity(experiment, trials, names, at, budget) -> _Sensitivity:
    """The model at ``at`` for every trial and its derivatives with respect to the incidence
    columns that carry uncertainty (or, for the speed, a shared scale), by central
    differences, in blocks of trials that fit the memory budget."""
    var = incidence_variance(experiment, trials)
    need = np.any(var > 0, axis=0)
    need[0] |= bool(np.any(np.nan_to_num(np.asarray(trials.scale_rel_sd, dtype=float)) > 0))
    n = trials.n
    base = np.column_stack([trials.incidence_speed, trials.incidence_angle,
                            trials.incidence_spin]).astype(float)
    steps = np.column_stack([1e-4 * base[:, 0], np.full(n, 1e-3), np.full(n, 1e-2)])
    theta = np.asarray(at, dtype=float)[None, :]
    jac, rebound = np.zeros((n, 2, 3)), np.full((n, 2), np.nan)
    block = batch_rows(budget, BYTES_PER_BOUNCE)

    def model(cond: np.ndarray) -> np.ndarray:
        r = Forward(experiment, names, speed=cond[:, 0], angle=cond[:, 1], spin=cond[:, 2])(theta)
        return np.column_stack([r.speed[0], r.angle[0]])

    for s in range(0, n, block):
        rows = slice(s, s + block)
        if need[0]:
            rebound[rows] = model(base[rows])
        for k in np.flatnonzero(need):
            sides = []
            for sign in (1.0, -1.0):
                cond = base[rows].copy()
                cond[:, k] += sign * steps[rows, k]
                sides.append(model(cond))
            jac[rows, :, k] = (sides[0] - sides[1]) / (2 * steps[rows, k, None])
    return _Sensitivity(rebound, jac)


def _jacobian_point(experiment, trials, names, se, noise, budget) -> np.ndarray:
    """Where to linearise: the best of a deterministic (Sobol) design over the prior box under
    the likelihood without the propagated term, judged on at most JACOBIAN_TRIALS evenly
    spaced trials and in batches that fit the memory budget."""
    boxes = np.array([experiment.priors[k].box(1e-4) for k in names])
    design = qmc.Sobol(len(names), scramble=False).random(256)
    theta = boxes[:, 0] + design * (boxes[:, 1] - boxes[:, 0])
    pick = np.unique(np.linspace(0, trials.n - 1, min(trials.n, JACOBIAN_TRIALS)).astype(int))
    if noise == "given":
        scale = se[pick]
    else:
        scale = np.broadcast_to([np.std(trials.rebound_speed, ddof=1),
                                 np.std(trials.rebound_angle, ddof=1)], (pick.size, 2))
    forward = Forward(experiment, names, speed=trials.incidence_speed[pick],
                      angle=trials.incidence_angle[pick], spin=trials.incidence_spin[pick])
    chi2 = np.empty(theta.shape[0])
    rows = batch_rows(budget, pick.size * BYTES_PER_BOUNCE)
    for s in range(0, theta.shape[0], rows):
        r = forward(theta[s:s + rows])
        with np.errstate(invalid="ignore", over="ignore"):
            c = (((r.speed - trials.rebound_speed[pick]) / scale[:, 0]) ** 2
                 + ((r.angle - trials.rebound_angle[pick]) / scale[:, 1]) ** 2)
        chi2[s:s + rows] = np.where(r.ok, c, np.inf).sum(axis=1)
    return theta[int(np.argmin(np.where(np.isnan(chi2), np.inf, chi2)))]
