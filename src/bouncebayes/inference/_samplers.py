"""Samplers: Metropolis–Hastings (the paper's), emcee's ensemble sampler, and exact grid
quadrature. Each returns :class:`Draws` of shape (chains, draws, d)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import optimize
from scipy.special import logsumexp
from scipy.stats import qmc

from ._posterior import LogPosterior, SamplerConfig


@dataclass(frozen=True)
class Draws:
    """Posterior draws and per-draw statistics, arrays of shape (chains, draws[, d])."""

    samples: np.ndarray
    stats: dict  #: name -> (chains, draws) array (``lp`` always)
    info: dict = field(default_factory=dict)  #: sampler facts for the summary


def _progress(total: int, desc: str, show: bool):
    from tqdm.auto import tqdm

    return tqdm(total=total, desc=desc, disable=not show, leave=False, unit="it",
                mininterval=0.2)


def find_mode(post: LogPosterior, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Mode and a covariance guess: the best point of a Sobol design over the prior box,
    polished by Nelder–Mead, and the inverse Hessian there (finite differences)."""
    box = post.box(1e-4)
    width = box[:, 1] - box[:, 0]
    design = qmc.Sobol(post.dim, scramble=True, seed=rng).random(1024)
    pilot = box[:, 0] + design * width
    lp = post(pilot)
    if not np.isfinite(lp).any():
        raise ValueError("the posterior is zero on all 1024 points of a design over the prior "
                         "box: no parameter value in the prior reproduces the data")
    best = pilot[int(np.argmax(lp))]
    res = optimize.minimize(lambda x: -post(x[None, :])[0], best, method="Nelder-Mead",
                            bounds=list(map(tuple, box)),
                            options={"xatol": 1e-10, "fatol": 1e-10, "maxiter": 400 * post.dim})
    mode = res.x if np.isfinite(res.fun) and -res.fun >= lp.max() else best
    return mode, _covariance(post, mode, width)


def _covariance(post: LogPosterior, mode: np.ndarray, width: np.ndarray) -> np.ndarray:
    d = post.dim
    h = 1e-4 * width
    points = [mode]
    for i in range(d):
        for j in range(i, d):
            for si, sj in ((1, 1), (1, -1), (-1, 1), (-1, -1)):
                p = mode.copy()
                p[i] += si * h[i]
                p[j] += sj * h[j]
                points.append(p)
    lp = post(np.array(points))
    hess = np.zeros((d, d))
    k = 1
    for i in range(d):
        for j in range(i, d):
            f = lp[k:k + 4]
            hess[i, j] = hess[j, i] = (f[0] - f[1] - f[2] + f[3]) / (4 * h[i] * h[j])
            k += 4
    fallback = np.diag((width / 10.0) ** 2)
    if not np.all(np.isfinite(hess)):
        return fallback
    flat = ~(-np.diag(hess) > 0)  # a direction the data do not constrain (e.g. mu, rolling)
    if flat.any():  # give it a quarter of the box, keep the curvature of the others
        idx = np.flatnonzero(flat)
        hess[flat, :] = 0.0
        hess[:, flat] = 0.0
        hess[idx, idx] = -(4.0 / width[idx]) ** 2
    try:
        cov = np.linalg.inv(-hess)
        np.linalg.cholesky(cov)
    except np.linalg.LinAlgError:
        return fallback
    sd = np.sqrt(np.diag(cov))
    cap = np.minimum(sd, width / 4.0) / sd  # a flat direction: at most a quarter of the box
    return cov * cap[:, None] * cap[None, :]


def _dispersed_starts(post, mode, cov, n, rng, spread):
    chol = np.linalg.cholesky(cov)
    starts = np.empty((n, post.dim))
    for c in range(n):
        for _ in range(1000):
            x = mode + spread * chol @ rng.standard_normal(post.dim)
            if np.isfinite(post.log_prior(x[None, :])[0]):
                break
        else:
            x = mode
        starts[c] = x
    return starts


