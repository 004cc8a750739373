"""``simulate``: full results of bounces for broadcast arguments (through :class:`BounceModel`)."""

from __future__ import annotations

from .._validate import check_choice
from ._config import PAPER_BALL, STANDARD_GRAVITY, Ball, SolverConfig, check_normal_law
from ._engine import BounceModel, Errors, Method
from ._results import Bounces


def simulate(ball: Ball = PAPER_BALL, *, mu, eta=None, speed, angle, spin=0.0,
             inclination=0.0, youngs_modulus=None, normal_law: str = "kelvin-voigt",
             tangential: str = "none", restitution=None, normal_stiffness=None,
             tangential_stiffness_ratio=None, gravity=STANDARD_GRAVITY,
             solver: SolverConfig | None = None, errors: Errors = "raise",
             method: Method = "auto") -> Bounces:
    """Simulate oblique bounces of ``ball`` on a rigid plane, batched over broadcast arrays.

    Free flight is ballistic (closed form); only the contact is integrated, from first touch
    (where ``speed``, ``angle`` and ``spin`` are given) to separation (where the rebound is
    reported). Every numeric argument may be an array; all broadcast together. Every input
    must lie in its physical domain (``bouncebayes.model.PARAMETER_DOMAINS``).

    Arguments:
        ball: the ball (radius, mass, modulus, Poisson ratio, inertia factor).
        mu: Coulomb friction coefficient, >= 0.
        eta: damping coefficient of the ``"kelvin-voigt"`` (kg/s, F_n = k d^1.5 + eta d') and
            ``"hunt-crossley"`` (s/m, F_n = k d^1.5 (1 + 1.5 eta d')) laws, >= 0.
        speed: incident speed at first contact, m/s, > 0.
        angle: incident angle from the plane normal, degrees, in [0, 90).
        spin: incident spin, rad/s, counter-clockwise positive (x forward, y outward).
        inclination: plane inclination to the horizontal, degrees, in (-90, 90); positive when
            the ball travels down-slope (tangential gravity g sin(inclination) along +x).
        youngs_modulus: optional Young's modulus in Pa overriding ``ball.youngs_modulus``
            element-wise (for inferring it); not used by ``"linear-dashpot"``.
        normal_law: ``"kelvin-voigt"`` (the paper's), ``"hunt-crossley"``,
            ``"linear-dashpot"`` (F_n = k_n d + c_n d') or ``"hertz-tsuji"`` (F_n = k d^1.5 +
            alpha sqrt(m k) d^(1/4) d'), docs/model.md §4; forces are clamped at >= 0 (a
            contact never pulls) and the ball separates where F_n returns to zero.
        tangential: ``"none"`` (rigid tangential contact, the paper's), ``"mindlin"`` (a
            tangential spring of Mindlin's no-slip stiffness, proportional to the contact
            radius) or ``"linear"`` (a constant Cundall–Strack spring), each capped by Coulomb
            friction (docs/model.md §5.2); with a spring every bounce takes the ODE path.
        restitution: the restitution coefficient in (0, 1] that sets the damping of the DEM
            laws ``"linear-dashpot"`` and ``"hertz-tsuji"`` as DEM codes do (docs/model.md
            §4.5-4.6).
        normal_stiffness: k_n of ``"linear-dashpot"``, N/m.
        tangential_stiffness_ratio: the ratio of the tangential spring's stiffness to the
            normal stiffness it refers to (docs/model.md §5.2); default Mindlin's
            2(1-nu)/(2-nu) of the ball's Poisson ratio.
        gravity: gravitational acceleration, m/s^2, >= 0 (the standard 9.80665 by default).
        solver: tolerances and limits (:class:`SolverConfig`).
        errors: ``"raise"``: invalid input raises ``ValueError`` and unsolved bounces give a
            :class:`SimulationWarning`; ``"flag"``: both only set the element's ``status``.
        method: ``"auto"`` (default): the tabulated normal impact with the closed-form
            tangential outcome wherever that is exact, the ODE solver elsewhere, element by
            element; ``"ode"``: the ODE solver everywhere.

    Returns:
        :class:`Bounces` with one entry per broadcast element.
    """
    check_choice("errors", errors, ("raise", "flag"))
    check_choice("method", method, ("auto", "ode"))
    normal_law = check_normal_law(normal_law)
    model = BounceModel(ball, mu=mu, eta=eta, speed=speed, angle=angle, spin=spin,
                        inclination=inclination, youngs_modulus=youngs_modulus, gravity=gravity,
                        normal_law=normal_law, tangential=tangential, restitution=restitution,
                        normal_stiffness=normal_stiffness,
                        tangential_stiffness_ratio=tangential_stiffness_ratio, solver=solver,
                        errors=errors)
    return model.bounces(method=method)
