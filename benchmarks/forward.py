"""Forward-model speed: the compiled batched solver against a SciPy ``solve_ivp`` loop.

Both solve the same bounces (paper's ball, Kelvin–Voigt law, exact stick/slip friction, peak
forces and overlap tracked) at the SAME accuracy:

1. accuracy: on a few bounces, both are compared with a tight DOP853 reference
   (``tests/reference_scipy.py``, rtol 1e-13). The error of a bounce is the largest of the
   relative errors of rebound speed (scale: incident speed V), rebound angle (scale: max(|angle|,
   1 degree)) and rebound spin (scale: max(|spin|, V / r)), as in tests/test_model_reference.py.
   One accuracy target, 1e-7 (the agreement the issues ask of the simulator): for the package's
   ODE path and for SciPy's RK45 a ladder of tolerances (rtol = atol, atol as a fraction of
   each component's natural scale, the package's convention) is tried, and each runs at the
   LOOSEST rung whose error meets the target;
2. speed: solves per second of one batched ``bb.simulate`` call (after the numba warm-up),
   with numba's default thread count and with one thread, against a Python loop of
   ``reference_bounce(method="RK45")`` at the chosen tolerance (and, for information, at the
   package's own rtol). ``ratio`` uses the default thread count, ``ratio_1thread`` one thread.

3. the fast exact path (issue 3): ``bb.simulate``'s default ``method="auto"`` (tabulated normal
   impact + closed-form tangential outcome, ODE only where that is not exact) on batched
   bounces on a horizontal plane, where it covers the whole box (``fast_per_s``), and on the
   mixed draws above with slopes, where it hands rolling-on-a-slope bounces to the ODE
   (``auto_per_s_mixed``); its accuracy is measured against the same DOP853 reference.

``python benchmarks/forward.py --quick`` takes well under a minute; the last stdout line is one
JSON object with the rates, the ratios and the errors.
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


def rate_package(p, repeats: int, method: str = "ode", rtol: float | None = None) -> float:
    n = p["speed"].size
    best = math.inf
    solver = bb.SolverConfig() if rtol is None else bb.SolverConfig(rtol=rtol, atol=rtol)
    for _ in range(repeats):
        t0 = time.perf_counter()
        res = bb.simulate(BALL, normal_law=LAW, method=method, solver=solver, **p)
        best = min(best, time.perf_counter() - t0)
        assert res.n_failed == 0, res.failure_summary()
    return n / best


def rate_scipy(p, rtol: float) -> float:
    n = p["speed"].size
    t0 = time.perf_counter()
    for i in range(n):
        reference_bounce(BALL, normal_law=LAW, method="RK45", rtol=rtol, atol=rtol, **one(p, i))
    return n / (time.perf_counter() - t0)


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="small batches (< 60 s in all)")
    args = ap.parse_args(argv)
    n_acc, n_scipy, n_ode, n_fast, repeats = (12, 400, 50_000, 1_000_000, 3) if args.quick \
        else (32, 2_000, 200_000, 4_000_000, 5)
    t_start = time.perf_counter()

    # numba warm-up (compilation or cache load) before anything is timed
    t0 = time.perf_counter()
    bb.simulate(BALL, normal_law=LAW, method="ode", **draw(4, seed=0))
    bb.simulate(BALL, normal_law=LAW, **draw(4, seed=0))
    print(f"numba warm-up: {time.perf_counter() - t0:.2f} s")

    # 1. accuracy against a tight DOP853 reference
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
    ode_err = ode_ladder[ode_rtol]
    acc_flat = flat(acc)
    refs_flat = [reference_bounce(BALL, normal_law=LAW, **REFERENCE, **one(acc_flat, i))
                 for i in range(n_acc)]
    res = bb.simulate(BALL, normal_law=LAW, **acc_flat)
    fast_err = errors(acc_flat, res.rebound_speed, res.rebound_angle, res.rebound_spin,
                      refs_flat)
    print(f"fast path (closed form for {res.closed_form.sum()} of {n_acc}) error: "
          + ", ".join(f"{k} {v:.2e}" for k, v in fast_err.items()))
    print(f"package (default SolverConfig: rtol={bb.SolverConfig().rtol:g}, "
          f"atol={bb.SolverConfig().atol:g}) error on {n_acc} bounces: "
          + ", ".join(f"{k} {v:.2e}" for k, v in ode_err.items()))
    ladder = {}
    for rtol in RK45_LADDER:
        ladder[rtol] = scipy_errors(acc, refs, rtol)
        print(f"RK45 rtol=atol={rtol:g}: error " + ", ".join(f"{k} {v:.2e}"
                                                             for k, v in ladder[rtol].items()))
    rtol = max([r for r in RK45_LADDER if ladder[r]["max"] <= TARGET] or [1e-12])
    scipy_err = ladder[rtol]
    print(f"accuracy target {TARGET:g}: package ODE at rtol {ode_rtol:g} (error "
          f"{ode_err['max']:.2e}), RK45 at rtol {rtol:g} (error {scipy_err['max']:.2e})")

    # 2. speed
    threads = numba.get_num_threads()
    ode_rate = rate_package(draw(n_ode, seed=2), repeats, rtol=ode_rtol)
    numba.set_num_threads(1)
    ode_rate_1 = rate_package(draw(n_ode, seed=2), repeats, rtol=ode_rtol)
    numba.set_num_threads(threads)
    fast_draws = flat(draw(n_fast, seed=4))
    fast_rate = rate_package(fast_draws, repeats, method="auto")
    share = float(bb.simulate(BALL, normal_law=LAW, **fast_draws).closed_form.mean())
    auto_rate_mixed = rate_package(draw(n_ode, seed=2), repeats, method="auto")
    scipy_rate = rate_scipy(draw(n_scipy, seed=3), rtol)
    # for reference: RK45 at the package's own rtol (the same Dormand-Prince 5(4) pair)
    same_rtol = ode_rtol
    scipy_rate_same = rate_scipy(draw(n_scipy, seed=3), same_rtol)
    print(f"bb.simulate(method='ode', rtol={ode_rtol:g}): {ode_rate:,.0f} bounces/s "
          f"({threads} numba threads), "
          f"{ode_rate_1:,.0f} bounces/s (1 thread), batch of {n_ode}")
    print(f"solve_ivp RK45 loop: {scipy_rate:,.1f} bounces/s ({n_scipy} bounces, rtol {rtol:g}); "
          f"{scipy_rate_same:,.1f} bounces/s at the package's rtol {same_rtol:g} "
          f"(error {ladder.get(same_rtol, {}).get('max', math.nan):.2e})")
    print(f"fast path: {fast_rate:,.0f} bounces/s on a horizontal plane ({100 * share:.0f} % in "
          f"closed form, batch of {n_fast}); {auto_rate_mixed:,.0f} bounces/s on the mixed "
          f"draws with slopes; ratio to the ODE path {fast_rate / ode_rate:,.1f}, to SciPy "
          f"{fast_rate / scipy_rate:,.0f}")
    print(f"ratio: {ode_rate / scipy_rate:,.0f} ({threads} threads), "
          f"{ode_rate_1 / scipy_rate:,.0f} (1 thread); total {time.perf_counter() - t_start:.1f} s")
    summary = {
        "ode_per_s": ode_rate, "ode_per_s_1thread": ode_rate_1, "scipy_per_s": scipy_rate,
        "fast_per_s": fast_rate, "fast_closed_form_share": share,
        "auto_per_s_mixed": auto_rate_mixed, "fast_err": fast_err["max"],
        "fast_ratio_to_ode": fast_rate / ode_rate, "fast_ratio_to_scipy": fast_rate / scipy_rate,
        "ratio": ode_rate / scipy_rate, "ratio_1thread": ode_rate_1 / scipy_rate,
        "ode_err": ode_err["max"], "scipy_err": scipy_err["max"],
        "ode_err_by_quantity": {k: v for k, v in ode_err.items() if k != "max"},
        "scipy_err_by_quantity": {k: v for k, v in scipy_err.items() if k != "max"},
        "scipy_per_s_at_ode_rtol": scipy_rate_same,
        "scipy_method": "RK45", "scipy_rtol": rtol, "scipy_atol": rtol,
        "ode_rtol": ode_rtol, "ode_atol": ode_rtol, "accuracy_target": TARGET,
        "ode_ladder_err": {f"{r:g}": ode_ladder[r]["max"] for r in RK45_LADDER},
        "rk45_ladder_err": {f"{r:g}": ladder[r]["max"] for r in RK45_LADDER},
        "n_accuracy": n_acc, "n_scipy": n_scipy, "n_ode": n_ode, "numba_threads": threads,
        "normal_law": LAW, "quick": args.quick,
        "wall_s": time.perf_counter() - t_start,
    }
    print(json.dumps(summary))
    return summary


if __name__ == "__main__":
    main()
