"""Time histories of one bounce (for plots and propagation): contact solved, flight in closed form."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._errors import Rebuilt
from .._validate import check_scalar
from . import _kernel as K
from ._arrays import explain_invalid
from ._config import PAPER_BALL, STANDARD_GRAVITY, Ball, SolverConfig
from ._engine import BounceModel, ode_bounce
from ._ode import sample, solve_with_segments
from ._results import Bounces


class BounceFailed(Rebuilt, RuntimeError):
    """A single bounce asked for in detail could not be solved; ``status`` says why."""

    def __init__(self, status, message: str):
        super().__init__(message)
        self.status = status


@dataclass(frozen=True)
class BounceHistory:
    """Time series through one bounce; ``time`` is 0 at first contact, in s.

    Positions are of the centre in the plane-aligned frame: ``x`` along the plane from the point
    of first contact, ``y`` the height of the centre above the plane (``y = r - overlap``).
    """

    time: np.ndarray  #: s
    x: np.ndarray  #: m
    y: np.ndarray  #: m
    tangential_velocity: np.ndarray  #: m/s
    normal_velocity: np.ndarray  #: m/s
    spin: np.ndarray  #: rad/s
    normal_force: np.ndarray  #: N
    friction_force: np.ndarray  #: N, signed along +x
    in_contact: np.ndarray  #: bool
    rolling: np.ndarray  #: bool (contact point not slipping; False in flight)
    bounce: Bounces  #: the summary results of the same bounce
    mass: float  #: kg
    moment_of_inertia: float  #: kg m^2
    radius: float  #: m

    @property
    def overlap(self) -> np.ndarray:
        """Penetration ``r - y`` in m (negative in flight)."""
        return self.radius - self.y


def _ballistic(t, x0, y0, u0, v0, gx, gy):
    """Closed-form free flight under gravity (gx, -gy) from the state at t = 0."""
    return (x0 + u0 * t + 0.5 * gx * t**2, y0 + v0 * t - 0.5 * gy * t**2, u0 + gx * t,
            v0 - gy * t)


def simulate_history(ball: Ball = PAPER_BALL, *, mu: float, eta: float | None = None,
                     speed: float, angle: float, spin: float = 0.0, inclination: float = 0.0,
                     youngs_modulus: float | None = None, normal_law: str = "kelvin-voigt",
                     tangential: str = "none", restitution: float | None = None,
                     normal_stiffness: float | None = None,
                     tangential_stiffness_ratio: float | None = None,
                     gravity: float = STANDARD_GRAVITY, solver: SolverConfig | None = None,
                     n_contact: int = 400, n_flight: int = 100,
                     flight_time: float | None = None) -> BounceHistory:
    """Time histories through one bounce: ``n_flight`` samples of free flight before first
    contact, ``n_contact`` samples over the contact, ``n_flight`` after separation.

    Arguments are those of :func:`simulate` (scalars only), plus ``flight_time``: the span of
    each free-flight part in s (default: one contact time).

    Raises:
        BounceFailed: if the bounce cannot be solved (its ``status`` says why).
    """
    solver = SolverConfig() if solver is None else solver
    for name, n, low in (("n_contact", n_contact, 2), ("n_flight", n_flight, 0)):
        if isinstance(n, bool) or not isinstance(n, int) or n < low:
            raise ValueError(f"`{name}` must be an integer >= {low}; got {n!r}")
    kwargs = dict(mu=mu, eta=eta, speed=speed, angle=angle, spin=spin, inclination=inclination,
                  youngs_modulus=youngs_modulus, gravity=gravity, restitution=restitution,
                  normal_stiffness=normal_stiffness,
                  tangential_stiffness_ratio=tangential_stiffness_ratio)
    for name, value in kwargs.items():
        if value is not None:
            check_scalar(name, value)
    model = BounceModel(ball, mu=mu, eta=eta, speed=speed, angle=angle, spin=spin,
                        inclination=inclination, youngs_modulus=youngs_modulus, gravity=gravity,
                        normal_law=normal_law, tangential=tangential, restitution=restitution,
                        normal_stiffness=normal_stiffness,
                        tangential_stiffness_ratio=tangential_stiffness_ratio, solver=solver)
    explain_invalid(model.values, model.normal_law)
    # the ODE path, its dense output kept: the samples and the summary come from one solve
    res, status, segs, params = solve_with_segments(model.inputs, 0, solver)
    bounce = ode_bounce(model.inputs, res, status, ball.radius)
    if bounce.n_failed:
        raise BounceFailed(int(bounce.status), f"the bounce could not be solved: "
                                               f"{bounce.failure_summary()}")
    tc = float(bounce.contact_time)
    t_contact = np.linspace(0.0, tc, n_contact)
    hist = sample(res, segs, params, t_contact)
    span = tc if flight_time is None else check_scalar("flight_time", flight_time, unit="s",
                                                       low=0.0, low_open=True)
    return _with_flights(ball, bounce, t_contact, hist, params, span, n_flight)


def _with_flights(ball: Ball, bounce: Bounces, t_contact: np.ndarray, hist: np.ndarray,
                  params: np.ndarray, span: float, n_flight: int) -> BounceHistory:
    """The contact samples with ``n_flight`` ballistic samples over ``span`` on either side."""
    tc = t_contact[-1]
    gx, gy, r = params[K.P_GX], params[K.P_GY], ball.radius
    t_before = np.linspace(-span, 0.0, n_flight, endpoint=False)
    t_after = np.linspace(0.0, span, n_flight + 1)[1:]
    first = hist[0]
    before = _ballistic(t_before, 0.0, r, first[K.S_U], first[K.S_V], gx, gy)
    last = hist[-1]
    after = _ballistic(t_after, last[K.S_X], r - last[K.S_D], last[K.S_U], last[K.S_V], gx, gy)
    contact = (hist[:, K.S_X], r - hist[:, K.S_D], hist[:, K.S_U], hist[:, K.S_V])
    parts = [np.concatenate([b, c, a]) for b, c, a in zip(before, contact, after, strict=True)]
    zeros = np.zeros(n_flight)
    spin_series = np.concatenate([np.full(n_flight, first[K.S_W]), hist[:, K.S_W],
                                  np.full(n_flight, last[K.S_W])])
    return BounceHistory(
        time=np.concatenate([t_before, t_contact, tc + t_after]),
        x=parts[0], y=parts[1], tangential_velocity=parts[2], normal_velocity=parts[3],
        spin=spin_series,
        normal_force=np.concatenate([zeros, hist[:, K.H_FN], zeros]),
        friction_force=np.concatenate([zeros, hist[:, K.H_FT], zeros]),
        in_contact=np.concatenate([zeros, np.ones(t_contact.size), zeros]).astype(bool),
        rolling=np.concatenate([zeros, hist[:, K.H_PHASE] == 0, zeros]).astype(bool),
        bounce=bounce, mass=ball.mass, moment_of_inertia=ball.moment_of_inertia, radius=r)
