"""The ``population`` likelihood: a hierarchical model of bounce-to-bounce variability.

Each bounce ``i`` has its own parameters ``theta_i`` (mu, eta, ...), drawn from a population
whose density is a product over parameters of a normal (or lognormal) density with mean
``<p>_mean`` and standard deviation ``<p>_sd``, truncated to the prior's domain and
renormalised. Each trial's measured rebound is the model's rebound for its own incidence and
``theta_i``, plus its measurement noise (the table's standard errors, with the incidence
uncertainty propagated as in the gaussian likelihood). The hyper-parameters are sampled; the
per-bounce parameters are integrated out exactly on a grid (``docs/likelihoods.md``):

1. once, each trial's measurement likelihood ``L_i(g)`` at every node ``g`` of a regular grid
   over the part of the prior box where any trial's likelihood is not negligible (one model
   call for all nodes and trials);
2. per hyper-parameter row, the integral of the bilinear interpolant of ``L_i`` against the
   population density, which is separable: ``w_1^T L_i w_2`` with hat-function weights
   ``w_k[j] = int hat_j(x) p_k(x) dx`` in closed form (normal and lognormal partial moments).
   These weights are exact for any spread, zero included (where they become the linear
   interpolation weights at the mean), so the quadrature error is that of interpolating
   ``L_i`` alone. It is measured at the posterior draws after sampling (Richardson: the grid
   of every other node has 4 times the error, the error falling like h^2), and where its
   variation over the draws (what moves the posterior) exceeds ``QUADRATURE_LIMIT`` nats the
   grid's spacing is halved and the hyper-parameters sampled again;
3. each ``L_i`` is held as its singular value decomposition truncated at ``SVD_TOL`` of its
   largest singular value, so that a row costs two small matrix products instead of a sum
   over every node: this is what makes sampling the hyper-parameters fast.

Why hand-written: no library integrates a tabulated likelihood against a truncated
parametric density by exact hat-function weights; SciPy supplies the normal integrals.

Inferred measurement noise is refused: it would change every ``L_i`` at every step, which the
precomputed grid cannot follow exactly. A model discrepancy is refused for the same reason.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np
from numba import njit
from scipy import special

from ..data import Experiment, Prior, Trials, Uniform
from ._memory import DEFAULT_MEMORY_BUDGET, batch_rows, require

FAMILIES = ("normal", "lognormal")
POINTS = {1: 1025, 2: 129}  #: first grid nodes per parameter (refined by halving the spacing)
MAX_POINTS = {1: 8193, 2: 513}  #: finest grid tried
COARSE_POINTS = {1: 257, 2: 41}  #: the coarse grid that finds where the likelihoods live
SVD_TOL = 1e-6  #: singular values kept, relative to each trial's largest
CUT = 1e-12  #: relative likelihood below which a node is outside a trial's support
SD_RANGE = 0.5  #: the spread's hyper-prior reaches this share of the prior box's width
TINY = 1e-300
_SQRT2 = math.sqrt(2.0)
_SQRT2PI = math.sqrt(2.0 * math.pi)
PREDICTIVE_DRAWS = 400  #: hyper-parameter draws with replicated rebounds (adequacy, figures)
BOUNCE_DRAWS = 200  #: hyper-parameter draws averaged over for the per-bounce estimates
ERROR_DRAWS = 50  #: draws at which the quadrature error of the log-likelihood is measured
ROLLING_LIMIT = 0.95  #: share of rolling bounces above which mu's population is only bounded


def hyper_names(names: tuple[str, ...]) -> tuple[str, ...]:
    """``<p>_mean``, ``<p>_sd`` for each parameter, in order."""
    return tuple(f"{n}_{k}" for n in names for k in ("mean", "sd"))


def hyper_priors(experiment: Experiment, names: tuple[str, ...]) -> dict[str, Prior]:
    """The documented hyper-priors: each population mean uniform on the parameter's prior box,
    each spread uniform from 0 to half the box's width (Gelman 2006, Bayesian Analysis 1, 515:
    a uniform prior on a standard deviation, proper and flat down to zero, for a population
    seen through many groups; a spread of half the box is already a population flatter than
    the box itself)."""
    out: dict[str, Prior] = {}
    for n in names:
        lo, hi = experiment.priors[n].box(1e-6)
        out[f"{n}_mean"] = Uniform(float(lo), float(hi))
        out[f"{n}_sd"] = Uniform(0.0, SD_RANGE * float(hi - lo))
    return out


# ------------------------------------------------------------------ the population density


def _lognormal(mean: np.ndarray, sd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(mu, sigma) of the log of a lognormal with this mean and sd."""
    m = np.maximum(mean, TINY)
    s2 = np.log1p((sd / m) ** 2)
    return np.log(m) - 0.5 * s2, np.sqrt(s2)


