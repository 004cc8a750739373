"""Standard errors of the trial table from the camera: frame rate and position noise.

The kinematics stage fits the free flights of a tracked trajectory and gives standard errors by
the delta method (``bouncebayes.kinematics``). A design's errors are those very numbers: a few
bounces of the design are simulated at its frame rate with its position noise, fitted by the
kinematics stage, and the median of each standard error over them is taken.
"""

from __future__ import annotations

import copy

import numpy as np

COLUMNS = ("rebound_speed", "rebound_angle", "incidence_speed", "incidence_angle")
SYNTH_NOISE = {"rebound_speed": "rebound_speed_noise_m_s",
               "rebound_angle": "rebound_angle_noise_deg",
               "incidence_speed": "incidence_speed_noise_m_s",
               "incidence_angle": "incidence_angle_noise_deg"}


def design_document(doc: dict, *, angle_deg: float, speed_m_s: float, frame_rate_hz: float,
                    position_noise_m: float, errors: dict[str, float] | None = None) -> dict:
    """The experiment document (parsed TOML) with the design's nominal incidence, camera and,
    if given, the trial-table standard errors as the synthetic measurement noise."""
    out = copy.deepcopy(doc)
    out.setdefault("incidence", {}).update(angle_deg=float(angle_deg), speed_m_s=float(speed_m_s))
    synth = out.setdefault("synth", {})
    synth.update(camera_rate_hz=float(frame_rate_hz), position_noise_m=float(position_noise_m))
    if errors is not None:
        synth.update({SYNTH_NOISE[k]: float(v) for k, v in errors.items()})
    return out


def kinematics_errors(experiment, *, seed: int, n: int = 5) -> dict[str, float]:
    """Median delta-method standard errors of the four measured columns over ``n`` simulated
    trajectories of ``experiment`` (its incidence, ``[synth] camera_rate_hz``,
    ``position_noise_m``, ``flight_time_s``) fitted by ``bouncebayes.kinematics``."""
    from ..data import synthesize
    from ..kinematics import TrajectoryError, fit_kinematics, trajectory_from_arrays

    campaign = synthesize(experiment, seed=seed, n=n)
    rows, reasons = [], []
    for i, traj in enumerate(campaign.trajectories):
        try:
            k = fit_kinematics(trajectory_from_arrays(*traj.T, source=f"design#{i + 1}"))
        except TrajectoryError as exc:
            reasons.append(exc.reason)
            continue
        rows.append([getattr(k, f"{c}_se") for c in COLUMNS])
    if len(rows) < max(1, n // 2):
        s = experiment.synth
        raise ValueError(f"the kinematics could not fit simulated bounces at "
                         f"{experiment.incidence.angle:g} deg, {experiment.incidence.speed:g} "
                         f"m/s, {s['camera_rate_hz']:g} frames/s and {s['position_noise_m']:g} m "
                         f"position noise ({', '.join(sorted(set(reasons)))}); drop this design "
                         f"or raise the frame rate")
    return dict(zip(COLUMNS, (float(v) for v in np.median(np.array(rows), axis=0)),
                    strict=True))


def table_errors(experiment) -> dict[str, float]:
    """The standard errors given as the experiment's ``[synth]`` measurement noise."""
    return {k: float(experiment.synth[v]) for k, v in SYNTH_NOISE.items()}
