"""``simulate``: full results of bounces for broadcast arguments (through :class:`BounceModel`)."""

from __future__ import annotations

from .._validate import check_choice
from ._config import PAPER_BALL, STANDARD_GRAVITY, Ball, SolverConfig
from ._engine import BounceModel, Errors, Method
from ._results import Bounces


def simulate(ball: Ball = PAPER_BALL, *, mu, eta=None, speed, angle, spin=0.0,
             inclination=0.0, youngs_modulus=None, normal_law: str = "kelvin-voigt",
             tangential: str = "none", restitution=None, normal_stiffness=None,
             tangential_stiffness_ratio=None, gravity=STANDARD_GRAVITY,
             solver: SolverConfig | None = None, errors: Errors = "raise",
             method: Method = "auto") -> Bounces:
    """Simulate oblique bounces of ``ball`` on a rigid plane, batched over broadcast arrays.

    The contact is integrated from first touch (the incidence) to separation (the rebound).
    Numeric arguments may be arrays, broadcast together, each inside its physical domain
    (``PARAMETER_DOMAINS``). Laws and parameters: docs/model.md §4-5.

    Arguments:
        ball: the ball (radius, mass, modulus, Poisson ratio, inertia factor).
        mu: Coulomb friction coefficient, >= 0.
        eta: damping of ``"kelvin-voigt"`` (kg/s, F_n = k d^1.5 + eta d') or
            ``"hunt-crossley"`` (s/m, F_n = k d^1.5 (1 + 1.5 eta d')), >= 0.
        speed: incident speed at first contact, m/s, > 0.
        angle: incident angle from the plane normal, degrees, in [0, 90).
        spin: incident spin, rad/s, counter-clockwise positive (x forward, y outward).
        inclination: plane angle to the horizontal, degrees, in (-90, 90); positive when the
            ball travels down-slope.
        youngs_modulus: Pa, overrides ``ball.youngs_modulus`` element-wise (Hertz laws).
        normal_law: ``"kelvin-voigt"`` (the study's), ``"hunt-crossley"``,
            ``"linear-dashpot"`` or ``"hertz-tsuji"``; forces are clamped at >= 0.
        tangential: ``"none"`` (rigid tangential contact, the study's), ``"mindlin"`` or
            ``"linear"``: a tangential spring capped by Coulomb friction (every bounce then
            takes the ODE path).
        restitution: in (0, 1], sets the damping of the DEM laws as DEM codes do.
        normal_stiffness: k_n of ``"linear-dashpot"``, N/m.
        tangential_stiffness_ratio: the spring's stiffness over the normal stiffness it
            refers to; default Mindlin's 2(1-nu)/(2-nu).
        gravity: m/s^2, >= 0 (standard 9.80665 by default).
        solver: tolerances and limits (:class:`SolverConfig`).
        errors: ``"raise"`` (invalid input raises ``ValueError``, unsolved bounces warn) or
            ``"flag"`` (both only set ``status``).
        method: ``"auto"``: the closed form wherever it is exact, the ODE elsewhere, element by
            element; ``"ode"``: the ODE everywhere.

    Returns:
        :class:`Bounces` with one entry per broadcast element (``closed_form``: which path).
    """
    check_choice("method", method, ("auto", "ode"))  # BounceModel checks the rest
    model = BounceModel(ball, mu=mu, eta=eta, speed=speed, angle=angle, spin=spin,
                        inclination=inclination, youngs_modulus=youngs_modulus, gravity=gravity,
                        normal_law=normal_law, tangential=tangential, restitution=restitution,
                        normal_stiffness=normal_stiffness,
                        tangential_stiffness_ratio=tangential_stiffness_ratio, solver=solver,
                        errors=errors)
    return model.bounces(method=method)
