"""One way into the forward model: BounceModel (samplers, grid, propagation, simulate), the
import graph of the model package, and histories that reuse their solve."""

import ast
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import bouncebayes as bb
from bouncebayes.model import BounceModel, Status

SRC = Path(bb.__file__).parent
MODEL = SRC / "model"
PAPER = dict(mu=0.16, eta=1.35, speed=3.0, angle=60.0)


def _model_imports(path: Path) -> set[str]:
    """Sibling modules of the model package that ``path`` imports (relative imports)."""
    out = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.level == 1:
            if node.module:
                out.add(node.module)
            else:
                out.update(a.name for a in node.names)
    return out


def test_model_package_has_no_import_cycle():
    graph = {p.stem: _model_imports(p) for p in MODEL.glob("*.py") if p.stem != "__init__"}
    state: dict[str, int] = {}

    def visit(node, path):
        if state.get(node) == 1:
            raise AssertionError(f"import cycle: {' -> '.join(path + [node])}")
        if state.get(node) == 2:
            return
        state[node] = 1
        for dep in graph.get(node, ()):
            visit(dep, path + [node])
        state[node] = 2

    for node in graph:
        visit(node, [])
    assert "_fast" not in graph["_simulate"] and "_simulate" not in graph["_fast"]


@pytest.mark.parametrize("module", ["_fast", "_simulate", "_engine"])
def test_model_modules_import_alone(module):
    """A fresh interpreter imports the modules that once imported each other first (an import
    cycle fails here; the graph test above covers every module)."""
    subprocess.run([sys.executable, "-c", f"import bouncebayes.model.{module}"], check=True,
                   timeout=120, env={"PYTHONPATH": str(SRC.parent), "NUMBA_DISABLE_JIT": "0"})


def test_no_package_imports_private_names_of_the_model():
    offenders = []
    for path in SRC.rglob("*.py"):
        if MODEL in path.parents:
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.module and "model" in node.module:
                names = [a.name for a in node.names]
                parts = node.module.split(".")
                if any(p.startswith("_") for p in parts[parts.index("model") + 1:]) or any(
                        n.startswith("_") for n in names):
                    offenders.append(f"{path.relative_to(SRC)}: {node.module} {names}")
    assert not offenders, offenders


def test_speed_and_angle_are_converted_in_one_place():
    """Only _outputs.py calls atan2 (the rebound angle) in the model and its adapters
    (_vmath.py defines the one it calls)."""
    users = [p.name for p in list(MODEL.glob("*.py")) + [SRC / "inference" / "_forward.py",
                                                          SRC / "inference" / "_grid_kernel.py"]
             if "atan2(" in p.read_text(encoding="utf-8") and p.name != "_vmath.py"]
    assert users == ["_outputs.py"]


def conditions(n=55, seed=3):
    rng = np.random.default_rng(seed)
    return dict(speed=rng.uniform(2.5, 3.5, n), angle=rng.uniform(50, 70, n),
                spin=rng.uniform(-20, 20, n))


def test_rebounds_equal_simulate_element_by_element():
    """The sampler path (normal impact prepared per condition) and simulate (everything per
    element) run the same arithmetic: bit-identical rebounds."""
    cond = conditions()
    model = BounceModel(varying=("mu", "eta"), **cond)
    theta = np.array([[0.05, 0.5], [0.16, 1.35], [0.4, 4.0]])
    r = model(theta)
    assert r.speed.shape == r.angle.shape == r.spin.shape == r.contact_time.shape == (3, 55)
    for k, (mu, eta) in enumerate(theta):
        b = bb.simulate(mu=mu, eta=eta, **cond)
        np.testing.assert_array_equal(r.speed[k], b.rebound_speed)
        np.testing.assert_array_equal(r.angle[k], b.rebound_angle)
        np.testing.assert_array_equal(r.spin[k], b.rebound_spin)
        np.testing.assert_array_equal(r.contact_time[k], b.contact_time)
        np.testing.assert_array_equal(r.rolling[k], b.rolling)
    assert r.ok.all() and (r.status == Status.OK).all()
    full = model.bounces(theta)
    np.testing.assert_array_equal(full.rebound_speed, r.speed)


