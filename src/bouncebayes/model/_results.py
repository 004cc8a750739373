"""What the forward model returns: per-bounce statuses, full results and rebound-only results."""

from __future__ import annotations

from dataclasses import dataclass, fields
from enum import IntEnum
from typing import NamedTuple

import numpy as np

from . import _kernel as K
from ._outputs import (O_ANGLE, O_DMAX, O_DSEP, O_FN, O_FT, O_SPEED, O_SPIN, O_STEPS, O_TC,
                       O_TPK, O_U, O_VN)


class Status(IntEnum):
    """Outcome of one bounce; ``Status(code).message`` says what happened and what to do."""

    OK = K.ST_OK
    INVALID_INPUT = K.ST_INVALID
    NO_SEPARATION = K.ST_NO_SEPARATION
    MAX_STEPS = K.ST_MAX_STEPS
    STEP_UNDERFLOW = K.ST_STEP_UNDERFLOW
    NON_FINITE = K.ST_NONFINITE
    TIMEOUT = K.ST_TIMEOUT

    @property
    def message(self) -> str:
        """What happened to a bounce with this status, and what to do."""
        return _STATUS_MESSAGES[self]


_STATUS_MESSAGES = {
    Status.OK: "solved",
    Status.INVALID_INPUT: "input outside the physical domain (e.g. negative eta or speed, see "
                          "bouncebayes.model.PARAMETER_DOMAINS); the element was not simulated",
    Status.NO_SEPARATION: "the ball did not leave the surface within "
                          "SolverConfig.max_contact_time_factor Hertz contact times: damping "
                          "this strong stops it on the surface; raise the factor if a long "
                          "contact is expected",
    Status.MAX_STEPS: "the solver made SolverConfig.max_steps step attempts (accepted or "
                      "rejected) without finishing; raise max_steps or loosen rtol/atol",
    Status.STEP_UNDERFLOW: "the step size fell below 1e-12 of the contact time scale "
                           "(the equations are too stiff at these parameters)",
    Status.NON_FINITE: "a quantity of the solver overflowed or was not a number (inputs far "
                       "outside any real ball's range reached the solver); check the units of "
                       "the ball and of the incidence",
    Status.TIMEOUT: "not attempted: the batch used up SolverConfig.time_limit seconds in the "
                    "solver before reaching this bounce; raise time_limit (or None) or split "
                    "the batch",
}


class SimulationWarning(UserWarning):
    """Some bounces of a batch could not be solved; their results are NaN with a status."""


def failure_summary(status: np.ndarray) -> str:
    """Counts of failed bounces by reason, with what to do; empty when all succeeded."""
    codes, counts = np.unique(status[status != Status.OK], return_counts=True)
    return "; ".join(f"{n} x {Status(c).name}: {Status(c).message}"
                     for c, n in zip(codes, counts, strict=True))


@dataclass(frozen=True)
class Bounces:
    """Per-bounce results of :func:`simulate`, arrays of the broadcast input shape.

    Velocities are in the plane-aligned frame at the moment of separation; the rebound angle is
    measured from the plane normal in degrees (positive: the ball keeps moving forward); spin is
    counter-clockwise positive. Failed elements hold NaN and a non-zero ``status``; bounces
    beyond the validity of Hertz's contact have ``hertz_valid`` False.
    """

    rebound_speed: np.ndarray  #: m/s
    rebound_angle: np.ndarray  #: deg from the normal
    rebound_spin: np.ndarray  #: rad/s
    rebound_tangential_velocity: np.ndarray  #: m/s
    rebound_normal_velocity: np.ndarray  #: m/s, outward
    contact_time: np.ndarray  #: s
    peak_normal_force: np.ndarray  #: N
    peak_friction_force: np.ndarray  #: N (magnitude)
    max_overlap: np.ndarray  #: m
    separation_overlap: np.ndarray  #: m, overlap when the normal force vanished
    time_of_peak_normal_force: np.ndarray  #: s after first contact
    rolling: np.ndarray  #: bool, the contact point was not slipping at separation
    #: bool, solved and inside the validity of Hertz's small-strain contact: the maximum overlap
    #: stays within ``HERTZ_OVERLAP_LIMIT`` (0.1) of the radius. Where False the numbers are
    #: the model's, but a real ball deforms beyond what the model describes.
    hertz_valid: np.ndarray
    closed_form: np.ndarray  #: bool, solved by the tabulated closed form (not the ODE)
    status: np.ndarray  #: int8 codes of :class:`Status`
    n_steps: np.ndarray  #: accepted solver steps

    @property
    def shape(self) -> tuple[int, ...]:
        """Shape of the batch."""
        return self.status.shape

    @property
    def ok(self) -> np.ndarray:
        """Boolean mask of solved bounces."""
        return self.status == Status.OK

    @property
    def n_failed(self) -> int:
        """Number of bounces that could not be solved."""
        return int(np.count_nonzero(~self.ok))

    @property
    def regime(self) -> np.ndarray:
        """``"roll"``, ``"slip"`` or ``"failed"`` per bounce."""
        return np.where(~self.ok, "failed", np.where(self.rolling, "roll", "slip"))

    def failure_summary(self) -> str:
        """Counts of failed bounces by reason, with what to do; empty when all succeeded."""
        return failure_summary(self.status)

    def item(self, index=()) -> dict[str, float | str | bool]:
        """The results of one bounce as plain Python values (for JSON and tables)."""
        row = {f.name: getattr(self, f.name)[index] for f in fields(self)}
        flags = ("rolling", "hertz_valid", "closed_form")
        out: dict[str, float | str | bool] = {k: float(v) for k, v in row.items()
                                              if k not in flags + ("status", "n_steps")}
        out["regime"] = str(self.regime[index])
        out["status"] = Status(int(row["status"])).name
        out["n_steps"] = int(row["n_steps"])
        for k in flags[1:]:
            out[k] = bool(row[k])
        return out

    @classmethod
    def from_block(cls, out: np.ndarray, status: np.ndarray, rolling: np.ndarray,
                   flags: np.ndarray, shape: tuple[int, ...]) -> Bounces:
        """Views of the kernels' output block (``_outputs`` layout), shaped ``shape``."""
        def shaped(x):
            return x.reshape(shape)

        return cls(
            rebound_speed=shaped(out[O_SPEED]), rebound_angle=shaped(out[O_ANGLE]),
            rebound_spin=shaped(out[O_SPIN]), rebound_tangential_velocity=shaped(out[O_U]),
            rebound_normal_velocity=shaped(out[O_VN]), contact_time=shaped(out[O_TC]),
            peak_normal_force=shaped(out[O_FN]), peak_friction_force=shaped(out[O_FT]),
            max_overlap=shaped(out[O_DMAX]), separation_overlap=shaped(out[O_DSEP]),
            time_of_peak_normal_force=shaped(out[O_TPK]), rolling=shaped(rolling),
            hertz_valid=shaped(flags[0]), closed_form=shaped(flags[1]), status=shaped(status),
            n_steps=shaped(out[O_STEPS].astype(np.int64)))


class Rebounds(NamedTuple):
    """Rebound-only results of :class:`BounceModel` calls, arrays of shape
    (parameter rows, *condition shape); what likelihoods need."""

    speed: np.ndarray  #: m/s
    angle: np.ndarray  #: deg from the normal
    spin: np.ndarray  #: rad/s, counter-clockwise positive
    contact_time: np.ndarray  #: s
    rolling: np.ndarray  #: bool: the contact point was not slipping at separation
    ok: np.ndarray  #: bool: solved (False: see ``status``)
    status: np.ndarray  #: int8 codes of :class:`Status`