def _parts(x: np.ndarray, mean: np.ndarray, sd: np.ndarray,
           family: str) -> tuple[np.ndarray, np.ndarray]:
    """F(x) = P(X <= x) and G(x) = E[X; X <= x] of the untruncated population, rows (R, n):
    ``x`` (n,) or (R, n), ``mean``, ``sd`` (R,). A zero spread is a point mass (half of it at
    ``x = mean``)."""
    x = np.broadcast_to(x, (mean.size,) + np.shape(x)[-1:])
    m, s = mean[:, None], sd[:, None]
    point = s <= 0
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        if family == "normal":
            z = (x - m) / np.where(point, 1.0, s)
            f = special.ndtr(z)
            g = m * f - s * np.exp(-0.5 * z * z) / math.sqrt(2 * math.pi)
        else:
            ml, sl = _lognormal(mean, sd)
            ml, sl = ml[:, None], sl[:, None]
            lx = np.log(np.where(x > 0, x, 1.0))
            z = (lx - ml) / np.where(point, 1.0, sl)
            f = np.where(x > 0, special.ndtr(z), 0.0)
            g = np.where(x > 0, m * special.ndtr(z - sl), 0.0)
    step = np.where(x > m, 1.0, np.where(x == m, 0.5, 0.0))
    f = np.where(point, step, f)
    g = np.where(point, m * step, g)
    return f, g


@njit(cache=True, inline="always")
def _point_parts(x, m, s, ml, sl, lognormal):
    """F(x) = P(X <= x) and G(x) = E[X; X <= x] of one untruncated population (a point mass
    at ``m`` for zero spread, half of it at ``x = m``)."""
    if s <= 0.0:
        f = 1.0 if x > m else (0.5 if x == m else 0.0)
        return f, m * f
    if lognormal:
        if x <= 0.0:
            return 0.0, 0.0
        z = (math.log(x) - ml) / sl
        return 0.5 * math.erfc(-z / _SQRT2), m * 0.5 * math.erfc(-(z - sl) / _SQRT2)
    z = (x - m) / s
    f = 0.5 * math.erfc(-z / _SQRT2)
    dens = math.exp(-0.5 * z * z) / _SQRT2PI if math.isfinite(z) else 0.0
    return f, m * f - s * dens


@njit(cache=True)
def _hat_kernel(nodes, lo, hi, mean, sd, lognormal, out):
    """The hat weights of every row (see :func:`hat_weights`); a compiled loop because the
    samplers ask for them at every step (NumPy's version cost 2/3 of a run)."""
    n = nodes.size
    h = nodes[1] - nodes[0]
    for r in range(mean.size):
        m, s = mean[r], sd[r]
        ml, sl = 0.0, 0.0
        if lognormal and s > 0.0:
            m = max(m, TINY)
            s2 = math.log1p((s / m) ** 2)
            ml, sl = math.log(m) - 0.5 * s2, math.sqrt(s2)
        for j in range(n):
            out[r, j] = 0.0
        f0, g0 = _point_parts(nodes[0], m, s, ml, sl, lognormal)
        for j in range(n - 1):
            f1, g1 = _point_parts(nodes[j + 1], m, s, ml, sl, lognormal)
            mass, first = f1 - f0, g1 - g0
            out[r, j] += (nodes[j + 1] * mass - first) / h
            out[r, j + 1] += (first - nodes[j] * mass) / h
            f0, g0 = f1, g1
        z = (_point_parts(hi, m, s, ml, sl, lognormal)[0]
             - _point_parts(lo, m, s, ml, sl, lognormal)[0])
        z = max(z, TINY)
        for j in range(n):
            out[r, j] = max(out[r, j], 0.0) / z


