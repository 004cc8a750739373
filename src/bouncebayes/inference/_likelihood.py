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
``extra_parameters`` (parameters it adds to the model's) and ``bytes_per_row`` (its working
memory per parameter row, for the memory plan).

What "pointwise" means: the gaussian likelihood is a product over trials, and its terms are the
log-densities of each trial's rebound (``arviz_stats.loo`` and ``compare`` apply). The kde and
consistent likelihoods are one density evaluated at one simulated rebound (the nominal
incidence); they do not factor over trials, so their single term per draw is stored as one
observation, ``campaign``, and leave-one-out cross-validation across trials is not defined for
them.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any, Literal, NamedTuple, get_args

import numpy as np
from scipy.stats import qmc

from ..data import Experiment, LogUniform, Prior, Trials
from ..density import ReboundDensity, rebound_density
from . import _kernels as _kernel_module
from ._forward import Forward
from ._memory import BYTES_PER_BOUNCE, DEFAULT_MEMORY_BUDGET, batch_rows

_kernels: Any = _kernel_module  # numba dispatchers: mypy cannot see their signatures
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
JACOBIAN_TRIALS = 2000  #: trials (evenly spaced) that choose where to linearise
POINTWISE_MEANING = {
    "gaussian": "per trial: the log-density of each trial's measured rebound",
    "kde": "one term per draw (observation `campaign`): the kde likelihood is one density "
           "evaluated at one simulated rebound and does not factor over trials, so "
           "leave-one-out cross-validation across trials is not defined for it",
    "consistent": "one term per draw (observation `campaign`): the consistent likelihood is "
                  "one density ratio at one simulated rebound and does not factor over "
                  "trials, so leave-one-out cross-validation across trials is not defined",
}


class Pointwise(NamedTuple):
    """Log-likelihood terms (n, n_observations) and the rebounds they came from."""

    terms: np.ndarray
    rebounds: Any  #: ``Forward`` output, arrays (n, n_conditions)


def _nominal(experiment: Experiment):
    """The experiment's nominal incidence as one condition (speed, angle, spin arrays)."""
    inc = experiment.incidence
    return np.array([inc.speed]), np.array([inc.angle]), np.array([inc.spin])


@dataclass(frozen=True)
class _AtNominal:
    """Shared behaviour of the likelihoods evaluated at the nominal incidence."""

    forward: Forward

    extra_parameters = ()
    observations = ("campaign",)

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
    """Bivariate normal per trial: residual covariance = measurement noise of the rebound plus
    J Sigma_inc J^T, the incidence uncertainty pushed through the model's Jacobian J."""

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
    _terms: tuple[np.ndarray, ...] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        """Precompute what every call needs: contiguous observations and either the inverse
        covariances and normalisations (given noise) or the propagated parts (inferred)."""
        cov = self.propagated.copy()
        cov[:, 0, 0] += self.rebound_var[:, 0]
        cov[:, 1, 1] += self.rebound_var[:, 1]
        c00, c01, c11 = (np.ascontiguousarray(cov[:, i, j]) for i, j in ((0, 0), (0, 1), (1, 1)))
        terms: tuple[np.ndarray, ...]
        if self.noise == "given":
            det = c00 * c11 - c01**2
            terms = (c11 / det, -c01 / det, c00 / det, 0.5 * np.log(det) + _kernels.LOG_2PI)
        else:
            terms = (c00, c01, c11)
        obs = (np.ascontiguousarray(self.speed, dtype=float),
               np.ascontiguousarray(self.angle, dtype=float))
        object.__setattr__(self, "_terms", obs + terms)

    @property
    def bytes_per_row(self) -> float:
        return float(self.forward.n_conditions * BYTES_PER_BOUNCE)

    def _model(self, theta: np.ndarray):
        theta = np.asarray(theta, dtype=float)
        theta = theta[None, :] if theta.ndim == 1 else theta
        d = len(self.forward.names)
        return theta, self.forward(theta if theta.shape[1] == d else theta[:, :d])

    def __call__(self, theta: np.ndarray) -> np.ndarray:
        theta, r = self._model(theta)
        out = np.empty(theta.shape[0])
        if self.noise == "given":
            _kernels.given_noise_sum(r.speed, r.angle, r.ok, *self._terms, out)
        else:
            d = len(self.forward.names)
            _kernels.inferred_noise_sum(r.speed, r.angle, r.ok, *self._terms,
                                        np.ascontiguousarray(theta[:, d]),
                                        np.ascontiguousarray(theta[:, d + 1]), out)
        return out

    def pointwise(self, theta: np.ndarray) -> Pointwise:
        """Log-density of each trial's rebound, (n, trials)."""
        theta, r = self._model(theta)
        out = np.empty(r.speed.shape)
        if self.noise == "given":
            _kernels.given_noise_terms(r.speed, r.angle, r.ok, *self._terms, out)
        else:
            d = len(self.forward.names)
            _kernels.inferred_noise_terms(r.speed, r.angle, r.ok, *self._terms,
                                          np.ascontiguousarray(theta[:, d]),
                                          np.ascontiguousarray(theta[:, d + 1]), out)
        return Pointwise(out, r)

    def predict(self, theta: np.ndarray, rebounds, rng: np.random.Generator):
        """Replicated measurements (n, trials): each trial's simulated rebound plus a draw of
        its measurement noise (covariance as in the likelihood)."""
        theta = np.atleast_2d(theta)
        cov = np.broadcast_to(self.propagated, rebounds.speed.shape + (2, 2)).copy()
        if self.noise == "given":
            cov[..., 0, 0] += self.rebound_var[:, 0]
            cov[..., 1, 1] += self.rebound_var[:, 1]
        else:
            d = len(self.forward.names)
            cov[..., 0, 0] += theta[:, d, None] ** 2
            cov[..., 1, 1] += theta[:, d + 1, None] ** 2
        l00 = np.sqrt(cov[..., 0, 0])
        l10 = np.divide(cov[..., 0, 1], l00, out=np.zeros_like(l00), where=l00 > 0)
        l11 = np.sqrt(np.maximum(cov[..., 1, 1] - l10**2, 0.0))
        z = rng.standard_normal((2,) + rebounds.speed.shape)
        return rebounds.speed + l00 * z[0], rebounds.angle + l10 * z[0] + l11 * z[1]

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
                       observations=tuple(self.observations[i] for i in pick), incidence=inc)

    def structured_grid(self, names: tuple[str, ...], axes) -> tuple[np.ndarray,
                                                                      np.ndarray] | None:
        """Log-likelihood on the (mu, eta) mesh of ``axes`` (in ``names`` order) without
        repeating the normal impact for every mu, and the cells it could not do exactly;
        ``None`` unless the parameters are exactly mu and eta with given noise."""
        if self.noise != "given" or sorted(names) != ["eta", "mu"]:
            return None
        from ._grid_kernel import gaussian_grid

        i_mu, i_eta = names.index("mu"), names.index("eta")
        ll, bad = gaussian_grid(self, np.asarray(axes[i_mu]), np.asarray(axes[i_eta]))
        return (ll.T, bad.T) if i_mu == 1 else (ll, bad)

    def describe(self) -> dict:
        return {"noise": self.noise, "incidence": "per trial",
                "incidence_uncertainty": "propagated through the model's Jacobian at "
                                         + ", ".join(f"{k} = {v:.6g}" for k, v in
                                                     self.jacobian_at.items()),
                "pointwise": POINTWISE_MEANING["gaussian"]}


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
                    *, rng: np.random.Generator, noise: str = "auto",
                    bandwidth="normal-reference", density_kind: Any = "auto",
                    n_predicted: int = 4000,
                    memory_budget: float = DEFAULT_MEMORY_BUDGET) -> Likelihood:
    """Build the named likelihood for the inferred parameters ``names`` (model parameters);
    ``memory_budget``: bytes its preparation may use for model evaluations at once."""
    if name in ("kde", "consistent"):
        _check_spread(trials, name)
        speed, angle, spin = _nominal(experiment)
        forward = Forward(experiment, names, speed=speed, angle=angle, spin=spin)
        observed = rebound_density(trials.rebound_speed, trials.rebound_angle,
                                   kind=density_kind, bandwidth=bandwidth)
        if name == "kde":
            return KDELikelihood(forward, observed)
        return _consistent(forward, observed, experiment, names, rng, n_predicted)
    return _gaussian(experiment, trials, names, noise, memory_budget)


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


