"""Validation of the bounce simulator against results that nobody on this project wrote.

The sources, each cited again by the test that uses it:

- the Hertz closed forms of docs/model.md §3 (K.L. Johnson, *Contact Mechanics*, CUP 1985, §11.4);
- the rigid-body law of oblique impact with Coulomb friction, docs/model.md §3 (``rigid_body_rebound``);
- the figures of Y.C. Chung & J.Y. Ooi, Granular Matter 13, 643-656 (2011),
  doi:10.1007/s10035-011-0277-0, as digitized by the Kratos developers, plus one Kratos DEM run
  (``tests/data/external/chung-ooi-kratos/SOURCE.md``);
- the experiment of A.H. Kharaz, D.A. Gorham & A.D. Salman, Powder Technol. 120, 281-291 (2001),
  digitized twice by third parties (``tests/data/external/kharaz2001-digitized/SOURCE.md``).

Digitized curves are compared with a box test: a point (x, y) passes when the model, evaluated
anywhere within +-1 % of the x-axis range of x, comes within 1 % of the y-axis range of y (the
digitization error that SOURCE.md estimates). Without tangential compliance (the study's model)
oblique benchmarks are compared only where the closed form says the contact slides throughout
the impact; with a Mindlin tangential spring (docs/model.md §5.2) Test 4 and the Kharaz
experiment are compared over the whole incidence range (section "with tangential compliance").
docs/validation.md explains the tolerances and lists the measured agreement; running this file
as a script (``python tests/test_model_validation.py``) prints that agreement.
"""

from __future__ import annotations

import math
from functools import lru_cache
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.special import beta as beta_function

import bouncebayes as bb
from bouncebayes.model import (STANDARD_GRAVITY, hertz_elastic_impact, rigid_body_rebound,
                               simulate_history)

DATA = Path(__file__).parent / "data" / "external"
DIGITIZATION = 0.01  # fraction of an axis range; SOURCE.md: "errors of order 1% of the axis range"
# Exactness checks use tight tolerances: the solver's global error is ~30-80 x rtol (measured),
# so 1e-12 leaves the 1e-8 comparisons below testing the model, not the tolerance.
EXACT = bb.SolverConfig(rtol=1e-12, atol=1e-12)
KAPPA = 0.4  # solid sphere, I = (2/5) m r^2


# --------------------------------------------------------------------------- helpers


def sphere(radius: float, density: float, youngs_modulus: float, poisson_ratio: float) -> bb.Ball:
    """A solid sphere on a rigid plane, from its radius (m) and density (kg/m^3)."""
    mass = density * 4.0 / 3.0 * math.pi * radius**3
    return bb.Ball(radius=radius, mass=mass, youngs_modulus=youngs_modulus,
                   poisson_ratio=poisson_ratio)


def normal_restitution(ball: bb.Ball, eta: float, normal_speed: float,
                       solver: bb.SolverConfig | None = None) -> float:
    """The package's own normal coefficient of restitution (head-on, no gravity)."""
    res = bb.simulate(ball, mu=0.0, eta=eta, speed=normal_speed, angle=0.0, gravity=0.0,
                      solver=solver)
    return float(res.rebound_normal_velocity) / normal_speed


@lru_cache(maxsize=None)
def eta_for_restitution(ball: bb.Ball, restitution: float, normal_speed: float) -> float:
    """Kelvin-Voigt damping (kg/s) giving ``restitution`` at ``normal_speed``, by root-finding."""
    if restitution == 1.0:
        return 0.0
    scale = ball.mass / float(hertz_elastic_impact(ball, normal_speed).contact_time)
    return brentq(lambda eta: normal_restitution(ball, eta, normal_speed) - restitution,
                  0.0, 30.0 * scale, xtol=1e-12 * scale, rtol=1e-14)


def etas_for_restitution(ball: bb.Ball, restitution: float, normal_speed) -> np.ndarray:
    """:func:`eta_for_restitution` element-wise."""
    vn = np.asarray(normal_speed, dtype=float)
    return np.array([eta_for_restitution(ball, restitution, float(v)) for v in vn.ravel()]
                    ).reshape(vn.shape)


def read_kratos(name: str) -> dict[str, np.ndarray]:
    """Series of a Kratos ``.dat`` file, keyed by their ``#label`` line ("" when unlabelled)."""
    series: dict[str, list] = {}
    label = ""
    for line in (DATA / "chung-ooi-kratos" / name).read_text().splitlines():
        line = line.strip()
        if line.startswith("#"):
            label = line.lstrip("#").split("#")[0].strip()
        elif line:
            series.setdefault(label, []).append([float(v) for v in line.replace(",", " ").split()])
    return {k: np.array(v) for k, v in series.items()}


def read_kharaz(digitized_by: str, quantity: str) -> np.ndarray:
    """(incident angle in deg, value) rows of the Kharaz et al. (2001) digitizations.

    The unit field of some rows contains an unquoted comma, so the fields are split from both ends.
    """
    rows = []
    path = DATA / "kharaz2001-digitized" / "kharaz2001_alumina_on_glass_digitized.csv"
    for line in path.read_text().splitlines():
        if line.startswith(("#", "digitized_by,")):
            continue
        who, what, rest = line.split(",", 2)
        _, angle, value = rest.rsplit(",", 2)
        if (who, what) == (digitized_by, quantity):
            rows.append((float(angle), float(value)))
    return np.array(rows)


