"""Kernel density estimates of the measured rebounds, rho_exp(v, theta) (docs/likelihoods.md, the `kde` likelihood).

The paper builds a Gaussian KDE of the rebound speed v_f (m/s) and of the rebound angle theta_f
(deg) with MATLAB's ``ksdensity`` (normal-reference bandwidth), checks that they are
uncorrelated (Pearson) and takes rho_exp(v, theta) = rho_1(v) rho_2(theta). This module does the
same, offers a joint 2-D KDE when the data reject zero correlation, and evaluates log densities
at millions of simulated rebounds with a compiled, stable log-sum-exp.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Literal, cast, get_args

import numpy as np
from numba import njit, prange
from scipy import stats

from ._validate import as_float_array, broadcast, check_array, check_choice, check_scalar

BandwidthRule = Literal["normal-reference", "scott", "silverman"]
RULES: tuple[str, ...] = get_args(BandwidthRule)
Kind = Literal["product", "joint"]
KINDS: tuple[str, ...] = get_args(Kind)
# MATLAB ksdensity (and mvksdensity): "the default bandwidth is optimal for normal densities":
# sig = mad(x, 1) / 0.6745 (median absolute deviation from the median, rescaled to a normal
# sigma; 0.6745 ~ norminv(0.75)), h = sig * (4 / ((d + 2) n))^(1 / (d + 4)), i.e. Silverman's
# factor (4/(3n))^(1/5) in 1-D. Checked against the MATLAB Answers thread "ksdensity default
# bandwidth value" (x = [1 3 2 5] gives bw = 1.1901, see tests) and the Python port that cites it.
MAD_TO_SD = 0.6745
SMALL_N = 20  # below this a KDE is rough; summarize() says so


def bandwidth(data: Any, rule: BandwidthRule | float = "normal-reference") -> float:
    """Bandwidth (in the data's unit) of a 1-D Gaussian KDE by a named rule, or a float as is.

    ``"normal-reference"`` (MATLAB ``ksdensity``): h = MAD/0.6745 (4/(3n))^{1/5};
    ``"scott"``: h = s n^{-1/5}; ``"silverman"``: h = s (4/(3n))^{1/5}, s = std(ddof=1)
    (scipy ``gaussian_kde``'s factors times s in 1-D).

    Raises:
        ValueError: fewer than 2 values, non-finite values, zero spread, unknown rule.
    """
    return _bandwidth_1d(_check_sample("data", data), rule, "rule")


def _bandwidth_1d(x: np.ndarray, rule: Any, arg: str) -> float:
    if not isinstance(rule, str):
        return check_scalar(arg, rule, low=0.0, low_open=True)
    check_choice(arg, rule, RULES)
    return _scale(x, rule, "data") * _factor(rule, x.size, dim=1)


def _factor(rule: str, n: int, dim: int) -> float:
    """Bandwidth / scale for ``n`` points in ``dim`` dimensions (scipy's and MATLAB's factors)."""
    if rule == "scott":
        return n ** (-1.0 / (dim + 4))
    return (4.0 / ((dim + 2) * n)) ** (1.0 / (dim + 4))


def _scale(x: np.ndarray, rule: str, name: str) -> float:
    """Spread of the data that the rule multiplies: robust (MAD) or the standard deviation."""
    if rule == "normal-reference":
        scale = float(np.median(np.abs(x - np.median(x)))) / MAD_TO_SD
        what = "median absolute deviation 0: at least half the values are equal"
    else:
        scale = float(np.std(x, ddof=1))
        what = "standard deviation 0: all values are equal"
    if not scale > 0.0:
        raise ValueError(f"`{name}` has zero spread ({what}), so rule {rule!r} gives no "
                         "bandwidth; pass a positive bandwidth or another rule")
    return scale


def _check_sample(name: str, value: Any, **limits: Any) -> np.ndarray:
    """A read-only 1-D float64 copy with >= 2 finite values (inside ``limits``, if given)."""
    arr = as_float_array(name, value, unit=limits.get("unit", ""))
    if arr.ndim != 1:
        raise ValueError(f"`{name}` must be a 1-D array of measurements; got shape {arr.shape}")
    if arr.size < 2:
        raise ValueError(f"`{name}` needs at least 2 values for a density; got {arr.size}")
    arr = check_array(name, arr, **limits).copy()
    arr.setflags(write=False)
    return arr


@njit(cache=True, inline="always")
def _r2(points, i, centres, j):
    s = 0.0
    for k in range(points.shape[1]):
        s += (points[i, k] - centres[j, k]) ** 2
    return s


@njit(cache=True, inline="always")
def _log_mixture_at(points, i, centres, log_norm):
    """Log sum_j exp(-|p_i - c_j|^2 / 2) + log_norm (whitened units), stably: the largest term
    (nearest centre) is factored out, so far tails stay finite. NaN -> NaN, +-inf -> -inf."""
    r2min = _r2(points, i, centres, 0)  # NaN or inf only for a NaN or infinite point
    if not np.isfinite(r2min):
        return np.nan if np.isnan(r2min) else -np.inf
    for j in range(1, centres.shape[0]):
        r2min = min(r2min, _r2(points, i, centres, j))
    total = 0.0
    for j in range(centres.shape[0]):
        total += math.exp(-0.5 * (_r2(points, i, centres, j) - r2min))
    return log_norm - 0.5 * r2min + math.log(total)


@njit(cache=True)
def _log_mixture_serial(points, centres, log_norm, out):
    for i in range(points.shape[0]):
        out[i] = _log_mixture_at(points, i, centres, log_norm)


@njit(cache=True, parallel=True)
def _log_mixture_parallel(points, centres, log_norm, out):
    for i in prange(points.shape[0]):
        out[i] = _log_mixture_at(points, i, centres, log_norm)


def _log_gauss_mixture(points: np.ndarray, centres: np.ndarray, log_norm: float) -> np.ndarray:
    """Per row of ``points`` (m, d): log of the Gaussian mixture at the whitened ``centres``."""
    out = np.empty(points.shape[0])
    # Threads only pay off for many points (a scalar call is ~100x slower through the pool).
    kernel = _log_mixture_parallel if points.shape[0] >= 4096 else _log_mixture_serial
    kernel(np.ascontiguousarray(points), np.ascontiguousarray(centres), log_norm, out)
    return out


@dataclass(frozen=True, eq=False)
class KDE1D:
    """Gaussian KDE of 1-D data: f(x) = 1/(n h) sum_j phi((x - x_j)/h).

    Arguments:
        data: the n >= 2 finite measurements (stored as a read-only float64 copy).
        bandwidth: kernel standard deviation h, in the data's unit, > 0.
        rule: how ``bandwidth`` was chosen (a rule name, or ``"user"``).
    """

    data: np.ndarray
    bandwidth: float
    rule: str = "user"

    def __post_init__(self) -> None:
        object.__setattr__(self, "data", _check_sample("data", self.data))
        h = check_scalar("bandwidth", self.bandwidth, low=0.0, low_open=True)
        object.__setattr__(self, "bandwidth", h)

    def logpdf(self, x: Any) -> np.ndarray:
        """Log f(x) for any-shaped ``x``; finite far in the tails, where f(x) underflows to 0."""
        x = as_float_array("x", x)
        h = self.bandwidth
        log_norm = -math.log(self.data.size * h * math.sqrt(2.0 * math.pi))
        out = _log_gauss_mixture((x / h).reshape(-1, 1), (self.data / h).reshape(-1, 1), log_norm)
        return out.reshape(x.shape)[()]

    def pdf(self, x: Any) -> np.ndarray:
        """f(x), any-shaped ``x``."""
        return np.exp(self.logpdf(x))


def kde1d(data: Any, bandwidth: BandwidthRule | float = "normal-reference") -> KDE1D:
    """Gaussian KDE of ``data`` with a rule's bandwidth (see :func:`bandwidth`) or a float."""
    x = _check_sample("data", data)
    h = _bandwidth_1d(x, bandwidth, "bandwidth")
    return KDE1D(x, h, bandwidth if isinstance(bandwidth, str) else "user")


@dataclass(frozen=True)
class Correlation:
    """Pearson correlation ``r`` of n pairs and the two-sided p-value of r = 0."""

    r: float
    p_value: float
    n: int

    def rejects_zero(self, alpha: float) -> bool:
        """True when the test rejects zero correlation at level ``alpha``."""
        return self.p_value < alpha

    def text(self) -> str:
        """``"Pearson r = 0.031, p = 0.82, n = 55"``."""
        return f"Pearson r = {self.r:.3f}, p = {self.p_value:.3g}, n = {self.n}"


def pearson(x: Any, y: Any) -> Correlation:
    """Pearson correlation of two equally long 1-D samples (``scipy.stats.pearsonr``)."""
    xa, ya = _check_pair(x, y, ("x", "y"), ({}, {}))
    return _pearson(xa, ya, names=("x", "y"))


def _pearson(x: np.ndarray, y: np.ndarray, names: tuple[str, str]) -> Correlation:
    for name, arr in zip(names, (x, y), strict=True):
        if np.ptp(arr) == 0.0:
            raise ValueError(f"`{name}` is constant ({float(arr[0])!r}), so its correlation "
                             "is undefined")
    res = stats.pearsonr(x, y)
    return Correlation(float(res.statistic), float(res.pvalue), int(x.size))


def _check_pair(x: Any, y: Any, names: tuple[str, str], limits: tuple[dict, dict]):
    a, b = (_check_sample(n, v, **lim) for n, v, lim in zip(names, (x, y), limits, strict=True))
    if a.size != b.size:
        raise ValueError(f"`{names[0]}` and `{names[1]}` must have the same length (one pair "
                         f"per bounce); got {a.size} and {b.size}")
    return a, b


SPEED_LIMITS = {"unit": "m/s", "low": 0.0}
ANGLE_LIMITS = {"unit": "deg", "low": -90.0, "high": 90.0}


@dataclass(frozen=True, eq=False)
class ReboundDensity:
    """rho_exp(v, theta) of rebound speed (m/s) and angle (deg).

    ``kind="product"``: rho_1(v) rho_2(theta), the paper's. ``kind="joint"``: one 2-D Gaussian
    KDE with bandwidth matrix H = D R D, D = diag(speed.bandwidth, angle.bandwidth), R the 2x2
    matrix with ``kernel_correlation`` off the diagonal. Either way ``speed`` and ``angle`` are
    the exact marginal densities (for ``"joint"`` their ``rule`` was applied with the d = 2
    factor, see :func:`rebound_density`). ``reason`` says why this kind was used.
    """

    kind: Kind
    speed: KDE1D
    angle: KDE1D
    kernel_correlation: float
    correlation: Correlation
    reason: str

    def __post_init__(self) -> None:
        check_choice("kind", self.kind, KINDS)
        if self.speed.data.size != self.angle.data.size:
            raise ValueError("`speed` and `angle` KDEs must hold the same bounces; got "
                             f"{self.speed.data.size} and {self.angle.data.size} values")
        check_scalar("kernel_correlation", self.kernel_correlation, low=-1.0, high=1.0,
                     low_open=True, high_open=True)

    @property
    def bandwidth_matrix(self) -> np.ndarray:
        """H in (m/s, deg) units (for ``"product"``: the diagonal of the two factors' h^2)."""
        h = np.array([self.speed.bandwidth, self.angle.bandwidth])
        r = self.kernel_correlation if self.kind == "joint" else 0.0
        return np.outer(h, h) * np.array([[1.0, r], [r, 1.0]])

    def logpdf(self, speed: Any, angle: Any) -> np.ndarray:
        """Log rho_exp(speed, angle), broadcasting the two arrays (m/s, deg)."""
        v, t = as_float_array("speed", speed), as_float_array("angle", angle)
        if self.kind == "product":  # each marginal at its own points, then broadcast
            broadcast(speed=v, angle=t)
            return self.speed.logpdf(v) + self.angle.logpdf(t)
        v, t = broadcast(speed=v, angle=t).values()
        chol = np.linalg.cholesky(self.bandwidth_matrix)
        log_norm = -math.log(self.speed.data.size * 2.0 * math.pi) - np.log(np.diag(chol)).sum()
        whiten = np.linalg.inv(chol).T
        centres = np.column_stack([self.speed.data, self.angle.data]) @ whiten
        points = np.column_stack([v.ravel(), t.ravel()]) @ whiten
        return _log_gauss_mixture(points, centres, log_norm).reshape(v.shape)[()]

    def pdf(self, speed: Any, angle: Any) -> np.ndarray:
        """rho_exp(speed, angle), broadcasting the two arrays (m/s, deg)."""
        return np.exp(self.logpdf(speed, angle))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready record of the density: kind, why, bandwidths, correlation."""
        return {"kind": self.kind, "reason": self.reason, "bandwidth_rule": self.speed.rule,
                "bandwidth_speed_m_s": self.speed.bandwidth,
                "bandwidth_angle_deg": self.angle.bandwidth,
                "kernel_correlation": self.kernel_correlation, **_corr_dict(self.correlation)}


def rebound_density(speed: Any, angle: Any, *, kind: Literal["auto", "product", "joint"] = "auto",
                    bandwidth: BandwidthRule | tuple[float, float] = "normal-reference",
                    alpha: float = 0.05) -> ReboundDensity:
    """rho_exp of measured rebounds: speed (m/s, >= 0) and angle (deg, in [-90, 90]).

    ``kind="auto"`` uses the product of marginal KDEs (the paper's) unless Pearson's test rejects
    zero correlation at level ``alpha``, then the joint KDE. ``bandwidth`` is a rule name or a
    pair (speed m/s, angle deg). A rule's bandwidths are the 1-D rule per axis for the product;
    for the joint KDE the rule is applied in d = 2 the way ``scipy.stats.gaussian_kde`` does:
    H = f^2 S with f = n^{-1/6} (Scott's, Silverman's and MATLAB's d = 2 factor coincide) and S
    the data covariance, with the marginal spreads from the rule's scale (MAD/0.6745 for
    ``"normal-reference"``, so that ``"scott"``/``"silverman"`` reproduce scipy exactly).
    """
    v, t = _check_pair(speed, angle, ("speed", "angle"), (SPEED_LIMITS, ANGLE_LIMITS))
    requested = check_choice("kind", kind, ("auto", *KINDS))
    alpha = check_scalar("alpha", alpha, low=0.0, high=1.0, low_open=True, high_open=True)
    bw = _check_bandwidth(bandwidth)
    corr = _pearson(v, t, ("speed", "angle"))
    chosen, reason = _decide(requested, corr, alpha)
    if chosen == "joint" and not abs(corr.r) < 1.0 - 1e-10:  # R singular to ~1e-10
        raise ValueError(f"`speed` and `angle` lie on a line ({corr.text()}), so a joint KDE "
                         "is degenerate; pass kind='product' or measure more bounces")
    h, rule = _axis_bandwidths(v, t, bw, dim=1 if chosen == "product" else 2)
    r = corr.r if chosen == "joint" else 0.0
    return ReboundDensity(cast(Kind, chosen), KDE1D(v, h[0], rule), KDE1D(t, h[1], rule), r, corr,
                          reason)


def _decide(kind: str, corr: Correlation, alpha: float) -> tuple[str, str]:
    if kind != "auto":
        return kind, f"kind={kind!r} requested ({corr.text()})"
    if corr.rejects_zero(alpha):
        return "joint", (f"auto: {corr.text()} rejects zero correlation at alpha = {alpha:g}; "
                         "using a joint 2-D KDE of (speed, angle)")
    return "product", (f"auto: {corr.text()} does not reject zero correlation at alpha = "
                       f"{alpha:g}; using the product of the marginal KDEs (as in the paper)")


def _check_bandwidth(bw: Any) -> str | tuple[float, float]:
    """A rule name, or a pair of positive floats (speed m/s, angle deg)."""
    if isinstance(bw, str):
        return check_choice("bandwidth", bw, RULES)
    if np.shape(bw) != (2,):
        raise ValueError(f"`bandwidth` must be one of {', '.join(map(repr, RULES))} or a pair "
                         f"(speed m/s, angle deg); got {bw!r}")
    low, high = (check_scalar("bandwidth", b, low=0.0, low_open=True) for b in bw)
    return (low, high)


def _axis_bandwidths(v: np.ndarray, t: np.ndarray, bw: str | tuple[float, float], dim: int):
    """Per-axis bandwidths (m/s, deg) and the rule's name (``"user"`` for an explicit pair)."""
    if not isinstance(bw, str):
        return bw, "user"
    f = _factor(bw, v.size, dim)
    return (_scale(v, bw, "speed") * f, _scale(t, bw, "angle") * f), bw


def _corr_dict(corr: Correlation) -> dict[str, Any]:
    return {"pearson_r": corr.r, "pearson_p_value": corr.p_value, "n_bounces": corr.n}


@dataclass(frozen=True, eq=False)
class VariableSummary:
    """n, mean, sd (ddof=1), min, max, KDE and histogram bin edges of one measured variable."""

    n: int
    mean: float
    sd: float
    min: float
    max: float
    kde: KDE1D
    bin_edges: np.ndarray = field(repr=False)

    def to_dict(self) -> dict[str, Any]:
        """The summary as plain JSON-ready numbers."""
        return {"n": self.n, "mean": self.mean, "sd": self.sd, "min": self.min, "max": self.max,
                "kde_bandwidth": self.kde.bandwidth, "bandwidth_rule": self.kde.rule,
                "histogram_bin_edges": self.bin_edges.tolist()}


def _summarize_one(x: np.ndarray, h: float, rule: str) -> VariableSummary:
    edges = np.histogram_bin_edges(x, bins="auto")  # max(Sturges, Freedman-Diaconis) bins
    edges.setflags(write=False)
    return VariableSummary(int(x.size), float(x.mean()), float(x.std(ddof=1)), float(x.min()),
                           float(x.max()), KDE1D(x, h, rule), edges)


@dataclass(frozen=True, eq=False)
class DataSummary:
    """What the measured rebounds look like, and whether rho_1(v) rho_2(theta) is supported."""

    speed: VariableSummary
    angle: VariableSummary
    correlation: Correlation
    alpha: float
    density_kind: Kind  # what rebound_density(kind="auto") picks
    warnings: tuple[str, ...]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready plain Python values; units are in the key names."""
        return {"rebound_speed_m_s": self.speed.to_dict(),
                "rebound_angle_deg": self.angle.to_dict(),
                "correlation": {**_corr_dict(self.correlation), "alpha": self.alpha},
                "density_kind": self.density_kind, "warnings": list(self.warnings)}


def summarize(speed: Any, angle: Any, *, bandwidth: BandwidthRule | tuple[float, float]
              = "normal-reference", alpha: float = 0.05) -> DataSummary:
    """Summary of measured rebound speeds (m/s) and angles (deg), with plain-language warnings."""
    v, t = _check_pair(speed, angle, ("speed", "angle"), (SPEED_LIMITS, ANGLE_LIMITS))
    alpha = check_scalar("alpha", alpha, low=0.0, high=1.0, low_open=True, high_open=True)
    (hv, ht), rule = _axis_bandwidths(v, t, _check_bandwidth(bandwidth), dim=1)
    corr = _pearson(v, t, ("speed", "angle"))
    kind = "joint" if corr.rejects_zero(alpha) else "product"
    warnings = _warnings(corr, alpha, hv, ht)
    return DataSummary(_summarize_one(v, hv, rule), _summarize_one(t, ht, rule), corr, alpha,
                       cast(Kind, kind), warnings)


def _warnings(corr: Correlation, alpha: float, hv: float, ht: float) -> tuple[str, ...]:
    out = []
    if corr.rejects_zero(alpha):
        out.append(f"Rebound speed and angle are correlated ({corr.text()}; zero correlation is "
                   f"rejected at alpha = {alpha:g}), so the paper's product of marginal "
                   "densities rho_1(v) rho_2(theta) is not supported by these data. bouncebayes "
                   "will use a joint 2-D KDE (kind='auto'); pass kind='product' to force the "
                   "paper's assumption.")
    if corr.n < SMALL_N:
        out.append(f"Only {corr.n} bounces: a kernel density estimate from fewer than {SMALL_N} "
                   f"points is rough and depends strongly on the bandwidth ({hv:.3g} m/s, "
                   f"{ht:.3g} deg). Record more bounces, or check how the results change with "
                   "`bandwidth`.")
    return tuple(out)