def _gaussian(experiment: Experiment, trials: Trials, names, noise: str,
              budget: float) -> GaussianLikelihood:
    se = np.column_stack([trials.se["rebound_speed"], trials.se["rebound_angle"]])
    if noise == "auto":
        noise = "given" if np.all(np.isfinite(se)) and np.all(se > 0) else "inferred"
    if noise == "given" and not (np.all(np.isfinite(se)) and np.all(se > 0)):
        raise ValueError(f"{trials.source}: noise='given' needs positive standard errors in "
                         "rebound_speed_se and rebound_angle_se for every trial; leave them out "
                         "to infer the noise levels instead")
    extra: tuple = ()
    if noise == "inferred":
        priors = noise_priors(trials)
        extra = tuple((n, priors[n], NOISE_UNITS[n]) for n in NOISE_PARAMETERS)
    forward = Forward(experiment, names, speed=trials.incidence_speed,
                      angle=trials.incidence_angle, spin=trials.incidence_spin)
    at = _jacobian_point(experiment, trials, names, se, noise, budget)
    propagated = _propagated_covariance(experiment, trials, names, at, budget)
    return GaussianLikelihood(forward, np.asarray(trials.rebound_speed),
                              np.asarray(trials.rebound_angle), noise,
                              se**2 if noise == "given" else np.zeros_like(se), propagated,
                              dict(zip(names, at.tolist(), strict=True)), trials.labels, extra,
                              np.column_stack([trials.incidence_speed, trials.incidence_angle,
                                               trials.incidence_spin]).astype(float))


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


def _propagated_covariance(experiment, trials, names, at, budget) -> np.ndarray:
    """J Sigma_inc J^T per trial, J by central differences of the model at ``at``, in blocks
    of trials that fit the memory budget."""
    var = _incidence_variance(experiment, trials)
    n = trials.n
    cov = np.zeros((n, 2, 2))
    base = np.column_stack([trials.incidence_speed, trials.incidence_angle,
                            trials.incidence_spin]).astype(float)
    steps = np.column_stack([1e-4 * base[:, 0], np.full(n, 1e-3), np.full(n, 1e-2)])
    theta = np.asarray(at, dtype=float)[None, :]
    block = batch_rows(budget, BYTES_PER_BOUNCE)
    for k in np.flatnonzero(np.any(var > 0, axis=0)):
        for s in range(0, n, block):
            rows = slice(s, s + block)
            sides = []
            for sign in (1.0, -1.0):
                cond = base[rows].copy()
                cond[:, k] += sign * steps[rows, k]
                r = Forward(experiment, names, speed=cond[:, 0], angle=cond[:, 1],
                            spin=cond[:, 2])(theta)
                sides.append(np.column_stack([r.speed[0], r.angle[0]]))
            jac = (sides[0] - sides[1]) / (2 * steps[rows, k, None])  # (block, 2)
            cov[rows] += var[rows, k, None, None] * jac[:, :, None] * jac[:, None, :]
    return np.nan_to_num(cov)


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
