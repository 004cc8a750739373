"""Synthetic campaigns: bounces from known parameters, as a trial table and as trajectories."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import stats

from .._version import __version__
from .._io import write_json
from ..model import simulate, simulate_history
from ._experiment import Experiment
from ._trajectory import write_trajectory
from ._trials import Trials, make_trials, write_trials


MAX_MEASURED_ANGLE = 89.99  #: deg: the trial table's incidence angle is below 90


class SynthesisError(ValueError):
    """The experiment's true values do not give a campaign (e.g. bounces that never separate)."""


@dataclass(frozen=True)
class Campaign:
    """A synthetic campaign: measured trials, noisy trajectories, and the truth behind them."""

    trials: Trials
    trajectories: tuple[np.ndarray, ...]  #: per bounce, columns t (s), x (m), y (m)
    truth: dict
    seed: int


def _truncated_normal(rng, mean, sd, low, high, n):
    if sd == 0.0:
        return np.full(n, float(mean))
    a, b = (low - mean) / sd, (high - mean) / sd
    return stats.truncnorm.rvs(a, b, loc=mean, scale=sd, size=n, random_state=rng)


def synthesize(experiment: Experiment, *, seed: int, n: int | None = None) -> Campaign:
    """Draw a campaign of ``n`` bounces (default ``[synth] n``) with the generator of ``seed``.

    Each bounce gets its own incidence (nominal +- the ``*_sd`` spreads) and its own ``mu`` and
    ``eta`` (the ``[contact]`` values +- ``[synth] mu_sd``, ``eta_sd``, truncated at 0); the
    other parameters of the contact law (``restitution``, ``normal_stiffness``,
    ``tangential_stiffness_ratio``, the modulus) are the experiment's values for every bounce.
    The measured table adds Gaussian noise of the ``[synth]`` sizes and records them as standard
    errors; trajectories are sampled at ``camera_rate_hz`` with ``position_noise_m``.
    """
    s = experiment.synth
    n = int(s["n"] if n is None else n)
    if n < 1:
        raise ValueError(f"`n` must be a positive integer; got {n!r}")
    rng = np.random.default_rng(seed)
    inc = experiment.incidence
    population = {name: experiment.true_value(name) for name in experiment.model_parameters
                  if name not in ("youngs_modulus", "spin")}
    per = {
        "mu": _truncated_normal(rng, population["mu"], s["mu_sd"], 0, np.inf, n),
        **({"eta": _truncated_normal(rng, population["eta"], s["eta_sd"], 0, np.inf, n)}
           if "eta" in population else {}),
        "incidence_speed": _truncated_normal(rng, inc.speed, inc.speed_sd, 0, np.inf, n),
        "incidence_angle": _truncated_normal(rng, inc.angle, inc.angle_sd, 0, 89.9, n),
        "incidence_spin": _truncated_normal(rng, inc.spin, inc.spin_sd, -np.inf, np.inf, n),
    }
    params = experiment.model_values({k: v for k, v in per.items() if k in population}
                                     | {"spin": per["incidence_spin"]})
    out = simulate(experiment.ball, speed=per["incidence_speed"], angle=per["incidence_angle"],
                   errors="flag", **params, **experiment.model_options)
    if out.n_failed:
        raise SynthesisError(f"{experiment.source}: {out.n_failed} of {n} synthetic bounces "
                             f"could not be simulated ({out.failure_summary()}); check "
                             f"[contact] and [incidence]")
    noise = {"rebound_speed": s["rebound_speed_noise_m_s"],
             "rebound_angle": s["rebound_angle_noise_deg"],
             "incidence_speed": s["incidence_speed_noise_m_s"],
             "incidence_angle": s["incidence_angle_noise_deg"]}
    true_obs = {"rebound_speed": out.rebound_speed, "rebound_angle": out.rebound_angle,
                "incidence_speed": per["incidence_speed"],
                "incidence_angle": per["incidence_angle"]}
    measured = {k: true_obs[k] + rng.normal(0.0, sd, n) for k, sd in noise.items()}
    # speeds and the incidence angle from the normal are magnitudes: noise near zero folds
    # back, as a measurement of them does (an incident angle is measured in [0, 90) deg)
    for k in ("rebound_speed", "incidence_speed", "incidence_angle"):
        measured[k] = np.abs(measured[k])
    measured["incidence_angle"] = np.minimum(measured["incidence_angle"], MAX_MEASURED_ANGLE)
    trials = make_trials(experiment, **measured,
                         se={k: np.full(n, sd) for k, sd in noise.items() if sd > 0},
                         labels=[f"bounce_{i + 1:03d}" for i in range(n)], source="synthetic")
    trajectories = tuple(_trajectory(experiment, rng, {k: v[i] for k, v in per.items()})
                         for i in range(n))
    return Campaign(trials, trajectories, _truth(experiment, seed, population, per, noise, out),
                    seed)


