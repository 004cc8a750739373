"""Forward-model speed: the compiled batched solver against a SciPy ``solve_ivp`` loop.

Both solve the same bounces (paper's ball, Kelvin–Voigt law, exact stick/slip friction, peak
forces and overlap tracked) at the SAME accuracy:

1. accuracy: on a few bounces, both are compared with a tight DOP853 reference
   (``tests/reference_scipy.py``, rtol 1e-13). The error of a bounce is the largest of the
   relative errors of rebound speed (scale: incident speed V), rebound angle (scale: max(|angle|,
   1 degree)) and rebound spin (scale: max(|spin|, V / r)), as in tests/test_model_reference.py.
   The package runs at its default ``SolverConfig``. For SciPy's RK45 a ladder of tolerances
   (rtol = atol, atol as a fraction of each component's natural scale, the package's convention)
   is tried and the TIGHTEST one whose error is still >= the package's is used, so the baseline
   is never asked to be more accurate than the package (if even the loosest rung is more
   accurate, the loosest is used);
2. speed: solves per second of one batched ``bb.simulate`` call (after the numba warm-up),
   with numba's default thread count and with one thread, against a Python loop of
   ``reference_bounce(method="RK45")`` at the chosen tolerance (and, for information, at the
   package's own rtol). ``ratio`` uses the default thread count, ``ratio_1thread`` one thread.

``python benchmarks/forward.py --quick`` takes well under a minute; the last stdout line is one
JSON object with the rates, the ratio and the errors.
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


def rate_package(p, repeats: int) -> float:
    n = p["speed"].size
    best = math.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        res = bb.simulate(BALL, normal_law=LAW, **p)
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
    n_acc, n_scipy, n_ode, repeats = (12, 400, 50_000, 3) if args.quick else \
        (32, 2_000, 200_000, 5)
    t_start = time.perf_counter()

    # numba warm-up (compilation or cache load) before anything is timed
    t0 = time.perf_counter()
    bb.simulate(BALL, normal_law=LAW, **draw(4, seed=0))
    print(f"numba warm-up: {time.perf_counter() - t0:.2f} s")

    # 1. accuracy against a tight DOP853 reference
    acc = draw(n_acc, seed=1)
    refs = [reference_bounce(BALL, normal_law=LAW, **REFERENCE, **one(acc, i))
            for i in range(n_acc)]
    res = bb.simulate(BALL, normal_law=LAW, **acc)
    ode_err = errors(acc, res.rebound_speed, res.rebound_angle, res.rebound_spin, refs)
    print(f"package (default SolverConfig: rtol={bb.SolverConfig().rtol:g}, "
          f"atol={bb.SolverConfig().atol:g}) error on {n_acc} bounces: "
          + ", ".join(f"{k} {v:.2e}" for k, v in ode_err.items()))
    ladder = {}
    for rtol in RK45_LADDER:
        ladder[rtol] = scipy_errors(acc, refs, rtol)
        print(f"RK45 rtol=atol={rtol:g}: error " + ", ".join(f"{k} {v:.2e}"
                                                             for k, v in ladder[rtol].items()))
    worse = [r for r in RK45_LADDER if ladder[r]["max"] >= ode_err["max"]]
    rtol = min(worse) if worse else max(RK45_LADDER)
    scipy_err = ladder[rtol]
    print(f"chosen RK45 tolerance {rtol:g} (tightest whose error {scipy_err['max']:.2e} "
          f">= the package's {ode_err['max']:.2e})")

    # 2. speed
    threads = numba.get_num_threads()
    ode_rate = rate_package(draw(n_ode, seed=2), repeats)
    numba.set_num_threads(1)
    ode_rate_1 = rate_package(draw(n_ode, seed=2), repeats)
    numba.set_num_threads(threads)
    scipy_rate = rate_scipy(draw(n_scipy, seed=3), rtol)
    # for reference: RK45 at the package's own rtol (the same Dormand-Prince 5(4) pair)
    same_rtol = bb.SolverConfig().rtol
    scipy_rate_same = rate_scipy(draw(n_scipy, seed=3), same_rtol)
    print(f"bb.simulate: {ode_rate:,.0f} bounces/s ({threads} numba threads), "
          f"{ode_rate_1:,.0f} bounces/s (1 thread), batch of {n_ode}")
    print(f"solve_ivp RK45 loop: {scipy_rate:,.1f} bounces/s ({n_scipy} bounces, rtol {rtol:g}); "
          f"{scipy_rate_same:,.1f} bounces/s at the package's rtol {same_rtol:g} "
          f"(error {ladder.get(same_rtol, {}).get('max', math.nan):.2e})")
    print(f"ratio: {ode_rate / scipy_rate:,.0f} ({threads} threads), "
          f"{ode_rate_1 / scipy_rate:,.0f} (1 thread); total {time.perf_counter() - t_start:.1f} s")
    summary = {
        "ode_per_s": ode_rate, "ode_per_s_1thread": ode_rate_1, "scipy_per_s": scipy_rate,
        "ratio": ode_rate / scipy_rate, "ratio_1thread": ode_rate_1 / scipy_rate,
        "ode_err": ode_err["max"], "scipy_err": scipy_err["max"],
        "ode_err_by_quantity": {k: v for k, v in ode_err.items() if k != "max"},
        "scipy_err_by_quantity": {k: v for k, v in scipy_err.items() if k != "max"},
        "scipy_per_s_at_ode_rtol": scipy_rate_same,
        "scipy_method": "RK45", "scipy_rtol": rtol, "scipy_atol": rtol,
        "ode_rtol": bb.SolverConfig().rtol, "ode_atol": bb.SolverConfig().atol,
        "rk45_ladder_err": {f"{r:g}": ladder[r]["max"] for r in RK45_LADDER},
        "n_accuracy": n_acc, "n_scipy": n_scipy, "n_ode": n_ode, "numba_threads": threads,
        "normal_law": LAW, "quick": args.quick,
        "wall_s": time.perf_counter() - t_start,
    }
    print(json.dumps(summary))
    return summary


if __name__ == "__main__":
    main()
