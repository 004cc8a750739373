"""Frozen, self-checking configuration of the forward model: the ball and the solver."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal, get_args

from .._validate import check_choice, check_scalar
from ._domain import PARAMETER_DOMAINS

NormalLaw = Literal["kelvin-voigt", "hunt-crossley", "linear-dashpot", "hertz-tsuji"]
NORMAL_LAWS: tuple[str, ...] = get_args(NormalLaw)
TangentialLaw = Literal["none", "mindlin", "linear"]
TANGENTIAL_LAWS: tuple[str, ...] = get_args(TangentialLaw)
STANDARD_GRAVITY = 9.80665  # m/s^2 (CGPM 1901)

#: Per normal law: the names of its damping parameter and of its stiffness parameter
#: (docs/model.md §4). The DEM laws take the restitution coefficient as DEM codes do.
LAW_PARAMETERS = {"kelvin-voigt": ("eta", "youngs_modulus"),
                  "hunt-crossley": ("eta", "youngs_modulus"),
                  "linear-dashpot": ("restitution", "normal_stiffness"),
                  "hertz-tsuji": ("restitution", "youngs_modulus")}
DAMPING_UNITS = {"kelvin-voigt": "kg/s", "hunt-crossley": "s/m", "linear-dashpot": "",
                 "hertz-tsuji": ""}
#: Parameters of the tangential spring, by tangential law.
TANGENTIAL_PARAMETERS = {"none": (), "mindlin": ("tangential_stiffness_ratio",),
                         "linear": ("tangential_stiffness_ratio",)}


def check_normal_law(law: str) -> str:
    """Validate a normal-force law name."""
    return check_choice("normal_law", law, NORMAL_LAWS)


def check_tangential(law: str) -> str:
    """Validate a tangential law name."""
    return check_choice("tangential", law, TANGENTIAL_LAWS)


def damping_unit(law: str) -> str:
    """Unit of the damping parameter under a normal law: kg/s (``eta`` of Kelvin–Voigt), s/m
    (``eta`` of Hunt–Crossley), or dimensionless (the DEM laws' ``restitution``)."""
    return DAMPING_UNITS[check_normal_law(law)]


def model_parameters(normal_law: str = "kelvin-voigt", tangential: str = "none"
                     ) -> tuple[str, ...]:
    """The per-bounce parameters of a contact law, in a fixed order: ``mu``, the normal law's
    damping (``eta`` or ``restitution``) and stiffness (``youngs_modulus`` or
    ``normal_stiffness``), the incident ``spin``, then the tangential spring's
    (``tangential_stiffness_ratio``). Each may be fixed or inferred."""
    damping, stiffness = LAW_PARAMETERS[check_normal_law(normal_law)]
    return ("mu", damping, stiffness, "spin") + TANGENTIAL_PARAMETERS[check_tangential(
        tangential)]


def mindlin_stiffness_ratio(poisson_ratio: float) -> float:
    """Mindlin's ratio of no-slip tangential to normal contact stiffness, 2(1-nu)/(2-nu).

    For a sphere on a rigid plane ``k_t = 8 G* a`` and ``dF_n/d(delta) = 2 E* a`` with
    ``G* = G/(2 - nu)``, ``E* = E/(1 - nu^2)``, ``G = E/(2(1 + nu))`` (Mindlin 1949; Johnson
    1985, §7.2); the ratio ``4 G*/E*`` depends on the Poisson ratio only: 2/3 at nu = 0.5,
    0.87 at 0.23, 1 at 0 (docs/model.md §5.2).
    """
    nu = check_scalar("poisson_ratio", poisson_ratio, low=-1.0, high=0.5, low_open=True)
    return 2.0 * (1.0 - nu) / (2.0 - nu)


@dataclass(frozen=True, kw_only=True)
class Ball:
    """A homogeneous (or shell) sphere, SI units throughout.

    Every value must also lie in its physical domain (``PARAMETER_DOMAINS``: radius 10 um to
    1 m, mean density 1 to 25,000 kg/m^3, modulus 1 kPa to 1.5 TPa; the reasons are in
    ``bouncebayes.model._domain``'s docstring), so that no quantity of the model overflows.

    Arguments:
        radius: radius in m, > 0.
        mass: mass in kg, > 0.
        youngs_modulus: Young's modulus E in Pa, > 0.
        poisson_ratio: Poisson ratio nu, in (-1, 0.5].
        inertia_factor: kappa in I = kappa m r^2, in (0, 1]; 2/5 for a solid sphere,
            2/3 for a thin hollow shell.
    """

    radius: float
    mass: float
    youngs_modulus: float
    poisson_ratio: float
    inertia_factor: float = 0.4

    def __post_init__(self) -> None:
        check_scalar("radius", self.radius, unit="m", low=0.0, low_open=True)
        check_scalar("mass", self.mass, unit="kg", low=0.0, low_open=True)
        check_scalar("youngs_modulus", self.youngs_modulus, unit="Pa", low=0.0, low_open=True)
        check_scalar("poisson_ratio", self.poisson_ratio, low=-1.0, high=0.5, low_open=True)
        check_scalar("inertia_factor", self.inertia_factor, low=0.0, high=1.0, low_open=True)
        PARAMETER_DOMAINS["radius"].check(self.radius)
        PARAMETER_DOMAINS["youngs_modulus"].check(self.youngs_modulus)
        density = PARAMETER_DOMAINS["density"]
        if not density.contains(self.density):
            raise ValueError(f"`mass` of {self.mass!r} kg gives a mean density of "
                             f"{self.density:.3g} kg/m^3 for the radius {self.radius:g} m; a "
                             f"ball's mean density must be {density.describe()} "
                             f"({density.reason})")

    @classmethod
    def from_diameter(cls, diameter: float, *, mass: float | None = None,
                      density: float | None = None, **kwargs: float) -> Ball:
        """Build a ball from its diameter (m) and either its mass (kg) or density (kg/m^3)."""
        d = check_scalar("diameter", diameter, unit="m", low=0.0, low_open=True)
        PARAMETER_DOMAINS["diameter"].check(d)
        if (mass is None) == (density is None):
            raise ValueError("give exactly one of `mass` (kg) or `density` (kg/m^3); got "
                             f"mass={mass!r}, density={density!r}")
        if mass is None:
            rho = check_scalar("density", density, unit="kg/m^3", low=0.0, low_open=True)
            PARAMETER_DOMAINS["density"].check(rho)
            mass = rho * math.pi * d**3 / 6.0
        return cls(radius=d / 2.0, mass=mass, **kwargs)

    @property
    def diameter(self) -> float:
        """Diameter in m."""
        return 2.0 * self.radius

    @property
    def density(self) -> float:
        """Mean density in kg/m^3."""
        return self.mass / (4.0 / 3.0 * math.pi * self.radius**3)

    @property
    def moment_of_inertia(self) -> float:
        """Moment of inertia about a diameter, kg m^2."""
        return self.inertia_factor * self.mass * self.radius**2

    @property
    def effective_modulus(self) -> float:
        """Contact modulus against a rigid plane, E* = E / (1 - nu^2), Pa."""
        return self.youngs_modulus / (1.0 - self.poisson_ratio**2)

    @property
    def hertz_stiffness(self) -> float:
        """Hertz stiffness k in F = k delta^(3/2): (4/3) sqrt(r) E*, N/m^(3/2)."""
        return 4.0 / 3.0 * math.sqrt(self.radius) * self.effective_modulus


# The paper's ball: a commercial polybutadiene ball of diameter 25.6 mm (paper, section 3). The
# paper gives nothing else; the other values are literature choices (README, "Default ball"):
# - mass 9.5 g, i.e. a mean density of 1082 kg/m^3: unfilled cis-1,4-polybutadiene is about
#   910 kg/m^3 and the high-bounce ball compounds add silica and zinc-oxide fillers, which raise it;
# - Young's modulus 5 MPa: small-strain modulus of a vulcanised rubber of Shore A hardness about 68
#   by Gent's relation (A.N. Gent, Trans. Inst. Rubber Ind. 34, 46-57, 1958), inside the 1-10 MPa
#   range of vulcanised rubbers (A.N. Gent, Engineering with Rubber, 3rd ed., Hanser 2012, ch. 1);
# - Poisson ratio 0.49: rubber is nearly incompressible (nu -> 0.5, same reference);
# - inertia factor 2/5: a solid homogeneous sphere.
PAPER_BALL = Ball(radius=0.0128, mass=0.0095, youngs_modulus=5.0e6, poisson_ratio=0.49,
                  inertia_factor=0.4)


@dataclass(frozen=True, kw_only=True)
class SolverConfig:
    """Accuracy and limits of the adaptive contact-phase solver.

    Arguments:
        rtol: relative tolerance of the Dormand–Prince 5(4) error control, in (0, 0.1].
        atol: absolute tolerance as a fraction of each variable's natural scale (the Hertz
            overlap for positions, the incident speed for velocities, speed / radius for spin).
        max_steps: step attempts (accepted or rejected) allowed per bounce before giving up
            (status ``MAX_STEPS``); a bounce of the paper's ball takes about 100.
        max_contact_time_factor: the contact may last at most this many elastic Hertz contact
            times before the bounce is declared not separating (status ``NO_SEPARATION``).
        time_limit: wall-clock seconds one call may spend in the ODE solver, or None for no
            limit. The solver works through a batch in chunks and checks the clock between
            them; the bounces of the chunks it did not reach get the status ``TIMEOUT``. (The
            step cap already bounds every bounce; this bounds a whole batch, whatever its size.)
    """

    rtol: float = 1e-10
    atol: float = 1e-10
    max_steps: int = 20_000
    max_contact_time_factor: float = 50.0
    time_limit: float | None = 300.0

    def __post_init__(self) -> None:
        check_scalar("rtol", self.rtol, low=1e-15, high=0.1)
        check_scalar("atol", self.atol, low=1e-15, high=0.1)
        if isinstance(self.max_steps, bool) or not isinstance(self.max_steps, int) \
                or self.max_steps < 10:
            raise ValueError(f"`max_steps` must be an integer >= 10; got {self.max_steps!r}")
        check_scalar("max_contact_time_factor", self.max_contact_time_factor, low=1.0)
        if self.time_limit is not None:
            check_scalar("time_limit", self.time_limit, unit="s", low=0.0, low_open=True)