class Comparison(NamedTuple):
    """Digitized points against the model, with the box tolerance of the module docstring."""

    label: str
    x: np.ndarray
    data: np.ndarray
    model: np.ndarray  # at x
    low: np.ndarray
    high: np.ndarray
    y_range: float

    @property
    def failures(self) -> list[str]:
        bad = (self.data < self.low) | (self.data > self.high)
        rows = zip(self.x[bad], self.data[bad], self.model[bad], self.low[bad], self.high[bad],
                   strict=True)
        return [f"{self.label}: x={x:.4g}: data {d:.4g}, model {m:.4g}, "
                f"allowed [{lo:.4g}, {hi:.4g}]" for x, d, m, lo, hi in rows]

    def summary(self) -> str:
        """Worst |data - model| in % of the y-axis range, and the worst share of the tolerance."""
        err = self.data - self.model
        allowed = np.where(err >= 0.0, self.high - self.model, self.model - self.low)
        worst = np.abs(err).max()
        return (f"{self.label:52s} n={self.x.size:2d}  max|data-model|={worst:.3g} "
                f"({100 * worst / self.y_range:.2f} % of axis)  "
                f"worst/tolerance={np.max(np.abs(err) / allowed):.2f}")


def compare(label, x, data, model, axes, extra=0.0) -> Comparison:
    """Box test of ``data`` at ``x`` against ``model`` (vectorised over any array shape).

    ``axes`` = (x-axis range, y-axis range) of the published figure; ``extra`` widens the y band
    (used only for the experiment's own scatter).
    """
    x_range, y_range = axes
    window = x[:, None] + DIGITIZATION * x_range * np.linspace(-1.0, 1.0, 5)
    values = model(window)
    band = DIGITIZATION * y_range + extra
    return Comparison(label, x, data, values[:, 2], values.min(axis=1) - band,
                      values.max(axis=1) + band, y_range)


def assert_agrees(comparison: Comparison) -> None:
    assert comparison.x.size > 0, f"{comparison.label}: no points in the compared range"
    assert not comparison.failures, "\n".join(comparison.failures)


def gross_slip(psi) -> np.ndarray:
    """Closed-form regime (docs/model.md §3): slides throughout iff (2/7)|s0| / (mu (1+e) V) > 1."""
    return np.asarray(psi) > 1.0


# --------------------------------------------------------------------------- Hertz, normal impact

HERTZ_BALLS = {
    "paper-rubber": bb.PAPER_BALL,
    "alumina-2.5mm": sphere(0.0025, 4000.0, 3.8e11, 0.23),
    "al-alloy-0.1m": sphere(0.1, 2699.0, 7.0e10, 0.30),
}


def hertz_exact(ball: bb.Ball, speed):
    """Hertz elastic impact with the exact contact-time constant (Johnson 1985, §11.4).

    t_c = 2 (delta_max / V) int_0^1 (1 - x^(5/2))^(-1/2) dx, the integral being (2/5) B(2/5, 1/2);
    docs/model.md's 2.8683 is the resulting 2 (15/16)^(2/5) (2/5) B(2/5, 1/2) = 2.868266, rounded.
    """
    m, r, e_star = ball.mass, ball.radius, ball.effective_modulus
    d_max = (15.0 * m * speed**2 / (16.0 * e_star * math.sqrt(r))) ** 0.4
    t_c = 2.0 * d_max / speed * 0.4 * beta_function(0.4, 0.5)
    return d_max, t_c, ball.hertz_stiffness * d_max**1.5


@pytest.mark.parametrize("normal_law", ["kelvin-voigt", "hunt-crossley"])
@pytest.mark.parametrize("name", list(HERTZ_BALLS))
def test_elastic_normal_impact_matches_hertz_closed_forms(name, normal_law):
    """docs/model.md §3 / Johnson §11.4: max overlap, contact time and peak force of an elastic impact.

    Measured agreement with the default solver (rtol = atol = 1e-10): about 3e-10 relative, so the
    tolerance is 1e-8 rather than the 0.5 % first asked for.
    """
    ball = HERTZ_BALLS[name]
    speed = np.array([0.05, 0.2, 1.0, 3.9, 20.0])
    res = bb.simulate(ball, mu=0.0, eta=0.0, speed=speed, angle=0.0, gravity=0.0,
                      normal_law=normal_law)
    d_max, t_c, f_max = hertz_exact(ball, speed)
    np.testing.assert_allclose(res.max_overlap, d_max, rtol=1e-8)
    np.testing.assert_allclose(res.contact_time, t_c, rtol=1e-8)
    np.testing.assert_allclose(res.peak_normal_force, f_max, rtol=1e-8)
    np.testing.assert_allclose(res.rebound_normal_velocity, speed, rtol=1e-8)


def test_hertz_closed_form_helper_is_exact():
    """``hertz_elastic_impact`` uses the exact constant 2.868266 (docs/model.md rounds it to 2.8683):
    it equals the closed forms above, computed independently here, to rounding."""
    ball = HERTZ_BALLS["alumina-2.5mm"]
    helper = hertz_elastic_impact(ball, 3.9)
    d_max, t_c, f_max = hertz_exact(ball, 3.9)
    np.testing.assert_allclose([helper.max_overlap, helper.contact_time, helper.peak_force],
                               [d_max, t_c, f_max], rtol=1e-13)
    # and docs/model.md's printed constant is its 5-digit rounding
    assert round(t_c / helper.contact_time * 2.868266, 4) == 2.8683


# --------------------------------------------------------------------------- Chung & Ooi Tests 1-2


def chung_ooi_test1_ball() -> bb.Ball:
    """Test 1, two identical glass spheres head-on (E 48 GPa, nu 0.20, 2800 kg/m^3, R 10 mm,
    10 m/s each), as the equivalent sphere on a rigid plane: reduced mass m/2, radius
    R1 R2 / (R1 + R2) = R/2, E* = [2 (1 - nu^2) / E]^-1 = E / (2 (1 - nu^2)) (here E/2 with the
    same nu), approach speed 20 m/s; the overlap is that of the two spheres together."""
    glass = sphere(0.010, 2800.0, 4.8e10, 0.20)
    return bb.Ball(radius=glass.radius / 2, mass=glass.mass / 2,
                   youngs_modulus=glass.youngs_modulus / 2, poisson_ratio=glass.poisson_ratio)


