"""Honest answers from draws: intervals, diagnostics, identifiability, modes, prior bounds."""

from __future__ import annotations

import math
import warnings
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from scipy import signal, stats

from ._draws import ESS_LIMIT as ESS_LIMIT
from ._likelihood import DISCREPANCY_PARAMETERS, NOISE_PARAMETERS
from ._draws import RHAT_LIMIT as RHAT_LIMIT

# noise levels and model discrepancies near their priors' lower bound mean "none needed": an
# answer, not a prior that cuts the posterior off
ZERO_IS_AN_ANSWER = NOISE_PARAMETERS + DISCREPANCY_PARAMETERS
ROLLING_LIMIT = 0.95  # share of (draw, bounce) pairs rolling above which mu is not identified
TAIL_PROBS = (0.05, 0.95)  # quantiles of the tail ESS (Vehtari et al. 2021)
# R-hat above which a result gets no interval (paper_form): the chains have not mixed, and an
# interval from them says more than they do (RHAT_LIMIT, 1.01, only warns: between the two the
# interval stands, with the warning)
UNCONVERGED = 1.1


@dataclass(frozen=True)
class ParameterSummary:
    """Posterior summary of one parameter (values in ``unit``)."""

    name: str
    unit: str
    prior: str
    mean: float
    sd: float
    median: float
    ci90: tuple[float, float]
    r_hat: float | None
    ess_bulk: float | None
    ess_tail: float | None
    identifiable: bool
    bound: dict | None  #: {"side": "lower"|"upper", "value", "level"} when not identified
    modes: tuple[float, ...]  #: locations of the modes of the marginal (several: multimodal)
    why_not_identified: str = ""
    misfit: str = ""  #: why the data do not support an interval (a model that misfits them)

    def paper_form(self) -> str:
        """``mu = 0.160 ± 0.021`` (centre and half-width of the 90 % interval), or a bound; no
        ``±`` where the model misfits the data, where the chains disagree (R-hat above
        ``UNCONVERGED``: the draws are not yet the posterior's) or where the posterior has
        several modes (one interval does not describe it): the posterior median and why."""
        unit = f" {self.unit}" if self.unit else ""
        if self.misfit:
            return (f"{self.name} ≈ {self.median:.3g}{unit} (no interval: {self.misfit})")
        if self.r_hat is not None and self.r_hat > UNCONVERGED:
            return (f"{self.name} ≈ {self.median:.3g}{unit} (no interval: the chains disagree, "
                    f"R-hat {self.r_hat:.2f}; run longer)")
        if len(self.modes) > 1:
            where = ", ".join(f"{m:.3g}" for m in self.modes)
            return (f"{self.name} ≈ {self.median:.3g}{unit} (no interval: {len(self.modes)} "
                    f"modes, at {where}{unit})")
        if self.bound is not None:
            op = ">" if self.bound["side"] == "lower" else "<"
            return (f"{self.name} {op} {_fmt(self.bound['value'], self.sd)}{unit} at "
                    f"{100 * self.bound['level']:.0f} %")
        lo, hi = self.ci90
        half = 0.5 * (hi - lo)
        digits = _decimals(half)
        return f"{self.name} = {0.5 * (lo + hi):.{digits}f} ± {half:.{digits}f}{unit}"

    def to_dict(self) -> dict:
        out = asdict(self)
        out["ci90"] = list(self.ci90)
        out["modes"] = list(self.modes)
        out["paper_form"] = self.paper_form()
        return out


def _decimals(half_width: float) -> int:
    """Decimals that show two significant digits of the half-width."""
    if not math.isfinite(half_width) or half_width <= 0:
        return 4
    return max(0, 1 - int(math.floor(math.log10(half_width))))


def _fmt(value: float, scale: float) -> str:
    return f"{value:.{_decimals(scale)}f}"


def diagnostics(samples: np.ndarray, names: tuple[str, ...]) -> dict[str, dict]:
    """Rank-normalised split R-hat and bulk/tail ESS (Vehtari et al. 2021) from arviz-stats,
    per parameter, for draws (chains, draws, d)."""
    import arviz_stats

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # e.g. a constant chain
        rhat = (arviz_stats.rhat(samples, chain_axis=0, draw_axis=1, method="rank")
                if samples.shape[0] > 1 else None)
        bulk = arviz_stats.ess(samples, chain_axis=0, draw_axis=1, method="bulk")
        tail = arviz_stats.ess(samples, chain_axis=0, draw_axis=1, method="tail",
                               prob=TAIL_PROBS)
    return {n: {"r_hat": None if rhat is None else _num(rhat[i]),
                "ess_bulk": _num(bulk[i]), "ess_tail": _num(tail[i])}
            for i, n in enumerate(names)}


def _num(x) -> float | None:
    v = float(np.asarray(x))
    return v if math.isfinite(v) else None


