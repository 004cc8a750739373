"""Quantities a DEM user sets in a simulation code, derived from a contact law and its parameters.

Every function is batched over parameter vectors (posterior draws): ``values`` maps each
parameter of the contact law (``model_parameters``, the incident ``spin`` excepted) to a number
or an array of n draws, and each result has the draws along its first axis. The bounces behind
them are material responses, as DEM codes define them: a ball with no incident spin on a
horizontal plane, without gravity (over a contact of microseconds to a millisecond gravity
changes the rebound by less than g t_c / V, under 1e-3 in the quantities' range).

``derived_quantities`` returns all of them, each a :class:`DerivedQuantity` with its
definition and a transfer note (docs/model.md §4.7).
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._validate import check_scalar
from ._config import (PAPER_BALL, Ball, SolverConfig, check_normal_law, check_tangential,
                      mindlin_stiffness_ratio, model_parameters)
from ._engine import BounceModel
from ._laws import restitution_damping_ratio
from ._results import SimulationWarning

#: Impact speeds (m/s) of the normal-restitution and contact-time curves.
DEFAULT_SPEEDS = np.geomspace(0.5, 10.0, 14)
#: Incidence angles (deg from the normal) of the oblique curves; 0 is left out (no tangential
#: velocity: the tangential restitution is undefined there).
DEFAULT_ANGLES = np.arange(5.0, 90.0, 5.0)

_TRANSFER = ("holds for this ball on this surface (this pair of materials, this ball's size and "
             "mass: a DEM particle of another size or another contact partner needs the law, "
             "not the number); the data measured it at normal impact speeds {measured} (the "
             "speed component along the normal, which sets the normal impact), and "
             "elsewhere it is the contact law's extrapolation, not a measurement")


@dataclass(frozen=True)
class DerivedQuantity:
    """One derived quantity over the draws.

    ``values`` has shape (n_draws,) for a number, or (n_draws, grid.size) for a curve over
    ``grid`` (``grid_name`` in ``grid_unit``: the impact speed or the incidence angle); NaN
    where a bounce could not be solved. ``definition`` says what the number is, ``transfer``
    where it may be used.
    """

    name: str
    unit: str
    definition: str
    transfer: str
    values: np.ndarray
    grid: np.ndarray | None = None
    grid_name: str | None = None
    grid_unit: str | None = None


def _draws(ball: Ball, values: Mapping, normal_law: str, tangential: str
           ) -> tuple[tuple[str, ...], np.ndarray]:
    """(names, theta (n, len(names))) of the law's parameters, spin excepted; a missing
    ``youngs_modulus`` is the ball's, a missing ``tangential_stiffness_ratio`` Mindlin's."""
    names = tuple(n for n in model_parameters(normal_law, tangential) if n != "spin")
    defaults = {"youngs_modulus": ball.youngs_modulus}
    if tangential != "none":
        defaults["tangential_stiffness_ratio"] = mindlin_stiffness_ratio(ball.poisson_ratio)
    unknown = sorted(set(values) - set(names) - {"spin"})
    if unknown:
        raise ValueError(f"`values` has {unknown}, not parameters of the contact law "
                         f"({normal_law}, tangential {tangential}): {names}")
    missing = [n for n in names if n not in values and n not in defaults]
    if missing:
        raise ValueError(f"`values` must give {missing} (parameters of the contact law "
                         f"{normal_law}); got {sorted(values)}")
    columns = [np.atleast_1d(np.asarray(values.get(n, defaults.get(n)), dtype=float))
               for n in names]
    if any(c.ndim != 1 for c in columns):
        raise ValueError("`values` must hold numbers or 1-D arrays of draws")
    try:
        theta = np.column_stack(np.broadcast_arrays(*columns))
    except ValueError:
        raise ValueError(f"`values` arrays must have one length (the number of draws); got "
                         f"{[c.size for c in columns]}") from None
    return names, theta


def _rebounds(ball, values, normal_law, tangential, *, speed, angle, solver):
    """Rebounds (n_draws, n_conditions) of the draws, spin 0, no gravity, horizontal plane."""
    names, theta = _draws(ball, values, normal_law, tangential)
    model = BounceModel(ball, speed=speed, angle=angle, spin=0.0, gravity=0.0,
                        normal_law=normal_law, tangential=tangential, solver=solver,
                        errors="flag", varying=names)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SimulationWarning)
        return model(theta)


def normal_response(ball: Ball = PAPER_BALL, values: Mapping | None = None, *,
                    speeds=DEFAULT_SPEEDS, normal_law: str = "kelvin-voigt",
                    tangential: str = "none",
                    solver: SolverConfig | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Head-on impacts at each of ``speeds`` (m/s): (normal restitution e = v'_n / v_n,
    contact time in s), each of shape (n_draws, len(speeds)), NaN where unsolved.

    The contact time is from first touch to the instant the normal force returns to zero
    (the ball separates there, docs/model.md §4)."""
    normal_law, tangential = check_normal_law(normal_law), check_tangential(tangential)
    speeds = np.atleast_1d(np.asarray(speeds, dtype=float))
    r = _rebounds(ball, values or {}, normal_law, tangential, speed=speeds, angle=0.0,
                  solver=solver)
    with np.errstate(invalid="ignore"):
        e = np.where(r.ok, r.speed / speeds, np.nan)
        tc = np.where(r.ok, r.contact_time, np.nan)
    return e, tc


