"""Inference speed: the paper's MH run and a 512 x 512 grid against a Python-loop + SciPy baseline.

Timed, in one run, on the bundled demo campaign (55 bounces of the paper's setup):

(a) ``infer(likelihood="kde", sampler="mh")`` with the paper's settings (``SamplerConfig()``:
    15,000 draws over 4 chains, burn-in 100, thinning 3), end to end (mode search, sampling,
    regime re-simulation, diagnostics);
(b) ``infer(likelihood="gaussian", sampler="grid")`` on the default 2-D grid (512 x 512 (mu, eta)
    cells, each with all 55 trials at their own incidence), end to end; the structured grid
    kernel alone is timed too.

Baseline, measured in the same run: a plain Python loop over parameter points whose forward model
is ``tests/reference_scipy.py``'s ``reference_bounce`` (SciPy ``solve_ivp``, RK45, rtol = atol =
1e-6, event-located phase switches, independent of the package) and whose likelihood is SciPy /
the standard library:

- kde: the product of two ``scipy.stats.gaussian_kde`` marginals with the package's bandwidths,
  evaluated at the rebound simulated for the nominal incidence (one bounce per point);
- gaussian: the bivariate normal log-density of each trial's residual with the package's
  covariance (table standard errors + propagated incidence uncertainty, taken from the package's
  likelihood object, not timed), one ``reference_bounce`` per trial (55 per point).

It is timed on a small subset of points (posterior draws of (a) for the kde baseline, uniform
draws over the prior box for the grid baseline) and extrapolated: seconds per point x the number
of points the package evaluated. For (a) that number counts only the MH proposals
(chains x (burn-in + thin x draws per chain) = 45,400), not the mode search or the regime
re-simulation, which favours the baseline; for (b) it is the 262,144 grid cells. The baseline's
log-likelihood is checked against the package's on the same points (the largest difference is
printed: the two forward models differ by RK45's tolerance).

``python benchmarks/inference.py [--quick]``; the last stdout line is one JSON object.
``--quick`` uses smaller baseline subsets (the package runs are the full ones) and takes < 60 s.
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
from scipy import stats  # noqa: E402

from bouncebayes.data import demo_campaign, load_experiment, load_trials  # noqa: E402
from bouncebayes.inference import SamplerConfig, infer  # noqa: E402
from bouncebayes.inference._grid_kernel import gaussian_grid  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from reference_scipy import reference_bounce  # noqa: E402

BASELINE_SOLVER = {"method": "RK45", "rtol": 1e-6, "atol": 1e-6}


def rebound(exp, mu: float, eta: float, speed: float, angle: float, spin: float):
    b = reference_bounce(exp.ball, mu=mu, eta=eta, speed=speed, angle=angle, spin=spin,
                         inclination=exp.inclination, normal_law=exp.normal_law,
                         gravity=exp.gravity, **BASELINE_SOLVER)
    return b.rebound_speed, b.rebound_angle


def kde_baseline(exp, trials, density: dict):
    """log rho_exp(h(theta)) with SciPy KDEs and the SciPy forward model, one point at a time."""
    if density["kind"] != "product":
        raise ValueError("the baseline implements the product KDE (the demo's)")
    marginals = []
    for column, h in (("rebound_speed", density["bandwidth_speed_m_s"]),
                      ("rebound_angle", density["bandwidth_angle_deg"])):
        x = np.asarray(trials.column(column), dtype=float)
        marginals.append(stats.gaussian_kde(x, bw_method=h / np.std(x, ddof=1)))
    inc = exp.incidence

    def loglike(mu, eta):
        v, a = rebound(exp, mu, eta, inc.speed, inc.angle, inc.spin)
        return float(marginals[0].logpdf(v)[0] + marginals[1].logpdf(a)[0])
    return loglike


def gaussian_baseline(exp, trials, like):
    """Sum over trials of the bivariate normal log-density, one reference_bounce per trial."""
    cov = like.propagated + np.einsum("ij,jk->ijk", like.rebound_var, np.eye(2))
    rows = [(float(s), float(a), float(w), float(vo), float(ao), float(c[0, 0]),
             float(c[0, 1]), float(c[1, 1]))
            for s, a, w, vo, ao, c in zip(trials.incidence_speed, trials.incidence_angle,
                                          trials.incidence_spin, like.speed, like.angle, cov,
                                          strict=True)]

    def loglike(mu, eta):
        total = 0.0
        for s, a, w, vo, ao, c00, c01, c11 in rows:
            v, ang = rebound(exp, mu, eta, s, a, w)
            ds, da = v - vo, ang - ao
            det = c00 * c11 - c01 * c01
            total += -0.5 * ((c11 * ds * ds - 2 * c01 * ds * da + c00 * da * da) / det
                             + math.log(det)) - math.log(2 * math.pi)
        return total
    return loglike


def time_baseline(loglike, points: np.ndarray) -> tuple[float, np.ndarray]:
    """Seconds per point of a plain Python loop, and the values."""
    t0 = time.perf_counter()
    values = np.array([loglike(float(mu), float(eta)) for mu, eta in points])
    return (time.perf_counter() - t0) / len(points), values


def timed(fn):
    t0 = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t0


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true",
                    help="smaller baseline subsets (the package runs stay full size); < 60 s")
    args = ap.parse_args(argv)
    n_mh_base, n_grid_base = (50, 3) if args.quick else (500, 20)
    t_start = time.perf_counter()
    demo = demo_campaign()
    exp = load_experiment(demo.experiment)
    trials = load_trials(demo.trials, exp)

    # numba warm-up (compilation or cache load) before anything is timed
    _, warm = timed(lambda: [infer(exp, trials, likelihood=lk, sampler=s,
                                   config=SamplerConfig(draws=200, burn_in=10, grid_points=16))
                             for lk, s in (("kde", "mh"), ("gaussian", "grid"))])
    print(f"numba warm-up: {warm:.2f} s; numba threads: {numba.get_num_threads()}")

    # (a) the paper's MH run
    config = SamplerConfig()
    mh, mh_seconds = timed(lambda: infer(exp, trials, likelihood="kde", sampler="mh",
                                         seed=0, config=config))
    mh_evals = config.chains * (config.burn_in + config.per_chain() * config.thin)
    print(f"(a) paper's MH (kde, {config.draws} draws, {config.chains} chains, burn-in "
          f"{config.burn_in}, thin {config.thin}): {mh_seconds:.2f} s end to end, "
          f"{mh_evals} proposals ({1e6 * mh_seconds / mh_evals:.1f} us each, all included)")
    rng = np.random.default_rng(2016)
    flat = mh.draws.samples.reshape(-1, 2)
    points = flat[rng.choice(flat.shape[0], n_mh_base, replace=False)]
    base_kde = kde_baseline(exp, trials, mh.likelihood_info["density"])
    per_mh, values = time_baseline(base_kde, points)
    diff_mh = float(np.max(np.abs(values - mh.posterior.likelihood(points))))
    mh_base = per_mh * mh_evals
    print(f"    baseline: {1e3 * per_mh:.2f} ms per point (RK45 rtol 1e-6 + scipy "
          f"gaussian_kde, {n_mh_base} posterior draws), x {mh_evals} = {mh_base:.0f} s "
          f"extrapolated; ratio {mh_base / mh_seconds:.0f}; |log-likelihood difference| "
          f"<= {diff_mh:.2e}")

    # (b) the 512 x 512 grid, gaussian likelihood, 55 trials
    grid, grid_seconds = timed(lambda: infer(exp, trials, likelihood="gaussian",
                                             sampler="grid", seed=0, config=SamplerConfig()))
    n = grid.draws.info["grid_points"]
    grid_evals = n * n
    like = grid.posterior.likelihood
    centres = grid.draws.info["grid"]["centres"]
    _, kernel_seconds = timed(lambda: gaussian_grid(like, np.asarray(centres[0]),
                                                    np.asarray(centres[1])))
    print(f"(b) {n} x {n} grid (gaussian, {trials.n} trials): {grid_seconds:.2f} s end to end, "
          f"{kernel_seconds:.2f} s for the structured kernel alone "
          f"({1e9 * kernel_seconds / (grid_evals * trials.n):.0f} ns per cell and trial)")
    box = grid.posterior.box()
    points = box[:, 0] + rng.uniform(size=(n_grid_base, 2)) * (box[:, 1] - box[:, 0])
    base_gauss = gaussian_baseline(exp, trials, like)
    per_grid, values = time_baseline(base_gauss, points)
    reference = like(points)
    diff_grid = float(np.max(np.abs(values - reference) / np.maximum(1.0, np.abs(reference))))
    grid_base = per_grid * grid_evals
    print(f"    baseline: {per_grid:.3f} s per point ({trials.n} RK45 bounces + normal "
          f"log-density, {n_grid_base} uniform points of the box), x {grid_evals} = "
          f"{grid_base:.0f} s ({grid_base / 3600:.1f} h) extrapolated; ratio "
          f"{grid_base / grid_seconds:.0f}; relative log-likelihood difference <= "
          f"{diff_grid:.2e}")
    summary = {
        "mh_seconds": mh_seconds, "grid_seconds": grid_seconds,
        "mh_baseline_seconds_extrapolated": mh_base,
        "grid_baseline_seconds_extrapolated": grid_base,
        "mh_ratio": mh_base / mh_seconds, "grid_ratio": grid_base / grid_seconds,
        "grid_kernel_seconds": kernel_seconds,
        "mh_evaluations": mh_evals, "grid_evaluations": grid_evals, "n_trials": trials.n,
        "mh_baseline_seconds_per_point": per_mh, "grid_baseline_seconds_per_point": per_grid,
        "mh_baseline_points": n_mh_base, "grid_baseline_points": n_grid_base,
        "baseline": "Python loop; tests/reference_scipy.py reference_bounce (solve_ivp RK45, "
                    "rtol=atol=1e-6) + scipy.stats.gaussian_kde (kde) or a closed-form "
                    "bivariate normal (gaussian); per-point time x package evaluations",
        "mh_baseline_max_abs_loglike_diff": diff_mh,
        "grid_baseline_max_rel_loglike_diff": diff_grid,
        "numba_threads": numba.get_num_threads(), "quick": args.quick,
        "total_seconds": time.perf_counter() - t_start,
    }
    print(f"total {summary['total_seconds']:.1f} s")
    print(json.dumps(summary))
    return summary


if __name__ == "__main__":
    main()