def marginal_modes(x: np.ndarray, low: float, high: float) -> tuple[float, ...]:
    """Modes of a marginal: peaks of a Gaussian KDE of the draws holding >= 10 % of the
    height of the highest peak and separated by a dip below 80 % of the lower peak."""
    x = x[np.isfinite(x)]
    if x.size < 20 or np.ptp(x) == 0:
        return (float(np.median(x)),) if x.size else ()
    sub = x[:: max(1, x.size // 4000)]
    grid = np.linspace(max(low, x.min()), min(high, x.max()), 512)
    density = stats.gaussian_kde(sub)(grid)
    peaks, props = signal.find_peaks(np.concatenate([[0], density, [0]]),
                                     prominence=0.0)
    peaks = peaks - 1
    keep = [p for p, prom in zip(peaks, props["prominences"], strict=True)
            if density[p] >= 0.1 * density.max() and prom >= 0.2 * density[p]]
    return tuple(float(grid[p]) for p in sorted(keep, key=lambda p: -density[p]))


def summarize_parameter(name, unit, prior, x, diag, rolling_share=None, *,
                        misfit: str = "") -> ParameterSummary:
    """Summary of one parameter's draws ``x`` (all chains flattened); ``misfit``: why an
    interval is not supported (the model misfits the data), or empty."""
    lo, hi = np.quantile(x, [0.05, 0.95])
    box = prior.box(1e-6)
    why = ""
    bound = None
    if name == "mu" and rolling_share is not None and rolling_share >= ROLLING_LIMIT:
        why = (f"{100 * rolling_share:.0f} % of the simulated bounces of the posterior leave "
               f"rolling, and a rolling rebound does not depend on mu: the data only bound mu "
               f"from below")
        bound = {"side": "lower", "value": float(np.quantile(x, 0.05)), "level": 0.95}
    elif name in ZERO_IS_AN_ANSWER and lo <= math.e * prior.support[0]:
        why = (f"the posterior reaches down to the prior's lower end ({prior.support[0]:.3g}"
               f"{' ' + unit if unit else ''}, far below the measurement noise): the data show "
               f"no {name.replace('_', ' ')}, only bound it from above")
        bound = {"side": "upper", "value": float(hi), "level": 0.95}
    elif np.std(x) > 0.8 * prior.sd and math.isfinite(prior.sd):
        why = (f"the posterior sd ({np.std(x):.3g}) is over 80 % of the prior sd "
               f"({prior.sd:.3g}): the data say little about {name}")
    return ParameterSummary(name=name, unit=unit, prior=prior.describe(), mean=float(np.mean(x)),
                            sd=float(np.std(x, ddof=1)), median=float(np.median(x)),
                            ci90=(float(lo), float(hi)), r_hat=diag["r_hat"],
                            ess_bulk=diag["ess_bulk"], ess_tail=diag["ess_tail"],
                            identifiable=not why, bound=bound,
                            modes=marginal_modes(x, *box), why_not_identified=why,
                            misfit=misfit)


def warnings_for(summaries: list[ParameterSummary], samples: np.ndarray, priors,
                 info: Any = None, *, impossible_data: bool = False) -> list[str]:
    """Plain-language warnings: the sampler's own (chains disagreeing, too few effective draws
    or autocorrelation times, a grid too coarse; ``info``: its typed run record), several
    modes, draws piled against a prior bound, parameters the data do not identify.
    ``impossible_data``: some bounces no parameter value can produce, so that widening a prior
    is not the remedy for draws piled against it."""
    # a noise level or discrepancy bounded from above wanders along its flat lower stretch,
    # where its chains mix slowly; that costs the bound little and the other parameters nothing
    judged = summaries if hasattr(info, "cells_per_sd") else [  # the grid has no chains
        s for s in summaries if not (s.name in ZERO_IS_AN_ANSWER and s.bound)]
    out = list(info.warnings(judged)) if info is not None else []
    flat = samples.reshape(-1, samples.shape[-1])
    for i, s in enumerate(summaries):
        if len(s.modes) > 1:
            where = ", ".join(f"{m:.4g}" for m in s.modes)
            out.append(f"{s.name}: the posterior has {len(s.modes)} modes (at {where}"
                       f"{' ' + s.unit if s.unit else ''}); a mean and a single interval "
                       f"do not describe it")
        out += _pile_warning(s, flat[:, i], priors[i], impossible_data)
        if not s.identifiable:
            out.append(f"{s.name} is not identified: {s.why_not_identified}")
    return out


def _is_spread(name: str) -> bool:
    """A population's spread (``<p>_sd``): zero is an answer (no bounce-to-bounce spread)."""
    return name.endswith("_sd")


def _pile_warning(s: ParameterSummary, x: np.ndarray, prior, impossible_data: bool) -> list[str]:
    low, high = prior.support
    remedy = ("widening the prior will not help: some bounces rebound faster than they "
              "arrived, which no parameter value can produce" if impossible_data
              else "widen the prior if values beyond are physical")
    out = []
    for side, edge in (("lower", low), ("upper", high)):
        if not math.isfinite(edge) or not all(map(math.isfinite, prior.support)):
            continue
        if side == "lower" and (s.name in ZERO_IS_AN_ANSWER or _is_spread(s.name)):
            continue
        near = np.mean(np.abs(x - edge) <= 0.01 * (high - low))
        if near > 0.05:
            out.append(f"{s.name}: {100 * near:.0f} % of the draws lie within 1 % of the prior's "
                       f"{side} bound ({edge:g}{' ' + s.unit if s.unit else ''}): the posterior "
                       f"piles against it; {remedy}")
    return out
