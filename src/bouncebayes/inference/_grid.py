"""Exact quadrature on a grid of cell centres: the normalised joint density, its marginals, the
evidence, and draws resampled from the cells. Memory is planned before the grid is made."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.special import logsumexp

from ._config import GridConfig
from ._draws import Draws, floats
from ._memory import require
from ._mode import nowhere_message
from ._posterior import LogPosterior

ZOOM_PASSES = 4
COARSE_POINTS = {1: 512, 2: 96, 3: 32}
ZOOM_DROP = 30.0  #: log-density below the maximum that the zoomed box may leave out
#: bytes per grid cell: log posterior, weights and density (float64 each), the structured
#: kernel's output and flags, and the resampling's cumulative weights
GRID_BYTES_PER_CELL = 48
CELLS_PER_SD_LIMIT = 3.0


@dataclass(frozen=True)
class GridDensity:
    """The normalised joint density on the grid (points,) * d and its marginals."""

    centres: tuple[np.ndarray, ...]  #: cell centres per parameter
    density: np.ndarray
    marginals: tuple[np.ndarray, ...]


@dataclass(frozen=True)
class GridRun:
    """How the grid quadrature went (``grid``: the density; ``None`` when reloaded from
    summary.json, whose grid lives in grid.npz)."""

    log_evidence: float
    grid_points: int
    box: tuple[tuple[float, float], ...]
    exact_mean: tuple[float, ...]
    exact_sd: tuple[float, ...]
    cells_per_sd: tuple[float, ...]
    grid: GridDensity | None = None
    #: numerical uncertainty of ``log_evidence``: the largest change over the 2^d interleaved
    #: sub-grids of twice the spacing (an upper estimate of the full grid's error; NaN: unknown)
    log_evidence_se: float = float("nan")

    def to_dict(self) -> dict[str, Any]:
        return {"log_evidence": self.log_evidence, "log_evidence_se": self.log_evidence_se,
                "grid_points": self.grid_points,
                "box": [list(b) for b in self.box], "exact_mean": list(self.exact_mean),
                "exact_sd": list(self.exact_sd), "cells_per_sd": list(self.cells_per_sd)}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> GridRun:
        se = d.get("log_evidence_se")
        return cls(float(d["log_evidence"]), int(d["grid_points"]),
                   tuple(tuple(b) for b in d["box"]), tuple(d["exact_mean"]),
                   tuple(d["exact_sd"]), tuple(d["cells_per_sd"]),
                   log_evidence_se=float("nan") if se is None else float(se))

    def warnings(self, summaries: list[Any]) -> list[str]:
        """A grid too coarse for the posterior (draws are independent: no ESS check)."""
        return [f"{s.name}: the posterior sd spans only {cells:.1f} grid cells; raise "
                f"`points` of GridConfig" for s, cells in zip(summaries, self.cells_per_sd,
                                                               strict=True)
                if cells < CELLS_PER_SD_LIMIT]


def grid_bytes(points: int, dim: int) -> float:
    """Memory of a grid of ``points`` per parameter in ``dim`` parameters."""
    return float(points) ** dim * GRID_BYTES_PER_CELL


def check_grid_memory(points: int, dim: int, budget: float, share: float = 1.0) -> None:
    """Refuse a grid that cannot fit in ``share`` of the memory budget, naming the largest
    that can."""
    most = int((share * budget / GRID_BYTES_PER_CELL) ** (1.0 / dim))
    require(f"a grid of {points} points per parameter in {dim} parameters "
            f"({float(points) ** dim:.3g} cells)", grid_bytes(points, dim), budget,
            f"use at most {most} `points` per parameter, or raise `memory_budget`", share)


def sample_grid(post: LogPosterior, config: GridConfig, rng: np.random.Generator,
                progress: bool = False) -> Draws:
    """Quadrature on a regular grid of cell centres over the prior box, zoomed onto the region
    where the posterior is within e^-30 of its maximum when that is much smaller (so that a
    narrow posterior is resolved; the mass left outside is below 1e-10); draws are resampled
    from the cells with a uniform jitter inside each. Its memory (:func:`grid_bytes`) is
    planned by the caller with :func:`check_grid_memory`."""
    n = config.points_for(post.dim)
    box = post.box(1e-6)
    for _ in range(ZOOM_PASSES):
        zoomed = _zoom(post, box, min(n, COARSE_POINTS[post.dim]))
        if np.all(zoomed[:, 1] - zoomed[:, 0] > 0.5 * (box[:, 1] - box[:, 0])):
            break
        box = zoomed
    edges = [np.linspace(lo, hi, n + 1) for lo, hi in box]
    centres = tuple(0.5 * (e[1:] + e[:-1]) for e in edges)
    lp = grid_log_posterior(post, centres, progress)
    if not np.isfinite(lp).any():
        probe = np.linspace(0, lp.size - 1, min(lp.size, 1024)).astype(int)
        raise ValueError(nowhere_message(post, _cells(centres, probe), "the grid"))
    steps = np.array([e[1] - e[0] for e in edges])
    weights = np.exp(lp - logsumexp(lp))
    density = (weights / float(np.prod(steps))).reshape((n,) * post.dim)
    cells = rng.choice(lp.size, size=config.draws, p=weights)
    draws = _cells(centres, cells) + (rng.uniform(size=(config.draws, post.dim)) - 0.5) * steps
    run = _run(lp, density, centres, steps, box, n)
    return Draws(draws[None], lp[cells][None], run)


def _run(lp, density, centres, steps, box, n) -> GridRun:
    """The run record: evidence, exact moments (in box-relative units, so that a huge prior
    box does not overflow), resolution."""
    dim = density.ndim
    volume = float(np.prod(steps))
    marginals = tuple(density.sum(axis=tuple(j for j in range(dim) if j != i)) * volume
                      / steps[i] for i in range(dim))
    mean, sd = [], []
    for i, (m, c) in enumerate(zip(marginals, centres, strict=True)):
        lo, width = box[i, 0], box[i, 1] - box[i, 0]
        u = (c - lo) / width
        p = m * steps[i]
        mu = float(np.sum(p * u))
        mean.append(lo + width * mu)
        sd.append(width * math.sqrt(max(float(np.sum(p * (u - mu) ** 2)), 0.0)))
    log_z = float(logsumexp(lp) + math.log(volume))
    return GridRun(log_z, n, tuple((float(a), float(b)) for a, b in box), tuple(mean),
                   tuple(sd), floats(np.array(sd) / steps),
                   GridDensity(centres, density, marginals),
                   _evidence_error(lp.reshape((n,) * dim), volume, log_z))


def _evidence_error(lp: np.ndarray, volume: float, log_z: float) -> float:
    """The largest change of the log evidence over the 2^d interleaved sub-grids of twice the
    spacing (each a quadrature rule of its own over the same box): where the posterior is
    resolved they agree with the full grid, and the full grid is closer still."""
    dim = lp.ndim
    out = 0.0
    for offsets in np.ndindex(*(2,) * dim):
        sub = lp[tuple(slice(o, None, 2) for o in offsets)]
        if not np.isfinite(sub).any():
            return float("inf")
        out = max(out, abs(float(logsumexp(sub)) + math.log(volume * 2**dim) - log_z))
    return out


def _cells(centres, flat: np.ndarray) -> np.ndarray:
    """Parameter rows (len(flat), d) of the cells with flat (C-order) indices ``flat``."""
    index = np.unravel_index(flat, tuple(c.size for c in centres))
    return np.column_stack([c[i] for c, i in zip(centres, index, strict=True)])


def _zoom(post: LogPosterior, box: np.ndarray, n: int) -> np.ndarray:
    """The part of ``box`` where a coarse grid finds the log posterior within ZOOM_DROP of its
    maximum, padded by two coarse cells on each side."""
    edges = [np.linspace(lo, hi, n + 1) for lo, hi in box]
    centres = tuple(0.5 * (e[1:] + e[:-1]) for e in edges)
    lp = grid_log_posterior(post, centres, False).reshape((n,) * post.dim)
    if not np.isfinite(lp).any():
        return box
    keep = np.argwhere(lp >= lp.max() - ZOOM_DROP)
    lo = np.maximum(keep.min(axis=0) - 2, 0)
    hi = np.minimum(keep.max(axis=0) + 3, n)
    return np.array([[e[a], e[b]] for e, a, b in zip(edges, lo, hi, strict=True)])


def grid_log_posterior(post: LogPosterior, centres, progress: bool) -> np.ndarray:
    """Log posterior of every cell (flat, C order): the likelihood's exact structured grid
    where it has one, else the generic posterior in batches of at most ``post.batch_rows``."""
    from tqdm.auto import tqdm

    structured = post.likelihood.structured_grid(post.names, centres)
    size = math.prod(c.size for c in centres)
    if structured is not None:
        ll, bad = (a.ravel() for a in structured)
        flat = np.flatnonzero(bad)
        if flat.size:
            ll[flat] = post.likelihood(_cells(centres, flat))
        return _log_prior_cells(post, centres, size) + ll
    lp = np.empty(size)
    chunk = max(1, min(post.batch_rows, 65536))
    with tqdm(total=size, desc="grid", disable=not progress, leave=False, unit="cell",
              mininterval=0.2) as bar:
        for s in range(0, size, chunk):
            rows = np.arange(s, min(s + chunk, size))
            lp[s:s + rows.size] = post(_cells(centres, rows))
            bar.update(rows.size)
    return lp


def _log_prior_cells(post: LogPosterior, centres, size: int) -> np.ndarray:
    """Log prior of every cell (a product of marginal priors: an outer sum, no mesh)."""
    out = np.zeros(())
    for prior, c in zip(post.priors, centres, strict=True):
        out = np.add.outer(out, prior.logpdf(c))
    return np.broadcast_to(out, (size,)) if out.ndim == 0 else out.ravel()
