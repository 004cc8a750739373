"""DEM-ready derived quantities (bouncebayes.model.derived_quantities and its parts).

Expected values come from closed forms: Hertz's elastic impact (docs/model.md §7.1), the
rigid-body law of oblique impact with Coulomb friction (docs/model.md §7.2: e_t = 1 -
mu (1 + e) / tan(theta) in gross slip, 1 / (1 + kappa) = 5/7 when the contact point stops
slipping), and the free damped linear oscillator (e and t_c of k_n, c_n).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import bouncebayes as bb
from bouncebayes.model import (DEFAULT_SPEEDS, derived_quantities, equivalent_linear_dashpot,
                               normal_response, oblique_response)

BALL = bb.PAPER_BALL


def test_elastic_normal_response_is_hertz():
    """eta = 0: e = 1 and the contact time is Hertz's t_c (closed form) at every speed, to the
    solver's 1e-8."""
    e, tc = normal_response(BALL, {"mu": 0.3, "eta": np.zeros(3)}, speeds=[0.5, 2.0, 10.0])
    assert e.shape == tc.shape == (3, 3)
    np.testing.assert_allclose(e, 1.0, rtol=0, atol=1e-8)
    hertz = bb.hertz_elastic_impact(BALL, np.array([0.5, 2.0, 10.0])).contact_time
    np.testing.assert_allclose(tc, np.broadcast_to(hertz, (3, 3)), rtol=1e-8)


def test_restitution_decreases_with_damping_and_is_batched_over_draws():
    e, _ = normal_response(BALL, {"mu": 0.2, "eta": np.array([0.5, 1.0, 2.0])})
    assert e.shape == (3, DEFAULT_SPEEDS.size)
    assert (np.diff(e, axis=0) < 0).all() and ((e > 0) & (e < 1)).all()


@pytest.mark.parametrize("tangential", ["none", "mindlin"])
def test_oblique_response_follows_the_rigid_body_law_in_gross_slip(tangential):
    """At large incidence the contact slides throughout: e_t = 1 - mu (1 + e) / tan(theta)
    with e from the same model's head-on impact at the normal speed, and r w' = (u' - u) /
    kappa (closed forms; 1e-6 of the incident speed: the draws use the default solver).
    Hunt–Crossley: its force starts from zero, so the spring does not stick at first touch."""
    mu, v, law = 0.1, 3.0, dict(normal_law="hunt-crossley")
    values = {"mu": mu, "eta": 0.1}
    angles = np.array([60.0, 70.0, 80.0])
    obl = oblique_response(BALL, values, speed=v, angles=angles, tangential=tangential, **law)
    vn = v * np.cos(np.radians(angles))
    e = np.array([normal_response(BALL, values, speeds=[x], **law)[0][0, 0] for x in vn])
    np.testing.assert_allclose(obl.tangential_restitution[0],
                               1.0 - mu * (1.0 + e) / np.tan(np.radians(angles)), atol=1e-6)
    u = v * np.sin(np.radians(angles))
    np.testing.assert_allclose(BALL.radius * obl.rebound_spin[0],
                               u * (obl.tangential_restitution[0] - 1.0) / BALL.inertia_factor,
                               atol=1e-6 * v)


def test_rigid_tangential_contact_rolls_out_at_five_sevenths():
    """Without a spring a contact that stops slipping leaves at u' = u / (1 + kappa) = 5/7 u
    (solid sphere), the plateau the tangentially compliant model departs from."""
    obl = oblique_response(BALL, {"mu": 0.5, "eta": 1.0}, speed=3.0, angles=[10.0, 20.0])
    np.testing.assert_allclose(obl.tangential_restitution, 5.0 / 7.0, rtol=1e-8)
    np.testing.assert_allclose(obl.contact_point_angle, 0.0, atol=1e-6)


