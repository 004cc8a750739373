"""Tangential compliance: a Mindlin or linear spring capped by Coulomb friction (docs/model.md §5.2).

Expected values come from:

- ``tests/reference_scipy.py``: an independent SciPy ``solve_ivp`` (DOP853, rtol 1e-12)
  implementation of the compliant contact, written from docs/model.md §5.2 with its own
  formulation of each law (Mindlin's stiffness as ``2 E* sqrt(r d)``, the Tsuji dashpot in the
  LIGGGHTS/EDEM form ``2 sqrt(5/6) zeta sqrt(S_n m)``, the spring state following the cap while
  sliding, the phase at first touch from a leading-order comparison) and checked here for its
  own convergence;
- closed forms: the rigid-body law of oblique impact (``rigid_body_rebound``, docs/model.md
  §7.2), which a contact that slides from first touch to separation must follow whatever its
  tangential stiffness; energy, which the loading/unloading rule must never create;
- the limit of an infinitely stiff spring, the rigid tangential contact of the paper's model.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

import bouncebayes as bb
from bouncebayes.model import BounceModel, Status, simulate_history

sys.path.insert(0, str(Path(__file__).resolve().parent))
from reference_scipy import STICK, reference_bounce  # noqa: E402

BALL = bb.PAPER_BALL
TIGHT = bb.SolverConfig(rtol=1e-12, atol=1e-12)
# Agreement asked of the model with the reference: 1e-7 relative (the project's standard for
# the ODE path). Measured worst over the 40 sets below: 6e-9 (over 120 other draws: 6e-9).
REL = 1e-7
# With the default SolverConfig (rtol = atol = 1e-10): measured worst 2.4e-7 (a peak friction
# force); the rigid contact's test allows 3e-6 for the same reason (docs/model.md §9).
REL_DEFAULT = 3e-6
LAWS = ("kelvin-voigt", "hunt-crossley", "linear-dashpot", "hertz-tsuji")
QUANTITIES = ("rebound_speed", "rebound_angle", "rebound_spin", "contact_time",
              "peak_normal_force", "peak_friction_force", "max_overlap")
N_SETS = 40


def compliant_sets(seed: int = 20250301) -> list[dict]:
    """40 bounces: the four normal laws x both springs, grazing to head-on, spin, slopes (one
    set in three horizontal), stiffness ratios from soft (0.3) to stiff (1.5)."""
    rng = np.random.default_rng(seed)
    out = []
    for i in range(N_SETS):
        law, tangential = LAWS[i % 4], ("mindlin", "linear")[(i // 4) % 2]
        kw = dict(normal_law=law, tangential=tangential, mu=rng.uniform(0.05, 0.5),
                  speed=rng.uniform(1.0, 6.0), angle=rng.uniform(0.0, 85.0),
                  spin=rng.uniform(-300.0, 300.0),
                  inclination=0.0 if i % 3 == 0 else rng.uniform(-30.0, 30.0),
                  tangential_stiffness_ratio=rng.uniform(0.3, 1.5))
        if law == "kelvin-voigt":
            kw["eta"] = rng.uniform(0.0, 5.0)
        elif law == "hunt-crossley":
            kw["eta"] = rng.uniform(0.0, 0.5)
        else:
            kw["restitution"] = rng.uniform(0.3, 1.0)
        if law == "linear-dashpot":
            kw["normal_stiffness"] = 10.0 ** rng.uniform(4.0, 5.0)
        out.append(kw)
    return out


@pytest.fixture(scope="module")
def sets():
    return compliant_sets()


@pytest.fixture(scope="module")
def refs(sets):
    return [reference_bounce(BALL, **kw) for kw in sets]


def package(kw: dict, solver: bb.SolverConfig = TIGHT) -> bb.Bounces:
    return bb.simulate(BALL, solver=solver, **kw)


def mismatch(kw: dict, got: bb.Bounces, ref, rel: float) -> list[str]:
    """Quantities off by more than ``rel``, relative with floors on the bounce's natural scales
    (the incident speed for velocities, speed / radius for spin, 1 degree for angles)."""
    v = kw["speed"]
    floors = {"rebound_speed": v, "rebound_angle": 1.0, "rebound_spin": v / BALL.radius,
              "peak_friction_force": 1e-12}
    bad = []
    for q in QUANTITIES:
        a, b = float(getattr(got, q)), getattr(ref, q)
        if abs(a - b) > rel * max(abs(b), floors.get(q, 0.0)):
            bad.append(f"{q}: package {a!r}, reference {b!r} ({kw})")
    return bad


def test_reference_of_the_compliant_contact_is_converged(sets, refs):
    """The reference's own error: halving its tolerance moves it by less than 2e-9 of each
    quantity's scale (measured 2.4e-10), so a 1e-7 disagreement is the package's; another
    integrator (RK45, a lower order, at rtol 1e-11) agrees to 1e-7 (measured 4e-8, under
    Tsuji's law, whose force grows like t^(1/4) from first touch)."""
    for i in (0, 5, 10, 15, 22, 31):
        for alt, tol in ((reference_bounce(BALL, rtol=5e-13, atol=5e-14, **sets[i]), 2e-9),
                         (reference_bounce(BALL, method="RK45", rtol=1e-11, atol=1e-12,
                                           **sets[i]), 1e-7)):
            problems = []
            for q in QUANTITIES[:4]:
                a, b = getattr(alt, q), getattr(refs[i], q)
                scale = {"rebound_speed": sets[i]["speed"], "rebound_angle": 1.0,
                         "rebound_spin": sets[i]["speed"] / BALL.radius}.get(q, abs(b))
                if abs(a - b) > tol * scale:
                    problems.append((q, a, b))
            assert not problems, problems


def test_sets_cover_stick_slip_and_grip(refs):
    """The sets exercise every transition of the spring: stick then slide, slide then grip
    again (the contact point reverses), sliding from first touch, and several switches."""
    phases = [r.phases for r in refs]
    assert sum(p[0] == STICK for p in phases) >= 10
    assert sum(p[0] != STICK for p in phases) >= 3  # slides from first touch
    assert sum(len(p) >= 4 for p in phases) >= 8  # stick, slide, grip again, slide
    assert sum(any(a * b < 0 for a, b in zip(p[1:], p[3:], strict=False)
                   if a != STICK and b != STICK) for p in phases) >= 8  # the slip reverses


def test_compliant_contact_agrees_with_the_independent_reference(sets, refs):
    bad = []
    for kw, ref in zip(sets, refs, strict=True):
        bad += mismatch(kw, package(kw), ref, REL)
    assert not bad, "\n".join(bad)


def test_default_solver_is_close_to_the_reference(sets, refs):
    bad = []
    for kw, ref in zip(sets, refs, strict=True):
        bad += mismatch(kw, package(kw, bb.SolverConfig()), ref, REL_DEFAULT)
    assert not bad, "\n".join(bad)


@pytest.mark.parametrize("tangential", ["mindlin", "linear"])
def test_sliding_from_first_touch_follows_the_rigid_body_law(tangential):
    """A contact that slides from first touch to separation has ``F_t = -mu F_n`` throughout,
    whatever its spring: the rigid-body law of docs/model.md §7.2 with e from the package's own
    head-on rebound (Hunt–Crossley: its force starts from zero, so the spring does not stick
    first; no gravity). Agreement 1e-8 of the incident velocity scale."""
    kw = dict(eta=0.1, speed=3.0, gravity=0.0, normal_law="hunt-crossley", solver=TIGHT)
    mu, angle = np.array([0.05, 0.1, 0.05]), np.array([60.0, 75.0, 45.0])
    spin = np.array([0.0, 100.0, 200.0])
    res = bb.simulate(mu=mu, angle=angle, spin=spin, tangential=tangential, **kw)
    vn, u0 = 3.0 * np.cos(np.radians(angle)), 3.0 * np.sin(np.radians(angle))
    head_on = bb.simulate(mu=0.0, angle=0.0, **(kw | {"speed": vn}))
    e = head_on.rebound_normal_velocity / vn
    law = bb.rigid_body_rebound(tangential_velocity=u0, normal_speed=vn, spin=spin,
                                radius=BALL.radius, mu=mu, restitution=e)
    assert not law.rolling.any()
    np.testing.assert_allclose(res.rebound_tangential_velocity, law.tangential_velocity,
                               rtol=0, atol=1e-8 * 3.0)
    np.testing.assert_allclose(res.rebound_spin * BALL.radius, law.spin * BALL.radius, rtol=0,
                               atol=1e-8 * 3.0)


def test_a_stiff_spring_tends_to_the_rigid_contact():
    """As the stiffness ratio grows the compliant rebound approaches the rigid tangential
    contact (rolling exit, docs/model.md §7.2): the difference (in u' and r w') shrinks with
    every tenfold stiffening, 0.09, 0.012, 0.0022 of the incident speed at ratios 1, 10, 100
    (measured); below 3e-3 at 100."""
    kw = dict(mu=0.3, eta=0.05, speed=3.0, angle=np.array([10.0, 25.0, 40.0]), gravity=0.0,
              normal_law="hunt-crossley", solver=TIGHT)
    rigid = bb.simulate(**kw)
    assert rigid.rolling.all()
    diffs = []
    for ratio in (1.0, 10.0, 100.0):
        res = bb.simulate(tangential="mindlin", tangential_stiffness_ratio=ratio, **kw)
        diffs.append(max(np.abs(res.rebound_tangential_velocity
                                - rigid.rebound_tangential_velocity).max(),
                         np.abs(res.rebound_spin - rigid.rebound_spin).max() * BALL.radius) / 3.0)
    assert diffs[0] > diffs[1] > diffs[2] and diffs[2] < 3e-3, diffs


@pytest.mark.parametrize(("normal_law", "damping", "tangential"), [
    ("kelvin-voigt", dict(eta=1.35), "mindlin"), ("hunt-crossley", dict(eta=0.1), "mindlin"),
    ("kelvin-voigt", dict(eta=0.0), "linear"), ("hertz-tsuji", dict(restitution=0.8), "mindlin")])
@pytest.mark.parametrize(("angle", "spin"), [(8.0, 0.0), (25.0, 0.0), (45.0, 300.0)])
def test_energy_never_increases_with_the_spring(normal_law, damping, tangential, angle, spin):
    """docs/model.md §5.2: translational + rotational kinetic energy + the normal elastic energy
    (2/5) k d^(5/2) + the spring's ft^2 / (2 k_t) never rises along the contact (gravity off):
    the spring unloads with its stiffness, and slides only against the cap. Samples may rise by
    interpolation noise only (<= 1e-9 of the initial energy)."""
    ratio = 0.8
    hist = simulate_history(BALL, mu=0.3, speed=3.0, angle=angle, spin=spin, gravity=0.0,
                            normal_law=normal_law, tangential=tangential,
                            tangential_stiffness_ratio=ratio, solver=TIGHT, n_contact=600,
                            n_flight=0, **damping)
    k = BALL.hertz_stiffness
    d = np.clip(hist.overlap, 0.0, None)
    if tangential == "mindlin":  # ratio x the tangent stiffness 2 E* sqrt(r d) of Hertz
        k_t = ratio * 2.0 * BALL.effective_modulus * np.sqrt(BALL.radius * d)
    else:  # the linear spring of the elastic Hertz contact time at the normal speed
        vn = 3.0 * math.cos(math.radians(angle))
        t_h = float(bb.hertz_elastic_impact(BALL, vn).contact_time)
        k_t = ratio * BALL.mass * (math.pi / t_h) ** 2 * np.ones_like(d)
    with np.errstate(divide="ignore", invalid="ignore"):
        spring = np.where(k_t > 0.0, hist.friction_force**2 / (2.0 * k_t), 0.0)
    energy = (0.5 * hist.mass * (hist.tangential_velocity**2 + hist.normal_velocity**2)
              + 0.5 * hist.moment_of_inertia * hist.spin**2 + 0.4 * k * d**2.5 + spring)
    assert np.diff(energy).max() <= 1e-9 * energy[0]
    assert energy[-1] < energy[0]


def test_without_friction_the_spring_never_loads():
    """mu = 0: no tangential force at all, as in the rigid model: u and the spin unchanged."""
    kw = dict(mu=0.0, eta=1.0, speed=3.0, angle=np.array([10.0, 50.0]), spin=150.0)
    res = bb.simulate(tangential="mindlin", **kw)
    np.testing.assert_array_equal(res.rebound_spin, [150.0, 150.0])
    np.testing.assert_array_equal(res.rebound_tangential_velocity,
                                  3.0 * np.sin(np.radians([10.0, 50.0])))


def test_default_stiffness_ratio_is_mindlins():
    """Without a ratio the spring takes Mindlin's 2(1-nu)/(2-nu) of the ball's Poisson ratio
    (0.675 for nu = 0.49: 2 x 0.51 / 1.51)."""
    assert bb.model.mindlin_stiffness_ratio(0.49) == pytest.approx(1.02 / 1.51, rel=1e-15)
    kw = dict(mu=0.3, eta=1.0, speed=3.0, angle=20.0, tangential="mindlin")
    a = bb.simulate(**kw)
    b = bb.simulate(tangential_stiffness_ratio=1.02 / 1.51, **kw)
    assert a.rebound_spin == b.rebound_spin


def test_compliant_bounces_take_the_ode_path_and_say_so():
    conditions = dict(speed=[2.5, 3.0, 3.5], angle=[15.0, 30.0, 60.0])
    res = bb.simulate(mu=0.3, eta=1.0, tangential="mindlin", **conditions)
    assert not res.closed_form.any() and (res.n_steps > 0).all()
    model = BounceModel(tangential="mindlin", eta=1.0,
                        varying=("mu", "tangential_stiffness_ratio"), **conditions)
    theta = np.array([[0.3, bb.model.mindlin_stiffness_ratio(0.49)], [0.2, 0.5], [0.3, 500.0]])
    r = model(theta)
    np.testing.assert_array_equal(r.speed[0], res.rebound_speed)
    np.testing.assert_array_equal(r.spin[0], res.rebound_spin)
    assert r.ok[:2].all() and (r.status[2] == Status.INVALID_INPUT).all()  # ratio beyond 100
    full = model.bounces(theta[:2])
    np.testing.assert_array_equal(full.rebound_angle, r.angle[:2])
    # no closed form for the grid either: every cell is left to the model's calls
    grid_model = BounceModel(tangential="mindlin", varying=("mu", "eta"), **conditions)
    _, bad = grid_model.gaussian_grid([0.1, 0.2], [1.0], speed=[2.0] * 3, angle=[30.0] * 3,
                                      inverse_covariance=np.ones((3, 3)), log_norm=np.zeros(3))
    assert bad.all()


@pytest.mark.parametrize(("kwargs", "match"), [
    (dict(tangential_stiffness_ratio=0.5),
     r"`tangential_stiffness_ratio` is not a parameter of the contact law \(kelvin-voigt, "
     r"tangential none\): it has no tangential spring \(set `tangential`\)"),
    (dict(tangential="mindlin", tangential_stiffness_ratio=0.0),
     r"`tangential_stiffness_ratio` must be a finite number > 0; got 0.0"),
    (dict(tangential="mindlin", tangential_stiffness_ratio=1e3),
     r"`tangential_stiffness_ratio` must be a finite number in \[0.001, 100\]"),
    (dict(tangential="coulomb"),
     r"`tangential` must be one of 'none', 'mindlin', 'linear'; got 'coulomb'"),
])
def test_spring_arguments_are_checked(kwargs, match):
    with pytest.raises(ValueError, match=match):
        bb.simulate(mu=0.3, eta=1.0, speed=3.0, angle=30.0, **kwargs)


def test_varying_the_ratio_needs_a_spring():
    with pytest.raises(ValueError, match=r"`varying` must name distinct inputs among the "
                                         r"parameters of the contact law"):
        BounceModel(eta=1.0, speed=3.0, angle=30.0, varying=("tangential_stiffness_ratio",))


def test_stiffness_ratio_is_inferred_through_the_experiment_file():
    """examples/mindlin.toml with eta fixed: a synthetic campaign (20 bounces) made with the
    Mindlin spring at ratio 0.675 and mu = 0.16, then the grid posterior of (mu, ratio): the
    truth lies within 3 posterior sd of the mean (a calibrated posterior misses by more than
    3 sd in 0.3 % of campaigns), the parameter is reported with its unit-free name, and the
    summary names the tangential law."""
    import tomllib

    from bouncebayes.data import parse_experiment, synthesize
    from bouncebayes.inference import GridConfig, infer

    text = (Path(__file__).resolve().parents[1] / "examples" / "mindlin.toml").read_text()
    text = text.replace('[parameters.eta]\nprior = "uniform"            # also "normal" (mean, '
                        'sd, optional low/high) and\nlow = 0.0                    # "lognormal" '
                        '(median, sd_log)\nhigh = 5.0\n', "")
    assert "[parameters.eta]" not in text
    e = parse_experiment(tomllib.loads(text), source="mindlin.toml")
    assert e.tangential == "mindlin" and e.parameter_names == ("mu",
                                                               "tangential_stiffness_ratio")
    campaign = synthesize(e, seed=3, n=20)
    assert campaign.truth["population"]["tangential_stiffness_ratio"] == 0.675
    result = infer(e, campaign.trials, sampler="grid", config=GridConfig(points=24, draws=500))
    for name, truth in (("mu", 0.16), ("tangential_stiffness_ratio", 0.675)):
        x = result.samples(name)
        assert abs(x.mean() - truth) < 3 * x.std(), (name, x.mean(), x.std())
    assert result.summary()["experiment"]["tangential"] == "mindlin"