# Test 2: Al-alloy sphere (E 70 GPa, 2699 kg/m^3, R 0.1 m) on a rigid plane at 0.2 m/s.
# Poisson's ratio 0.30, not 0.33: both digitized curves say so (best-fit E* = 7.62e10 Pa from
# force-overlap, 7.71e10 from force-time; 0.30 gives 7.69e10, 0.33 gives 7.86e10, force-time rms
# 0.025 vs 0.107 kN), and Kratos (Materials2.json) and YADE (Test2.py) both run this test with 0.30.
CHUNG_OOI_NORMAL = {
    "test1-glass": (chung_ooi_test1_ball(), 20.0, "test1_benchmark1"),
    "test2-al-alloy": (sphere(0.10, 2699.0, 7.0e10, 0.30), 0.2, "test2_benchmark2"),
}


def chung_ooi_normal_comparisons(case: str) -> list[Comparison]:
    """Force-overlap (loading branch) and force-time curves, in um, us and kN (SOURCE.md)."""
    ball, speed, stem = CHUNG_OOI_NORMAL[case]
    hist = simulate_history(ball, mu=0.0, eta=0.0, speed=speed, angle=0.0, gravity=0.0,
                            n_contact=2001, n_flight=0)
    overlap, force, time = hist.overlap * 1e6, hist.normal_force / 1e3, hist.time * 1e6
    loading = slice(0, int(np.argmax(overlap)) + 1)
    out = []
    for graph, x_model, in_range in ((1, overlap[loading], loading), (2, time, slice(None))):
        d = read_kratos(f"{stem}_graph{graph}.dat")[""]
        axes = (np.ptp(d[:, 0]), np.ptp(d[:, 1]))  # figure axes unknown: the data's own extent

        def model(x, xm=x_model, fm=force[in_range]):
            return np.interp(x, xm, fm)

        out.append(compare(f"Chung-Ooi {case} graph{graph}", d[:, 0], d[:, 1], model, axes))
    return out


@pytest.mark.parametrize("case", list(CHUNG_OOI_NORMAL))
def test_chung_ooi_elastic_normal_impact_curves(case):
    """Chung & Ooi (2011) Tests 1-2: the force-overlap and force-time curves of their figures."""
    for comparison in chung_ooi_normal_comparisons(case):
        assert_agrees(comparison)


@pytest.mark.parametrize("case", list(CHUNG_OOI_NORMAL))
def test_chung_ooi_peak_force_and_contact_time(case):
    """Chung & Ooi (2011) Tests 1-2: peak force and contact duration read off the force-time curve
    (duration = last - first digitized time, both at zero force), within 1 % of each axis."""
    ball, speed, stem = CHUNG_OOI_NORMAL[case]
    d = read_kratos(f"{stem}_graph2.dat")[""]
    res = bb.simulate(ball, mu=0.0, eta=0.0, speed=speed, angle=0.0, gravity=0.0)
    t_data, f_data = (d[-1, 0] - d[0, 0]) * 1e-6, d[:, 1].max() * 1e3
    assert abs(float(res.contact_time) - t_data) <= DIGITIZATION * np.ptp(d[:, 0]) * 1e-6
    assert abs(float(res.peak_normal_force) - f_data) <= DIGITIZATION * np.ptp(d[:, 1]) * 1e3


# --------------------------------------------------------------------------- energy


def mechanical_energy(hist, ball: bb.Ball) -> np.ndarray:
    """Translational + rotational kinetic energy + Hertz elastic energy (2/5) k d^(5/2), J."""
    k = ball.hertz_stiffness
    d = np.where(hist.in_contact, np.clip(hist.overlap, 0.0, None), 0.0)
    kinetic = 0.5 * hist.mass * (hist.tangential_velocity**2 + hist.normal_velocity**2)
    return kinetic + 0.5 * hist.moment_of_inertia * hist.spin**2 + 0.4 * k * d**2.5


@pytest.mark.parametrize("gravity", [0.0, STANDARD_GRAVITY])
def test_elastic_frictionless_bounce_conserves_speed(gravity):
    """docs/model.md §3: eta = 0 and mu = 0 conserve kinetic energy and leave u and spin unchanged;
    with gravity the ball leaves at the height where it touched, so its speed is unchanged too."""
    speed = np.array([0.5, 4.0])[:, None, None]
    angle = np.array([0.0, 20.0, 45.0, 70.0, 85.0])[:, None]
    spin = np.array([-500.0, 0.0, 300.0])
    res = bb.simulate(bb.PAPER_BALL, mu=0.0, eta=0.0, speed=speed, angle=angle, spin=spin,
                      gravity=gravity, solver=EXACT)
    np.testing.assert_allclose(res.rebound_speed, np.broadcast_to(speed, res.shape), rtol=1e-8)
    np.testing.assert_allclose(res.rebound_tangential_velocity,
                               np.broadcast_to(speed * np.sin(np.radians(angle)), res.shape),
                               rtol=1e-8, atol=1e-8 * 4.0)
    np.testing.assert_array_equal(res.rebound_spin, np.broadcast_to(spin, res.shape))


@pytest.mark.parametrize(("mu", "eta", "normal_law"), [
    (0.3, 0.0, "kelvin-voigt"), (0.0, 1.35, "kelvin-voigt"), (0.16, 1.35, "kelvin-voigt"),
    (1.0, 5.0, "kelvin-voigt"), (0.3, 0.05, "hunt-crossley")])
@pytest.mark.parametrize(("angle", "spin"), [(10.0, 0.0), (45.0, -200.0), (45.0, 300.0),
                                             (75.0, 0.0)])
def test_mechanical_energy_never_increases_during_contact(mu, eta, normal_law, angle, spin):
    """docs/model.md §3: with mu > 0 or eta > 0 the energy never increases (gravity off). The samples
    may rise by interpolation noise only (measured <= 3e-11 of the initial energy)."""
    hist = simulate_history(bb.PAPER_BALL, mu=mu, eta=eta, speed=4.0, angle=angle, spin=spin,
                            gravity=0.0, normal_law=normal_law, solver=EXACT, n_contact=400,
                            n_flight=20)
    energy = mechanical_energy(hist, bb.PAPER_BALL)
    assert np.diff(energy).max() <= 1e-9 * energy[0]
    assert energy[-1] < energy[0]


