"""The evidence (marginal likelihood) of a model and its numerical uncertainty.

Exact grid quadrature where the inference ran on a grid (``GridRun.log_evidence``, with the
spread over interleaved sub-grids as its uncertainty); otherwise nested sampling by dynesty
(Speagle 2020; Skilling 2006), whose run gives the evidence and its statistical uncertainty.
Both integrate the same thing, the likelihood over the normalised prior of every inferred
parameter, so evidences of different models of the same trials compare.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np

LIVE_POINTS = 400  #: dynesty's live points by default
DLOGZ = 0.05  #: dynesty stops when the remaining evidence is below this (in log)
FLOOR = -1e300  #: dynesty needs a finite log-likelihood; a bounce that failed counts as this


@dataclass(frozen=True)
class Evidence:
    """``log_evidence`` (natural log) and its numerical uncertainty ``se``; ``method`` says how
    it was computed, ``detail`` holds the method's own numbers."""

    log_evidence: float
    se: float
    method: str
    detail: dict

    def to_dict(self) -> dict[str, Any]:
        return {"log_evidence": self.log_evidence, "log_evidence_se": self.se,
                "evidence_method": self.method, "evidence_detail": self.detail}


def grid_evidence(result) -> Evidence:
    """The grid sampler's quadrature (``result.draws.info``, a GridRun)."""
    run = result.draws.info
    se = float(run.log_evidence_se)
    return Evidence(float(run.log_evidence), se,
                    f"grid quadrature ({run.grid_points} points per parameter)",
                    {"grid_points": run.grid_points, "box": [list(b) for b in run.box],
                     "cells_per_sd": list(run.cells_per_sd)})


def nested_evidence(result, *, seed: int, live_points: int = LIVE_POINTS,
                    progress: bool = False) -> Evidence:
    """Nested sampling (dynesty) of the result's likelihood over its priors (the inference's
    own ``LogPosterior``; a reloaded result has none and is refused)."""
    import dynesty

    post = result.posterior
    if post.likelihood is None:
        raise ValueError("nested sampling needs the likelihood of the inference; a result "
                         "reloaded from a run folder has none: compare from the experiment and "
                         "data instead")
    priors, like = post.priors, post.likelihood

    def loglike(x: np.ndarray) -> float:
        v = float(like(x[None, :])[0])
        return v if math.isfinite(v) else FLOOR

    def transform(u: np.ndarray) -> np.ndarray:
        return np.array([float(p.ppf(q)) for p, q in zip(priors, u, strict=True)])

    sampler = dynesty.NestedSampler(loglike, transform, post.dim, nlive=int(live_points),
                                    rstate=np.random.default_rng([int(seed), 3]))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # dynesty's bound updates, harmless
        sampler.run_nested(dlogz=DLOGZ, print_progress=progress)
    res = sampler.results
    return Evidence(float(res.logz[-1]), float(res.logzerr[-1]),
                    f"nested sampling (dynesty {dynesty.__version__}, {live_points} live points)",
                    {"live_points": int(live_points), "likelihood_calls": int(np.sum(res.ncall)),
                     "iterations": int(res.niter), "dlogz": DLOGZ})
