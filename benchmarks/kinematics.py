"""Kinematics speed with air drag: a 60-point trajectory in <= 20 ms, 100 in <= 5 s on 2 cores.

Trajectories: a table-tennis ball (40 mm, 2.7 g: k = 0.14 /m) bouncing once at 5 m/s and
30 deg, 60 samples at 1 kHz with 0.2 mm noise, integrated by ``scipy.integrate.solve_ivp``
(DOP853) with quadratic drag; written as trajectory files. Measured, each the best of
``--repeats`` runs:

1. ``one_ms``: ``fit_kinematics(..., drag="quadratic")`` of one trajectory already in memory
   (the fit as ``bouncebayes kinematics`` runs it: the ball's expected drag as the prior);
2. ``folder_s``: ``kinematics_from_folder`` on 100 such files (reading, cleaning, fitting,
   gates);
3. ``baseline_one_ms``: the same trajectories' drag kinematics as bouncebayes 0.1.0 computed
   them (``benchmarks/_baseline_kinematics.py``: NumPy RK4 inside Levenberg-Marquardt with
   finite-difference Jacobians and delta method), in the same run, on ``--baseline`` files;
4. ``generator_file_ms``: per file of the independent generator of the tests (3-D, 150 Hz,
   three bounces with drag and Magnus lift, ``tests/bounce_generator.py``), with drag.

Each is reported as wall-clock and CPU time (the CPU time is what the run costs on a machine of
its own; on a shared one other processes stretch the wall clock). The process is pinned to 2
cores (where the machine has more) and BLAS to one thread, as the command line does. ``python benchmarks/kinematics.py --quick`` finishes in about a minute; the
last stdout line is one JSON object, also written to ``benchmarks/results/kinematics.json``.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy is imported
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import platform  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
from scipy.integrate import solve_ivp  # noqa: E402

from bouncebayes.kinematics import (  # noqa: E402
    FitConfig,
    fit_kinematics,
    kinematics_from_folder,
    trajectory_from_arrays,
    write_trajectory,
)

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent / "tests"))
import _baseline_kinematics as baseline  # noqa: E402

G = 9.81
K = 1.2 * 0.47 * math.pi * 0.02**2 / (2 * 2.7e-3)  # the ball's expected drag, 0.13 /m
K_TRUE = 0.14
CONFIG = FitConfig(drag="quadratic", drag_k=K, drag_k_max=1.3 * math.pi * 0.02**2 / 5.4e-3)
TARGET_ONE_MS, TARGET_FOLDER_S = 20.0, 5.0


def trajectory(rng, n=60, rate=1000.0, noise=2e-4):
    """``n`` samples of one bounce of the table-tennis ball (impact at a random phase)."""
    def rhs(_, s):
        v = s[2:]
        return np.concatenate([v, [0.0, -G] - K_TRUE * np.linalg.norm(v) * v])

    def flight(v0, times):
        sol = solve_ivp(rhs, (0.0, times[-1]), [0.1, 0.02, *v0], method="DOP853", rtol=1e-11,
                        atol=1e-13, dense_output=True)
        return sol.sol(times)[:2].T

    s = (np.arange(n) - n // 2) / rate - rng.uniform(0.1, 0.9) / rate
    a_in, a_out = math.radians(30.0), math.radians(25.0)
    pre = flight((5.0 * math.sin(a_in), -5.0 * math.cos(a_in)), s[s < 0][::-1])[::-1]
    post = flight((4.0 * math.sin(a_out), 4.0 * math.cos(a_out)), s[s >= 0])
    pos = np.vstack([pre, post]) + rng.normal(0.0, noise, (n, 2))
    return s + 0.5, pos


def best(repeats, fn):
    """Best wall-clock and best CPU seconds of ``repeats`` calls of ``fn()`` (the CPU time is
    what the run costs on a machine of its own: on a shared one other processes stretch the
    wall clock), and the last result."""
    wall, cpu, result = math.inf, math.inf, None
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        result = fn()
        wall = min(wall, time.perf_counter() - t0)
        cpu = min(cpu, time.process_time() - c0)
    return (wall, cpu), result


def baseline_one(t, pos):
    """0.1.0's drag kinematics on the flights the current code splits off."""
    k = fit_kinematics(trajectory_from_arrays(t, *pos.T))  # drag-free: the split
    low = int(np.argmin(pos[:, 1]))
    t_ref = t[low]
    pre = np.flatnonzero(t < k.impact_time)[:-1]
    post = np.flatnonzero(t > k.impact_time)[1:]
    return baseline.kinematics(t[pre] - t_ref, pos[pre], t[post] - t_ref, pos[post],
                               k.impact_time - t_ref)


