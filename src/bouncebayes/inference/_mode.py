"""Where the Markov chains start: the posterior mode, a covariance guess, dispersed points."""

from __future__ import annotations

import numpy as np
from scipy import optimize
from scipy.stats import qmc

from ._posterior import LogPosterior

PILOT_POINTS = 1024
PILOT_TRIALS = 2000  #: evenly spaced trials that judge the design (all of a smaller table)


def find_mode(post: LogPosterior, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Mode and a covariance guess: the best point of a Sobol design over the prior box
    (judged on at most PILOT_TRIALS trials), polished by Nelder–Mead on the full posterior,
    and the inverse Hessian there (finite differences)."""
    box = post.box(1e-4)
    width = box[:, 1] - box[:, 0]
    design = qmc.Sobol(post.dim, scramble=True, seed=rng).random(PILOT_POINTS)
    pilot = box[:, 0] + design * width
    judge = post.subset(PILOT_TRIALS)
    lp = judge(pilot)
    if not np.isfinite(lp).any():
        raise ValueError(nowhere_message(judge, pilot, f"a {PILOT_POINTS}-point design"))
    best = pilot[int(np.argmax(lp))]
    lp_best = lp.max() if judge is post else post(best[None, :])[0]
    res = optimize.minimize(lambda x: -post(x[None, :])[0], best, method="Nelder-Mead",
                            bounds=list(map(tuple, box)),
                            options={"xatol": 1e-10, "fatol": 1e-10, "maxiter": 400 * post.dim})
    mode = res.x if np.isfinite(res.fun) and -res.fun >= lp_best else best
    return mode, covariance(post, mode, width)


def nowhere_message(post: LogPosterior, theta: np.ndarray, where: str) -> str:
    """Why the posterior is zero at every point of ``theta``: the model gave no rebound (the
    priors reach unphysical values), or the likelihood is zero although it did."""
    like = post.likelihood
    d = len(like.forward.names)
    ok = like.forward(theta[:, :d]).ok
    ranges = ", ".join(f"{n} in [{lo:.4g}, {hi:.4g}]{' ' + u if u else ''}"
                       for n, (lo, hi), u in zip(post.names, post.box(1e-4), post.units,
                                                 strict=True))
    if not ok.all(axis=1).any():
        return (f"the model gives no rebound for every bounce at any point of {where} over "
                f"the prior box ({ranges}; {100 * (1 - ok.mean()):.0f} % of the simulated "
                f"bounces failed): the priors reach values where the ball does not bounce; "
                f"narrow them to the physical range")
    return (f"the likelihood is zero at every point of {where} over the prior box ({ranges}) "
            f"although the model simulated the bounces: no parameter value in the prior "
            f"reproduces the data")


def covariance(post: LogPosterior, mode: np.ndarray, width: np.ndarray) -> np.ndarray:
    """Inverse of minus the Hessian of the log posterior at ``mode`` (central differences),
    with flat directions given a quarter of the box and every sd capped at a quarter."""
    d = post.dim
    h = 1e-4 * width
    offsets = [(i, j, si, sj) for i in range(d) for j in range(i, d)
               for si, sj in ((1, 1), (1, -1), (-1, 1), (-1, -1))]
    points = np.repeat(mode[None, :], len(offsets) + 1, axis=0)
    for k, (i, j, si, sj) in enumerate(offsets, start=1):
        points[k, i] += si * h[i]
        points[k, j] += sj * h[j]
    lp = post(points)
    hess = np.zeros((d, d))
    with np.errstate(invalid="ignore"):  # a point beyond a prior bound: -inf - -inf, NaN
        for k in range(0, len(offsets), 4):
            i, j = offsets[k][:2]
            f = lp[k + 1:k + 5]
            hess[i, j] = hess[j, i] = (f[0] - f[1] - f[2] + f[3]) / (4 * h[i] * h[j])
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


def dispersed_starts(post: LogPosterior, mode: np.ndarray, cov: np.ndarray, n: int,
                     rng: np.random.Generator, spread: float) -> np.ndarray:
    """``n`` points ``spread`` sd around the mode, each inside the prior's support."""
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
