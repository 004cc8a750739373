"""The fast exact path (tabulated normal impact + closed-form tangential outcome) against the ODE.

Expected values: the package's own ODE path at tight tolerance (rtol = atol = 1e-12), which
test_model_reference.py ties to an independent SciPy DOP853 solution to better than 1e-8; the
closed forms of docs/model.md §3 for the tangential part.
"""

import numpy as np
import pytest

import bouncebayes as bb
from bouncebayes.model import _fast

TIGHT = bb.SolverConfig(rtol=1e-12, atol=1e-12)
REL = 1e-7  # the required agreement with the ODE path, relative
QUANTITIES = ("rebound_speed", "rebound_angle", "rebound_spin", "contact_time",
              "peak_normal_force", "peak_friction_force")


def draws(n, seed, law, inclination=0.0):
    """The paper's prior box (mu <= 0.5, eta <= 5 kg/s; Hunt–Crossley eta <= 0.3 s/m) over
    incident speeds 1-6 m/s, angles 0-85 deg and spins +-200 rad/s."""
    rng = np.random.default_rng(seed)
    eta_max = 5.0 if law == "kelvin-voigt" else 0.3
    return dict(mu=rng.uniform(0, 0.5, n), eta=rng.uniform(0, eta_max, n),
                speed=rng.uniform(1, 6, n), angle=rng.uniform(0, 85, n),
                spin=rng.uniform(-200, 200, n), inclination=inclination, normal_law=law)


def relative_error(fast, ode, q, speed, mu):
    """|a - b| / max(|b|, floor): floors on each quantity's natural scale in this bounce
    (incident speed for velocities, speed / radius for spin, 1 degree for angles, mu times the
    peak normal force for the peak friction, which is tiny when the slip stops within
    microseconds), else its own value."""
    a, b = getattr(fast, q), getattr(ode, q)
    floor = {"rebound_speed": speed, "rebound_angle": 1.0,
             "rebound_spin": speed / bb.PAPER_BALL.radius,
             "peak_friction_force": mu * ode.peak_normal_force}.get(q, 0.0)
    return np.abs(a - b) / np.maximum(np.abs(b), floor)


@pytest.mark.parametrize(("law", "inclination", "seed"), [
    ("kelvin-voigt", 0.0, 11), ("hunt-crossley", 0.0, 12), ("kelvin-voigt", 15.0, 13),
    ("kelvin-voigt", -15.0, 14), ("hunt-crossley", 10.0, 15)])
def test_fast_path_agrees_with_the_ode_path(law, inclination, seed):
    kw = draws(600, seed, law, inclination)
    fast = bb.simulate(**kw)  # method="auto"
    ode = bb.simulate(**kw, method="ode", solver=TIGHT)
    closed = fast.closed_form
    # on a slope a ball whose slip stops rolls, then slides again before it leaves: the ODE
    # takes those; on a horizontal plane the closed form covers most of the box
    assert closed.mean() > (0.9 if inclination == 0.0 else 0.3), closed.mean()
    for q in QUANTITIES:
        err = relative_error(fast, ode, q, kw["speed"], kw["mu"])[closed]
        assert err.max() <= REL, (q, err.max())
    assert np.array_equal(fast.rolling, ode.rolling)
    # fallback elements went through the ODE at the default tolerance
    assert np.all(fast.n_steps[~closed] > 0) and np.all(fast.n_steps[closed] == 0)


def test_both_regimes_and_the_friction_peak_before_the_force_peak_are_covered():
    """The three tangential outcomes of the closed form: sliding throughout, slip stopping after
    the force peak, and slip stopping before it (where the peak friction comes from the
    compression table)."""
    kw = draws(2000, 21, "kelvin-voigt")
    fast = bb.simulate(**kw)
    ode = bb.simulate(**kw, method="ode", solver=TIGHT)
    table = _fast.normal_table("kelvin-voigt")
    assert table.compression.shape[1] == _fast.COMPRESSION_NODES[2]
    closed = fast.closed_form
    slides = closed & ~fast.rolling
    rolls = closed & fast.rolling
    early = rolls & (fast.peak_friction_force < kw["mu"] * fast.peak_normal_force * (1 - 1e-6))
    assert slides.sum() > 100 and rolls.sum() > 100 and early.sum() > 50
    err = relative_error(fast, ode, "peak_friction_force", kw["speed"], kw["mu"])
    assert err[early].max() <= REL