def test_conditions_too_many_to_prepare_give_the_same_numbers(monkeypatch):
    """Beyond PRECONTRACT_BYTES the sampler kernels contract the table's gravity axis at each
    evaluation instead of once per condition: the same arithmetic, so bit-identical rebounds
    (serial and parallel calls) and grid log-likelihoods, with bounded memory."""
    from bouncebayes.model import _fast

    cond = conditions()
    rng = np.random.default_rng(3)
    theta = np.column_stack([rng.uniform(0, 0.5, 200), rng.uniform(0, 5, 200)])
    mu, eta = np.linspace(0.0, 0.5, 17), np.linspace(0.1, 5.0, 13)
    speed, angle = np.full(55, 2.5), np.full(55, 30.0)
    icov, norm = np.tile([400.0, 0.0, 0.04], (55, 1)), np.zeros(55)
    out = {}
    for limit in (_fast.PRECONTRACT_BYTES, 0):
        monkeypatch.setattr(_fast, "PRECONTRACT_BYTES", limit)
        model = BounceModel(varying=("mu", "eta"), **cond)
        assert model._prepared_conditions()[1].shape[1] == (_fast.MAIN_PIECES if limit else 0)
        out[limit] = (model(theta[:3]), model(theta),
                      model.gaussian_grid(mu, eta, speed=speed, angle=angle,
                                          inverse_covariance=icov, log_norm=norm))
    (small_a, big_a, grid_a), (small_b, big_b, grid_b) = out.values()
    for a, b in ((small_a, small_b), (big_a, big_b)):  # serial, then parallel kernel
        np.testing.assert_array_equal(a.speed, b.speed)
        np.testing.assert_array_equal(a.angle, b.angle)
        np.testing.assert_array_equal(a.contact_time, b.contact_time)
    np.testing.assert_array_equal(grid_a[0], grid_b[0])
    np.testing.assert_array_equal(grid_a[1], grid_b[1])


@pytest.mark.parametrize("varying", [("mu", "eta", "youngs_modulus"), ("spin", "mu", "eta")])
def test_rebounds_of_other_parameters_equal_simulate(varying):
    cond = conditions(12)
    model = BounceModel(varying=varying, inclination=5.0, **cond)
    values = {"mu": [0.1, 0.3], "eta": [1.0, 2.0], "youngs_modulus": [3e6, 8e6],
              "spin": [-50.0, 80.0]}
    theta = np.column_stack([values[n] for n in varying])
    r = model(theta)
    for k in range(2):
        kw = cond | {n: values[n][k] for n in varying}
        b = bb.simulate(inclination=5.0, **kw)
        # on a slope some elements go to the ODE: same solver, same inputs, same numbers
        np.testing.assert_array_equal(r.speed[k], b.rebound_speed)
        np.testing.assert_array_equal(r.angle[k], b.rebound_angle)
        np.testing.assert_array_equal(r.ok[k], b.ok)


def test_invalid_parameter_rows_are_flagged_not_raised():
    model = BounceModel(varying=("mu", "eta"), **conditions(4))
    r = model(np.array([[0.1, 1.0], [-0.1, 1.0], [0.1, np.nan], [0.1, 1e300]]))
    assert r.ok[0].all() and not r.ok[1:].any()
    assert (r.status[1:] == Status.INVALID_INPUT).all()
    assert np.isnan(r.speed[1:]).all()


def test_rebounds_fall_back_to_the_ode():
    """Slow impacts (gravity number beyond the table) go to the ODE inside a sampler call."""
    model = BounceModel(varying=("mu", "eta"), speed=[0.2, 3.0], angle=[60.0, 60.0])
    r = model(np.array([[0.2, 4.0]]))
    b = bb.simulate(mu=0.2, eta=4.0, speed=[0.2, 3.0], angle=60.0)
    assert b.closed_form.tolist() == [False, True]
    np.testing.assert_array_equal(r.speed[0], b.rebound_speed)


def test_model_validates_its_arguments():
    with pytest.raises(ValueError, match=r"`mu` is required \(or name it in `varying`\)"):
        BounceModel(eta=1.0, speed=3.0, angle=60.0)
    with pytest.raises(ValueError, match=r"`varying` must name distinct inputs"):
        BounceModel(speed=3.0, angle=60.0, varying=("mu", "mu"))
    model = BounceModel(speed=3.0, angle=60.0, varying=("mu", "eta"))
    with pytest.raises(ValueError, match=r"`theta` must have shape \(n, 2\)"):
        model(np.ones((2, 3)))
    with pytest.raises(ValueError, match=r"`speed` must be a finite number in"):
        BounceModel(speed=1e5, angle=60.0, varying=("mu", "eta"))(np.ones((1, 2)))