def hat_weights(nodes: np.ndarray, domain: tuple[float, float], mean: np.ndarray,
                sd: np.ndarray, family: str) -> np.ndarray:
    """(R, n): ``int hat_j(x) p(x) dx`` for the hat functions of the regular ``nodes`` and the
    population ``p`` (``family``, ``mean``, ``sd`` per row) truncated to ``domain`` and
    renormalised; zero spread gives the linear interpolation weights at the mean."""
    mean = np.ascontiguousarray(mean, dtype=float).ravel()
    sd = np.ascontiguousarray(sd, dtype=float).ravel()
    out = np.empty((mean.size, nodes.size))
    _hat_kernel(np.ascontiguousarray(nodes, dtype=float), float(domain[0]), float(domain[1]),
                mean, sd, family == "lognormal", out)
    return out


def binned_density(edges: np.ndarray, mean: np.ndarray, sd: np.ndarray,
                   domain: tuple[float, float], family: str) -> np.ndarray:
    """(R, bins): the truncated population's density averaged over each bin of ``edges``
    (finite for any spread: a zero spread puts 1 / width in the bin of the mean)."""
    mean, sd = np.atleast_1d(mean).astype(float), np.atleast_1d(sd).astype(float)
    f, _ = _parts(np.asarray(edges, dtype=float), mean, sd, family)
    fd, _ = _parts(np.asarray(domain, dtype=float), mean, sd, family)
    return np.diff(f, axis=1) / np.diff(edges)[None, :] / np.maximum(fd[:, 1:] - fd[:, :1],
                                                                     TINY)


def sample_population(rng: np.random.Generator, mean: np.ndarray, sd: np.ndarray,
                      domain: tuple[float, float], family: str) -> np.ndarray:
    """One draw per row from the truncated population (inverse CDF)."""
    fd, _ = _parts(np.asarray(domain, dtype=float), mean, sd, family)
    u = fd[:, 0] + rng.uniform(size=mean.size) * (fd[:, 1] - fd[:, 0])
    z = special.ndtri(np.clip(u, 1e-300, 1 - 1e-16))
    if family == "normal":
        x = mean + sd * z
    else:
        ml, sl = _lognormal(mean, sd)
        x = np.exp(ml + sl * z)
    return np.clip(np.where(sd > 0, x, mean), domain[0], domain[1])


# ------------------------------------------------------------------ the measurement grid


@dataclass(frozen=True)
class MeasurementGrid:
    """Each trial's measurement likelihood on the grid: ``nodes`` per parameter, ``relative``
    (trials, n_1[, n_2]) likelihood over its maximum ``log_max`` (trials,), ``rolling`` the
    same shape (bool: the bounce leaves rolling), ``interpolation_error`` (the worst miss of the
    interpolant from every other node, relative to each trial's peak)."""

    nodes: tuple[np.ndarray, ...]
    relative: np.ndarray
    log_max: np.ndarray
    rolling: np.ndarray
    interpolation_error: float


def _loglik_nodes(forward, cov: np.ndarray, y: np.ndarray, nodes, budget: float,
                  bytes_per_row: float) -> tuple[np.ndarray, np.ndarray]:
    """(trials, *shape) log-likelihood of each trial's measurement and rolling flags."""
    mesh = np.stack(np.meshgrid(*nodes, indexing="ij"), axis=-1).reshape(-1, len(nodes))
    n = y.shape[0]
    c00, c01, c11 = cov[:, 0, 0], cov[:, 0, 1], cov[:, 1, 1]
    det = c00 * c11 - c01**2
    norm = 0.5 * np.log(det) + math.log(2 * math.pi)
    ll = np.empty((mesh.shape[0], n))
    rolling = np.zeros((mesh.shape[0], n), dtype=bool)
    rows = batch_rows(budget, bytes_per_row)
    for s in range(0, mesh.shape[0], rows):
        r = forward(mesh[s:s + rows])
        ds, da = r.speed - y[:, 0], r.angle - y[:, 1]
        with np.errstate(invalid="ignore"):
            q = (c11 * ds * ds - 2 * c01 * ds * da + c00 * da * da) / det
        ll[s:s + rows] = np.where(r.ok & np.isfinite(q), -0.5 * q - norm, -np.inf)
        rolling[s:s + rows] = r.ok & r.rolling
    shape = tuple(c.size for c in nodes)
    return ll.T.reshape((n,) + shape), rolling.T.reshape((n,) + shape)