def test_rebound_kinetic_energy_not_above_incident():
    """docs/model.md §3: translational + rotational kinetic energy after <= before (gravity off), and
    strictly less whenever there is damping."""
    ball = bb.PAPER_BALL
    mu = np.array([0.0, 0.1, 0.5])[:, None, None, None]
    eta = np.array([0.0, 0.5, 3.0])[:, None, None]
    angle = np.array([0.0, 15.0, 40.0, 80.0])[:, None]
    spin = np.array([-400.0, 0.0, 250.0])
    res = bb.simulate(ball, mu=mu, eta=eta, speed=3.0, angle=angle, spin=spin, gravity=0.0,
                      solver=EXACT)
    before = np.broadcast_to(0.5 * ball.mass * 3.0**2 + 0.5 * ball.moment_of_inertia * spin**2,
                             res.shape)
    after = (0.5 * ball.mass * res.rebound_speed**2
             + 0.5 * ball.moment_of_inertia * res.rebound_spin**2)
    assert np.all(after <= before * (1.0 + 1e-9))
    damped = np.broadcast_to(eta > 0.0, res.shape)
    assert np.all(after[damped] < before[damped] * (1.0 - 1e-3))


# --------------------------------------------------------------------------- rigid-body law


OBLIQUE_BALLS = {  # ball, eta (kg/s); the shell checks the law's kappa/(1+kappa) generalisation
    "paper-rubber": (bb.PAPER_BALL, 1.35),
    "steel-5mm": (sphere(0.005, 7850.0, 2.1e11, 0.30), 5.0),
    "rubber-shell": (bb.Ball(radius=0.0128, mass=0.0095, youngs_modulus=5.0e6, poisson_ratio=0.49,
                             inertia_factor=2.0 / 3.0), 1.35),
}


def rigid_body_reference(ball, eta, *, mu, speed, angle, spin):
    """``rigid_body_rebound`` with e from the package's own normal rebound at the normal speed."""
    theta = np.radians(angle)
    vn = speed * np.cos(theta)
    e = np.vectorize(lambda v: normal_restitution(ball, eta, float(v), EXACT))(vn)
    return rigid_body_rebound(tangential_velocity=speed * np.sin(theta), normal_speed=vn,
                              spin=spin, radius=ball.radius, mu=mu, restitution=e,
                              inertia_factor=ball.inertia_factor)


def assert_matches_rigid_body(ball, eta, *, mu, speed, angle, spin, rolling):
    res = bb.simulate(ball, mu=mu, eta=eta, speed=speed, angle=angle, spin=spin, gravity=0.0,
                      solver=EXACT)
    ref = rigid_body_reference(ball, eta, mu=mu, speed=speed, angle=angle, spin=spin)
    assert np.all(ref.rolling == rolling), "the cases must be in the intended regime"
    np.testing.assert_array_equal(res.rolling, ref.rolling)
    scale = np.maximum(speed, np.abs(ball.radius * spin))  # the incident velocity scale, m/s
    for got, want, unit in ((res.rebound_tangential_velocity, ref.tangential_velocity, 1.0),
                            (res.rebound_normal_velocity, ref.normal_velocity, 1.0),
                            (res.rebound_spin, ref.spin, 1.0 / ball.radius)):
        deviation = np.abs(got - want) / (scale * unit)
        assert np.all(deviation <= 1e-8), f"relative deviations {deviation}"
    return res


@pytest.mark.parametrize("name", list(OBLIQUE_BALLS))
def test_oblique_sliding_regime_matches_rigid_body_law(name):
    """docs/model.md §3 gross slip, mu (1+e) V < (2/7)|s0|: U' = U - mu(1+e)V sign(s0),
    w' = w0 - (5/2) mu (1+e) V sign(s0) / r. Slip of both signs (backspin makes s0 < 0)."""
    ball, eta = OBLIQUE_BALLS[name]
    cases = np.array([  # mu, speed, angle, spin
        [0.05, 4.0, 40.0, 0.0], [0.05, 4.0, 70.0, 200.0], [0.05, 4.0, 40.0, -300.0],
        [0.2, 4.0, 70.0, 0.0], [0.1, 2.0, 60.0, -30.0 / ball.radius],
        [0.3, 3.0, 15.0, -12.0 / ball.radius]])
    mu, speed, angle, spin = cases.T
    assert_matches_rigid_body(ball, eta, mu=mu, speed=speed, angle=angle, spin=spin,
                              rolling=False)


@pytest.mark.parametrize("name", list(OBLIQUE_BALLS))
def test_oblique_rolling_regime_matches_rigid_body_law_whatever_mu(name):
    """docs/model.md §3 rolling: U' = U - (2/7) s0, w' = w0 - (5/7) s0 / r, independent of mu."""
    ball, eta = OBLIQUE_BALLS[name]
    angle = np.array([15.0, 40.0, 70.0, 40.0])
    spin = np.array([0.0, 0.0, -300.0, 200.0])
    results = [assert_matches_rigid_body(ball, eta, mu=mu, speed=4.0, angle=angle, spin=spin,
                                         rolling=True) for mu in (0.6, 1.0, 2.5)]
    for res in results[1:]:
        for field in ("rebound_tangential_velocity", "rebound_normal_velocity", "rebound_spin"):
            np.testing.assert_allclose(getattr(res, field), getattr(results[0], field),
                                       rtol=1e-8, atol=0.0)


# --------------------------------------------------------------------------- Chung & Ooi 4, Kharaz


# Test 4 / Kharaz et al. (2001): 5 mm alumina spheres at 3.9 m/s, mu = 0.092, e = 0.98 (SOURCE.md).
# Chung & Ooi also ran an Al-alloy sphere (E 70 GPa, nu 0.33, 2700 kg/m^3, as in YADE's Test4.py).
T4_BALLS = {"oxide": sphere(0.0025, 4000.0, 3.8e11, 0.23),
            "alloy": sphere(0.0025, 2700.0, 7.0e10, 0.33)}
