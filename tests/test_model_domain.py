"""Hostile input to the forward model: physical domains, the Hertz validity flag, and a solver
that cannot loop (step cap, non-finite numbers, wall-clock deadline)."""

import math
import subprocess
import sys
import time

import numpy as np
import pytest

import bouncebayes as bb
from bouncebayes.data import parse_experiment
from bouncebayes.model import HERTZ_OVERLAP_LIMIT, PARAMETER_DOMAINS, Status, parameter_domain

PAPER = dict(mu=0.16, eta=1.35, speed=3.0, angle=60.0)


@pytest.mark.parametrize(("kwargs", "match"), [
    (dict(diameter=1e-300, mass=0.01), r"`diameter` must be a finite number in \[2e-05, 2\] m "
                                       r"\(.*\); got 1e-300"),
    (dict(diameter=1e300, mass=0.01), r"`diameter` .* got 1e\+300"),
    (dict(diameter=0.0256, mass=1e300), r"`mass` of 1e\+300 kg gives a mean density of "
                                        r"1.14e\+305 kg/m\^3 .* must be a finite number in "
                                        r"\[1, 25000\] kg/m\^3"),
    (dict(diameter=0.0256, density=1e-3), r"`density` must be .* got 0.001"),
    (dict(diameter=0.0256, mass=0.01, youngs_modulus=0.5), r"`youngs_modulus` must be a finite "
                                                           r"number in \[1000, 1.5e\+12\] Pa"),
])
def test_ball_outside_its_physical_domain_is_one_line_error(kwargs, match):
    kwargs = dict(youngs_modulus=5e6, poisson_ratio=0.49) | kwargs
    with pytest.raises(ValueError, match=match) as info:
        bb.Ball.from_diameter(**kwargs)
    assert "\n" not in str(info.value)


def test_domain_table_is_public_and_law_aware():
    assert PARAMETER_DOMAINS["youngs_modulus"].low == 1e3
    kv, hc = parameter_domain("eta", "kelvin-voigt"), parameter_domain("eta", "hunt-crossley")
    assert (kv.unit, hc.unit) == ("kg/s", "s/m") and hc.high < kv.high
    # every bound is finite: nothing inside a domain can overflow the model
    for d in PARAMETER_DOMAINS.values():
        assert math.isfinite(d.low) and math.isfinite(d.high) and d.reason


@pytest.mark.parametrize(("name", "value"), [
    ("speed", 1e5), ("speed", 1e-300), ("mu", 1e300), ("eta", 1e300), ("spin", 1e300),
    ("gravity", 1e300), ("youngs_modulus", 1e300)])
def test_simulate_refuses_values_outside_the_domain(name, value):
    with pytest.raises(ValueError, match=rf"`{name}` must be a finite number in .*\(.+\); got"):
        bb.simulate(**(PAPER | {name: value}))
    # flag mode (samplers): the element is marked, the others solved
    res = bb.simulate(**(PAPER | {name: [value, PAPER.get(name, 1e7 if name == "youngs_modulus"
                                                           else 1.0)]}), errors="flag")
    assert res.status.tolist() == [Status.INVALID_INPUT, Status.OK]


def hertz_threshold_speed(ball):
    """Normal speed at which Hertz's closed-form maximum overlap (15 m V^2 / (16 E* sqrt r))^0.4
    equals HERTZ_OVERLAP_LIMIT r (Johnson, Contact Mechanics, §11.4)."""
    d = HERTZ_OVERLAP_LIMIT * ball.radius
    return math.sqrt(d**2.5 * 16 * ball.effective_modulus * math.sqrt(ball.radius)
                     / (15 * ball.mass))


@pytest.mark.parametrize("method", ["auto", "ode"])
def test_hertz_validity_flag_at_the_closed_form_threshold(method):
    ball = bb.PAPER_BALL
    v = hertz_threshold_speed(ball)
    res = bb.simulate(ball, mu=0.0, eta=0.0, speed=[0.98 * v, 1.02 * v], angle=0.0, gravity=0.0,
                      method=method)
    # overlap ~ V^0.8: 2 % in speed is 1.6 % in overlap, either side of the limit
    np.testing.assert_allclose(res.max_overlap / (HERTZ_OVERLAP_LIMIT * ball.radius),
                               [0.98**0.8, 1.02**0.8], rtol=1e-8)
    assert res.hertz_valid.tolist() == [True, False]
    assert res.item(1)["hertz_valid"] is False