def _truth(experiment: Experiment, seed: int, population: dict, per: dict, noise: dict,
           out) -> dict:
    """What a synthetic campaign was made from (``truth.json``)."""
    s, n = experiment.synth, len(out.rebound_speed)
    return {
        "seed": seed, "n": n, "experiment": experiment.source,
        "experiment_sha256": experiment.text_sha256, "bouncebayes_version": __version__,
        "population": population,
        "spread": {"mu_sd": s["mu_sd"], "eta_sd": s["eta_sd"]},
        "measurement_noise": noise | {"position_noise_m": s["position_noise_m"],
                                      "camera_rate_hz": s["camera_rate_hz"]},
        "per_bounce": {k: v.tolist() for k, v in per.items()} | {
            "rebound_speed": out.rebound_speed.tolist(),
            "rebound_angle": out.rebound_angle.tolist(),
            "rebound_spin": out.rebound_spin.tolist(),
            "contact_time": out.contact_time.tolist(), "regime": out.regime.tolist()},
        "share_rolling": float(np.mean(out.rolling)),
    }


def _trajectory(experiment: Experiment, rng, bounce: dict) -> np.ndarray:
    """Centre positions sampled at the camera rate, with noise; plane frame, t from 0."""
    s = experiment.synth
    params = experiment.model_values({k: float(v) for k, v in bounce.items()
                                      if k in ("mu", "eta")}
                                     | {"spin": float(bounce["incidence_spin"])})
    h = simulate_history(experiment.ball, speed=bounce["incidence_speed"],
                         angle=bounce["incidence_angle"], n_contact=200, n_flight=2,
                         flight_time=s["flight_time_s"], **params, **experiment.model_options)
    dt = 1.0 / s["camera_rate_hz"]
    t0 = -s["flight_time_s"] + rng.uniform(0.0, dt)
    t = np.arange(t0, h.time[-1], dt)
    x, y = _position(h, t, experiment)
    sd = s["position_noise_m"]
    return np.column_stack([t - t[0], x + rng.normal(0, sd, t.size),
                            y + rng.normal(0, sd, t.size)])


def _position(h, t, experiment: Experiment):
    """Exact positions: ballistic before and after contact, the contact history in between."""
    g = experiment.gravity
    gx = g * np.sin(np.radians(experiment.inclination))
    gy = g * np.cos(np.radians(experiment.inclination))
    c = np.flatnonzero(h.in_contact)
    first, last = c[0], c[-1]
    tc = h.time[last]
    x = np.interp(t, h.time[c], h.x[c])
    y = np.interp(t, h.time[c], h.y[c])
    for mask, i, t_ref in ((t < 0.0, first, 0.0), (t > tc, last, tc)):
        dt = t[mask] - t_ref
        x[mask] = h.x[i] + h.tangential_velocity[i] * dt + 0.5 * gx * dt**2
        y[mask] = h.y[i] + h.normal_velocity[i] * dt - 0.5 * gy * dt**2
    return x, y


def write_campaign(campaign: Campaign, out: str | os.PathLike, *, trajectories: bool = True,
                   provenance: dict | None = None) -> dict[str, Path]:
    """Write ``trials.csv``, ``truth.json`` and ``trajectories/bounce_NNN.csv`` under ``out``.

    The table and every trajectory carry ``provenance`` as a comment line (default: the record
    of :func:`bouncebayes._provenance.provenance` with the experiment file and the seed; the
    truth itself is in ``truth.json``).
    """
    from .._provenance import provenance as make_provenance

    out = Path(out)
    truth = campaign.truth
    if provenance is None:
        provenance = make_provenance(inputs={"experiment": truth["experiment"]},
                                     seed=campaign.seed, config={"stage": "synth"})
    paths = {"trials": write_trials(out / "trials.csv", campaign.trials, provenance=provenance),
             "truth": write_json(out / "truth.json", truth)}
    if trajectories:
        folder = out / "trajectories"
        for label, traj in zip(campaign.trials.labels, campaign.trajectories, strict=True):
            write_trajectory(folder / f"{label}.csv", *traj.T, provenance=provenance)
        paths["trajectories"] = folder
    return paths