def measure(args) -> dict:
    rng = np.random.default_rng(2026)
    data = [trajectory(rng) for _ in range(args.files)]
    trajs = [trajectory_from_arrays(t, *pos.T) for t, pos in data]
    fit_kinematics(trajs[0], config=CONFIG)  # numba: compile or load the cache
    one, _ = best(args.repeats, lambda: [fit_kinematics(tr, config=CONFIG) for tr in trajs])
    with tempfile.TemporaryDirectory() as tmp:
        for i, (t, pos) in enumerate(data):
            write_trajectory(Path(tmp) / f"b{i:03d}.csv", t, *pos.T)
        folder, found = best(args.repeats, lambda: kinematics_from_folder(tmp, config=CONFIG))
    base, _ = best(1, lambda: [baseline_one(t, pos) for t, pos in data[:args.baseline]])
    gen, _ = generator_files(args.generator, args.repeats)
    n = len(trajs)
    return {"one_ms": 1e3 * one[0] / n, "one_cpu_ms": 1e3 * one[1] / n,
            "folder_s": folder[0] * 100 / args.files, "folder_cpu_s": folder[1] * 100 / args.files,
            "folder_trials": len(found.results), "folder_files": args.files,
            "baseline_one_ms": 1e3 * base[0] / args.baseline,
            "baseline_one_cpu_ms": 1e3 * base[1] / args.baseline,
            "speedup_one": base[0] / args.baseline / (one[0] / n),
            "speedup_one_cpu": base[1] / args.baseline / (one[1] / n),
            "generator_file_ms": 1e3 * gen[0] / args.generator,
            "generator_file_cpu_ms": 1e3 * gen[1] / args.generator}


def generator_files(n: int, repeats: int):
    import bounce_generator as g

    rng = np.random.default_rng(7)
    files = []
    for _ in range(n):
        t, pos, _ = g.simulate(rng, speed=rng.uniform(4, 11), angle_deg=rng.uniform(20, 60),
                               azimuth_deg=rng.uniform(-30, 30),
                               spin=[rng.uniform(-300, 300), 0, rng.uniform(-1500, 1500)],
                               height=rng.uniform(0.3, 0.6))
        files.append(trajectory_from_arrays(t, *pos.T))
    from bouncebayes.kinematics import fit_bounces

    return best(repeats, lambda: [fit_bounces(f, config=CONFIG) for f in files])


def pin_to_cores(n: int) -> int:
    if hasattr(os, "sched_setaffinity"):
        cores = sorted(os.sched_getaffinity(0))[:n]
        os.sched_setaffinity(0, cores)
        return len(cores)
    return os.cpu_count() or n


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer baseline runs (~1 min)")
    parser.add_argument("--repeats", type=int, default=3, help="runs per measurement")
    parser.add_argument("--cores", type=int, default=2, help="cores to run on")
    parser.add_argument("--no-write", action="store_true", help="do not write the results file")
    args = parser.parse_args(argv)
    args.files, args.baseline = 100, (5 if args.quick else 20)
    args.generator = 5 if args.quick else 20
    cores = pin_to_cores(args.cores)
    result = measure(args)
    result |= {"target_one_ms": TARGET_ONE_MS, "target_folder_s": TARGET_FOLDER_S,
               "meets_targets_wall": bool(result["one_ms"] <= TARGET_ONE_MS
                                          and result["folder_s"] <= TARGET_FOLDER_S),
               "meets_targets_cpu": bool(result["one_cpu_ms"] <= TARGET_ONE_MS
                                         and result["folder_cpu_s"] <= TARGET_FOLDER_S),
               "cores": cores, "quick": args.quick, "machine": platform.machine(),
               "python": platform.python_version()}
    text = json.dumps(result, indent=2)
    if not args.no_write:
        (HERE / "results" / "kinematics.json").write_text(text + "\n")
    print(json.dumps(result))
    return result


if __name__ == "__main__":
    main()