def test_failed_bounces_are_not_hertz_valid():
    res = bb.simulate(mu=0.2, eta=[1.0, 500.0], speed=0.1, angle=30.0, errors="flag")
    assert res.status.tolist() == [Status.OK, Status.NO_SEPARATION]
    assert res.hertz_valid.tolist() == [True, False]


def test_cli_warns_beyond_hertz_and_refuses_hostile_ball(capsys):
    from bouncebayes.cli import main

    assert main(["simulate", "--speed", "60"]) == 0
    err = capsys.readouterr().err
    assert "warning: the maximum overlap" in err and "10%" in err
    for flag, value in (("--diameter", "1e-300"), ("--diameter", "1e300"), ("--mass", "1e300"),
                        ("--speed", "1e5")):
        assert main(["simulate", flag, value]) == 2
        err = capsys.readouterr().err.strip()
        assert err.count("\n") == 0 and "error:" in err, err


def test_max_steps_counts_rejected_steps_too():
    # max_steps = 10 attempts cannot finish a bounce that needs about 100 steps
    res = bb.simulate(errors="flag", solver=bb.SolverConfig(max_steps=10), method="ode", **PAPER)
    assert res.status == Status.MAX_STEPS
    assert "rejected" in Status.MAX_STEPS.message


def test_time_limit_marks_unreached_bounces_timeout():
    """A deadline that has passed after the first chunk (which always runs): the rest are not
    attempted."""
    n = 2500
    solver = bb.SolverConfig(time_limit=1e-9)
    res = bb.simulate(mu=0.2, eta=1.0, speed=np.linspace(1, 5, n), angle=30.0, method="ode",
                      solver=solver, errors="flag")
    timeout = res.status == Status.TIMEOUT
    assert timeout.any() and res.ok.any()
    assert np.all(res.status[res.ok.size - timeout.sum():] == Status.TIMEOUT)
    assert np.isnan(res.rebound_speed[timeout]).all()
    assert "time_limit" in Status.TIMEOUT.message
    with pytest.raises(ValueError, match=r"`time_limit` must be a finite number > 0 s"):
        bb.SolverConfig(time_limit=0.0)


def test_solver_config_rejects_nonsense():
    with pytest.raises(ValueError, match="`max_steps` must be an integer >= 10"):
        bb.SolverConfig(max_steps=10**30 + 0.5)  # type: ignore[arg-type]


HANG = """
import math, time
import numpy as np
from bouncebayes.model import _kernel as K
# a reported hang: a mass of 1e300 overflows m^2; the step and time limits become infinite
p = np.zeros(K.N_PARAMS); p[K.P_R] = 0.0128; p[K.P_M] = 1e300; p[K.P_K] = 1e5
p[K.P_I] = 0.4 * 1e300 * 0.0128**2; p[K.P_MU] = 0.2; p[K.P_ETA] = 1.0; p[K.P_GY] = 9.8
p[K.P_DSCALE] = 1.0
y0 = np.array([0.0, 0.0, 1.0, -2.0, 0.0]); scale = np.ones(5)
for h_max, t_max in ((math.inf, math.inf), (math.inf, math.inf), (1e-5, math.inf),
                     (math.nan, 1.0)):
    t0 = time.monotonic()
    st = K.solve_contact(p, y0, scale, h_max, t_max, 1e-10, 1e-10, 20000,
                         np.empty((0, K.N_SEGMENT)), np.empty(K.N_RESULTS))
    print(st, time.monotonic() - t0)
"""


def test_solver_cannot_loop_on_overflowed_inputs():
    """Inputs that overflow (here straight into the compiled solver, past every check) stop
    with NON_FINITE at once; run in a subprocess with a timeout, so a regression fails
    instead of hanging the suite."""
    out = subprocess.run([sys.executable, "-c", HANG], capture_output=True, text=True,
                         timeout=120, check=True)
    lines = [line.split() for line in out.stdout.strip().splitlines()]
    assert [int(s) for s, _ in lines] == [Status.NON_FINITE] * 4
    assert all(float(t) < 1.0 for _, t in lines[1:])  # the first includes loading the kernel


