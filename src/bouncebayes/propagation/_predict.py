"""Predicting new bounces with the calibrated model (``bouncebayes predict``).

For every row of a table of incidences (speed, angle, spin), a seeded subset of posterior draws
is simulated at that incidence, drawn within its uncertainty (the row's standard errors where
it has them, the experiment's bounce-to-bounce spread where the nominal value stands in), as
the measurement model of the inference takes it. Rebound speed and angle get what a measurement
of them would carry: the row's own standard errors where the table gives them, the noise levels or the model
discrepancy the run inferred (Student-t where the run used it), and the row's calibration
uncertainty (``scale_rel_sd``) as one scale error shared by the rows of a draw. Rebound spin and
contact time are the model's, with the parameters' uncertainty only. The output is the
posterior predictive mean and the 5 %, 50 % and 95 % quantiles of each, per row, and where the
row has a measured rebound, the predictive distribution's value at it (``*_pit``: its
probability integral transform, uniform for a calibrated model).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .._io import write_text
from .._provenance import comment_line
from ..data import Trials
from ..inference import STUDENT_T_DOF, InferenceResult, incidence_variance
from ._propagate import N_DRAWS, draw_subset

PREDICTED = {"rebound_speed": "m/s", "rebound_angle": "deg", "rebound_spin": "rad/s",
             "contact_time": "s"}  #: predicted quantity -> unit
QUANTILES = (0.05, 0.5, 0.95)
BOUNCES_PER_BLOCK = 200_000  #: simulated at once (rows x draws)
MAX_ANGLE = 89.9  #: deg; an incidence drawn beyond grazing is held there


@dataclass(frozen=True)
class Predictions:
    """The predictive summary per row: ``columns`` (name -> array over rows, in output order),
    ``includes`` (what the rebound speed and angle predictions carry, in words)."""

    labels: tuple[str, ...]
    columns: dict[str, np.ndarray]
    n_draws: int
    seed: int
    includes: str
    n_failed: int

    def csv_text(self, provenance: Mapping[str, Any] | None = None) -> str:
        """The CSV file: a provenance comment, the header, one line per row."""
        names = list(self.columns)
        lines = [] if provenance is None else [comment_line(provenance)]
        lines.append(",".join(["trial", *names]))
        for i, label in enumerate(self.labels):
            cells = [_cell(self.columns[n][i]) for n in names]
            lines.append(",".join([f'"{label}"' if "," in label else label, *cells]))
        return "\n".join(lines) + "\n"


def _cell(x: float) -> str:
    return "" if not math.isfinite(float(x)) else repr(float(x))


def predict_bounces(result: InferenceResult, trials: Trials, *, n_draws: int = N_DRAWS,
                    seed: int | None = None, progress: bool = False) -> Predictions:
    """The posterior predictive distribution of the rebound of every row of ``trials`` (see
    the module docstring); ``seed`` (default: the run's) picks the draws and the noise;
    ``progress``: a progress bar over the rows."""
    from tqdm.auto import tqdm

    seed = result.seed if seed is None else int(seed)
    if isinstance(n_draws, bool) or not isinstance(n_draws, int) or n_draws < 20:
        raise ValueError(f"`draws` must be an integer >= 20; got {n_draws!r}")
    rng_pick, rng_noise = np.random.default_rng([seed, 2]).spawn(2)
    theta = draw_subset(result, n_draws, rng_pick)
    k = next(iter(theta.values())).size
    columns: dict[str, list[np.ndarray]] = {}
    block = max(1, BOUNCES_PER_BLOCK // k)
    failed = 0
    for s in tqdm(range(0, trials.n, block), desc="predict", disable=not progress, leave=False,
                  unit="block", mininterval=0.2):
        rows = np.arange(s, min(trials.n, s + block))
        sims, bad = _simulate_rows(result, trials, theta, rows, rng_noise)
        failed += bad
        for name, values in _summaries(sims, trials, rows).items():
            columns.setdefault(name, []).append(values)
    out = {name: np.concatenate(v) for name, v in columns.items()}
    return Predictions(tuple(trials.labels), _incidence(trials) | out, k, seed,
                       _includes(result, trials), failed)


def _incidence(trials: Trials) -> dict[str, np.ndarray]:
    return {c: np.asarray(trials.column(c), dtype=float)
            for c in ("incidence_speed", "incidence_angle", "incidence_spin")}


def _simulate_rows(result: InferenceResult, trials: Trials, theta: dict, rows: np.ndarray,
                   rng: np.random.Generator) -> tuple[dict[str, np.ndarray], int]:
    """Draws x rows of every predicted quantity (NaN where the bounce failed)."""
    e = result.experiment
    k, r = next(iter(theta.values())).size, rows.size
    speed, angle, spin = _incidences(result, trials, theta, rows, rng)
    values = {n: np.repeat(v, r) for n, v in theta.items() if n in e.model_parameters
              and n != "spin"}
    b = e.bounce_model(values=values, errors="flag", speed=np.ravel(speed),
                       angle=np.ravel(angle), spin=np.ravel(spin)).bounces()
    sims = {n: np.where(b.ok, getattr(b, n), np.nan).reshape(k, r) for n in PREDICTED}
    sims["rolling"] = np.where(b.ok, b.rolling, False).reshape(k, r)
    speed, angle = _measurement_noise(result, trials, theta, rows, rng)
    sims["rebound_speed"] = sims["rebound_speed"] * speed[1] + speed[0]
    sims["rebound_angle"] = sims["rebound_angle"] + angle
    return sims, int(np.count_nonzero(~b.ok))


def _incidences(result: InferenceResult, trials: Trials, theta: dict, rows: np.ndarray,
                rng: np.random.Generator) -> tuple[np.ndarray, ...]:
    """Draws x rows of the true incidence (speed, angle, spin): the row's values plus their
    uncertainty, as the likelihood has it (standard errors where measured, the experiment's
    bounce-to-bounce spread where the nominal value stands in); the inferred spin where the
    row has none."""
    k, r = next(iter(theta.values())).size, rows.size
    sd = np.sqrt(incidence_variance(result.experiment, trials)[rows])
    base = [np.asarray(trials.column(c), dtype=float)[rows]
            for c in ("incidence_speed", "incidence_angle", "incidence_spin")]
    if "spin" in result.names and "incidence_spin" not in trials.measured:
        base[2], sd[:, 2] = theta["spin"][:, None], 0.0
    z = rng.standard_normal((3, k, r))
    speed, angle, spin = (np.broadcast_to(b, (k, r)) + sd[None, :, j] * z[j]
                          for j, b in enumerate(base))
    return np.abs(speed), np.minimum(np.abs(angle), MAX_ANGLE), spin


def _measurement_noise(result: InferenceResult, trials: Trials, theta: dict, rows: np.ndarray,
                       rng: np.random.Generator):
    """((additive speed noise, scale factor), additive angle noise), draws x rows."""
    k, r = next(iter(theta.values())).size, rows.size
    sd = []
    for column, extra in (("rebound_speed", ("sigma_speed", "discrepancy_speed")),
                          ("rebound_angle", ("sigma_angle", "discrepancy_angle"))):
        own = np.nan_to_num(np.asarray(trials.se[column], dtype=float)[rows])
        inferred = next((theta[n] for n in extra if n in theta), np.zeros(k))
        sd.append(np.sqrt(own[None, :] ** 2 + inferred[:, None] ** 2))
    z = rng.standard_normal((2, k, r))
    if result.discrepancy == "student-t":
        z /= np.sqrt(rng.chisquare(STUDENT_T_DOF, size=(k, r)) / STUDENT_T_DOF)
    scale_sd = np.nan_to_num(np.asarray(trials.scale_rel_sd, dtype=float)[rows])
    scale = 1.0 + rng.standard_normal((k, 1)) * scale_sd[None, :]
    return (sd[0] * z[0], scale), sd[1] * z[1]


def _summaries(sims: dict[str, np.ndarray], trials: Trials,
               rows: np.ndarray) -> dict[str, np.ndarray]:
    """Mean and quantiles of each quantity per row, the share of rolling bounces, and the
    predictive CDF at a measured rebound."""
    out: dict[str, np.ndarray] = {}
    for name in PREDICTED:
        x = sims[name]
        n_ok = np.isfinite(x).sum(axis=0)
        with np.errstate(invalid="ignore"), _quiet():
            out[f"{name}_mean"] = np.where(n_ok > 0, np.nanmean(x, axis=0), np.nan)
            for q in QUANTILES:
                out[f"{name}_q{round(100 * q):02d}"] = np.nanquantile(x, q, axis=0)
    for name in ("rebound_speed", "rebound_angle"):
        observed = np.asarray(trials.column(name), dtype=float)[rows]
        if np.isfinite(observed).any():
            x = sims[name]
            with np.errstate(invalid="ignore"):
                pit = np.sum(x <= observed[None, :], axis=0) / np.isfinite(x).sum(axis=0)
            out[f"{name}_observed"] = observed
            out[f"{name}_pit"] = np.where(np.isfinite(observed), pit, np.nan)
    out["share_rolling"] = sims["rolling"].mean(axis=0)
    return out


class _quiet:
    """All-NaN rows (every bounce failed) give NaN without NumPy's RuntimeWarning."""

    def __enter__(self):
        import warnings

        self._w = warnings.catch_warnings()
        self._w.__enter__()
        warnings.simplefilter("ignore", RuntimeWarning)

    def __exit__(self, *exc):
        self._w.__exit__(*exc)


def _includes(result: InferenceResult, trials: Trials) -> str:
    parts = ["the posterior uncertainty of the parameters"]
    if any(not np.isnan(trials.se[c]).all() for c in ("rebound_speed", "rebound_angle")):
        parts.append("each row's stated standard errors")
    if "sigma_speed" in result.names:
        parts.append("the inferred measurement noise levels")
    if result.discrepancy != "none":
        parts.append(f"the inferred model discrepancy ({result.discrepancy})")
    if not np.isnan(trials.scale_rel_sd).all():
        parts.append("the rows' calibration uncertainty (scale_rel_sd), shared")
    return ", ".join(parts)


def write_predictions(pred: Predictions, path: str | Path,
                      provenance: Mapping[str, Any] | None = None) -> Path:
    """Write the predictions CSV atomically (``provenance`` as its first comment line)."""
    return write_text(path, pred.csv_text(provenance))