def _interpolation_error(rel: np.ndarray) -> float:
    """The worst miss, relative to each trial's peak, of the (bi)linear interpolant from the
    even nodes at the odd ones (the grid of twice the spacing)."""
    if rel.ndim == 2:
        even = rel[:, ::2]
        return float(np.max(np.abs(rel[:, 1::2] - 0.5 * (even[:, :-1] + even[:, 1:]))))
    even = rel[:, ::2, ::2]
    mid0 = 0.5 * (even[:, :-1] + even[:, 1:])  # odd rows, even columns
    mid1 = 0.5 * (even[:, :, :-1] + even[:, :, 1:])  # even rows, odd columns
    centre = 0.5 * (mid0[:, :, :-1] + mid0[:, :, 1:])
    return max(float(np.max(np.abs(got - want))) for got, want in (
        (mid0, rel[:, 1::2, ::2]), (mid1, rel[:, ::2, 1::2]), (centre, rel[:, 1::2, 1::2])))


def grid_log_likelihood(nodes, rel: np.ndarray, log_max: np.ndarray, domains, family: str,
                        theta: np.ndarray, step: int = 1) -> np.ndarray:
    """(R,) log-likelihood of hyper-parameter rows integrated on every ``step``-th node, by
    direct summation (no factorisation: for a few rows)."""
    nodes = tuple(c[::step] for c in nodes)
    rel = rel[(slice(None),) + (slice(None, None, step),) * len(nodes)]
    w = [hat_weights(c, dom, theta[:, 2 * k], theta[:, 2 * k + 1], family)
         for k, (c, dom) in enumerate(zip(nodes, domains, strict=True))]
    m = w[0] @ rel.T if len(w) == 1 else np.einsum("rj,ijk,rk->ri", w[0], rel, w[1])
    return (log_max + np.log(np.maximum(m, TINY))).sum(axis=1)


def measurement_grid(gauss, box: np.ndarray, budget: float = DEFAULT_MEMORY_BUDGET,
                     points: int | None = None) -> MeasurementGrid:
    """Each trial's likelihood on a grid of ``points`` nodes per parameter (default
    ``POINTS``) over the part of ``box`` (d, 2) where some trial's is above ``CUT`` of its peak
    on a coarse grid (padded by a coarse cell)."""
    d = box.shape[0]
    cov = gauss.covariances(np.mean(box, axis=1)[None, :])[0]
    y = np.column_stack([gauss.speed, gauss.angle]).astype(float)
    per_row = gauss.bytes_per_row
    coarse = tuple(np.linspace(lo, hi, COARSE_POINTS[d]) for lo, hi in box)
    ll, _ = _loglik_nodes(gauss.forward, cov, y, coarse, 0.25 * budget, per_row)
    _no_support(ll, gauss)
    peak = ll.reshape(ll.shape[0], -1).max(axis=1)
    alive = np.any(ll >= (peak + math.log(CUT)).reshape((-1,) + (1,) * d), axis=0)
    zoom = []
    for k, c in enumerate(coarse):
        idx = np.flatnonzero(np.any(alive, axis=tuple(j for j in range(d) if j != k)))
        zoom.append((c[max(idx.min() - 1, 0)], c[min(idx.max() + 1, c.size - 1)]))
    nodes = tuple(np.linspace(lo, hi, points or POINTS[d]) for lo, hi in zoom)
    # log-likelihood, relative likelihood, its factors (float64 each) and the rolling flags
    require(f"holding {y.shape[0]} trials' likelihoods on the integration grid "
            f"({' x '.join(str(c.size) for c in nodes)} nodes)",
            y.shape[0] * math.prod(c.size for c in nodes) * 25.0, budget,
            "raise `memory_budget`, or split the table")
    ll, rolling = _loglik_nodes(gauss.forward, cov, y, nodes, 0.25 * budget, per_row)
    peak = ll.reshape(ll.shape[0], -1).max(axis=1)
    rel = np.exp(ll - peak.reshape((-1,) + (1,) * d))
    return MeasurementGrid(nodes, rel, peak, rolling, _interpolation_error(rel))