def test_overflowing_state_stops_with_a_status():
    """Forces that overflow during the integration (absurd stiffness straight into the kernel):
    every step is rejected, the attempts are counted, the bounce ends with a status."""
    from bouncebayes.model import _kernel as K

    p = np.zeros(K.N_PARAMS)
    p[[K.P_R, K.P_M, K.P_K, K.P_I, K.P_GY, K.P_DSCALE]] = [0.01, 0.01, 1e300, 4e-7, 9.8, 1e-3]
    t0 = time.monotonic()
    st = K.solve_contact(p, np.array([0.0, 0.0, 1.0, -2.0, 0.0]), np.ones(5), 1e-4, 1.0, 1e-10,
                         1e-10, 20000, np.empty((0, K.N_SEGMENT)), np.empty(K.N_RESULTS))
    assert st in (Status.STEP_UNDERFLOW, Status.MAX_STEPS, Status.NON_FINITE)
    assert time.monotonic() - t0 < 10.0


MINIMAL = """
[ball]
diameter_m = 0.0256
mass_kg = 0.0095
youngs_modulus_Pa = 5e6
poisson_ratio = 0.49
[incidence]
speed_m_s = 3.0
angle_deg = 60.0
[contact]
mu = 0.16
eta = 1.35
"""


@pytest.mark.parametrize(("prior", "match"), [
    ("[parameters.youngs_modulus]\nlow = 0.0\nhigh = 1e7",
     r"`parameters.youngs_modulus`: the prior \(uniform.*\) puts mass below 1000 Pa, where "
     r"`youngs_modulus` is not physical; set `low` >= 1000 \(the model's domain"),
    ("[parameters.mu]\nlow = 0.0\nhigh = 1e300",
     r"`parameters.mu`: .* puts mass above 10, where `mu` is not physical; set `high` <= 10"),
    ("[parameters.eta]\nlow = 0.0\nhigh = 1e300", r"`parameters.eta`: .* puts mass above 1e\+08 "
                                                  r"kg/s"),
    ("[parameters.spin]\nprior = \"normal\"\nmean = 0.0\nsd = 1e6",
     r"`parameters.spin`: .* puts mass below -100000 rad/s.*truncate it with `low = -100000`"),
])
def test_priors_leaving_the_domain_are_refused_naming_the_key(prior, match):
    from bouncebayes._errors import InputFileError

    with pytest.raises(InputFileError, match=match):
        parse_experiment(__import__("tomllib").loads(MINIMAL + prior))


@pytest.mark.parametrize(("old", "new", "match"), [
    ("speed_m_s = 3.0", "speed_m_s = 1e5", r"`incidence.speed_m_s`: must be a finite number in "
                                           r"\[0.001, 500\] m/s"),
    ("mu = 0.16", "mu = 1e300", r"`contact.mu`: must be a finite number in \[0, 10\]"),
    ("mass_kg = 0.0095", "mass_kg = 1e300", r"`ball`: `mass` of 1e\+300 kg"),
])
def test_experiment_values_outside_the_domain_name_the_key(old, new, match):
    import tomllib

    from bouncebayes._errors import InputFileError

    assert old in MINIMAL
    with pytest.raises(InputFileError, match=match):
        parse_experiment(tomllib.loads(MINIMAL.replace(old, new)))


def test_priors_with_negligible_tails_outside_the_domain_are_accepted():
    """A lognormal modulus prior has a tail beyond 1.5 TPa and below 1 kPa, of mass ~1e-60."""
    import tomllib

    e = parse_experiment(tomllib.loads(
        MINIMAL + "[parameters.youngs_modulus]\nprior = \"lognormal\"\nmedian = 5e6\n"
                  "sd_log = 0.5\n"))
    assert "youngs_modulus" in e.priors
    # hunt-crossley's damping domain is in s/m and narrower
    with pytest.raises(Exception, match=r"puts mass above 10000 s/m"):
        parse_experiment(tomllib.loads(
            MINIMAL.replace("[contact]", "[model]\nnormal = \"hunt-crossley\"\n[contact]")
            + "[parameters.eta]\nlow = 0.0\nhigh = 2e4\n"))