T4_SPEED, T4_MU, T4_E = 3.9, 0.092, 0.98
# Axes of Chung & Ooi's Test 4 figures (x: incident angle 0-90 deg), as Kratos replots them
# (Chung_Ooi_class.py): tangential COR 0.4-1, spin -750-0 rad/s, rebound angle -30-90 deg.
T4_AXES = {"et": (90.0, 0.6), "spin": (90.0, 750.0), "patch": (90.0, 120.0), "com": (90.0, 120.0)}


def bench4_model(ball: bb.Ball, quantity: str, *, sliding: bool = True):
    """Rebound quantity vs incident angle (deg); checks the package's regime on the way.

    Signs: the package's spin is counter-clockwise about z = x (forward) cross y (outward normal);
    in Kratos's Test 4 the ball moves along +Y with the normal along +Z, so that axis is Kratos's X
    and ANGULAR_VELOCITY_X is this spin (negative = topspin). Contact-patch rebound angle =
    atan((u' + r w') / v'n) as in Chung_Ooi_class.py; centre-of-mass angle = atan(u' / v'n).
    """

    def model(angle):
        vn = T4_SPEED * np.cos(np.radians(angle))
        res = bb.simulate(ball, mu=T4_MU, eta=etas_for_restitution(ball, T4_E, vn),
                          speed=T4_SPEED, angle=angle, gravity=0.0)
        assert np.all(res.rolling != sliding)
        u, v, w = (res.rebound_tangential_velocity, res.rebound_normal_velocity,
                   res.rebound_spin)
        return {"et": u / (T4_SPEED * np.sin(np.radians(angle))), "spin": w,
                "patch": np.degrees(np.arctan((u + ball.radius * w) / v)),
                "com": res.rebound_angle}[quantity]

    return model


def bench4_in_range(angle) -> np.ndarray:
    """Points whose whole digitization window slides throughout: tan(theta) > 3.5 mu (1+e),
    theta > 32.5 deg, i.e. theta > 33.4 deg once the 0.9 deg window is taken off."""
    lowest = np.radians(np.asarray(angle) - DIGITIZATION * 90.0)
    return gross_slip(np.tan(lowest) / (3.5 * T4_MU * (1.0 + T4_E)))


T4_FILES = {"et": "test4_benchmark4_graph1_tangential_COR.dat",
            "spin": "test4_benchmark4_graph2_angular_velocity.dat",
            "patch": "test4_benchmark4_graph3_rebound_angle.dat"}
# (quantity, series label, material); the "Al. alloy" series of graph 3 is a copy of "Al. oxide"
T4_DEM_SERIES = [("et", "Oxide", "oxide"), ("et", "Alloy", "alloy"),
                 ("spin", "Al. oxide", "oxide"), ("spin", "Al. alloy", "alloy"),
                 ("patch", "Al. oxide", "oxide")]
T4_KRATOS_RUN = {"et": "tangential_COR", "spin": "angular_velocity", "patch": "rebound_angle"}


def bench4_dem_comparison(quantity: str, label: str, material: str) -> Comparison:
    """Chung & Ooi's own DEM curve (their figure, digitized)."""
    d = read_kratos(T4_FILES[quantity])[label]
    d = d[bench4_in_range(d[:, 0])]
    return compare(f"Chung-Ooi Test 4 {label} {quantity}", d[:, 0], d[:, 1],
                   bench4_model(T4_BALLS[material], quantity), T4_AXES[quantity])


def bench4_kratos_run_comparison(quantity: str) -> Comparison:
    """Kratos's DEM run (exact angles: no x window; y band 1 % of the figure's axis)."""
    d = read_kratos(f"test4_kratos_dem_output_{T4_KRATOS_RUN[quantity]}.dat")[""]
    d = d[bench4_in_range(d[:, 0])]
    return compare(f"Kratos DEM run, Test 4 {quantity}", d[:, 0], d[:, 1],
                   bench4_model(T4_BALLS["oxide"], quantity), (0.0, T4_AXES[quantity][1]))


def kharaz_spin_scatter() -> float:
    """How far Kharaz's measured spin and e_t disagree with each other, rad/s.

    For a sphere, r (w' - w0) = (u' - u) / kappa exactly, whatever the tangential force law
    (angular and linear impulse of one contact force). At Lethe's three pairs of angles less than
    1 deg apart, the spin implied by the measured e_t differs from the measured spin by up to
    ~49 rad/s (at 60 deg), both digitizations agreeing to ~6 rad/s: experimental scatter, which
    the spin comparison must allow for.
    """
    et = read_kharaz("lethe_postprocessing", "tangential_COR_et")
    spin = read_kharaz("lethe_postprocessing", "angular_velocity_after")
    worst = 0.0
    for angle, magnitude in spin:
        j = int(np.argmin(np.abs(et[:, 0] - angle)))
        if abs(et[j, 0] - angle) < 1.0:
            du = (et[j, 1] - 1.0) * T4_SPEED * np.sin(np.radians(et[j, 0]))
            worst = max(worst, abs(magnitude - abs(du / (KAPPA * T4_BALLS["oxide"].radius))))
    return worst


# (digitized_by, quantity in the csv, model quantity, sign): Lethe stores |spin|
KHARAZ_SERIES = [("kratos_chung_ooi_fig", "tangential_COR_et", "et", 1.0),
                 ("lethe_postprocessing", "tangential_COR_et", "et", 1.0),
                 ("kratos_chung_ooi_fig", "angular_velocity_after", "spin", 1.0),
                 ("lethe_postprocessing", "angular_velocity_after", "spin", -1.0),
                 ("kratos_chung_ooi_fig", "rebound_angle_contact_patch", "patch", 1.0),
                 ("lethe_postprocessing", "rebound_angle_centre_of_mass", "com", 1.0)]