@pytest.mark.parametrize(("law", "seed"), [("kelvin-voigt", 31), ("hunt-crossley", 32)])
def test_peak_friction_of_balls_whose_slip_stops_before_the_force_peak(law, seed):
    """The compression table's accuracy where it is used: the normal force when the impulse
    reaches the slip's need, times mu, within 5e-8 of the tight ODE path (measured ~1e-8 at
    most: the table is built from the ODE's dense output, good to ~2e-8 in the force)."""
    kw = draws(1500, seed, law)
    fast = bb.simulate(**kw)
    ode = bb.simulate(**kw, method="ode", solver=TIGHT)
    early = (fast.closed_form & fast.rolling
             & (ode.peak_friction_force < kw["mu"] * ode.peak_normal_force * (1 - 1e-6)))
    assert early.sum() > 300
    err = relative_error(fast, ode, "peak_friction_force", kw["speed"], kw["mu"])
    assert err[early].max() <= 5e-8, err[early].max()


def _soa_columns(phis, targets, ppk=0.7):
    """The early balls' vector-pass rows (``_fast.R_*``) for force series ``phis``, target
    impulses and impulse at the force peak, with the impulse series and scale of
    ``_early_series`` (tested below)."""
    ns, block = _fast.NS, _fast.ROW
    soa = np.zeros(_fast.N_ROWS_EARLY * block)
    for k, (phi, target) in enumerate(zip(phis, targets, strict=True)):
        soa[(_fast.R_PHI + np.arange(ns)) * block + k] = phi
        soa[_fast.R_TARGET * block + k], soa[_fast.R_PPK * block + k] = target, ppk
    _fast._early_series(soa, len(phis))
    return soa


def test_impulse_series_is_the_integral_of_the_force_series():
    """Expected: NumPy's Chebyshev product and integral (an independent implementation) of
    (u + 1) Phi(u) from -1, scaled to the given impulse at u = 1, for each ball's column."""
    ns, block = _fast.NS, _fast.ROW
    rng = np.random.default_rng(7)
    phis = rng.normal(size=(5, ns)) / (1.0 + np.arange(ns)) ** 2
    soa = _soa_columns(phis, np.full(5, 0.1), ppk=0.7)
    rows = soa.reshape(_fast.N_ROWS_EARLY, block)
    cheb = np.polynomial.chebyshev
    for k, phi in enumerate(phis):
        integral = cheb.chebint(cheb.chebmul([1.0, 1.0], phi), lbnd=-1)
        expected = integral * 0.7 / cheb.chebval(1.0, integral)
        np.testing.assert_allclose(rows[_fast.R_PI:_fast.R_PI + ns + 2, k], expected, rtol=0,
                                   atol=1e-14)
        assert rows[_fast.R_SCALE, k] == pytest.approx(0.7 / cheb.chebval(1.0, integral),
                                                       rel=1e-14)


def test_series_pair_is_numpys_chebval():
    """Expected: numpy.polynomial.chebyshev.chebval (an independent implementation) of the
    impulse's NS + 2 and the force's NS coefficients of a column, at u across [-1, 1]."""
    ns, block = _fast.NS, _fast.ROW
    rng = np.random.default_rng(8)
    soa = rng.normal(size=_fast.N_ROWS_EARLY * block)
    rows = soa.reshape(_fast.N_ROWS_EARLY, block)
    for k, u in enumerate(np.linspace(-1.0, 1.0, 9)):
        pi, phi = _fast._series_pair(soa, k, u)
        cheb = np.polynomial.chebyshev
        assert pi == pytest.approx(cheb.chebval(u, rows[_fast.R_PI:_fast.R_PI + ns + 2, k]),
                                   rel=1e-13, abs=1e-13)
        assert phi == pytest.approx(cheb.chebval(u, rows[_fast.R_PHI:_fast.R_PHI + ns, k]),
                                    rel=1e-13, abs=1e-13)