@dataclass(frozen=True)
class ObliqueResponse:
    """Oblique impacts at one speed over incidence angles; arrays (n_draws, n_angles), NaN
    where unsolved. Angles from the plane normal, spin counter-clockwise positive with the
    ball moving along +x (topspin negative)."""

    angles: np.ndarray  #: deg
    tangential_restitution: np.ndarray  #: u' / u of the centre of mass
    rebound_spin: np.ndarray  #: rad/s
    rebound_angle: np.ndarray  #: deg, atan(u' / v'_n) of the centre of mass
    contact_point_angle: np.ndarray  #: deg, atan((u' + r w') / v'_n) of the contact point


def oblique_response(ball: Ball = PAPER_BALL, values: Mapping | None = None, *, speed: float,
                     angles=DEFAULT_ANGLES, normal_law: str = "kelvin-voigt",
                     tangential: str = "none",
                     solver: SolverConfig | None = None) -> ObliqueResponse:
    """Impacts at ``speed`` (m/s) and each incidence angle of ``angles`` (deg from the normal,
    in (0, 90)) with no incident spin: tangential restitution, rebound spin and angles."""
    normal_law, tangential = check_normal_law(normal_law), check_tangential(tangential)
    speed = check_scalar("speed", speed, unit="m/s", low=0.0, low_open=True)
    angles = np.atleast_1d(np.asarray(angles, dtype=float))
    if not ((angles > 0.0) & (angles < 90.0)).all():
        raise ValueError(f"`angles` must lie in (0, 90) deg (the tangential restitution is "
                         f"undefined head-on); got {angles.min():g} to {angles.max():g}")
    r = _rebounds(ball, values or {}, normal_law, tangential, speed=speed, angle=angles,
                  solver=solver)
    a_out = np.radians(r.angle)
    u_out, v_out = r.speed * np.sin(a_out), r.speed * np.cos(a_out)
    u_in = speed * np.sin(np.radians(angles))
    with np.errstate(invalid="ignore"):
        patch = np.degrees(np.arctan2(u_out + ball.radius * r.spin, v_out))
        return ObliqueResponse(angles=angles,
                               tangential_restitution=np.where(r.ok, u_out / u_in, np.nan),
                               rebound_spin=np.where(r.ok, r.spin, np.nan),
                               rebound_angle=np.where(r.ok, r.angle, np.nan),
                               contact_point_angle=np.where(r.ok, patch, np.nan))