def test_equivalent_linear_dashpot_inverts_the_damped_oscillator():
    """A free damped oscillator of k = 1e5 N/m, zeta = 0.1, m = 9.5 g has e = exp(-pi zeta /
    sqrt(1 - zeta^2)) and t_c = pi / (w0 sqrt(1 - zeta^2)); the equivalence gives them back."""
    m, k, zeta = 0.0095, 1e5, np.array([0.0, 0.1, 0.5])
    w0 = math.sqrt(k / m)
    e = np.exp(-np.pi * zeta / np.sqrt(1 - zeta**2))
    tc = np.pi / (w0 * np.sqrt(1 - zeta**2))
    k_eq, c_eq, z_eq = equivalent_linear_dashpot(m, e, tc)
    np.testing.assert_allclose(k_eq, k, rtol=1e-12)
    np.testing.assert_allclose(c_eq, 2 * zeta * math.sqrt(m * k), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(z_eq, zeta, rtol=1e-12, atol=1e-15)
    assert np.isnan(equivalent_linear_dashpot(m, [0.0, 1.2, 0.5], [1e-3, 1e-3, 0.0])[0]).all()


def test_linear_dashpot_law_is_its_own_equivalent_when_undamped():
    """restitution = 1 under the linear law: an undamped spring, t_c = pi sqrt(m / k_n), so
    the equivalent stiffness is k_n itself (closed form) and its damping zero."""
    q = derived_quantities(BALL, {"mu": 0.2, "restitution": 1.0, "normal_stiffness": 5e4},
                           normal_law="linear-dashpot", reference_speed=3.0)
    np.testing.assert_allclose(q["contact_time_at_reference"].values,
                               math.pi * math.sqrt(BALL.mass / 5e4), rtol=1e-8)
    np.testing.assert_allclose(q["linear_normal_stiffness"].values, 5e4, rtol=1e-7)
    np.testing.assert_allclose(q["linear_damping_ratio"].values, 0.0, atol=1e-7)


def test_derived_quantities_carry_definitions_and_transfer_notes():
    draws = {"mu": np.array([0.1, 0.2]), "eta": np.array([1.0, 1.5]),
             "tangential_stiffness_ratio": np.array([0.5, 0.7])}
    q = derived_quantities(BALL, draws, tangential="mindlin", reference_speed=3.0,
                           speeds=[1.0, 3.0], angles=[10.0, 45.0], measured_speeds=(3.5, 2.5))
    assert set(q) == {"normal_restitution", "contact_time", "tangential_restitution",
                      "rebound_spin", "rebound_angle", "restitution_at_reference",
                      "contact_time_at_reference", "linear_normal_stiffness",
                      "linear_normal_damping", "linear_damping_ratio", "friction_coefficient",
                      "tangential_stiffness_ratio"}
    for x in q.values():
        assert x.definition and "this ball" in x.transfer and x.values.shape[0] == 2
        assert "2.5-3.5 m/s" in x.transfer or x.name == "friction_coefficient"
        assert (x.grid is None) == (x.values.ndim == 1)
    assert q["normal_restitution"].grid_unit == "m/s" and q["rebound_spin"].grid_unit == "deg"
    np.testing.assert_array_equal(q["friction_coefficient"].values, [0.1, 0.2])
    np.testing.assert_array_equal(q["tangential_stiffness_ratio"].values, [0.5, 0.7])
    # the curve at 3 m/s is the reference value
    np.testing.assert_array_equal(q["normal_restitution"].values[:, 1],
                                  q["restitution_at_reference"].values)


@pytest.mark.parametrize(("values", "match"), [
    ({"mu": 0.1}, r"`values` must give \['eta'\]"),
    ({"mu": 0.1, "eta": 1.0, "restitution": 0.5}, r"`values` has \['restitution'\], not "
                                                   r"parameters of the contact law"),
    ({"mu": [0.1, 0.2], "eta": [1.0, 2.0, 3.0]}, r"`values` arrays must have one length"),
])
def test_bad_values_are_refused(values, match):
    with pytest.raises(ValueError, match=match):
        normal_response(BALL, values)
