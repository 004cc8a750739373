"""Physical domains of the model's inputs: one public table, checked at every boundary.

Each input has two ranges. Its *definition* (a speed is > 0, an angle is in [0, 90) degrees) is
checked first, with the plain message of every other argument check. Its *domain* is the range of
values a real ball can have; it is wide enough for any ball from a fine powder grain to a large
ball, and narrow enough that no floating-point quantity of the model overflows or underflows
inside it (a mass of 1e300 kg squares to infinity, a modulus of 0 divides by zero). Values
outside the domain are refused with the domain's reason, priors must stay inside it (the
experiment file checks them), and samplers' proposals outside it get the status
``INVALID_INPUT``.

The bounds, and why:

- radius 10 um to 1 m: below ~10 um adhesion (JKR) rather than Hertz's elasticity governs a
  contact; 1 m is beyond any ball used in impact tests.
- mean density 1 to 25,000 kg/m^3: from a gas-filled balloon (~1) through foams, rubbers and
  ceramics to osmium and iridium (22,600), the densest elements.
- Young's modulus 1 kPa to 1.5 TPa: from soft hydrogels (~1 kPa) to diamond (1.05-1.2 TPa), the
  stiffest solid.
- friction coefficient 0 to 10: measured Coulomb coefficients of solids span about 0.01 to 5
  (clean metals in vacuum); 10 leaves a wide margin.
- damping: Kelvin–Voigt up to 1e8 kg/s (about the critical damping of a 1 m steel ball on its
  Hertz stiffness: far beyond a ball that still bounces); Hunt–Crossley up to 1e4 s/m (the ball
  stops without rebound once eta V exceeds a few, so 1e4 s/m covers speeds down to 1 mm/s).
- restitution (the DEM laws' damping parameter) 0.001 to 1: 1 is elastic; below 0.001 the
  ball barely leaves the surface, and the damping ratio approaches the critical value 1.
- normal stiffness of the linear spring-dashpot 1 N/m to 1e12 N/m: from a soft foam grain
  (a 1 mm overlap under a milli-newton) to the Hertz stiffness of a 1 m steel ball at a 10 %
  overlap.
- tangential stiffness ratio 0.001 to 100: isotropic elastic solids give 2(1-nu)/(2-nu),
  2/3 to 4/3 (Mindlin 1949), DEM codes use 2/7 to 1; the range leaves wide margins either
  side (at 100 the tangential vibration is ten times faster than the normal one).
- incident speed 1 mm/s to 500 m/s: below 1 mm/s the rebound rises less than 0.05 um; 500 m/s
  is above any ball sport (golf, ~80 m/s) and gas-gun impact tests of spheres, where plastic
  deformation, outside this model, already dominates.
- spin up to 1e5 rad/s in magnitude (about 1 million rpm): a hundred times a table-tennis
  topspin; the surface speed of a 10 um grain at that spin is 1 m/s.
- gravity 0 to 1000 m/s^2: free fall on Earth (9.8) or Jupiter (24.8), centrifuge tests up to
  about 100 g.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np

from .._validate import in_range_mask, range_text


@dataclass(frozen=True)
class Domain:
    """The physical range of one input: ``[low, high]`` (ends open where marked) and why.

    ``high_by_law`` overrides ``high`` (and ``unit_by_law`` the unit) per normal-force law,
    for the damping coefficient whose unit depends on the law.
    """

    name: str
    unit: str
    low: float
    high: float
    reason: str
    low_open: bool = False
    high_open: bool = False
    high_by_law: Mapping[str, float] | None = None
    unit_by_law: Mapping[str, str] | None = None

    def for_law(self, normal_law: str) -> Domain:
        """This domain under ``normal_law`` (the same object if it does not depend on it)."""
        if self.high_by_law is None:
            return self
        unit = self.unit_by_law[normal_law] if self.unit_by_law else self.unit
        return Domain(self.name, unit, self.low, self.high_by_law[normal_law], self.reason,
                      self.low_open, self.high_open)

    def describe(self) -> str:
        """The allowed range in words, e.g. ``a finite number in [0, 10]``."""
        return range_text(self.low, self.high, self.low_open, self.high_open, self.unit)

    def contains(self, value) -> np.ndarray:
        """True where ``value`` (scalar or array) lies inside the domain."""
        return in_range_mask(np.asarray(value, dtype=float), self.low, self.high, self.low_open,
                             self.high_open)

    def check(self, value, name: str | None = None) -> np.ndarray:
        """Return ``value`` as a float array, or raise ``ValueError`` naming the first element
        outside the domain, the domain and its reason."""
        arr = np.asarray(value, dtype=float)
        ok = self.contains(arr)
        if not ok.all():
            index = np.unravel_index(int(np.argmin(ok)), arr.shape)
            where = f" at index {tuple(int(i) for i in index)}" if arr.ndim else ""
            raise ValueError(f"`{name or self.name}` must be {self.describe()} "
                             f"({self.reason}); got {float(arr[index])!r}{where}")
        return arr


def _domains(*items: Domain) -> Mapping[str, Domain]:
    return MappingProxyType({d.name: d for d in items})


#: The physical domain of every input of the model, by argument name (see the module docstring
#: for the sources of the bounds). ``eta`` depends on the normal law: use
#: :func:`parameter_domain` or ``PARAMETER_DOMAINS["eta"].for_law(law)``.
PARAMETER_DOMAINS: Mapping[str, Domain] = _domains(
    Domain("radius", "m", 1e-5, 1.0, "from fine powder grains, below which adhesion governs the "
                                     "contact, to the largest balls"),
    Domain("diameter", "m", 2e-5, 2.0, "from fine powder grains, below which adhesion governs "
                                       "the contact, to the largest balls"),
    Domain("density", "kg/m^3", 1.0, 25_000.0, "mean density of a ball, from a gas-filled "
                                               "balloon to osmium"),
    Domain("youngs_modulus", "Pa", 1e3, 1.5e12, "from soft hydrogels to diamond"),
    Domain("mu", "", 0.0, 10.0, "Coulomb coefficients of solids span about 0.01 to 5"),
    Domain("eta", "kg/s", 0.0, 1e8, "beyond, the ball sticks to the surface for any speed",
           high_by_law=MappingProxyType({"kelvin-voigt": 1e8, "hunt-crossley": 1e4}),
           unit_by_law=MappingProxyType({"kelvin-voigt": "kg/s", "hunt-crossley": "s/m"})),
    Domain("restitution", "", 1e-3, 1.0, "1 is elastic; below 0.001 the ball barely leaves the "
                                         "surface"),
    Domain("normal_stiffness", "N/m", 1.0, 1e12, "from a soft foam grain to a steel ball of "
                                                 "1 m at a 10 % overlap"),
    Domain("tangential_stiffness_ratio", "", 1e-3, 100.0,
           "isotropic elastic solids give 2/3 to 4/3, DEM codes 2/7 to 1"),
    Domain("speed", "m/s", 1e-3, 500.0, "from a bounce that rises 0.05 um to beyond gas-gun "
                                        "impact tests"),
    Domain("spin", "rad/s", -1e5, 1e5, "about a million rpm in either sense"),
    Domain("gravity", "m/s^2", 0.0, 1000.0, "from weightlessness to centrifuge tests at 100 g"),
)

#: The maximum overlap, as a fraction of the radius, up to which a bounce counts as inside the
#: validity of Hertz's small-strain contact (``Bounces.hertz_valid``). Hertz's theory assumes a
#: contact radius ``a = sqrt(r d)`` small against ``r``: at ``d = 0.1 r`` it is already
#: ``0.32 r``, the exact-profile solution of a rigid sphere on an elastic half-space (Sneddon,
#: Int. J. Eng. Sci. 3, 47-57, 1965) departs from Hertz's force by ``d / (10 r)`` (1 %), and
#: the strains near the contact, of order ``a / r``, are far from small; beyond it the
#: finite-strain and finite-body corrections that Hertz neglects grow quickly (K.L. Johnson,
#: Contact Mechanics, CUP 1985, §4.1 states the assumption ``a << r``).
HERTZ_OVERLAP_LIMIT = 0.1


def parameter_domain(name: str, normal_law: str = "kelvin-voigt") -> Domain:
    """The physical domain of input ``name`` under ``normal_law`` (``KeyError`` if unknown)."""
    return PARAMETER_DOMAINS[name].for_law(normal_law)
