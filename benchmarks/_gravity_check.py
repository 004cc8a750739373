"""The flights' fall against the rendered truth, for the tracking benchmarks: a campaign's
scale from gravity (``bouncebayes.kinematics.gravity_scale``) against the mean of its clips'
true scale errors (the renderer falls at 9.81 m/s^2 without air)."""

from __future__ import annotations

import math

import numpy as np

from bouncebayes.kinematics import gravity_scale

RENDERED_G = 9.81  # tests/render_pbr.py


def fall_check(falls, scale_errors_pct) -> dict:
    """The fall's scale error and its SD (%), the clips' mean true scale error (%), and the z of
    their difference (the fall's SD alone: the truth's mean is exact)."""
    g = gravity_scale(list(falls), RENDERED_G)
    if g is None:
        return {"n_clips": len(scale_errors_pct), "scale_error_pct": None}
    truth = float(np.mean(scale_errors_pct))
    fall = 100 * (g.scale - 1.0)
    return {"n_clips": len(scale_errors_pct), "n_flights": g.n_flights,
            "scale_error_pct": round(fall, 3), "sd_pct": round(100 * g.scale_sd, 3),
            "true_mean_scale_error_pct": round(truth, 3),
            "z": round((fall - truth) / (100 * g.scale_sd), 2),
            "scatter_p": round(g.scatter_p, 4) if math.isfinite(g.scatter_p) else None}