def kharaz_comparison(who: str, name: str, quantity: str, sign: float) -> Comparison:
    """The Kharaz et al. (2001) experiment; spin gets the experiment's own scatter on top."""
    d = read_kharaz(who, name)
    d = d[bench4_in_range(d[:, 0])]
    base = bench4_model(T4_BALLS["oxide"], quantity)
    extra = kharaz_spin_scatter() if quantity == "spin" else 0.0
    return compare(f"Kharaz 2001 ({who}) {quantity}", d[:, 0], d[:, 1],
                   lambda a: sign * base(a), T4_AXES[quantity], extra=extra)


def test_kharaz_spin_scatter_is_the_experiments_own():
    """The extra spin tolerance is measured from the experiment itself (see kharaz_spin_scatter)
    and stays well below the spin scale (710 cos(theta) rad/s)."""
    assert 30.0 < kharaz_spin_scatter() < 60.0


@pytest.mark.parametrize(("quantity", "label", "material"), T4_DEM_SERIES)
def test_chung_ooi_test4_dem_curves_in_sliding_range(quantity, label, material):
    """Chung & Ooi (2011) Test 4, their DEM curves, for incidence > 33.4 deg (gross slip)."""
    assert_agrees(bench4_dem_comparison(quantity, label, material))


@pytest.mark.parametrize("quantity", list(T4_KRATOS_RUN))
def test_kratos_dem_run_test4_in_sliding_range(quantity):
    """Kratos DEM_D_Hertz_viscous_Coulomb run of Test 4 (cross-code), incidence > 33.4 deg."""
    assert_agrees(bench4_kratos_run_comparison(quantity))


@pytest.mark.parametrize(("who", "name", "quantity", "sign"), KHARAZ_SERIES)
def test_kharaz_experiment_in_sliding_range(who, name, quantity, sign):
    """Kharaz, Gorham & Salman (2001) rebound of alumina spheres, incidence > 33.4 deg."""
    assert_agrees(kharaz_comparison(who, name, quantity, sign))


# --------------------------------------------------------------------------- with tangential compliance


# The compliant model: Mindlin's no-slip spring (docs/model.md §5.2) at the stiffness ratio of
# the sphere's Poisson ratio, 2(1-nu)/(2-nu) (0.870 for alumina), as Chung & Ooi's Hertz-Mindlin
# codes and Kratos's run take it; nothing is fitted.
T4_COMPLIANT_FROM = 9.0  # deg: below, see test_low_incidence_is_left_to_the_record
T4_GRIP = (T4_COMPLIANT_FROM, 33.4)  # deg: the grip range, below gross slip (bench4_in_range)


def bench4_compliant_model(ball: bb.Ball, quantity: str, tangential: str = "mindlin"):
    """As :func:`bench4_model`, with a tangential spring (and no regime check)."""

    def model(angle):
        angle = np.asarray(angle, dtype=float)
        vn = T4_SPEED * np.cos(np.radians(angle))
        res = bb.simulate(ball, mu=T4_MU, eta=etas_for_restitution(ball, T4_E, vn),
                          speed=T4_SPEED, angle=angle, gravity=0.0, tangential=tangential)
        u, v, w = (res.rebound_tangential_velocity, res.rebound_normal_velocity,
                   res.rebound_spin)
        return {"et": u / (T4_SPEED * np.sin(np.radians(angle))), "spin": w,
                "patch": np.degrees(np.arctan((u + ball.radius * w) / v)),
                "com": res.rebound_angle}[quantity]

    return model


def kharaz_scatter_in(quantity: str, angle) -> np.ndarray:
    """The experiment's own inconsistency (``kharaz_spin_scatter``, a spin of ds rad/s) carried
    into each quantity through r (w' - w0) = (u' - u) / kappa: a change du = kappa r ds of u'
    moves e_t by du / (V sin theta), the centre-of-mass angle by about du / v'_n and the
    contact-point angle by (1 + kappa) r ds / v'_n (radians, v'_n ~ e V cos theta)."""
    ds = kharaz_spin_scatter()
    r = T4_BALLS["oxide"].radius
    a = np.radians(np.asarray(angle, dtype=float))
    vn_out = T4_E * T4_SPEED * np.cos(a)
    return {"et": KAPPA * r * ds / (T4_SPEED * np.sin(a)), "spin": np.full(a.shape, ds),
            "com": np.degrees(KAPPA * r * ds / vn_out),
            "patch": np.degrees((1.0 + KAPPA) * r * ds / vn_out)}[quantity]


def compliant_comparison(source: str, spec: tuple) -> Comparison:
    """Test 4 with a Mindlin spring, from ``T4_COMPLIANT_FROM`` to grazing: Chung & Ooi's DEM
    curves and the Kharaz experiment by the box test (the experiment's with its own scatter
    on top), Kratos's run at its exact angles."""
    if source == "chung-ooi":
        quantity, label, material = spec
        d = read_kratos(T4_FILES[quantity])[label]
        model, axes, extra = (bench4_compliant_model(T4_BALLS[material], quantity),
                              T4_AXES[quantity], 0.0)
        name = f"Chung-Ooi Test 4 {label} {quantity}, Mindlin"
    elif source == "kratos":
        (quantity,) = spec
        d = read_kratos(f"test4_kratos_dem_output_{T4_KRATOS_RUN[quantity]}.dat")[""]
        model, axes, extra = (bench4_compliant_model(T4_BALLS["oxide"], quantity),
                              (0.0, T4_AXES[quantity][1]), 0.0)
        name = f"Kratos DEM run, Test 4 {quantity}, Mindlin"
    else:
        who, what, quantity, sign = spec
        d = read_kharaz(who, what)
        base = bench4_compliant_model(T4_BALLS["oxide"], quantity)
        model, axes = (lambda a: sign * base(a)), T4_AXES[quantity]
        name = f"Kharaz 2001 ({who}) {quantity}, Mindlin"
    d = d[d[:, 0] >= T4_COMPLIANT_FROM]
    if source == "kharaz":
        extra = kharaz_scatter_in(quantity, d[:, 0])
    return compare(name, d[:, 0], d[:, 1], model, axes, extra=extra)