def sample_mh(post: LogPosterior, config: SamplerConfig, rng: np.random.Generator,
              progress: bool = False) -> Draws:
    """Random-walk Metropolis–Hastings with a symmetric Gaussian proposal, chains from
    overdispersed starts (2 sd around the mode), proposal scale tuned during burn-in."""
    mode, cov = find_mode(post, rng)
    c, d = config.chains, post.dim
    starts = _dispersed_starts(post, mode, cov, c, rng, spread=2.0)
    x = starts.copy()
    lp = post(x)
    chol = np.linalg.cholesky(cov) * (2.38 / math.sqrt(d))
    log_scale = np.zeros(c)
    target = 0.44 if d == 1 else 0.234
    keep = config.per_chain()
    total = config.burn_in + keep * config.thin
    samples = np.empty((c, keep, d))
    lps = np.empty((c, keep))
    accepted = np.zeros((c, keep), dtype=bool)
    n_accept = np.zeros(c)
    bar = _progress(total, "mh", progress)
    normals = rng.standard_normal((total, c, d)) @ chol.T  # drawn in bulk: the same stream
    log_u = np.log(rng.uniform(size=(total, c)))
    for it in range(total):
        proposal = x + normals[it] * np.exp(log_scale)[:, None]
        lp_new = post(proposal)
        accept = log_u[it] < lp_new - lp
        x = np.where(accept[:, None], proposal, x)
        lp = np.where(accept, lp_new, lp)
        if it < config.burn_in:  # Robbins–Monro tuning of each chain's proposal scale
            log_scale += (accept.astype(float) - target) / math.sqrt(it + 1.0)
        else:
            n_accept += accept
            k, r = divmod(it - config.burn_in, config.thin)
            if r == config.thin - 1:
                samples[:, k], lps[:, k], accepted[:, k] = x, lp, accept
        bar.update()
    bar.close()
    rate = n_accept / (keep * config.thin)
    return Draws(samples, {"lp": lps, "accepted": accepted},
                 {"acceptance_rate": rate.tolist(), "proposal_scale": np.exp(log_scale).tolist(),
                  "mode": mode.tolist(), "starts": starts.tolist(),
                  "iterations_per_chain": total})


def sample_ensemble(post: LogPosterior, config: SamplerConfig, rng: np.random.Generator,
                    progress: bool = False) -> Draws:
    """emcee's affine-invariant ensemble sampler (Goodman & Weare 2010, Foreman-Mackey et al.
    2013), walkers started in a ball around the mode, vectorised log posterior."""
    import emcee

    mode, cov = find_mode(post, rng)
    w = max(config.walkers, 2 * post.dim + 2)
    w += w % 2
    start = _dispersed_starts(post, mode, cov, w, rng, spread=1.0)
    sampler = emcee.EnsembleSampler(w, post.dim, post, vectorize=True)
    state = np.random.RandomState(int(rng.integers(2**31 - 1)))
    sampler.random_state = state.get_state()
    if not np.array_equal(sampler.random_state[1], state.get_state()[1]):  # pragma: no cover
        raise RuntimeError("could not seed emcee's random generator")
    steps = math.ceil(config.draws / w) * config.ensemble_thin
    sampler.run_mcmc(start, config.ensemble_burn_in + steps, progress=progress,
                     progress_kwargs={"leave": False, "desc": "ensemble"})
    chain = sampler.get_chain(discard=config.ensemble_burn_in, thin=config.ensemble_thin)
    lps = sampler.get_log_prob(discard=config.ensemble_burn_in, thin=config.ensemble_thin)
    samples = np.swapaxes(chain, 0, 1)  # (walkers, draws, d)
    # walkers are not independent chains: judge convergence by the autocorrelation time
    # (Foreman-Mackey et al. 2013: run for at least 50 of them), not by R-hat across walkers
    tau = emcee.autocorr.integrated_time(chain, quiet=True) * config.ensemble_thin
    with np.errstate(invalid="ignore"):
        return Draws(samples, {"lp": lps.T},
                     {"acceptance_rate": sampler.acceptance_fraction.tolist(), "walkers": w,
                      "mode": mode.tolist(), "steps": config.ensemble_burn_in + steps,
                      "autocorrelation_steps": tau.tolist(),
                      "kept_steps_per_autocorrelation": (steps / tau).tolist()})


