"""What a fit of one bounce gives: :class:`Kinematics`, or a :class:`TrajectoryError` that says
why not."""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from .._errors import InputFileError
from ._gravity import Fall

FailureReason = Literal["no bounce", "several bounces", "too few points", "no crossing",
                        "bad fit", "misfit", "implausible errors", "energy gain",
                        "impact outside the gap", "no spin"]
# The columns kinematics writes (bouncebayes.data.write_trials' layout), before the optional
# incidence_spin(_se) and scale_rel_sd.
TRIAL_TABLE_COLUMNS = ("trial", "rebound_speed", "rebound_angle", "incidence_speed",
                       "incidence_angle", "rebound_speed_se", "rebound_angle_se",
                       "incidence_speed_se", "incidence_angle_se")


class TrajectoryError(InputFileError):
    """A trajectory (or one bounce of it: ``path`` is then ``<file>#<k>``) that was read but
    cannot give kinematics.

    ``reason`` is a short code (:data:`FailureReason`); the message says what was found and
    what to do.
    """

    def __init__(self, path: str | os.PathLike, message: str, *, reason: FailureReason,
                 line: int | None = None, field: str | None = None):
        super().__init__(path, f"{reason}: {message}", line=line, field=field)
        self.reason = reason
        self.detail = message


@dataclass(frozen=True)
class Kinematics:
    """Incidence and rebound of one bounce, with standard errors (m/s, deg, s, m, m/s^2).

    Angles are from the plane normal; the rebound angle is positive when the ball keeps moving
    forward. ``acceleration_before``/``after``: the fitted constant accelerations (x, y[, z]) of
    the free flight, in the trajectory's frame (with drag: the constant part ``a``).
    ``lateral_angle`` (3-D only): the angle between the rebound velocity and the plane of
    incidence, positive towards ``t x n`` (``t``: incident direction in the plane, ``n``: normal).
    ``flipped_x``: the reported x axis points opposite to the file's (after any rotation).
    ``drag_coefficient``: fitted ``k`` (1/m) before and after with ``drag="quadratic"`` (NaN for
    a flight that fell back to constant acceleration; ``notes`` says why).

    ``label``: the trial's name, ``<file>`` or ``<file>#<k>`` for bounce ``k`` (1-based) of a
    file with ``n_bounces > 1``. ``notes``: one-line messages about the file and the fit (rows
    merged or left out, drag fallbacks). ``gates``: the statistics the quality gates tested.
    ``incidence_spin`` (rad/s, with its standard error), ``scale_rel_sd``: from a ``spin.csv``
    beside the trajectories and the tracker's sidecar, where given.
    ``impact_acceleration_before``/``after``: the flights' accelerations at the impact (drag
    included) along the incident direction in the plane and along the normal, in the frame of
    the reported angles. ``fall``: the flights' fall against gravity, which measures the
    length scale (:class:`~bouncebayes.kinematics._gravity.Fall`); ``calibration_source``: what
    set the trajectory's scale, as its tracker's sidecar says (None: not said).
    """

    incidence_speed: float
    incidence_speed_se: float
    incidence_angle: float
    incidence_angle_se: float
    rebound_speed: float
    rebound_speed_se: float
    rebound_angle: float
    rebound_angle_se: float
    impact_time: float
    impact_time_se: float
    n_before: int
    n_after: int
    residual_rms: float
    acceleration_before: tuple[float, ...]
    acceleration_after: tuple[float, ...]
    sample_rate_hz: float
    source: str
    lateral_angle: float | None = None
    lateral_angle_se: float | None = None
    flipped_x: bool = False
    drag: str | None = None
    drag_coefficient: tuple[float, float] | None = None
    instants: str = "crossing"  #: "crossing" of the fitted flights, or "contact" (referred)
    label: str = ""
    bounce: int = 1
    n_bounces: int = 1
    notes: tuple[str, ...] = ()
    gates: Mapping[str, float] = field(default_factory=dict)
    incidence_spin: float | None = None
    incidence_spin_se: float | None = None
    scale_rel_sd: float | None = None
    impact_acceleration_before: tuple[float, float] | None = None
    impact_acceleration_after: tuple[float, float] | None = None
    fall: Fall | None = None
    calibration_source: str | None = None


def observables(v_in: np.ndarray, v_out: np.ndarray) -> list[float]:
    """[incidence speed, angle, rebound speed, angle(, lateral angle)] from impact velocities."""
    if v_in.size == 2:
        return [math.hypot(*v_in), math.degrees(math.atan2(v_in[0], abs(v_in[1]))),
                math.hypot(*v_out), math.degrees(math.atan2(v_out[0], abs(v_out[1])))]
    h = math.hypot(v_in[0], v_in[2])
    ex, ez = (v_in[0] / h, v_in[2] / h) if h > 0 else (1.0, 0.0)
    u = v_out[0] * ex + v_out[2] * ez  # along the incident direction
    w = -v_out[0] * ez + v_out[2] * ex  # towards t x n
    return [math.hypot(h, v_in[1]), math.degrees(math.atan2(h, abs(v_in[1]))),
            math.hypot(u, v_out[1]), math.degrees(math.atan2(u, abs(v_out[1]))),
            math.degrees(math.atan2(w, math.hypot(u, v_out[1])))]
