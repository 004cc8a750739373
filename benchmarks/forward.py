"""Forward-model speed: the compiled batched solver against a SciPy ``solve_ivp`` loop.

Both solve the same bounces (paper's ball, Kelvin–Voigt law, exact stick/slip friction, peak
forces and overlap tracked) at the SAME accuracy:

1. accuracy: on a few bounces, both are compared with a tight DOP853 reference
   (``tests/reference_scipy.py``, rtol 1e-13). The error of a bounce is the largest of the
   relative errors of rebound speed (scale: incident speed V), rebound angle (scale: max(|angle|,
   1 degree)) and rebound spin (scale: max(|spin|, V / r)), as in tests/test_model_reference.py.
   One accuracy target, 1e-7 (the agreement required of the simulator): for the package's
   ODE path and for SciPy's RK45 a ladder of tolerances (rtol = atol, atol as a fraction of
   each component's natural scale, the package's convention) is tried, and each runs at the
   LOOSEST rung whose error meets the target;
2. speed: solves per second of one batched ``bb.simulate`` call (after the numba warm-up),
   with numba's default thread count and with one thread, against a Python loop of
   ``reference_bounce(method="RK45")`` at the chosen tolerance (and, for information, at the
   package's own rtol). ``ratio`` uses the default thread count, ``ratio_1thread`` one thread.

3. the fast exact path: ``bb.simulate``'s default ``method="auto"`` (tabulated normal
   impact + closed-form tangential outcome, ODE only where that is not exact) on batched
   bounces on a horizontal plane, where it covers the whole box (``fast_per_s``), and on the
   mixed draws above with slopes, where it hands rolling-on-a-slope bounces to the ODE
   (``auto_per_s_mixed``); its accuracy is measured against the same DOP853 reference.

4. the batched call of samplers: ``BounceModel(varying=("mu", "eta"))`` called with 4 parameter
   rows x 55 incidence conditions (the paper's Metropolis–Hastings run with the gaussian
   likelihood makes 11,500 such calls), ``batch_call_us`` per call, against the same rebounds
   from ``bb.simulate`` on broadcast arrays (the generic path) in the same run.

Timings on a shared machine are noisy: every rate is the best of several repeats, and next to
the wall-clock rates the CPU-time rates (``*_per_cpu_s``: bounces per second of CPU time of
the process, all threads together) are given, which contention for the cores disturbs less.

5. the compliant contact (``tangential="mindlin"``, docs/model.md §5.2; every bounce on the ODE
   path): the same accuracy ladder against a tight DOP853 reference of the compliant equations
   (``tests/reference_scipy.py``), then bounces per second of ``bb.simulate`` (wall and CPU
   time) against a loop of ``reference_bounce(method="RK45", tangential="mindlin")`` at the
   loosest tolerance meeting the same 1e-7 target, in the same run. Draws: the four normal
   laws in turn, stiffness ratios 0.3-1.5, the rest as above. ``--compliant`` runs this part
   alone and writes ``benchmarks/results/forward_compliant.json``.

``python benchmarks/forward.py --quick`` takes a few minutes; the last stdout line is one JSON
object with the rates, the ratios and the errors, also written to
``benchmarks/results/forward.json`` (its ``quick`` field says which run).
"""

from __future__ import annotations

import os

os.environ["OPENBLAS_NUM_THREADS"] = "1"  # before numpy is imported

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numba  # noqa: E402
import numpy as np  # noqa: E402

import bouncebayes as bb  # noqa: E402
from bouncebayes._io import write_json  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from reference_scipy import reference_bounce  # noqa: E402

BALL = bb.PAPER_BALL
LAW = "kelvin-voigt"
NUMERIC = ("mu", "eta", "speed", "angle", "spin", "inclination")
RK45_LADDER = (1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12)
TARGET = 1e-7  # accuracy both solvers must reach
REFERENCE = {"method": "DOP853", "rtol": 1e-13, "atol": 1e-15}


def draw(n: int, seed: int) -> dict[str, np.ndarray]:
    """Bounces over the typical ranges (paper's prior for mu and eta)."""
    rng = np.random.default_rng(seed)
    return {"mu": rng.uniform(0.0, 0.5, n), "eta": rng.uniform(0.0, 5.0, n),
            "speed": rng.uniform(1.0, 6.0, n), "angle": rng.uniform(0.0, 85.0, n),
            "spin": rng.uniform(-300.0, 300.0, n), "inclination": rng.uniform(-30.0, 30.0, n)}