def sample_grid(post: LogPosterior, config: SamplerConfig, rng: np.random.Generator,
                progress: bool = False) -> Draws:
    """Exact quadrature on a regular grid of cell centres: the normalised joint density, its
    marginals and the evidence; draws are resampled from the cells (with a uniform jitter
    inside each) for propagation. The grid covers the prior box, zoomed onto the region where
    the posterior is within e^-30 of its maximum when that is much smaller (so that a narrow
    posterior is resolved; the mass left outside is below 1e-10)."""
    n = config.points(post.dim)
    box = post.box(1e-6)
    for _ in range(ZOOM_PASSES):
        zoomed = _zoom(post, box, min(n, COARSE_POINTS[post.dim]))
        if np.all(zoomed[:, 1] - zoomed[:, 0] > 0.5 * (box[:, 1] - box[:, 0])):
            break
        box = zoomed
    edges = [np.linspace(lo, hi, n + 1) for lo, hi in box]
    centres = [0.5 * (e[1:] + e[:-1]) for e in edges]
    lp = _grid_log_posterior(post, centres, progress)
    if not np.isfinite(lp).any():
        raise ValueError("the posterior is zero everywhere on the grid")
    steps = np.array([e[1] - e[0] for e in edges])
    volume = float(np.prod(steps))
    log_evidence = float(logsumexp(lp) + math.log(volume))
    weights = np.exp(lp - logsumexp(lp))
    mesh_shape = (n,) * post.dim
    density = (weights / volume).reshape(mesh_shape)
    marginals = [density.sum(axis=tuple(j for j in range(post.dim) if j != i))
                 * volume / steps[i] for i in range(post.dim)]
    mean = [float(np.sum(m * c) * steps[i]) for i, (m, c) in enumerate(zip(marginals, centres,
                                                                            strict=True))]
    sd = [math.sqrt(max(float(np.sum(m * (c - mu) ** 2) * steps[i]), 0.0))
          for i, (m, c, mu) in enumerate(zip(marginals, centres, mean, strict=True))]
    cells = rng.choice(weights.size, size=config.draws, p=weights)
    mesh = np.stack(np.meshgrid(*centres, indexing="ij"), axis=-1).reshape(-1, post.dim)
    draws = mesh[cells] + (rng.uniform(size=(config.draws, post.dim)) - 0.5) * steps
    return Draws(draws[None], {"lp": lp[cells][None]},
                 {"log_evidence": log_evidence, "grid_points": n, "box": box.tolist(),
                  "exact_mean": mean, "exact_sd": sd,
                  "cells_per_sd": [s_ / h for s_, h in zip(sd, steps, strict=True)],
                  "grid": {"centres": [c.tolist() for c in centres], "density": density,
                           "marginals": marginals}})


ZOOM_PASSES = 4
COARSE_POINTS = {1: 512, 2: 96, 3: 32}
ZOOM_DROP = 30.0  # log-density below the maximum that the zoomed box may leave out


def _zoom(post: LogPosterior, box: np.ndarray, n: int) -> np.ndarray:
    """The part of ``box`` where a coarse grid finds the log posterior within ZOOM_DROP of its
    maximum, padded by two coarse cells on each side."""
    edges = [np.linspace(lo, hi, n + 1) for lo, hi in box]
    centres = [0.5 * (e[1:] + e[:-1]) for e in edges]
    lp = _grid_log_posterior(post, centres, False).reshape((n,) * post.dim)
    if not np.isfinite(lp).any():
        return box
    keep = np.argwhere(lp >= lp.max() - ZOOM_DROP)
    lo = np.maximum(keep.min(axis=0) - 2, 0)
    hi = np.minimum(keep.max(axis=0) + 3, n)
    return np.array([[e[a], e[b]] for e, a, b in zip(edges, lo, hi, strict=True)])


def _grid_log_posterior(post: LogPosterior, centres, progress: bool) -> np.ndarray:
    mesh = np.stack(np.meshgrid(*centres, indexing="ij"), axis=-1).reshape(-1, post.dim)
    lp = _structured_grid(post, centres, mesh)
    if lp is None:
        lp = np.empty(mesh.shape[0])
        chunk = 65536
        bar = _progress(mesh.shape[0], "grid", progress)
        for s in range(0, mesh.shape[0], chunk):
            lp[s:s + chunk] = post(mesh[s:s + chunk])
            bar.update(min(chunk, mesh.shape[0] - s))
        bar.close()
    return lp


def _structured_grid(post: LogPosterior, centres, mesh):
    """The (mu, eta) grid of a Gaussian likelihood with given noise, without repeating the
    normal impact for every mu (see _grid_kernel); None where that does not apply."""
    like = post.likelihood
    if sorted(post.names) != ["eta", "mu"] or getattr(like, "noise", None) != "given":
        return None
    from ._grid_kernel import gaussian_grid

    i_mu, i_eta = post.names.index("mu"), post.names.index("eta")
    ll, bad = gaussian_grid(like, centres[i_mu], centres[i_eta])
    if i_mu == 1:
        ll, bad = ll.T, bad.T
    ll, bad = ll.ravel(), bad.ravel()
    if bad.any():
        ll[bad] = like(mesh[bad])
    return post.log_prior(mesh) + ll