def refined(n: int, d: int) -> int | None:
    """Nodes per parameter of the grid of half the spacing (``None``: beyond MAX_POINTS)."""
    return 2 * n - 1 if 2 * n - 1 <= MAX_POINTS[d] else None


def _no_support(ll: np.ndarray, gauss) -> None:
    flat = ll.reshape(ll.shape[0], -1)
    bad = np.flatnonzero(~np.isfinite(flat).any(axis=1))
    if bad.size:
        names = ", ".join(gauss.observations[i] for i in bad[:5])
        raise ValueError(f"the model gives no rebound anywhere in the prior box for "
                         f"{bad.size} trial(s) ({names}): the population likelihood needs "
                         f"every trial inside the model's reach; check those trials or widen "
                         f"the priors")


@dataclass(frozen=True)
class Factors:
    """Each trial's relative likelihood as a truncated SVD on its support: column ``k`` of
    trial ``owner[k]`` is ``ut[k]`` (scaled by its singular value) times ``vt[k]``, nonzero
    only on nodes ``lo0[k]:hi0[k]`` and ``lo1[k]:hi1[k]``; ``start[i]:start[i + 1]`` are the
    columns of trial ``i``."""

    ut: np.ndarray  #: (K, n_1)
    vt: np.ndarray  #: (K, n_2)
    start: np.ndarray
    lo0: np.ndarray
    hi0: np.ndarray
    lo1: np.ndarray
    hi1: np.ndarray

    @property
    def rank(self) -> int:
        return int(np.max(np.diff(self.start)))

    @cached_property
    def u(self) -> np.ndarray:
        """(n_1, K) contiguous, for the matrix products."""
        return np.ascontiguousarray(self.ut.T)

    @cached_property
    def v(self) -> np.ndarray:
        """(n_2, K) contiguous."""
        return np.ascontiguousarray(self.vt.T)


def factorise(rel: np.ndarray) -> Factors:
    """The :class:`Factors` of the relative likelihoods (trials, n_1[, n_2])."""
    if rel.ndim == 2:  # one parameter: the likelihood itself
        rel = rel[:, :, None]
    n_trials, n0, n1 = rel.shape
    us, vs, start, bounds = [], [], [0], []
    for i in range(n_trials):
        a = rel[i]
        rows = np.flatnonzero(a.max(axis=1) > CUT)
        cols = np.flatnonzero(a.max(axis=0) > CUT)
        r0, r1, c0, c1 = rows.min(), rows.max() + 1, cols.min(), cols.max() + 1
        u, sv, vt = np.linalg.svd(a[r0:r1, c0:c1], full_matrices=False)
        k = int(np.count_nonzero(sv > SVD_TOL * sv[0]))
        big_u = np.zeros((k, n0))
        big_v = np.zeros((k, n1))
        big_u[:, r0:r1] = (u[:, :k] * sv[:k]).T
        big_v[:, c0:c1] = vt[:k]
        us.append(big_u)
        vs.append(big_v)
        start.append(start[-1] + k)
        bounds += [(r0, r1, c0, c1)] * k
    b = np.asarray(bounds, dtype=np.int64)
    return Factors(np.ascontiguousarray(np.vstack(us)), np.ascontiguousarray(np.vstack(vs)),
                   np.asarray(start, dtype=np.int64), b[:, 0].copy(), b[:, 1].copy(),
                   b[:, 2].copy(), b[:, 3].copy())