def one(p: dict[str, np.ndarray], i: int) -> dict[str, float]:
    return {k: float(p[k][i]) for k in NUMERIC}


def errors(p, got_speed, got_angle, got_spin, refs) -> dict[str, float]:
    """Largest relative errors over the bounces, per quantity (floors: V, 1 deg, V / r)."""
    out = {"rebound_speed": 0.0, "rebound_angle": 0.0, "rebound_spin": 0.0}
    for i, ref in enumerate(refs):
        v = float(p["speed"][i])
        for q, got, floor in (("rebound_speed", got_speed[i], v),
                              ("rebound_angle", got_angle[i], 1.0),
                              ("rebound_spin", got_spin[i], v / BALL.radius)):
            b = getattr(ref, q)
            out[q] = max(out[q], abs(float(got) - b) / max(abs(b), floor))
    out["max"] = max(out.values())
    return out


def scipy_errors(p, refs, rtol) -> dict[str, float]:
    sols = [reference_bounce(BALL, normal_law=LAW, method="RK45", rtol=rtol, atol=rtol,
                             **one(p, i)) for i in range(len(refs))]
    return errors(p, [s.rebound_speed for s in sols], [s.rebound_angle for s in sols],
                  [s.rebound_spin for s in sols], refs)


def flat(p: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The same draws on a horizontal plane."""
    return p | {"inclination": np.zeros_like(p["speed"])}


def rate_package(p, repeats: int, method: str = "ode", rtol: float | None = None,
                 cpu: bool = False) -> float:
    """Bounces per second of ``bb.simulate`` (best of ``repeats``; CPU time if ``cpu``)."""
    n = p["speed"].size
    best = math.inf
    clock = time.process_time if cpu else time.perf_counter
    solver = bb.SolverConfig() if rtol is None else bb.SolverConfig(rtol=rtol, atol=rtol)
    for _ in range(repeats):
        t0 = clock()
        res = bb.simulate(BALL, normal_law=LAW, method=method, solver=solver, **p)
        best = min(best, clock() - t0)
        assert res.n_failed == 0, res.failure_summary()
    return n / best


def batch_calls(n_calls: int, repeats: int) -> dict[str, float]:
    """Microseconds per sampler call (4 parameter rows x 55 conditions) of BounceModel, and of
    the same rebounds from bb.simulate on broadcast arrays (the generic path)."""
    rng = np.random.default_rng(5)
    cond = {"speed": rng.uniform(2.5, 3.5, 55), "angle": rng.uniform(50.0, 70.0, 55),
            "spin": np.zeros(55)}
    model = bb.model.BounceModel(BALL, normal_law=LAW, varying=("mu", "eta"), **cond)
    thetas = np.column_stack([rng.uniform(0.0, 0.5, 4 * n_calls),
                              rng.uniform(0.0, 5.0, 4 * n_calls)]).reshape(n_calls, 4, 2)
    r = model(thetas[0])
    b = bb.simulate(BALL, normal_law=LAW, mu=thetas[0][:, :1], eta=thetas[0][:, 1:], **cond)
    assert np.array_equal(r.speed, b.rebound_speed) and np.array_equal(r.angle, b.rebound_angle)
    out = {}
    for name, call in (("batch_call_us", lambda t: model(t)),
                       ("batch_call_simulate_us", lambda t: bb.simulate(
                           BALL, normal_law=LAW, mu=t[:, :1], eta=t[:, 1:], **cond))):
        for label, clock in (("", time.perf_counter), ("_cpu", time.process_time)):
            best = math.inf
            for _ in range(repeats):
                t0 = clock()
                for t in thetas:
                    call(t)
                best = min(best, clock() - t0)
            out[name.replace("_us", f"{label}_us")] = best / n_calls * 1e6
    out["batch_call_ratio"] = out["batch_call_simulate_us"] / out["batch_call_us"]
    out["mh_gaussian_model_seconds"] = 11_500 * out["batch_call_us"] * 1e-6
    return out


def rate_scipy(p, rtol: float, cpu: bool = False) -> float:
    """Bounces per second of a Python loop of SciPy's RK45 (CPU time if ``cpu``)."""
    n = p["speed"].size
    clock = time.process_time if cpu else time.perf_counter
    t0 = clock()
    for i in range(n):
        reference_bounce(BALL, normal_law=LAW, method="RK45", rtol=rtol, atol=rtol, **one(p, i))
    return n / (clock() - t0)


def accuracy(n_acc: int) -> dict:
    """Errors against the tight DOP853 reference: the ladder of both ODE solvers, the loosest
    tolerance of each that meets TARGET, and the fast path's error."""
    acc = draw(n_acc, seed=1)
    refs = [reference_bounce(BALL, normal_law=LAW, **REFERENCE, **one(acc, i))
            for i in range(n_acc)]
    ode_ladder = {}
    for r in RK45_LADDER:
        res = bb.simulate(BALL, normal_law=LAW, method="ode", **acc,
                          solver=bb.SolverConfig(rtol=r, atol=r))
        ode_ladder[r] = errors(acc, res.rebound_speed, res.rebound_angle, res.rebound_spin, refs)
        print(f"package ODE rtol=atol={r:g}: error " + ", ".join(
            f"{k} {v:.2e}" for k, v in ode_ladder[r].items()))
    ode_rtol = max([r for r in RK45_LADDER if ode_ladder[r]["max"] <= TARGET] or [1e-12])
    acc_flat = flat(acc)
    refs_flat = [reference_bounce(BALL, normal_law=LAW, **REFERENCE, **one(acc_flat, i))
                 for i in range(n_acc)]
    res = bb.simulate(BALL, normal_law=LAW, **acc_flat)
    fast_err = errors(acc_flat, res.rebound_speed, res.rebound_angle, res.rebound_spin,
                      refs_flat)
    print(f"fast path (closed form for {res.closed_form.sum()} of {n_acc}) error: "
          + ", ".join(f"{k} {v:.2e}" for k, v in fast_err.items()))
    ladder = {}
    for rtol in RK45_LADDER:
        ladder[rtol] = scipy_errors(acc, refs, rtol)
        print(f"RK45 rtol=atol={rtol:g}: error " + ", ".join(f"{k} {v:.2e}"
                                                             for k, v in ladder[rtol].items()))
    rtol = max([r for r in RK45_LADDER if ladder[r]["max"] <= TARGET] or [1e-12])
    print(f"accuracy target {TARGET:g}: package ODE at rtol {ode_rtol:g} (error "
          f"{ode_ladder[ode_rtol]['max']:.2e}), RK45 at rtol {rtol:g} (error "
          f"{ladder[rtol]['max']:.2e})")
    return {"ode_ladder": ode_ladder, "ode_rtol": ode_rtol, "fast_err": fast_err,
            "ladder": ladder, "rtol": rtol, "n": n_acc}


def speeds(acc: dict, sizes: tuple[int, ...], repeats: int, quick: bool) -> dict:
    """Rates of the ODE path (default and one thread), the fast path (wall and CPU time), the
    sampler call, and the SciPy baseline at the tolerances ``accuracy`` chose."""
    n_scipy, n_ode, n_fast = sizes
    ode_rtol = acc["ode_rtol"]
    threads = numba.get_num_threads()
    out = {"threads": threads, "ode": rate_package(draw(n_ode, seed=2), repeats, rtol=ode_rtol)}
    numba.set_num_threads(1)
    out["ode_1"] = rate_package(draw(n_ode, seed=2), repeats, rtol=ode_rtol)
    numba.set_num_threads(threads)
    fast_draws = flat(draw(n_fast, seed=4))
    out["fast"] = rate_package(fast_draws, repeats, method="auto")
    out["fast_cpu"] = rate_package(fast_draws, repeats, method="auto", cpu=True)
    out["ode_cpu"] = rate_package(draw(n_ode, seed=2), repeats, rtol=ode_rtol, cpu=True)
    out["calls"] = batch_calls(500 if quick else 2000, repeats + 2)
    out["share"] = float(bb.simulate(BALL, normal_law=LAW, **fast_draws).closed_form.mean())
    out["mixed"] = rate_package(draw(n_ode, seed=2), repeats, method="auto")
    out["scipy"] = rate_scipy(draw(n_scipy, seed=3), acc["rtol"])
    out["scipy_cpu"] = rate_scipy(draw(n_scipy // 2, seed=3), acc["rtol"], cpu=True)
    # for reference: RK45 at the package's own rtol (the same Dormand-Prince 5(4) pair)
    out["scipy_same"] = rate_scipy(draw(n_scipy, seed=3), ode_rtol)
    return out


def report(acc: dict, sp: dict, sizes: tuple[int, ...]) -> None:
    """The human-readable lines of the speed results."""
    n_scipy, n_ode, n_fast = sizes
    calls = sp["calls"]
    print(f"bb.simulate(method='ode', rtol={acc['ode_rtol']:g}): {sp['ode']:,.0f} bounces/s "
          f"({sp['threads']} numba threads), {sp['ode_1']:,.0f} bounces/s (1 thread), batch of "
          f"{n_ode}")
    print(f"solve_ivp RK45 loop: {sp['scipy']:,.1f} bounces/s ({n_scipy} bounces, rtol "
          f"{acc['rtol']:g}); {sp['scipy_same']:,.1f} bounces/s at the package's rtol")
    print(f"fast path: {sp['fast']:,.0f} bounces/s on a horizontal plane "
          f"({100 * sp['share']:.1f} % in closed form, batch of {n_fast}); {sp['mixed']:,.0f} "
          f"bounces/s on the mixed draws with slopes; ratio to the ODE path "
          f"{sp['fast'] / sp['ode']:,.1f}, to SciPy {sp['fast'] / sp['scipy']:,.0f}")
    print(f"CPU time: fast path {sp['fast_cpu']:,.0f} bounces per CPU-second, ODE path "
          f"{sp['ode_cpu']:,.0f} (ratio {sp['fast_cpu'] / sp['ode_cpu']:,.1f})")
    print(f"sampler call (4 x 55): {calls['batch_call_us']:.1f} us "
          f"({calls['batch_call_cpu_us']:.1f} us CPU), bb.simulate for the same "
          f"{calls['batch_call_simulate_us']:.1f} us: {calls['batch_call_ratio']:.1f}x; the "
          f"model's share of the paper's MH run {calls['mh_gaussian_model_seconds']:.2f} s")
    print(f"ratio: {sp['ode'] / sp['scipy']:,.0f} ({sp['threads']} threads), "
          f"{sp['ode_1'] / sp['scipy']:,.0f} (1 thread), {sp['ode_cpu'] / sp['scipy_cpu']:,.0f} "
          f"in CPU time")


def summarize(acc: dict, sp: dict, sizes: tuple[int, ...], quick: bool) -> dict:
    """The JSON record of a run."""
    n_scipy, n_ode, n_fast = sizes
    ode_err, scipy_err = acc["ode_ladder"][acc["ode_rtol"]], acc["ladder"][acc["rtol"]]
    return {
        "ode_per_s": sp["ode"], "ode_per_s_1thread": sp["ode_1"], "scipy_per_s": sp["scipy"],
        "fast_per_s": sp["fast"], "fast_closed_form_share": sp["share"],
        "fast_per_cpu_s": sp["fast_cpu"], "ode_per_cpu_s": sp["ode_cpu"],
        "fast_ratio_to_ode_cpu": sp["fast_cpu"] / sp["ode_cpu"], **sp["calls"],
        "auto_per_s_mixed": sp["mixed"], "fast_err": acc["fast_err"]["max"],
        "fast_ratio_to_ode": sp["fast"] / sp["ode"],
        "fast_ratio_to_scipy": sp["fast"] / sp["scipy"],
        "ratio": sp["ode"] / sp["scipy"], "ratio_1thread": sp["ode_1"] / sp["scipy"],
        "scipy_per_cpu_s": sp["scipy_cpu"], "ratio_cpu": sp["ode_cpu"] / sp["scipy_cpu"],
        "ode_err": ode_err["max"], "scipy_err": scipy_err["max"],
        "ode_err_by_quantity": {k: v for k, v in ode_err.items() if k != "max"},
        "scipy_err_by_quantity": {k: v for k, v in scipy_err.items() if k != "max"},
        "scipy_per_s_at_ode_rtol": sp["scipy_same"],
        "scipy_method": "RK45", "scipy_rtol": acc["rtol"], "scipy_atol": acc["rtol"],
        "ode_rtol": acc["ode_rtol"], "ode_atol": acc["ode_rtol"], "accuracy_target": TARGET,
        "ode_ladder_err": {f"{r:g}": acc["ode_ladder"][r]["max"] for r in RK45_LADDER},
        "rk45_ladder_err": {f"{r:g}": acc["ladder"][r]["max"] for r in RK45_LADDER},
        "n_accuracy": acc["n"], "n_scipy": n_scipy, "n_ode": n_ode,
        "n_fast": n_fast, "numba_threads": sp["threads"], "normal_law": LAW, "quick": quick,
        "cpu_count": os.cpu_count(), "load_average_1min": os.getloadavg()[0],
    }


COMPLIANT_LAWS = ("kelvin-voigt", "hunt-crossley", "linear-dashpot", "hertz-tsuji")


def compliant_draws(n: int, seed: int) -> list[dict]:
    """Compliant bounces, one keyword set per normal law (each law's own damping parameter)."""
    rng = np.random.default_rng(seed)
    p = draw(n, seed) | {"ratio": rng.uniform(0.3, 1.5, n), "e": rng.uniform(0.4, 1.0, n),
                         "hc": rng.uniform(0.0, 0.5, n), "kn": 10.0 ** rng.uniform(4, 5, n)}
    out = []
    for j, law in enumerate(COMPLIANT_LAWS):
        sel = np.arange(n) % len(COMPLIANT_LAWS) == j
        kw = {k: p[k][sel] for k in ("mu", "speed", "angle", "spin", "inclination")}
        kw |= {"normal_law": law, "tangential": "mindlin",
               "tangential_stiffness_ratio": p["ratio"][sel]}
        kw |= ({"eta": p["eta"][sel]} if law == "kelvin-voigt" else
               {"eta": p["hc"][sel]} if law == "hunt-crossley" else {"restitution": p["e"][sel]})
        if law == "linear-dashpot":
            kw["normal_stiffness"] = p["kn"][sel]
        out.append(kw)
    return out


def _rows(groups: list[dict]):
    """Each bounce of ``compliant_draws`` as keyword arguments of ``reference_bounce``."""
    for kw in groups:
        n = kw["speed"].size
        for i in range(n):
            yield {k: (v if isinstance(v, str) else float(v[i])) for k, v in kw.items()}


def compliant_errors(groups, refs, solve) -> float:
    """Largest relative error (floors V, 1 deg, V / r) of ``solve(kw)`` over the bounces."""
    worst = 0.0
    for kw, ref in zip(_rows(groups), refs, strict=True):
        got = solve(kw)
        v = kw["speed"]
        for q, floor in (("rebound_speed", v), ("rebound_angle", 1.0),
                         ("rebound_spin", v / BALL.radius)):
            b = getattr(ref, q)
            worst = max(worst, abs(float(getattr(got, q)) - b) / max(abs(b), floor))
    return worst


def compliant_rate(groups, rtol: float, repeats: int, clock) -> float:
    """Bounces per second (of ``clock``) of ``bb.simulate`` over the groups, best of repeats."""
    n = sum(kw["speed"].size for kw in groups)
    solver = bb.SolverConfig(rtol=rtol, atol=rtol)
    best = math.inf
    for _ in range(repeats):
        t0 = clock()
        for kw in groups:
            res = bb.simulate(BALL, method="ode", solver=solver, **kw)
            assert res.n_failed == 0, res.failure_summary()
        best = min(best, clock() - t0)
    return n / best


def compliant_scipy_rate(groups, rtol: float, clock) -> float:
    """Bounces per second (of ``clock``) of a loop of SciPy's RK45 on the compliant contact."""
    rows = list(_rows(groups))
    t0 = clock()
    for kw in rows:
        reference_bounce(BALL, method="RK45", rtol=rtol, atol=rtol, **kw)
    return len(rows) / (clock() - t0)


def compliant_accuracy(n_acc: int) -> dict:
    """The loosest rung of each solver's ladder meeting TARGET against DOP853 at 1e-13."""
    groups = compliant_draws(n_acc, seed=11)
    refs = [reference_bounce(BALL, **REFERENCE, **kw) for kw in _rows(groups)]
    ladders: dict[str, dict[float, float]] = {"ode": {}, "rk45": {}}
    for r in RK45_LADDER:
        solver = bb.SolverConfig(rtol=r, atol=r)
        ladders["ode"][r] = compliant_errors(groups, refs, lambda kw, s=solver: bb.simulate(
            BALL, method="ode", solver=s, **kw))
        ladders["rk45"][r] = compliant_errors(groups, refs, lambda kw, t=r: reference_bounce(
            BALL, method="RK45", rtol=t, atol=t, **kw))
        print(f"compliant, rtol=atol={r:g}: package ODE error {ladders['ode'][r]:.2e}, "
              f"RK45 error {ladders['rk45'][r]:.2e}")
    pick = {k: max([r for r in RK45_LADDER if v[r] <= TARGET] or [1e-12])
            for k, v in ladders.items()}
    return {"ladders": ladders, "rtol": pick, "n": len(refs)}


def compliant(quick: bool) -> dict:
    """Part 5: the compliant contact against SciPy at the same accuracy, in one run."""
    n_acc, n_pkg, n_scipy, repeats = (12, 8_000, 120, 3) if quick else (32, 40_000, 600, 5)
    t_start = time.perf_counter()
    bb.simulate(BALL, method="ode", **compliant_draws(4, seed=0)[0])  # numba warm-up
    acc = compliant_accuracy(n_acc)
    pkg, ref = compliant_draws(n_pkg, seed=12), compliant_draws(n_scipy, seed=13)
    rates = {"ode_per_s": compliant_rate(pkg, acc["rtol"]["ode"], repeats, time.perf_counter),
             "ode_per_cpu_s": compliant_rate(pkg, acc["rtol"]["ode"], repeats,
                                             time.process_time),
             "scipy_per_s": compliant_scipy_rate(ref, acc["rtol"]["rk45"], time.perf_counter),
             "scipy_per_cpu_s": compliant_scipy_rate(ref, acc["rtol"]["rk45"],
                                                     time.process_time)}
    out = rates | {
        "ratio": rates["ode_per_s"] / rates["scipy_per_s"],
        "ratio_cpu": rates["ode_per_cpu_s"] / rates["scipy_per_cpu_s"],
        "tangential": "mindlin", "normal_laws": list(COMPLIANT_LAWS),
        "ode_rtol": acc["rtol"]["ode"], "scipy_method": "RK45", "scipy_rtol": acc["rtol"]["rk45"],
        "ode_err": acc["ladders"]["ode"][acc["rtol"]["ode"]],
        "scipy_err": acc["ladders"]["rk45"][acc["rtol"]["rk45"]], "accuracy_target": TARGET,
        "ode_ladder_err": {f"{r:g}": v for r, v in acc["ladders"]["ode"].items()},
        "rk45_ladder_err": {f"{r:g}": v for r, v in acc["ladders"]["rk45"].items()},
        "n_accuracy": acc["n"], "n_ode": n_pkg, "n_scipy": n_scipy,
        "numba_threads": numba.get_num_threads(), "quick": quick,
        "cpu_count": os.cpu_count(), "load_average_1min": os.getloadavg()[0],
        "wall_s": time.perf_counter() - t_start}
    print(f"compliant contact (Mindlin spring, four normal laws): bb.simulate "
          f"{out['ode_per_s']:,.0f} bounces/s ({out['ode_per_cpu_s']:,.0f} per CPU-s, rtol "
          f"{out['ode_rtol']:g}, error {out['ode_err']:.1e}); SciPy RK45 loop "
          f"{out['scipy_per_s']:,.1f} bounces/s ({out['scipy_per_cpu_s']:,.1f} per CPU-s, rtol "
          f"{out['scipy_rtol']:g}, error {out['scipy_err']:.1e}); ratio {out['ratio']:,.0f} "
          f"(wall), {out['ratio_cpu']:,.0f} (CPU time)")
    return out


def main(argv=None) -> dict:
    """Run the benchmark; print the results and write them to benchmarks/results/."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="small batches (a few minutes)")
    ap.add_argument("--compliant", action="store_true",
                    help="only part 5, the compliant contact (forward_compliant.json)")
    args = ap.parse_args(argv)
    results = Path(__file__).resolve().parent / "results"
    if args.compliant:
        summary = compliant(args.quick)
        write_json(results / "forward_compliant.json", summary)
        print(json.dumps(summary))
        return summary
    n_acc, n_scipy, n_ode, n_fast, repeats = (12, 400, 50_000, 1_000_000, 3) if args.quick \
        else (32, 2_000, 200_000, 4_000_000, 5)
    sizes = (n_scipy, n_ode, n_fast)
    t_start = time.perf_counter()
    # numba warm-up (compilation or cache load) before anything is timed
    bb.simulate(BALL, normal_law=LAW, method="ode", **draw(4, seed=0))
    bb.simulate(BALL, normal_law=LAW, **draw(4, seed=0))
    print(f"numba warm-up: {time.perf_counter() - t_start:.2f} s")
    acc = accuracy(n_acc)
    sp = speeds(acc, sizes, repeats, args.quick)
    report(acc, sp, sizes)
    summary = summarize(acc, sp, sizes, args.quick) | {"wall_s": time.perf_counter() - t_start}
    write_json(results / "forward.json", summary)  # "quick" in it says which run
    print(json.dumps(summary))
    return summary


if __name__ == "__main__":
    main()