def test_early_roots_agree_with_brentq_and_settle_what_the_vector_pass_leaves():
    """The force when the impulse reaches a target, for the compression table's own series at
    random points and for a force exp(12 (sigma - 1)), unlike any compression (the two-term
    model's start is then several per cent off, and Newton needs more than the vector pass's
    four steps: the ball is searched again one at a time). Expected: SciPy's brentq on NumPy's
    chebval of the impulse series (independent of the passes), then chebval of the force at
    the root."""
    from scipy.optimize import brentq

    ns, block = _fast.NS, _fast.ROW
    table = _fast.normal_table("kelvin-voigt")
    rng = np.random.default_rng(9)
    phis = []
    for _ in range(40):  # the table's force series at random damping and gravity nodes
        piece = table.compression[rng.integers(table.compression.shape[0])]  # (ns, nx, ng)
        ux, ug = rng.uniform(-1, 1, 2)
        tx = np.polynomial.chebyshev.chebvander(ux, piece.shape[1] - 1)[0]
        tg = np.polynomial.chebyshev.chebvander(ug, piece.shape[2] - 1)[0]
        phis.append(np.einsum("sij,i,j->s", piece, tx, tg))
    sigma = np.linspace(0.0, 1.0, 2001)
    steep = np.polynomial.chebyshev.chebfit(2 * sigma - 1, np.exp(12.0 * (sigma - 1.0)), ns - 1)
    phis.append(steep)
    targets = list(rng.uniform(0.0, 1.0, 40) ** 2 * 0.7) + [0.35]
    soa = _soa_columns(phis, targets)
    res = np.zeros(3 * block)
    _fast.early_roots(soa, len(phis), res)
    ok = res[_fast.R_OK * block:_fast.R_OK * block + len(phis)]
    assert ok[:40].mean() >= 0.9 and ok[40] == 0.0  # the steep force needed the second search
    rows = soa.reshape(_fast.N_ROWS_EARLY, block)
    cheb = np.polynomial.chebyshev
    for k, target in enumerate(targets):
        pi_series = rows[_fast.R_PI:_fast.R_PI + ns + 2, k]
        root = brentq(lambda s, c=pi_series, t=target: cheb.chebval(2 * s - 1, c) - t,
                      0.0, 1.0, xtol=1e-15, rtol=1e-15)
        expected = cheb.chebval(2 * root - 1, rows[_fast.R_PHI:_fast.R_PHI + ns, k])
        force = res[_fast.R_FORCE * block + k]
        assert force == pytest.approx(expected, rel=1e-9, abs=1e-12), k


def test_rigid_body_closed_form_is_what_the_fast_path_applies():
    """docs/model.md §3, with e and P from the table: U' = U - mu (1+e) V sign(s0) when sliding
    (no gravity), U' = U - (2/7) s0 when the slip stops."""
    speed, angle = 3.0, 45.0
    fast = bb.simulate(mu=[0.02, 0.4], eta=1.0, speed=speed, angle=angle, gravity=0.0)
    assert fast.closed_form.all()
    u, v = speed * np.sin(np.radians(angle)), speed * np.cos(np.radians(angle))
    e = fast.rebound_normal_velocity / v
    expected = bb.rigid_body_rebound(tangential_velocity=u, normal_speed=v, spin=0.0,
                                     radius=bb.PAPER_BALL.radius, mu=np.array([0.02, 0.4]),
                                     restitution=e)
    np.testing.assert_allclose(fast.rebound_tangential_velocity, expected.tangential_velocity,
                               rtol=1e-14)
    np.testing.assert_allclose(fast.rebound_spin, expected.spin, rtol=1e-13)
    assert fast.rolling.tolist() == expected.rolling.tolist() == [False, True]


@pytest.mark.parametrize(("kwargs", "why"), [
    (dict(speed=0.2, angle=60.0, eta=4.0), "outside the table: gravity number > 0.05"),
    (dict(speed=3.0, angle=30.0, eta=1.0, mu=0.5, inclination=20.0),
     "on a slope the slip stops: rolling then sliding again before separation"),
    (dict(speed=3.0, angle=0.0, eta=1.0, inclination=10.0), "exactly zero slip on a slope"),
])
def test_outside_the_closed_form_the_ode_is_used(kwargs, why):
    kw = dict(mu=0.2, spin=0.0) | kwargs
    auto = bb.simulate(**kw)
    assert not auto.closed_form, why
    ode = bb.simulate(**kw, method="ode")
    for q in QUANTITIES:
        assert getattr(auto, q) == getattr(ode, q)


