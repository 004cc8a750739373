"""Checks of an inference problem that no sampler can fix: priors too wide to explore, and
bounces that no parameter value can produce."""

from __future__ import annotations

import numpy as np

from ..data import Experiment, Trials


ENERGY_SLACK = 0.01  #: relative: gravity's work during the contact, rounding in the table


def faster_than_arrived(experiment: Experiment, trials: Trials) -> np.ndarray:
    """Bounces whose rebound speed exceeds what the incident kinetic energy allows (beyond 3
    standard errors and 1 %): a passive contact cannot add energy, so
    ``v_out <= sqrt(v_in^2 + kappa r^2 omega_in^2)`` for every parameter value."""
    ball = experiment.ball
    spin = np.abs(trials.incidence_spin)
    if "spin" in experiment.priors:  # the incident spin is inferred: its largest prior value
        spin = np.full(trials.n, max(map(abs, experiment.priors["spin"].box(1e-6))))
    v_max = np.sqrt(trials.incidence_speed**2
                    + ball.inertia_factor * ball.radius**2 * spin**2)
    se_in = (np.nan_to_num(trials.se["incidence_speed"]) if "incidence_speed" in trials.measured
             else np.full(trials.n, experiment.incidence.speed_sd))
    se_out = np.nan_to_num(trials.se["rebound_speed"])
    tolerance = 3.0 * np.hypot(se_in, se_out) + ENERGY_SLACK * v_max
    return np.asarray(trials.rebound_speed > v_max + tolerance)


def data_warnings(experiment: Experiment, trials: Trials) -> list[str]:
    """Warnings about bounces no parameter value can produce; an error when all are such."""
    bad = np.flatnonzero(faster_than_arrived(experiment, trials))
    if bad.size == 0:
        return []
    k = bad[0]
    example = (f"{trials.labels[k]}: {trials.rebound_speed[k]:.4g} m/s after "
               f"{trials.incidence_speed[k]:.4g} m/s")
    why = ("a passive contact cannot add energy, so no parameter value can produce them; "
           "check the kinematics (which flight is the incidence, units, frame rate) or the "
           "incident spin")
    if bad.size == trials.n:
        raise ValueError(f"{trials.source}: every bounce rebounds faster than it arrived "
                         f"(trial {example}): {why}")
    shown = ", ".join(trials.labels[i] for i in bad[:10]) + (", ..." if bad.size > 10 else "")
    return [f"{bad.size} of {trials.n} bounces rebound faster than they arrived, beyond their "
            f"measurement error (trials {shown}; trial {example}): {why}"]
