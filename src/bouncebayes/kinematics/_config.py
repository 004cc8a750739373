"""The settings of the kinematics fit and the thresholds of its quality gates, in one frozen,
self-checking object."""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Literal, get_args

import numpy as np

from .._validate import check_choice, check_scalar
from ._flight import Aero

Drag = Literal["none", "quadratic"]  # "none" (or None): constant acceleration
DRAG_MODELS: tuple[str, ...] = get_args(Drag)


@dataclass(frozen=True, kw_only=True)
class FitConfig:
    """How each free flight is fitted, and the gates every fitted bounce must pass.

    Fit:
        min_points: free-flight samples needed on each side of an impact (>= 4).
        contact_guard: samples left out next to each impact on each side (they may be in
            contact: use ``ceil(contact time x frame rate / 2)``).
        drag: ``"none"`` (constant acceleration) or ``"quadratic"``: the aerodynamic force of a
            spinning ball, quadratic in the speed, ``r'' = a - k |v| v + |v| (c x v)`` (drag
            ``k``, Magnus lift ``c``), with the lift left out, then the drag, where a flight
            cannot determine them.
        lift: with ``drag = "quadratic"``, also fit the lift (default True; False: drag only).
        drag_k: the ball's expected drag coefficient ``k`` (1/m), where known from its size
            and mass. With ``drag = "quadratic"``, ``k`` then has a normal prior of this mean
            and a 50 % SD, and each lift component one of mean 0 and SD ``drag_k`` (the lift
            coefficient of a spinning sphere is of the order of its drag coefficient); None:
            ``k`` is only bounded, and the lift's SD is ``drag_k_max / 2``. With
            ``drag = "none"`` it checks that ignoring the drag moves no observable by more
            than ``max_drag_bias`` standard errors.
        window: fit only the samples within this time of the impact (s; None: the whole
            flight up to the neighbouring impact or the end of the record). Default 0.3 s:
            over longer flights the speed, and with it the drag and lift coefficients and the
            spin ratio, change enough that a model with constant coefficients biases the
            velocities at the impact by several standard errors (measured on table-tennis
            balls spinning at up to 1500 rad/s, tests/test_kinematics.py).

        drag_k_max: upper end of the physical range of the drag coefficient ``k`` (1/m), and
            of each component of the lift ``c = rho C_L A / (2 m)`` (the lift coefficient
            ``C_L`` of a spinning sphere stays below the drag coefficient's bound, 1);
            ``k = rho C_d A / (2 m)`` is 0.14 /m for a 40 mm, 2.7 g ball, 0.01 /m for a tennis
            ball. The default, 1 /m, is seven times a table-tennis ball's.
        position_noise: the standard deviation of the tracked positions (m) where known; then
            the standard errors use it and the residuals are tested against it. None (default):
            estimated from each flight's residuals.

    Gates (a bounce that fails one is reported with the reason and not used):
        p_min: residual tests fail below this p-value: the two flights' residual levels must
            agree (F test, equal noise), or with ``position_noise`` each flight's chi-square
            must be consistent with it; and no flight's residuals may hold a cubic trend its
            model lacks (a score test of one more term ``tau^3`` per coordinate): a smooth
            change of the acceleration along the flight, which is what biases the velocities
            at the impact.
        max_noise_ratio: the F test also needs the residual SDs of the two flights to differ
            by more than this factor (honest differences, such as more motion blur in the
            faster flight, stay below it).
            It also rejects a flight whose residuals hold a cubic trend its model lacks (a
            score test of one more term ``tau^3`` per coordinate): a smooth change of the
            acceleration along the flight, which is what biases the velocities at the impact.
        max_misfit: a flight whose residual variance exceeds this many times the variance of
            its successive residual differences (over two) has residuals with a smooth pattern
            the model lacks (von Neumann's ratio; white noise gives 1). Above 1 also needs
            ``p < p_min``; correlated tracking noise raises it too, hence the margin.
        max_speed_rel_se: largest standard error of a speed, relative to the speed.
        max_angle_se_deg: largest standard error of an angle, deg.
        energy_gain_sd: the rebound may exceed the incidence speed (and what the spin allowance
            adds) by at most this many standard errors.
        max_drag_bias: see ``drag_k``.
        gap_sd: the fitted impact must lie between the last sample before and the first after,
            within this many of its standard errors.
    """

    min_points: int = 5
    contact_guard: int = 1
    drag: Drag = "none"
    lift: bool = True
    drag_k: float | None = None
    window: float | None = 0.3
    drag_k_max: float = 1.0
    position_noise: float | None = None
    p_min: float = 1e-4
    max_noise_ratio: float = 2.0
    max_misfit: float = 2.5
    max_speed_rel_se: float = 0.25
    max_angle_se_deg: float = 10.0
    energy_gain_sd: float = 3.0
    gap_sd: float = 3.0
    max_drag_bias: float = 1.0

    def __post_init__(self) -> None:
        _check_int("min_points", self.min_points, 4, "a quadratic fit needs >= 4 points for a "
                                                      "residual variance")
        _check_int("contact_guard", self.contact_guard, 0, "samples left out on each side of "
                                                           "the impact")
        object.__setattr__(self, "drag", "none" if self.drag is None else
                           check_choice("drag", self.drag, DRAG_MODELS))
        if not isinstance(self.lift, bool):
            raise TypeError(f"`lift` must be True or False; got {self.lift!r}")
        if self.window is not None:
            check_scalar("window", self.window, unit="s", low=0.0, low_open=True)
        check_scalar("drag_k_max", self.drag_k_max, unit="1/m", low=0.0, low_open=True)
        if self.drag_k is not None:
            check_scalar("drag_k", self.drag_k, unit="1/m", low=0.0, high=self.drag_k_max,
                         low_open=True, high_open=True)
        if self.position_noise is not None:
            check_scalar("position_noise", self.position_noise, unit="m", low=0.0,
                         low_open=True)
        check_scalar("p_min", self.p_min, low=0.0, high=0.5, low_open=True)
        check_scalar("max_noise_ratio", self.max_noise_ratio, low=1.0)
        for name in ("max_misfit", "energy_gain_sd", "max_drag_bias", "gap_sd", "max_speed_rel_se",
                     "max_angle_se_deg"):
            check_scalar(name, getattr(self, name), low=0.0, low_open=True)

    @classmethod
    def from_options(cls, config: FitConfig | None = None, **options) -> FitConfig:
        """``config`` (default: the defaults) with ``options`` replacing its fields.

        Raises:
            TypeError: an option that is not a field.
        """
        if config is not None and not options:
            return config
        names = {f.name for f in fields(cls)}
        unknown = sorted(set(options) - names)
        if unknown:
            raise TypeError(f"unknown kinematics option(s) {', '.join(map(repr, unknown))}; "
                            f"allowed: {', '.join(sorted(names))}")
        base = config or cls()
        return cls(**({f.name: getattr(base, f.name) for f in fields(cls)} | options))

    def aero(self) -> Aero:
        """The bounds and priors of the aerodynamic fit."""
        k = self.drag_k
        return Aero(self.drag_k_max, k, None if k is None else 0.5 * k,
                    None if k is None else k, self.lift)

    @property
    def fit_drag(self) -> bool:
        """True with ``drag = "quadratic"``."""
        return self.drag == "quadratic"


def _check_int(name: str, value, low: int, why: str) -> None:
    message = f"`{name}` must be an integer >= {low} ({why}); got {value!r}"
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise TypeError(message)
    if value < low:
        raise ValueError(message)

