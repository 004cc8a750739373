"""The DEM normal laws (docs/model.md §4.5-4.6): the linear spring-dashpot and Hertz with
Tsuji's dashpot, both set by a restitution coefficient as DEM codes set them.

Expected values come from:

- ``tests/reference_scipy.py``: an independent SciPy ``solve_ivp`` (DOP853, rtol 1e-12)
  implementation, with its own formulation of each law (the Tsuji dashpot in the LIGGGHTS/EDEM
  form ``2 sqrt(5/6) zeta sqrt(S_n m)``, S_n = 2 E* sqrt(r d));
- closed forms: the undamped linear oscillator (e = 1, t_c = pi sqrt(m / k_n)), Hertz's
  elastic impact (docs/model.md §7.1) when Tsuji's law has no damping, and the DEM conversion
  e <-> zeta of the free damped oscillator.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

import bouncebayes as bb
from bouncebayes.model import BounceModel, damping_ratio_restitution, restitution_damping_ratio

sys.path.insert(0, str(Path(__file__).resolve().parent))
from reference_scipy import reference_bounce  # noqa: E402

BALL = bb.PAPER_BALL
TIGHT = bb.SolverConfig(rtol=1e-12, atol=1e-12)
DEM_LAWS = ("linear-dashpot", "hertz-tsuji")
QUANTITIES = ("rebound_speed", "rebound_angle", "rebound_spin", "contact_time",
              "peak_normal_force", "max_overlap")


def law_sets(seed: int = 7) -> list[dict]:
    """24 bounces of both DEM laws, rigid tangential contact: grazing to head-on, spin, slopes,
    restitution 0.4 to 1 (inside and beyond the closed form's tables)."""
    rng = np.random.default_rng(seed)
    out = []
    for i in range(24):
        kw = dict(normal_law=DEM_LAWS[i % 2], mu=rng.uniform(0.05, 0.6),
                  speed=rng.uniform(1.0, 6.0), angle=rng.uniform(0.0, 80.0),
                  spin=rng.uniform(-200.0, 200.0),
                  inclination=0.0 if i % 3 == 0 else rng.uniform(-20.0, 20.0),
                  restitution=rng.uniform(0.4, 1.0))
        if kw["normal_law"] == "linear-dashpot":
            kw["normal_stiffness"] = 10.0 ** rng.uniform(4.0, 5.0)
        out.append(kw)
    return out


@pytest.fixture(scope="module")
def sets():
    return law_sets()


@pytest.fixture(scope="module")
def refs(sets):
    return [reference_bounce(BALL, **kw) for kw in sets]


def _off(kw, got, ref, rel) -> list[str]:
    v = kw["speed"]
    floors = {"rebound_speed": v, "rebound_angle": 1.0, "rebound_spin": v / BALL.radius}
    bad = []
    for q in QUANTITIES:
        a, b = float(getattr(got, q)), getattr(ref, q)
        if abs(a - b) > rel * max(abs(b), floors.get(q, 0.0)):
            bad.append(f"{q}: package {a!r}, reference {b!r} ({kw})")
    return bad


@pytest.mark.parametrize("method", ["ode", "auto"])
def test_dem_laws_agree_with_the_independent_reference(sets, refs, method):
    """Both paths (the ODE and, where its tables apply, the closed form) within 1e-7 of the
    reference's scale (the project's standard for the ODE path, docs/model.md §9)."""
    bad = []
    for kw, ref in zip(sets, refs, strict=True):
        bad += _off(kw, bb.simulate(BALL, solver=TIGHT, method=method, **kw), ref, 1e-7)
    assert not bad, "\n".join(bad)


def test_rebounds_of_samplers_match_full_results(sets):
    """``BounceModel(...)(theta)`` (the closed-form tables where exact, samplers' path) gives
    the rebounds of ``simulate`` (tight ODE) for restitution drawn per row, to 1e-8."""
    for law in DEM_LAWS:
        kw = [s for s in sets if s["normal_law"] == law][0]
        cond = dict(speed=[2.0, 3.0, 4.5], angle=[10.0, 35.0, 60.0], spin=[0.0, 50.0, -80.0])
        fixed = {"normal_stiffness": kw["normal_stiffness"]} if law == "linear-dashpot" else {}
        model = BounceModel(BALL, normal_law=law, varying=("mu", "restitution"), **cond,
                            **fixed)
        theta = np.array([[0.1, 0.5], [0.3, 0.8], [0.2, 0.95]])
        r = model(theta)
        for i, (mu, e) in enumerate(theta):
            full = bb.simulate(BALL, normal_law=law, mu=mu, restitution=e, method="ode",
                               solver=TIGHT, **cond, **fixed)
            np.testing.assert_allclose(r.speed[i], full.rebound_speed, rtol=1e-8)
            np.testing.assert_allclose(r.angle[i], full.rebound_angle, rtol=0, atol=1e-7)
            np.testing.assert_allclose(r.spin[i], full.rebound_spin, rtol=1e-8, atol=1e-6)


def test_undamped_linear_spring_is_the_harmonic_oscillator():
    """restitution = 1: e = 1 and t_c = pi sqrt(m / k_n) (closed form), both paths."""
    k_n = np.array([1e4, 5e4, 2e5])
    for method in ("auto", "ode"):
        res = bb.simulate(BALL, normal_law="linear-dashpot", mu=0.2, restitution=1.0,
                          normal_stiffness=k_n, speed=3.0, angle=0.0, gravity=0.0,
                          method=method, solver=TIGHT)
        np.testing.assert_allclose(res.rebound_speed, 3.0, rtol=1e-9)
        np.testing.assert_allclose(res.contact_time, np.pi * np.sqrt(BALL.mass / k_n),
                                   rtol=1e-9)


def test_undamped_tsuji_law_is_hertz():
    """restitution = 1 under Tsuji's law: Hertz's elastic impact (docs/model.md §7.1)."""
    speeds = np.array([0.5, 3.0, 9.0])
    res = bb.simulate(BALL, normal_law="hertz-tsuji", mu=0.2, restitution=1.0, speed=speeds,
                      angle=0.0, gravity=0.0, solver=TIGHT)
    hertz = bb.hertz_elastic_impact(BALL, speeds)
    np.testing.assert_allclose(res.rebound_speed, speeds, rtol=1e-9)
    np.testing.assert_allclose(res.contact_time, hertz.contact_time, rtol=1e-8)
    np.testing.assert_allclose(res.max_overlap, hertz.max_overlap, rtol=1e-8)


def test_restitution_is_the_dem_codes_number():
    """The restitution a DEM user types in gives the damping ratio of the free oscillator:
    zeta = -ln e / sqrt(pi^2 + ln^2 e) and back (closed form; LIGGGHTS/EDEM's beta = -zeta).
    The clamped linear law rebounds a little above it (the dashpot cannot pull: Schwager &
    Pöschel 2007), so e_model >= e, and equal at e = 1."""
    e = np.array([0.3, 0.6, 0.9, 1.0])
    zeta = restitution_damping_ratio(e)
    np.testing.assert_allclose(zeta, -np.log(e) / np.sqrt(np.pi**2 + np.log(e) ** 2),
                               rtol=1e-15)
    np.testing.assert_allclose(damping_ratio_restitution(zeta), e, rtol=1e-14)
    res = bb.simulate(BALL, normal_law="linear-dashpot", mu=0.2, restitution=e,
                      normal_stiffness=5e4, speed=3.0, angle=0.0, gravity=0.0)
    got = res.rebound_speed / 3.0
    assert (got >= e - 1e-9).all() and got[-1] == pytest.approx(1.0, abs=1e-9)
    assert math.isclose(float(got[1]), 0.6, rel_tol=0.2)


def test_restitution_is_inferred_through_the_experiment_file():
    """examples/dem-linear.toml (linear spring-dashpot with a tangential spring) with the
    stiffness ratio fixed: a synthetic campaign of 20 bounces, then the grid posterior of
    (mu, restitution) covers the truth (0.16, 0.87) within 3 posterior sd (a calibrated
    posterior misses by more in 0.3 % of campaigns)."""
    import tomllib

    from bouncebayes.data import parse_experiment, synthesize
    from bouncebayes.inference import GridConfig, infer

    text = (Path(__file__).resolve().parents[1] / "examples" / "dem-linear.toml").read_text()
    head, tail = text.split("[parameters.tangential_stiffness_ratio]")
    text = head + tail[tail.index("[trajectories]"):]
    e = parse_experiment(tomllib.loads(text), source="dem-linear.toml")
    assert (e.normal_law, e.tangential) == ("linear-dashpot", "mindlin")
    assert e.parameter_names == ("mu", "restitution")
    campaign = synthesize(e, seed=5, n=20)
    result = infer(e, campaign.trials, sampler="grid", config=GridConfig(points=24, draws=500))
    for name, truth in (("mu", 0.16), ("restitution", 0.87)):
        x = result.samples(name)
        assert abs(x.mean() - truth) < 3 * x.std(), (name, x.mean(), x.std())
