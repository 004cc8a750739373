"""Each model's rebound against the incidence angle: the posterior bands of the comparison's
figure, from a seeded subset of every model's draws."""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np

N_BAND_DRAWS = 200  #: posterior draws behind each band
N_ANGLES = 60  #: incidence angles of each band


def band_angles(trials) -> np.ndarray:
    """Incidence angles (deg) spanning the trials' and a little beyond, inside (0, 90)."""
    a = np.asarray(trials.incidence_angle, dtype=float)
    pad = max(1.0, 0.05 * float(np.ptp(a)))
    return np.linspace(max(0.5, a.min() - pad), min(89.5, a.max() + pad), N_ANGLES)


def prediction_bands(results: dict, *, seed: int = 0) -> dict[str, Any]:
    """Per model, at the trials' median incident speed and spin and over :func:`band_angles`:
    the 5 %, 50 % and 95 % posterior quantiles of the rebound speed, angle and tangential
    restitution u'/u; ``speed_varies`` says when the trials' speeds spread by more than 2 %
    (the bands then hold at the median speed only)."""
    from ..model import SimulationWarning
    from ..propagation import draw_subset

    trials = next(iter(results.values())).trials
    angles = band_angles(trials)
    speeds = np.asarray(trials.incidence_speed, dtype=float)
    v, spin = float(np.median(speeds)), float(np.median(trials.incidence_spin))
    out: dict[str, Any] = {"angles": angles, "speed": v, "spin": spin,
                           "speed_varies": bool(np.ptp(speeds) > 0.02 * v), "models": {}}
    for k, (name, r) in enumerate(results.items()):
        theta = draw_subset(r, N_BAND_DRAWS, np.random.default_rng([seed, 4, k]))
        values = {n: np.repeat(x, angles.size) for n, x in theta.items()
                  if n in r.experiment.model_parameters and n != "spin"}
        n = next(iter(values.values())).size // angles.size
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", SimulationWarning)  # failures flagged as NaN
            b = r.experiment.bounce_model(speed=v, angle=np.tile(angles, n), spin=spin,
                                          values=values, errors="flag").bounces()
        ok = np.asarray(b.ok)
        speed = np.where(ok, b.rebound_speed, np.nan).reshape(n, -1)
        angle = np.where(ok, b.rebound_angle, np.nan).reshape(n, -1)
        e_t = speed * np.sin(np.radians(angle)) / (v * np.sin(np.radians(angles)))
        out["models"][name] = {key: _quantiles(x) for key, x in (
            ("rebound_speed", speed), ("rebound_angle", angle),
            ("tangential_restitution", e_t))}
    return out


def _quantiles(x: np.ndarray) -> np.ndarray:
    """5 %, 50 %, 95 % over the draws at each angle (NaN where no draw was solved)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # an all-NaN angle stays NaN
        return np.nanquantile(x, [0.05, 0.5, 0.95], axis=0)