COMPLIANT_CASES = ([("chung-ooi", spec) for spec in T4_DEM_SERIES]
                   + [("kratos", (q,)) for q in T4_KRATOS_RUN]
                   + [("kharaz", spec) for spec in KHARAZ_SERIES])


@pytest.mark.parametrize(("source", "spec"), COMPLIANT_CASES,
                         ids=[f"{s}-{'-'.join(map(str, x[:3]))}" for s, x in COMPLIANT_CASES])
def test_test4_and_kharaz_with_tangential_compliance(source, spec):
    """Chung & Ooi (2011) Test 4 and Kharaz et al. (2001) from 9 deg to grazing with the Mindlin
    spring: within the digitization band of 1 % of each axis (Chung & Ooi's curves, Kratos's
    run), plus, for the experiment, its own measured scatter (``kharaz_scatter_in``). Measured
    agreement: docs/validation.md §5."""
    assert_agrees(compliant_comparison(source, spec))


def grip_misfit(model, data: np.ndarray) -> float:
    """RMS of data - model over the grip range (9 to 33.4 deg)."""
    d = data[(data[:, 0] >= T4_GRIP[0]) & (data[:, 0] <= T4_GRIP[1])]
    return float(np.sqrt(np.mean((d[:, 1] - model(d[:, 0])) ** 2)))


@pytest.mark.parametrize("spec", KHARAZ_SERIES, ids=[f"{w}-{q}" for w, _, q, _ in KHARAZ_SERIES])
def test_compliance_explains_the_grip_regime(spec):
    """In the grip range, where the study's rigid tangential contact stops applying, the Mindlin
    spring brings the measured rebound at least twice as close (RMS over 9-33.4 deg) as the
    rigid contact: measured 2.2 to 4.4 times (e_t 2.8 / 2.2, spin 3.4 / 3.4, contact-point angle
    4.4, centre-of-mass angle 2.3; docs/validation.md §5). Near 9 deg both models agree and
    the measured e_t lies below both, which caps the ratio."""
    who, what, quantity, sign = spec
    data = read_kharaz(who, what)
    ball = T4_BALLS["oxide"]
    spring = grip_misfit(lambda a: sign * bench4_compliant_model(ball, quantity)(a), data)
    rigid = grip_misfit(lambda a: sign * bench4_compliant_model(ball, quantity, "none")(a),
                        data)
    assert spring < rigid / 2.0, (spring, rigid)


def test_low_incidence_is_left_to_the_record():
    """Below 9 deg the measured e_t (0.75-0.80 at 2-4 deg) lies far below every Hertz-Mindlin
    model, this one (0.87-0.88) and Kratos's DEM run (0.854 at 5 deg) alike, while this model
    and Kratos's run agree (0.006): the experiment there is not a test of this package's
    implementation (docs/validation.md §5). Guard: the agreement with Kratos at 5 deg."""
    run = read_kratos("test4_kratos_dem_output_tangential_COR.dat")[""]
    at5 = run[run[:, 0] == 5.0][0]
    model = float(bench4_compliant_model(T4_BALLS["oxide"], "et")(np.array([5.0]))[0])
    assert abs(model - at5[1]) < 0.015 * T4_AXES["et"][1]
    measured = read_kharaz("kratos_chung_ooi_fig", "tangential_COR_et")
    assert (measured[measured[:, 0] < 5.0, 1] < model - 0.05).all()


# --------------------------------------------------------------------------- Chung & Ooi Tests 5-6


# Test 5: mu = 0.3, normal speed 5 m/s, elastic (e = 1: the sliding branch passes through
# (10, 3) and (13, 6), i.e. psi2 = psi1 - 3.5 (1 + e) with e = 1), R = 10 um as in Kratos.
# Steel 208 GPa / 0.30 / 7850 kg/m^3 and polyethylene 1 GPa / 0.40 / 1400 kg/m^3 as in PySPH's
# Chung-Ooi Test 5 script; in the sliding range the result does not depend on them.
T5_BALLS = {"Steel": sphere(1e-5, 7850.0, 2.08e11, 0.30),
            "Polyethylene": sphere(1e-5, 1400.0, 1.0e9, 0.40)}
T5_MU, T5_VN = 0.3, 5.0
T5_FILES = {1: "test5_benchmark5_graph1_recoil_angle.dat",
            2: "test5_benchmark5_graph2_angular_velocity.dat"}
T5_AXES = {1: (14.0, 10.0), 2: (20.0, 6.0)}  # Kratos's replot: [0:14][-4:6], [0:20][-6:0]


def bench5_model(ball: bb.Ball, graph: int, *, sliding: bool = True):
    """psi1 = Vst / (mu Vcn) -> graph 1: V'st / (mu V'cn), graph 2: R w' / (mu Vcn),
    with V'st = u' + r w' the contact-point velocity (Chung_Ooi_class.py, Benchmark5)."""

    def model(psi1):
        u0 = psi1 * T5_MU * T5_VN
        res = bb.simulate(ball, mu=T5_MU, eta=0.0, speed=np.hypot(u0, T5_VN),
                          angle=np.degrees(np.arctan2(u0, T5_VN)), gravity=0.0)
        assert np.all(res.rolling != sliding)
        rw = ball.radius * res.rebound_spin
        if graph == 1:
            return (res.rebound_tangential_velocity + rw) / (T5_MU * res.rebound_normal_velocity)
        return rw / (T5_MU * T5_VN)

    return model


def bench5_comparison(graph: int, material: str) -> Comparison:
    d = read_kratos(T5_FILES[graph])[material]
    lowest = d[:, 0] - DIGITIZATION * T5_AXES[graph][0]
    d = d[gross_slip(lowest / (3.5 * 2.0))]  # psi1 > 3.5 (1 + e) = 7, window included
    return compare(f"Chung-Ooi Test 5 {material} graph{graph}", d[:, 0], d[:, 1],
                   bench5_model(T5_BALLS[material], graph), T5_AXES[graph])