@njit(cache=True)
def _log_marginals(theta, nodes0, lo0_dom, hi0_dom, nodes1, lo1_dom, hi1_dom, two, lognormal,
                   u, v, start, log_max, out):
    """Each trial's log marginal likelihood of the hyper-parameter rows ``theta`` (mean, sd
    per parameter): the hat weights, the projections of the weights on every factor (two
    matrix products), the sums per trial and the logarithms in one call."""
    n_rows = theta.shape[0]
    w0 = np.empty((n_rows, nodes0.size))
    w1 = np.ones((n_rows, nodes1.size))
    _hat_kernel(nodes0, lo0_dom, hi0_dom, theta[:, 0].copy(), theta[:, 1].copy(), lognormal,
                w0)
    if two:
        _hat_kernel(nodes1, lo1_dom, hi1_dom, theta[:, 2].copy(), theta[:, 3].copy(),
                    lognormal, w1)
    a = np.dot(w0, u)  # (rows, K): BLAS, faster than summing only over the supports
    b = np.dot(w1, v)
    for r in range(n_rows):
        for i in range(out.shape[1]):
            total = 0.0
            for k in range(start[i], start[i + 1]):
                total += a[r, k] * b[r, k]
            out[r, i] = log_max[i] + math.log(max(total, TINY))


# ------------------------------------------------------------------ the likelihood


@dataclass(frozen=True)
class PopulationLikelihood:
    """Log-likelihood of hyper-parameter rows (``<p>_mean``, ``<p>_sd`` per parameter): the sum
    over trials of each trial's measurement likelihood integrated against the population."""

    gauss: Any  #: the GaussianLikelihood of the trials (forward model, covariances)
    names: tuple[str, ...]  #: the model parameters of the population
    family: str
    domains: tuple[tuple[float, float], ...]  #: the population's support per parameter
    grid: MeasurementGrid
    name: str = "population"
    compares = "population"
    extra_parameters = ()
    _factors: Factors = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "_factors", factorise(self.grid.relative))

    @property
    def observations(self) -> tuple[str, ...]:
        return tuple(self.gauss.observations)

    @property
    def forward(self):
        return self.gauss.forward

    @property
    def bytes_per_row(self) -> float:
        return 8.0 * (sum(c.size for c in self.grid.nodes) + len(self.observations))

    def weights(self, theta: np.ndarray) -> list[np.ndarray]:
        """Hat weights (R, n_k) per parameter of the hyper-parameter rows."""
        theta = np.atleast_2d(theta)
        return [hat_weights(c, dom, theta[:, 2 * k], theta[:, 2 * k + 1], self.family)
                for k, (c, dom) in enumerate(zip(self.grid.nodes, self.domains, strict=True))]

    def pointwise(self, theta: np.ndarray) -> np.ndarray:
        """(R, trials): each trial's log marginal likelihood (one compiled call: weights,
        sums, logarithms)."""
        theta = np.ascontiguousarray(np.atleast_2d(theta), dtype=float)
        f, g = self._factors, self.grid
        nodes1 = g.nodes[1] if len(g.nodes) > 1 else np.ones(1)
        dom1 = self.domains[1] if len(self.domains) > 1 else (0.0, 0.0)
        out = np.empty((theta.shape[0], f.start.size - 1))
        _log_marginals(theta, g.nodes[0], self.domains[0][0], self.domains[0][1], nodes1,
                       dom1[0], dom1[1], len(g.nodes) > 1, self.family == "lognormal", f.u,
                       f.v, f.start, g.log_max, out)
        return out

    def __call__(self, theta: np.ndarray) -> np.ndarray:
        return self.pointwise(theta).sum(axis=1)

    def on_coarser_grid(self, theta: np.ndarray) -> np.ndarray:
        """The log-likelihood of rows on the grid of every other node (for the Richardson
        estimate of the quadrature error)."""
        g = self.grid
        return grid_log_likelihood(g.nodes, g.relative, g.log_max, self.domains, self.family,
                                   np.atleast_2d(theta), 2)

    def structured_grid(self, names, axes) -> None:
        return None

    def subset(self, most: int) -> PopulationLikelihood:
        return self

    def describe(self) -> dict:
        g = self.grid
        return {
            "noise": "given", "incidence": "per trial",
            "family": self.family,
            "population": (f"{self.family} per parameter, truncated to the prior's domain "
                           f"({', '.join(f'{n} in [{a:g}, {b:g}]' for n, (a, b) in zip(self.names, self.domains, strict=True))}) and renormalised; "
                           f"parameters independent"),
            "hyper_priors": "each <p>_mean uniform on the prior box; each <p>_sd uniform on "
                            f"[0, {SD_RANGE:g} x the box's width]",
            "marginalisation": "exact integration of each trial's likelihood (bilinear "
                               "interpolant on the grid) against the population density",
            "grid_points": [int(c.size) for c in g.nodes],
            "grid_box": [[float(c[0]), float(c[-1])] for c in g.nodes],
            "interpolation_error": g.interpolation_error,
            "svd_rank_max": self._factors.rank,
            "incidence_uncertainty": self.gauss.describe()["incidence_uncertainty"],
            "pointwise": "per trial: the log of each trial's likelihood integrated over its "
                         "own parameters against the population",
        }


