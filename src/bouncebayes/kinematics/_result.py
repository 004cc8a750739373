"""What a fit of one bounce gives: :class:`Kinematics`, or a :class:`TrajectoryError` that says
why not; and the fitted free-flight segment that both flight models share."""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from .._errors import InputFileError

FailureReason = Literal["no bounce", "several bounces", "too few points", "no crossing",
                        "bad fit"]
TRIAL_TABLE_COLUMNS = ("file", "incidence_speed", "incidence_speed_se", "incidence_angle",
                       "incidence_angle_se", "rebound_speed", "rebound_speed_se",
                       "rebound_angle", "rebound_angle_se")


class TrajectoryError(InputFileError):
    """A trajectory file that was read but cannot give kinematics.

    ``reason`` is a short code (:data:`FailureReason`: ``"no bounce"``, ``"several bounces"``,
    ``"too few points"``, ``"no crossing"``, ``"bad fit"``); the message says what was found
    and what to do.
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
    the free flight, in the trajectory's frame (with ``drag``: the constant part ``a``).
    ``lateral_angle`` (3-D only): the angle between the rebound velocity and the plane of
    incidence, positive towards ``t x n`` (``t``: incident direction in the plane, ``n``: normal).
    ``flipped_x``: the reported x axis points opposite to the file's (after any rotation).
    ``drag_coefficient``: fitted ``k`` (1/m) before and after, with ``drag="quadratic"``.
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

    def to_row(self) -> dict[str, str | float]:
        """The trial-table row: ``file`` (name) plus the eight columns ``load_trials`` reads."""
        return {name: Path(self.source).name if name == "file" else float(getattr(self, name))
                for name in TRIAL_TABLE_COLUMNS}


@dataclass(frozen=True)
class _Segment:
    """A fitted free-flight segment; ``params`` (flat) and ``cov`` for the delta method."""

    index: np.ndarray  # samples used
    params: np.ndarray
    cov: np.ndarray
    rss: float
    n_resid: int
    acceleration: tuple[float, ...]
    drag_k: float | None = None


def _observables(v_in: np.ndarray, v_out: np.ndarray) -> list[float]:
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