def test_table_reproduces_tight_ode_solutions_of_the_scaled_problem():
    """Between its nodes the Chebyshev table matches fresh tight ODE solutions of the unit
    problem (m = k = V = 1) to 1e-8 (measured ~2e-10; the time of the peak ~3e-8)."""
    rng = np.random.default_rng(5)
    for law in ("kelvin-voigt", "hunt-crossley"):
        t = _fast.normal_table(law)
        x = rng.uniform(0, t.x_max, 40)
        g = rng.uniform(0, t.gamma_max, 40)
        res = _fast._solve_unit(law, x**t.power, g)
        vals = np.empty(_fast.N_TABLE)
        for i in range(x.size):
            _fast._contract(t.coef, x[i], g[i], t.x_max, t.gamma_max, np.empty(t.coef.shape[1]),
                            np.empty(t.coef.shape[2]), vals)
            ref = {_fast.T_E: res[i, bb.model._kernel.R_V], _fast.T_TC: res[i, 0],
                   _fast.T_FN: res[i, bb.model._kernel.R_FN_PEAK]}
            for q, want in ref.items():
                assert vals[q] == pytest.approx(want, rel=1e-8)


@pytest.mark.parametrize("law", sorted(_fast.DOMAIN))
def test_kernels_table_pieces_reproduce_the_24_term_table(law):
    """The kernels read the main table in MAIN_PIECES pieces of NX damping terms: at random
    points (and at the pieces' ends) they give the 24 x 8 Chebyshev series evaluated directly
    (``_contract``, the reference evaluation) to 1e-10 of each quantity's range (measured
    5e-12 for Kelvin–Voigt, 7e-11 for Tsuji's law near the end of its damping range: below the
    24-term table's own ~2e-10 from tight ODE solutions). Hunt–Crossley separates at zero
    overlap (a range of ~1e-19): judged on a floor of 1e-6."""
    t = _fast.normal_table(law)
    main = t.gravity_first
    assert main.shape == (_fast.MAIN_PIECES, _fast.NG, _fast.N_TABLE * _fast.NX)
    rng = np.random.default_rng(8)
    x = np.concatenate([rng.uniform(0, t.x_max, 400),
                        np.arange(_fast.MAIN_PIECES + 1) * t.x_max / _fast.MAIN_PIECES])
    g = rng.uniform(0, t.gamma_max, x.size)
    direct = np.empty((x.size, _fast.N_TABLE))
    pieced = np.empty_like(direct)
    for i in range(x.size):
        _fast._contract(t.coef, x[i], g[i], t.x_max, t.gamma_max, np.empty(t.coef.shape[1]),
                        np.empty(t.coef.shape[2]), direct[i])
        piece, u = _fast.main_piece(x[i], t.x_max)
        rows = main[piece].T @ np.polynomial.chebyshev.chebvander(
            2 * g[i] / t.gamma_max - 1, _fast.NG - 1)[0]
        pieced[i] = rows.reshape(_fast.N_TABLE, _fast.NX) @ np.polynomial.chebyshev.chebvander(
            u, _fast.NX - 1)[0]
    span = np.maximum(np.ptp(direct, axis=0), 1e-6)
    assert np.all(np.abs(pieced - direct) <= 1e-10 * span)


def test_method_is_validated():
    with pytest.raises(ValueError, match=r"`method` must be one of 'auto', 'ode'; got 'fast'"):
        bb.simulate(mu=0.1, eta=1.0, speed=3.0, angle=60.0, method="fast")


def test_tables_are_cached_on_disk_unchanged(tmp_path, monkeypatch):
    """A table is built once and kept on disk: the cached one is the built one, bit for bit
    (expected: the fresh build); an unreadable cache file is rebuilt, not trusted."""
    path = tmp_path / "table.npz"
    monkeypatch.setattr(_fast, "_cache_path", lambda law: path)
    build = _fast.normal_table.__wrapped__  # without the per-process cache
    built = build("hunt-crossley")
    assert path.is_file()
    cached = build("hunt-crossley")
    np.testing.assert_array_equal(cached.coef, built.coef)
    np.testing.assert_array_equal(cached.compression, built.compression)
    path.write_bytes(b"not a table")
    rebuilt = build("hunt-crossley")
    np.testing.assert_array_equal(rebuilt.coef, built.coef)
    assert np.load(path)["coef"].shape == built.coef.shape  # the bad file was replaced
