"""The forward model's API: validation, broadcasting, statuses, histories, the compiled tableau.

Physics against independent sources lives in test_model_validation.py (closed forms, published
data) and test_model_reference.py (an independent SciPy implementation).
"""

import numpy as np
import pytest
from scipy.integrate import RK45

import bouncebayes as bb
from bouncebayes.model import Status, simulate_history
from bouncebayes.model import _kernel as K

PAPER = dict(mu=0.16, eta=1.35, speed=3.0, angle=60.0)


def test_tableau_is_scipys_rk45():
    """The hand-written Dormand–Prince coefficients equal SciPy's RK45 (the source we copy)."""
    a = np.array([[0, 0, 0, 0, 0], [K.A21, 0, 0, 0, 0], [K.A31, K.A32, 0, 0, 0],
                  [K.A41, K.A42, K.A43, 0, 0], [K.A51, K.A52, K.A53, K.A54, 0],
                  [K.A61, K.A62, K.A63, K.A64, K.A65]])
    np.testing.assert_allclose(a, RK45.A, rtol=1e-15, atol=0)
    np.testing.assert_allclose([K.B1, 0, K.B3, K.B4, K.B5, K.B6], RK45.B, rtol=1e-15, atol=0)
    np.testing.assert_allclose([K.E1, 0, K.E3, K.E4, K.E5, K.E6, K.E7], RK45.E, rtol=1e-15,
                               atol=0)
    np.testing.assert_allclose(K.DENSE, RK45.P, rtol=1e-15, atol=0)


@pytest.mark.parametrize(("kwargs", "match"), [
    (dict(radius=0.0), r"`radius` must be a finite number > 0 m; got 0.0"),
    (dict(mass=-1.0), r"`mass` must be a finite number > 0 kg; got -1.0"),
    (dict(youngs_modulus=float("nan")), r"`youngs_modulus` must be .* got nan"),
    (dict(poisson_ratio=0.6), r"`poisson_ratio` must be a finite number in \(-1, 0.5\]"),
    (dict(poisson_ratio=-1.0), r"`poisson_ratio` .* got -1.0"),
    (dict(inertia_factor=1.5), r"`inertia_factor` must be a finite number in \(0, 1\]"),
])
def test_ball_rejects_nonphysical_values(kwargs, match):
    base = dict(radius=0.01, mass=0.01, youngs_modulus=1e7, poisson_ratio=0.4)
    with pytest.raises(ValueError, match=match):
        bb.Ball(**(base | kwargs))


def test_ball_rejects_wrong_types():
    with pytest.raises(TypeError, match=r"`radius` must be a real number \(in m\); got '1'"):
        bb.Ball(radius="1", mass=0.01, youngs_modulus=1e7, poisson_ratio=0.4)


def test_ball_from_diameter_and_density():
    ball = bb.Ball.from_diameter(0.02, density=1000.0, youngs_modulus=1e7, poisson_ratio=0.4)
    # closed form: m = rho pi d^3 / 6
    assert ball.mass == pytest.approx(1000.0 * np.pi * 0.02**3 / 6, rel=1e-15)
    assert ball.density == pytest.approx(1000.0, rel=1e-14)
    with pytest.raises(ValueError, match="give exactly one of `mass`"):
        bb.Ball.from_diameter(0.02, mass=0.01, density=1000.0, youngs_modulus=1e7,
                              poisson_ratio=0.4)


@pytest.mark.parametrize(("name", "value", "match"), [
    ("angle", 90.0, r"`angle` must be a finite number in \[0, 90\) deg; got 90.0"),
    ("angle", -1.0, r"`angle` .* got -1.0"),
    ("speed", 0.0, r"`speed` must be a finite number > 0 m/s; got 0.0"),
    ("mu", -0.1, r"`mu` must be a finite number >= 0; got -0.1"),
    ("eta", [1.0, np.inf], r"`eta` must be .* got inf at index \(1,\)"),
    ("spin", np.nan, r"`spin` must be a finite number"),
    ("inclination", 90.0, r"`inclination` must be a finite number in \(-90, 90\) deg"),
])
def test_simulate_rejects_invalid_input(name, value, match):
    with pytest.raises(ValueError, match=match):
        bb.simulate(**(PAPER | {name: value}))


def test_simulate_rejects_bad_options():
    with pytest.raises(ValueError, match=r"`normal_law` must be one of 'kelvin-voigt', "
                                         r"'hunt-crossley', 'linear-dashpot', 'hertz-tsuji'; "
                                         r"got 'maxwell'"):
        bb.simulate(normal_law="maxwell", **PAPER)
    with pytest.raises(ValueError, match=r"array arguments must broadcast to one shape; "
                                         r"got `mu` \(3,\), `eta` \(2,\)"):
        bb.simulate(mu=[0.1, 0.2, 0.3], eta=[1.0, 2.0], speed=3.0, angle=60.0)
    with pytest.raises(ValueError, match=r"`rtol` must be a finite number in \[1e-15, 0.1\]"):
        bb.SolverConfig(rtol=0.0)