# Test 6: a spinning sphere (no tangential velocity of the centre) hits the plane at 0.2 m/s;
# mu = 0.4, e = 0.5, R = 0.1 m (Kratos's Benchmark6). Al alloy 70 GPa / 0.33 / 2700 kg/m^3, nylon
# 2.5 GPa / 0.40 / 1000 kg/m^3 (chosen; in the sliding range the result does not depend on them).
T6_BALLS = {"Al. alloy": sphere(0.1, 2700.0, 7.0e10, 0.33),
            "Nylon": sphere(0.1, 1000.0, 2.5e9, 0.40)}
T6_MU, T6_E, T6_VN = 0.4, 0.5, 0.2
T6_FILES = {1: "test6_benchmark6_graph1_beta.dat",
            2: "test6_benchmark6_graph2_recoil_vs_incident.dat"}
T6_AXES = {1: (25.0, 1.6), 2: (7.0, 10.0)}  # Kratos's replot: [0:25][-1:.6], [0:7][-2:8]
T6_SCALE = 3.5 * T6_MU * (1.0 + T6_E)  # = 2.1: gross slip iff Vst / Vcn > 2.1


def bench6_model(ball: bb.Ball, graph: int, *, sliding: bool = True):
    """Graph 1: chi = 3.5 mu (1+e) Vcn / Vst -> beta = -V'st / Vst; graph 2: Vst / Vcn ->
    V'st / V'cn, with Vst = r w0 (the centre has no tangential velocity) and V'st = u' + r w'."""
    eta = eta_for_restitution(ball, T6_E, T6_VN)

    def model(x):
        slip = T6_SCALE * T6_VN / x if graph == 1 else x * T6_VN
        res = bb.simulate(ball, mu=T6_MU, eta=eta, speed=T6_VN, angle=0.0,
                          spin=slip / ball.radius, gravity=0.0)
        assert np.all(res.rolling != sliding)
        slip_out = res.rebound_tangential_velocity + ball.radius * res.rebound_spin
        return -slip_out / slip if graph == 1 else slip_out / res.rebound_normal_velocity

    return model


def bench6_comparison(graph: int, material: str) -> Comparison:
    d = read_kratos(T6_FILES[graph])[material]
    window = DIGITIZATION * T6_AXES[graph][0]
    psi = 1.0 / (d[:, 0] + window) if graph == 1 else (d[:, 0] - window) / T6_SCALE
    d = d[gross_slip(psi)]
    return compare(f"Chung-Ooi Test 6 {material} graph{graph}", d[:, 0], d[:, 1],
                   bench6_model(T6_BALLS[material], graph), T6_AXES[graph])


@pytest.mark.parametrize("graph", [1, 2])
@pytest.mark.parametrize("material", list(T5_BALLS))
def test_chung_ooi_test5_in_sliding_range(material, graph):
    """Chung & Ooi (2011) Test 5, their DEM curves, where psi1 > 7 (gross slip)."""
    assert_agrees(bench5_comparison(graph, material))


@pytest.mark.parametrize("graph", [1, 2])
@pytest.mark.parametrize("material", list(T6_BALLS))
def test_chung_ooi_test6_in_sliding_range(material, graph):
    """Chung & Ooi (2011) Test 6, their DEM curves, where Vst / Vcn > 2.1 (gross slip)."""
    assert_agrees(bench6_comparison(graph, material))


# --------------------------------------------------------------------------- where the model stops


def test_model_without_tangential_compliance_misses_the_grip_regime():
    """Below gross slip the package leaves the ball rolling (V'st = 0), while the data show what a
    rigid tangential contact cannot produce: a reversed contact-point velocity, i.e. the grip-slip
    and spin reversal of a compliant contact (Maw, Barber & Fawcett, Wear 38, 101, 1976): Kharaz's
    e_t at 20 deg, Test 5 at psi1 = 4, Test 6 at chi = 1.45. Each point here lies more
    than 5 tolerances away; this is why the comparisons above stop at gross slip
    (docs/validation.md)."""
    kharaz_et = read_kharaz("kratos_chung_ooi_fig", "tangential_COR_et")
    cases = [  # model (package, rolling regime), digitized (x, y) nearest x, y-axis range
        (bench4_model(T4_BALLS["oxide"], "et", sliding=False), nearest(kharaz_et, 20.0),
         T4_AXES["et"][1]),
        (bench5_model(T5_BALLS["Polyethylene"], 1, sliding=False),
         nearest(read_kratos(T5_FILES[1])["Polyethylene"], 4.0), T5_AXES[1][1]),
        (bench6_model(T6_BALLS["Nylon"], 1, sliding=False),
         nearest(read_kratos(T6_FILES[1])["Nylon"], 1.45), T6_AXES[1][1]),
    ]
    for model, (x, data), y_range in cases:
        assert abs(float(model(np.array(x))) - data) > 5 * DIGITIZATION * y_range


def nearest(points: np.ndarray, x: float) -> np.ndarray:
    """The digitized (x, y) row whose x is closest to ``x``."""
    return points[np.argmin(np.abs(points[:, 0] - x))]


if __name__ == "__main__":  # prints the measured agreement quoted in docs/validation.md
    comparisons = [c for case in CHUNG_OOI_NORMAL for c in chung_ooi_normal_comparisons(case)]
    comparisons += [bench4_dem_comparison(*spec) for spec in T4_DEM_SERIES]
    comparisons += [bench4_kratos_run_comparison(q) for q in T4_KRATOS_RUN]
    comparisons += [kharaz_comparison(*spec) for spec in KHARAZ_SERIES]
    comparisons += [bench5_comparison(g, m) for m in T5_BALLS for g in (1, 2)]
    comparisons += [bench6_comparison(g, m) for m in T6_BALLS for g in (1, 2)]
    comparisons += [compliant_comparison(*case) for case in COMPLIANT_CASES]
    for c in comparisons:
        print(c.summary())
    print(f"Kharaz spin scatter (the experiment's own): {kharaz_spin_scatter():.1f} rad/s")