def check_population(names: tuple[str, ...], noise: str, discrepancy: str, trials: Trials,
                     family: str) -> None:
    """What the population likelihood can do exactly: refuse the rest, saying why."""
    if family not in FAMILIES:
        raise ValueError(f"`population` must be one of {', '.join(map(repr, FAMILIES))}; "
                         f"got {family!r}")
    if not 1 <= len(names) <= 2:
        raise ValueError(f"the population likelihood integrates each bounce's parameters on a "
                         f"grid, for 1 or 2 inferred parameters; this experiment infers "
                         f"{len(names)} ({', '.join(names)}): fix the others in [contact]")
    if noise == "inferred":
        raise ValueError("the population likelihood needs the measurement noise given (the "
                         "table's rebound_speed_se and rebound_angle_se): an inferred noise "
                         "level would change every trial's likelihood on the integration grid "
                         "at every step, which the exact precomputed integration cannot "
                         "follow; add the standard errors, or use likelihood='gaussian'")
    if discrepancy not in ("none", "auto"):
        raise ValueError(f"`discrepancy` ({discrepancy!r}) is not available with the "
                         f"population likelihood (the bounce-to-bounce spread it infers "
                         f"already absorbs scatter beyond the noise): use discrepancy='none'")
    se = np.column_stack([trials.se["rebound_speed"], trials.se["rebound_angle"]])
    if not (np.all(np.isfinite(se)) and np.all(se > 0)):
        raise ValueError(f"{trials.source}: the population likelihood needs positive standard "
                         f"errors in rebound_speed_se and rebound_angle_se for every trial "
                         f"(the measurement noise it separates from the bounce-to-bounce "
                         f"spread); add them")
    if family == "lognormal":
        return


def make_population(experiment: Experiment, trials: Trials, names: tuple[str, ...], *,
                    family: str = "normal", noise: str = "auto", discrepancy: str = "none",
                    memory_budget: float = DEFAULT_MEMORY_BUDGET,
                    points: int | None = None) -> PopulationLikelihood:
    """The population likelihood of the trials for the model parameters ``names``
    (``points``: grid nodes per parameter, default ``POINTS``)."""
    from ._likelihood import _gaussian

    check_population(names, noise, discrepancy, trials, family)
    if family == "lognormal":
        low = [n for n in names if experiment.priors[n].support[0] < 0]
        if low:
            raise ValueError(f"a lognormal population needs positive parameters; the prior of "
                             f"{low[0]} reaches {experiment.priors[low[0]].support[0]:g}: use "
                             f"population='normal'")
    gauss = _gaussian(experiment, trials, names, "given", "none", memory_budget)
    box = np.array([experiment.priors[n].box(1e-6) for n in names], dtype=float)
    domains = tuple((float(a), float(b)) for a, b in
                    (experiment.priors[n].support for n in names))
    grid = measurement_grid(gauss, box, memory_budget, points)
    return PopulationLikelihood(gauss, tuple(names), family, domains, grid)