def test_batch_broadcasts_and_matches_scalar_calls():
    """Batched evaluation equals element-wise evaluation (elements are independent)."""
    mu = np.array([[0.05], [0.3]])
    eta = np.array([0.5, 1.5, 3.0])
    batch = bb.simulate(mu=mu, eta=eta, speed=3.0, angle=[30.0, 45.0, 60.0])
    assert batch.rebound_speed.shape == (2, 3)
    for i in range(2):
        for j in range(3):
            one = bb.simulate(mu=mu[i, 0], eta=eta[j], speed=3.0, angle=[30.0, 45.0, 60.0][j])
            assert one.rebound_speed == batch.rebound_speed[i, j]
            assert one.contact_time == batch.contact_time[i, j]


def test_flag_mode_marks_invalid_elements_and_solves_the_rest():
    res = bb.simulate(mu=[0.1, -1.0, 0.2], eta=1.0, speed=[3.0, 3.0, np.nan], angle=45.0,
                      errors="flag")
    assert list(res.status) == [Status.OK, Status.INVALID_INPUT, Status.INVALID_INPUT]
    assert res.n_failed == 2
    assert np.isfinite(res.rebound_speed[0]) and np.isnan(res.rebound_speed[1:]).all()
    assert "2 x INVALID_INPUT" in res.failure_summary()
    # 0.1 (1 + e) V cos45 < (2/7) V sin45 for any e <= 1: sliding throughout (docs/model.md §3)
    assert res.regime.tolist() == ["slip", "failed", "failed"]


def test_unsolvable_bounce_is_reported_not_hung():
    """Damping far beyond critical at a slow impact: the ball stops on the surface."""
    with pytest.warns(bb.SimulationWarning, match=r"1 of 2 bounces could not be solved: "
                                                  r"1 x NO_SEPARATION"):
        res = bb.simulate(mu=0.2, eta=[1.0, 500.0], speed=0.1, angle=30.0)
    assert res.status.tolist() == [Status.OK, Status.NO_SEPARATION]
    assert np.isnan(res.rebound_speed[1])
    assert res.item(1)["status"] == "NO_SEPARATION"


def test_max_steps_status():
    res = bb.simulate(errors="flag", solver=bb.SolverConfig(max_steps=10), method="ode", **PAPER)
    assert res.status == Status.MAX_STEPS
    assert "max_steps" in Status.MAX_STEPS.message


def test_history_matches_summary_and_free_flight():
    h = simulate_history(**PAPER, inclination=10.0, n_contact=300, n_flight=50)
    b = h.bounce
    assert h.time.shape == h.x.shape == h.normal_force.shape == (400,)
    assert np.all(np.diff(h.time) > 0)
    contact = h.in_contact
    # the contact samples end exactly at separation: the summary's rebound state
    last = np.flatnonzero(contact)[-1]
    assert h.time[last] == b.contact_time
    assert h.tangential_velocity[last] == pytest.approx(float(b.rebound_tangential_velocity),
                                                        rel=1e-12)
    # sampled peak force cannot exceed the located peak, and comes within 1e-4 of it
    assert h.normal_force.max() <= b.peak_normal_force * (1 + 1e-12)
    assert h.normal_force.max() == pytest.approx(float(b.peak_normal_force), rel=1e-4)
    # free flight: ballistic, normal acceleration -g cos(10 deg) (closed form)
    after = h.time > b.contact_time
    acc = np.gradient(h.normal_velocity[after], h.time[after])
    np.testing.assert_allclose(acc, -bb.model.STANDARD_GRAVITY * np.cos(np.radians(10.0)),
                               rtol=1e-9)
    assert not h.in_contact[0] and h.y[0] > h.radius


def test_history_rejects_arrays_and_failed_bounces():
    with pytest.raises(TypeError, match="`mu` must be a real number"):
        simulate_history(mu=[0.1, 0.2], eta=1.0, speed=3.0, angle=60.0)
    with pytest.raises(bb.model.BounceFailed, match="NO_SEPARATION") as info:
        simulate_history(mu=0.2, eta=500.0, speed=0.1, angle=30.0)
    assert info.value.status == Status.NO_SEPARATION


def test_regimes_follow_the_rigid_body_criterion():
    """docs/model.md §3: sliding throughout iff mu (1+e) V < (2/7)|s0|; e from the simulated normal
    rebound. Far from the boundary the simulated regime must agree."""
    speed, angle = 3.0, 45.0
    res = bb.simulate(mu=[0.02, 0.5], eta=1.0, speed=speed, angle=angle, gravity=0.0)
    assert res.rolling.tolist() == [False, True]
    assert res.regime.tolist() == ["slip", "roll"]


def test_history_contact_samples_are_all_filled():
    """Regression: the summary and the samples must come from one integration (every contact
    sample finite, the last exactly at separation)."""
    h = simulate_history(**PAPER, n_contact=50, n_flight=3)
    assert np.isfinite(h.normal_force).all() and np.isfinite(h.y).all()
