"""Density curves and surfaces of samples for the figures.

The measured rebounds are drawn with the density the likelihood uses
(:class:`bouncebayes.density.ReboundDensity`). Samples of thousands of draws (posterior
marginals, predictive, contact time, the joint posterior) are drawn with binned Gaussian KDEs:
counts on the plotting grid convolved with the sampled kernel (Wand, J. Comput. Graph. Stat. 3,
433-445, 1994). They use every draw at the cost of one convolution, where summing the kernel
over every draw at every grid node took seconds for the joint posterior
(``scipy.stats.gaussian_kde``). Neither SciPy nor NumPy offers the binned estimator; it is the
few lines below.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..density import BandwidthRule, bandwidth

MIN_POINTS = 2


def kde_curve(x: Any, grid: np.ndarray) -> np.ndarray | None:
    """Gaussian KDE of the finite values of ``x`` on the regular ``grid``, by binning: counts on
    bins centred on the grid nodes (extended by four bandwidths on each side, so that values
    beyond the grid still contribute near its ends) convolved with the sampled kernel.

    The bandwidth is MATLAB's normal-reference rule (:func:`bouncebayes.density.bandwidth`;
    the standard-deviation rule where more than half the values are equal). Binning adds a
    twelfth of the squared node spacing to the kernel's variance; the sampled kernel is narrowed
    by as much, so that the estimate has the rule's bandwidth. None when ``x`` has fewer than two
    distinct finite values.
    """
    x = np.asarray(x, dtype=float)
    x = x[np.isfinite(x)]
    if x.size < MIN_POINTS or np.ptp(x) == 0:
        return None
    rule: BandwidthRule = "normal-reference" if np.median(np.abs(x - np.median(x))) > 0 else "silverman"
    h = bandwidth(x, rule)
    step = float(grid[1] - grid[0])
    pad = min(int(np.ceil(4.0 * h / step)), 4 * grid.size)
    edges = grid[0] + step * (np.arange(-pad, grid.size + pad + 1) - 0.5)
    counts = np.histogram(x, edges)[0].astype(float)
    h_kernel = np.sqrt(max(h**2 - step**2 / 12.0, 1e-6 * h**2))
    kernel = np.exp(-0.5 * (np.arange(-pad, pad + 1) * step / h_kernel) ** 2)
    kernel /= kernel.sum() * step  # exact mass on the grid, also for a kernel under a bin
    return np.convolve(counts, kernel, mode="same")[pad:pad + grid.size] / x.size


def _edges(centres: np.ndarray) -> np.ndarray:
    step = centres[1] - centres[0]
    return np.append(centres - step / 2, centres[-1] + step / 2)


def binned_kde_2d(x: np.ndarray, y: np.ndarray, gx: np.ndarray, gy: np.ndarray) -> np.ndarray:
    """Gaussian KDE of the pairs (x, y) at the nodes of the regular grid ``gx`` x ``gy``
    (indexing ``ij``), with Scott's bandwidth matrix ``n^(-1/3) cov(x, y)`` (the default of
    ``scipy.stats.gaussian_kde`` in 2-D); the sampled kernel is narrowed by the variance that
    binning adds (a twelfth of the squared node spacing per axis). Pairs outside the grid count
    in the normalisation (the density of all draws) but add nothing inside it."""
    from scipy.signal import fftconvolve

    n = x.size
    counts, _, _ = np.histogram2d(x, y, bins=[_edges(gx), _edges(gy)])
    cov = np.cov(x, y) * n ** (-1.0 / 3.0)
    dx, dy = gx[1] - gx[0], gy[1] - gy[0]
    for i, d in ((0, dx), (1, dy)):
        cov[i, i] = max(cov[i, i] - d**2 / 12.0, 1e-6 * cov[i, i])
    half = [min(int(np.ceil(4.0 * np.sqrt(cov[i, i]) / d)), g.size)
            for i, d, g in ((0, dx, gx), (1, dy, gy))]
    ox, oy = np.meshgrid(np.arange(-half[0], half[0] + 1) * dx,
                         np.arange(-half[1], half[1] + 1) * dy, indexing="ij")
    inv = np.linalg.pinv(cov)
    q = inv[0, 0] * ox**2 + 2.0 * inv[0, 1] * ox * oy + inv[1, 1] * oy**2
    kernel = np.exp(-0.5 * q)
    kernel /= kernel.sum() * dx * dy  # exact mass on the grid, also for a kernel under a bin
    return np.clip(fftconvolve(counts, kernel, mode="same"), 0.0, None) / n