def equivalent_linear_dashpot(mass, restitution, contact_time
                              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The linear spring-dashpot F = k_n d + c_n d' (as DEM codes set it: the free damped
    oscillator, no clamping of the force) with the given restitution and contact time for a
    body of ``mass`` (kg) on a rigid wall: (k_n in N/m, c_n in kg/s, damping ratio zeta).

    From e = exp(-pi zeta / sqrt(1 - zeta^2)) and t_c = pi / (w0 sqrt(1 - zeta^2)),
    w0^2 = k_n / m: zeta = -ln e / sqrt(pi^2 + ln^2 e), k_n = m (pi^2 + ln^2 e) / t_c^2,
    c_n = 2 zeta sqrt(m k_n) = -2 m ln e / t_c (Cundall & Strack 1979; the inverse of the
    conversion of ``restitution_damping_ratio``). NaN where e is not in (0, 1] or t_c not > 0.
    """
    e, tc = (np.asarray(a, dtype=float) for a in (restitution, contact_time))
    ok = (e > 0.0) & (e <= 1.0) & (tc > 0.0)
    with np.errstate(all="ignore"):
        log_e = np.log(np.where(ok, e, 1.0))
        t = np.where(ok, tc, 1.0)
        k = mass * (np.pi**2 + log_e**2) / t**2
        c = -2.0 * mass * log_e / t
    zeta = restitution_damping_ratio(np.where(ok, e, np.nan))
    return np.where(ok, k, np.nan), np.where(ok, c, np.nan), zeta


def derived_quantities(ball: Ball = PAPER_BALL, values: Mapping | None = None, *,
                       reference_speed: float, normal_law: str = "kelvin-voigt",
                       tangential: str = "none", speeds=DEFAULT_SPEEDS, angles=DEFAULT_ANGLES,
                       measured_speeds: tuple[float, float] | None = None,
                       solver: SolverConfig | None = None) -> dict[str, DerivedQuantity]:
    """Every DEM-ready quantity of the draws ``values``, by name (docs/model.md §4.7).

    ``reference_speed`` (m/s): the speed of the oblique curves and of the linear equivalence
    (the campaign's incident speed: the data hold there); ``speeds`` (m/s) and ``angles``
    (deg): the curves' grids; ``measured_speeds``: (lowest, highest) normal impact speed of the
    data (incident speed times the cosine of the incidence angle), m/s, for the transfer notes
    (default: the reference speed). The names are the keys of
    ``DERIVED_QUANTITIES``, plus ``tangential_stiffness_ratio`` with a spring.
    """
    v_ref = check_scalar("reference_speed", reference_speed, unit="m/s", low=0.0,
                         low_open=True)
    values = dict(values or {})
    law: dict[str, Any] = {"normal_law": normal_law, "tangential": tangential,
                           "solver": solver}
    speeds = np.atleast_1d(np.asarray(speeds, dtype=float))
    e, tc = normal_response(ball, values, speeds=speeds, **law)
    e_ref, tc_ref = (a[:, 0] for a in normal_response(
        ball, values, speeds=[v_ref], **law))
    obl = oblique_response(ball, values, speed=v_ref, angles=angles, **law)
    k, c, zeta = equivalent_linear_dashpot(ball.mass, e_ref, tc_ref)
    lo, hi = (v_ref, v_ref) if measured_speeds is None else sorted(map(float, measured_speeds))
    transfer = _TRANSFER.format(measured=f"{lo:.3g} m/s" if lo == hi
                                else f"{lo:.3g}-{hi:.3g} m/s")
    by_speed, by_angle = (speeds, "impact_speed", "m/s"), (obl.angles, "incidence_angle", "deg")
    found = {"normal_restitution": (e, by_speed), "contact_time": (tc, by_speed),
             "tangential_restitution": (obl.tangential_restitution, by_angle),
             "rebound_spin": (obl.rebound_spin, by_angle),
             "rebound_angle": (obl.rebound_angle, by_angle),
             "restitution_at_reference": (e_ref, None),
             "contact_time_at_reference": (tc_ref, None), "linear_normal_stiffness": (k, None),
             "linear_normal_damping": (c, None), "linear_damping_ratio": (zeta, None),
             "friction_coefficient": (np.broadcast_to(np.asarray(
                 values.get("mu", np.nan), dtype=float), e.shape[:1]).copy(), None)}
    definitions = dict(DERIVED_QUANTITIES)
    if tangential != "none":
        found["tangential_stiffness_ratio"] = (
            _draws(ball, values, normal_law, tangential)[1][:, -1], None)
        definitions["tangential_stiffness_ratio"] = ("", _RATIO_DEFINITIONS[tangential])
    out = {}
    for name, (v, grid) in found.items():
        unit, definition = definitions[name]
        note = _FRICTION_TRANSFER if name == "friction_coefficient" else transfer
        out[name] = DerivedQuantity(name, unit, definition.format(v=v_ref), note,
                                    np.asarray(v), *(grid or (None, None, None)))
    return out


#: (unit, definition) of each quantity of ``derived_quantities`` (``{v}``: the reference speed,
#: m/s); ``tangential_stiffness_ratio`` is added with a spring.
DERIVED_QUANTITIES = {
    "normal_restitution": ("", "v'_n / v_n of a head-on impact at each impact speed (no spin, "
                               "no gravity)"),
    "contact_time": ("s", "time from first touch to the normal force's return to zero, "
                          "head-on, at each impact speed"),
    "tangential_restitution": ("", "u' / u of the centre of mass at {v:g} m/s and each "
                                   "incidence angle (from the normal), no incident spin"),
    "rebound_spin": ("rad/s", "spin after impact at {v:g} m/s and each incidence angle, no "
                              "incident spin (counter-clockwise positive, ball moving along "
                              "+x: topspin is negative)"),
    "rebound_angle": ("deg", "atan(u' / v'_n) of the centre of mass at {v:g} m/s and each "
                             "incidence angle"),
    "restitution_at_reference": ("", "normal restitution of a head-on impact at {v:g} m/s"),
    "contact_time_at_reference": ("s", "contact time of a head-on impact at {v:g} m/s"),
    "linear_normal_stiffness": ("N/m", "k_n of the linear spring-dashpot F = k_n d + c_n d' "
                                       "(unclamped, as DEM codes set it) with the same "
                                       "restitution and contact time as the model in a "
                                       "head-on impact at {v:g} m/s: k_n = m (pi^2 + ln^2 e) / "
                                       "t_c^2 with the ball's mass m (a ball on a wall; "
                                       "between two such balls use the reduced mass m/2)"),
    "linear_normal_damping": ("kg/s", "c_n of that linear spring-dashpot, c_n = -2 m ln(e) / "
                                      "t_c"),
    "linear_damping_ratio": ("", "damping ratio zeta = c_n / (2 sqrt(m k_n)) = -ln e / "
                                 "sqrt(pi^2 + ln^2 e) of that linear spring-dashpot "
                                 "(LIGGGHTS/EDEM's -beta)"),
    "friction_coefficient": ("", "Coulomb's sliding friction coefficient mu (tangential force "
                                 "<= mu x normal force at the contact)"),
}
_FRICTION_TRANSFER = ("holds for this ball on this surface (this pair of materials, their "
                      "finish and cleanliness), in sliding at the campaign's speeds; it does not "
                      "transfer to another pair of materials")
_RATIO_DEFINITIONS = {
    "mindlin": "k_t / (dF_n/d delta): the Mindlin no-slip tangential stiffness 8 G* a over the "
               "Hertz normal tangent stiffness 2 E* a (a = sqrt(r delta)); 2(1-nu)/(2-nu) for "
               "an isotropic elastic ball, the ratio LIGGGHTS's and EDEM's Hertz-Mindlin "
               "models take from the Poisson ratio",
    "linear": "k_t / k_n of a linear (Cundall-Strack) tangential spring; under a Hertz normal "
              "law k_n is the linear stiffness with the elastic Hertz contact time of the "
              "impact, m (pi / t_H)^2",
}
