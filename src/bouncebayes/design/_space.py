"""The candidate designs: incidence angles and speeds, numbers of bounces, camera settings."""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Literal

ErrorSource = Literal["trajectories", "table"]
DEFAULT_ANGLES = tuple(float(a) for a in range(20, 85, 5))  #: deg from the normal
DEFAULT_BOUNCES = (10, 25, 55)
MAX_GRID_PARAMETERS = 3


def _positive(name: str, values, integer: bool = False, high: float = math.inf) -> tuple:
    values = tuple(values)
    if not values:
        raise ValueError(f"`{name}` must hold at least one value; got none")
    for v in values:
        bad = (isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v)
               or not 0 < v < high or (integer and int(v) != v))
        if bad:
            kind = "integers >= 1" if integer else f"numbers in (0, {high:g})"
            raise ValueError(f"`{name}` must be {kind}; got {v!r}")
    if len(set(values)) != len(values):
        raise ValueError(f"`{name}` lists a value twice; got {list(values)}")
    return tuple(int(v) if integer else float(v) for v in values)


@dataclass(frozen=True, kw_only=True)
class DesignSpace:
    """The candidate designs (every combination) and how each is evaluated.

    Arguments:
        angles_deg: nominal incidence angles from the normal, deg, in (0, 90).
        speeds_m_s: nominal incidence speeds, m/s.
        n_bounces: numbers of bounces filmed.
        frame_rates_hz: camera frame rates, frames/s.
        position_noise_m: standard deviation of the tracked centre positions, m.
        campaigns: simulated campaigns per design (truths drawn from the prior).
        errors: ``"trajectories"``: the trial table's standard errors from the kinematics
            fit of simulated trajectories at each frame rate and position noise;
            ``"table"``: the experiment's ``[synth]`` measurement noise as given (the camera
            settings are then not varied).
        grid_points: grid points per parameter of each campaign's posterior.
    """

    angles_deg: tuple[float, ...] = DEFAULT_ANGLES
    speeds_m_s: tuple[float, ...]
    n_bounces: tuple[int, ...] = DEFAULT_BOUNCES
    frame_rates_hz: tuple[float, ...]
    position_noise_m: tuple[float, ...]
    campaigns: int = 16
    errors: ErrorSource = "trajectories"
    grid_points: int = 64

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "angles_deg", _positive("angles_deg", self.angles_deg, high=90.0))
        set_(self, "speeds_m_s", _positive("speeds_m_s", self.speeds_m_s, high=500.0))
        set_(self, "n_bounces", tuple(sorted(_positive("n_bounces", self.n_bounces, True))))
        set_(self, "frame_rates_hz", _positive("frame_rates_hz", self.frame_rates_hz))
        set_(self, "position_noise_m", _positive("position_noise_m", self.position_noise_m))
        if self.errors not in ("trajectories", "table"):
            raise ValueError(f"`errors` must be 'trajectories' or 'table'; got {self.errors!r}")
        if self.errors == "table" and (len(self.frame_rates_hz) > 1
                                       or len(self.position_noise_m) > 1):
            raise ValueError("`errors` 'table' uses the experiment's standard errors: give one "
                             "frame rate and one position noise (they are not used)")
        for name, low in (("campaigns", 2), ("grid_points", 16)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < low:
                raise ValueError(f"`{name}` must be an integer >= {low}; got {v!r}")

    @classmethod
    def for_experiment(cls, experiment, **given) -> DesignSpace:
        """Defaults from ``experiment``: its nominal speed, camera rate and position noise;
        angles 20-80 deg every 5; 10, 25 and 55 bounces (``None`` values take defaults)."""
        s = experiment.synth
        defaults = {"speeds_m_s": (experiment.incidence.speed,),
                    "frame_rates_hz": (s["camera_rate_hz"],),
                    "position_noise_m": (s["position_noise_m"],)}
        return cls(**(defaults | {k: v for k, v in given.items() if v is not None}))

    def settings(self) -> list[tuple[float, float, float, float]]:
        """(angle, speed, frame rate, position noise) of every simulated setting; the numbers
        of bounces are nested in each (the first n bounces of one campaign)."""
        return list(itertools.product(self.angles_deg, self.speeds_m_s, self.frame_rates_hz,
                                      self.position_noise_m))

    def to_dict(self) -> dict:
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in vars(self).items()}


def cost(n_bounces: int, frame_rate_hz: float) -> float:
    """What a design costs: bounces filmed times frame rate over 1000 frames/s (the frames to
    record and track, in bounces at 1000 frames/s)."""
    return n_bounces * frame_rate_hz / 1000.0