def test_gaussian_grid_equals_the_sum_over_rebounds():
    """The grid kernel against the same log density summed from model calls (closed form)."""
    cond = conditions(20)
    model = BounceModel(varying=("mu", "eta"), **cond)
    rng = np.random.default_rng(1)
    obs_s, obs_a = rng.uniform(2, 3, 20), rng.uniform(50, 70, 20)
    icov = np.column_stack([rng.uniform(1, 2, 20), rng.uniform(-0.1, 0.1, 20),
                            rng.uniform(1, 2, 20)])
    log_norm = rng.uniform(0, 1, 20)
    mu, eta = np.linspace(0.0, 0.5, 7), np.linspace(0.1, 5.0, 5)
    ll, bad = model.gaussian_grid(mu, eta, speed=obs_s, angle=obs_a, inverse_covariance=icov,
                                  log_norm=log_norm)
    assert not bad.any()
    theta = np.array([[m, e] for m in mu for e in eta])
    r = model(theta)
    ds, da = r.speed - obs_s, r.angle - obs_a
    want = -(0.5 * (icov[:, 0] * ds**2 + 2 * icov[:, 1] * ds * da + icov[:, 2] * da**2)
             + log_norm).sum(axis=1)
    np.testing.assert_allclose(ll.ravel(), want, rtol=1e-12)


def test_history_is_the_summary_of_the_same_solve(monkeypatch):
    """simulate_history integrates once: no batch solve, one solve with its dense output kept,
    and the summary equals simulate(method="ode") (the same integration) exactly."""
    from bouncebayes.model import _history, _kernel

    bb.simulate(**PAPER)  # the closed form's tables, built by batch solves at first use
    calls = []
    solve = _history.solve_with_segments
    monkeypatch.setattr(_history, "solve_with_segments",
                        lambda *a, **k: calls.append(1) or solve(*a, **k))
    monkeypatch.setattr(_kernel, "solve_batch", None)  # any second integration would fail
    h = bb.simulate_history(**PAPER, inclination=5.0, n_contact=200, n_flight=5)
    monkeypatch.undo()
    assert calls == [1]
    b = bb.simulate(**PAPER, inclination=5.0, method="ode")
    for name in ("rebound_speed", "rebound_angle", "rebound_spin", "contact_time",
                 "peak_normal_force", "peak_friction_force", "max_overlap", "n_steps"):
        assert getattr(h.bounce, name) == getattr(b, name), name
    contact = np.flatnonzero(h.in_contact)
    assert h.tangential_velocity[contact[-1]] == b.rebound_tangential_velocity
    assert h.normal_velocity[contact[-1]] == b.rebound_normal_velocity
    assert h.spin[contact[-1]] == b.rebound_spin
    # the sampled dense output is continuous where steps meet: the force changes smoothly
    f = h.normal_force[contact]
    assert np.all(np.abs(np.diff(f, 2)) < 0.05 * f.max())


def test_inference_forward_adapter_keeps_its_interface():
    """inference's Forward(experiment, names, speed=, angle=, spin=) -> (n, n_conditions) arrays
    of speed, angle, rolling, ok, status, spin and contact time: the model's rebounds."""
    from bouncebayes.data import load_experiment
    from bouncebayes.inference._forward import Forward

    exp = load_experiment(Path(__file__).parents[1] / "examples" / "paper.toml")
    cond = conditions(7)
    fwd = Forward(exp, ("mu", "eta"), **cond)
    theta = np.array([[0.1, 1.0], [0.3, 2.0], [0.2, 1.5]])
    r = fwd(theta)
    for name in ("speed", "angle", "rolling", "ok", "status", "spin", "contact_time"):
        assert getattr(r, name).shape == (3, 7), name
    b = bb.simulate(exp.ball, mu=theta[:, :1], eta=theta[:, 1:], **cond,
                    inclination=exp.inclination, gravity=exp.gravity)
    np.testing.assert_array_equal(r.spin, b.rebound_spin)
    np.testing.assert_array_equal(r.contact_time, b.contact_time)
    # a scalar incidence is one condition
    assert Forward(exp, ("mu", "eta"), speed=3.0, angle=60.0)(theta).speed.shape == (3, 1)
    # conditions outside the domain are refused when the adapter is built
    with pytest.raises(ValueError, match=r"`speed` must be"):
        Forward(exp, ("mu", "eta"), speed=[3.0, 1e4], angle=60.0)
