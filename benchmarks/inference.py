"""Inference speed: the paper's MH runs and a 512 x 512 grid, each against a baseline measured in
the same run.

Timed, in one run, on the bundled demo campaign (55 bounces of the paper's setup):

(g) the paper's Metropolis–Hastings settings (``MHConfig()``: 15,000 draws over 4 chains,
    burn-in 100, thinning 3: 11,350 iterations per chain) with the ``gaussian`` likelihood, every
    trial at its own incidence. ``mh_gaussian_seconds`` is the sampler as a user runs it (wall
    clock, the model's default threads): mode search and the chains, all four advanced by one
    batched model call per iteration; ``mh_gaussian_infer_seconds`` is ``infer`` end to end
    (also the pointwise log-likelihood, the predictive and the diagnostics). The same sampler
    is then run on one thread and timed in CPU seconds of this process (``*_cpu_seconds``),
    which a loaded machine does not inflate: as a user runs it (whole blocks of iterations in
    one compiled call, ``mh_gaussian_cpu_seconds``), and step by step through a timed model
    (``mh_gaussian_stepwise_cpu_seconds``, the same draws), split into the time inside the model
    and the rest (sampler and likelihood, ``mh_gaussian_own_cpu_seconds``), with the floor of
    that many bare model calls. Baseline, both ways: the previous design of the same algorithm on the same
    model, one NumPy expression at a time (prior densities summed, the covariance broadcast and
    copied at every call, ``np.where`` accept), its chains timed on the first iterations and
    extrapolated;
(l) with ``--large``: a 100,000-row table (the demo tiled) under a 512 MiB memory budget, short
    chains, in a child process: seconds and the growth of its resident set;
(a) ``infer(likelihood="kde", sampler="mh")`` with the paper's settings, end to end (mode
    search, sampling, regime re-simulation, diagnostics);
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

``python benchmarks/inference.py [--quick] [--large]``; the last stdout line is one JSON object,
also written to ``benchmarks/results/inference.json``. ``--quick`` uses smaller baseline subsets
(the package runs are the full ones).
"""

from __future__ import annotations

import os

os.environ["OPENBLAS_NUM_THREADS"] = "1"  # before numpy is imported

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import platform  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from datetime import datetime, timezone  # noqa: E402
from pathlib import Path  # noqa: E402

import numba  # noqa: E402
import numpy as np  # noqa: E402
from scipy import stats  # noqa: E402

from bouncebayes._io import write_json  # noqa: E402
from bouncebayes.data import demo_campaign, load_experiment, load_trials  # noqa: E402
from bouncebayes.inference import GridConfig, LogPosterior, MHConfig, infer  # noqa: E402
from bouncebayes.inference._grid_kernel import gaussian_grid  # noqa: E402
from bouncebayes.inference._mh import sample_mh  # noqa: E402
from bouncebayes.inference._mode import dispersed_starts, find_mode  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from reference_scipy import reference_bounce  # noqa: E402

BASELINE_SOLVER = {"method": "RK45", "rtol": 1e-6, "atol": 1e-6}
RESULTS = Path(__file__).resolve().parent / "results" / "inference.json"


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


class TimedForward:
    """The likelihood's forward model with the time spent inside it accumulated."""

    def __init__(self, forward, clock=time.perf_counter):
        self.forward, self.seconds, self.calls, self.clock = forward, 0.0, 0, clock
        self.names, self.n_conditions = forward.names, forward.n_conditions
        self.experiment = forward.experiment

    def __call__(self, theta):
        t0 = self.clock()
        out = self.forward(theta)
        self.seconds += self.clock() - t0
        self.calls += 1
        return out


def baseline_mh_seconds(post, like, config: MHConfig, iterations: int, seed: int,
                        clock=time.perf_counter) -> float:
    """Seconds of the sampler in the previous design (mode search, then the chains timed for
    ``iterations`` and extrapolated to the run's): one chain batch per iteration, but the prior
    as a sum of per-prior densities, the likelihood's covariance broadcast and copied at every
    call, NumPy accept and bookkeeping (a faithful copy of that code, same model)."""
    d = post.dim

    def loglike(theta):
        r = like.forward(theta)
        cov = np.broadcast_to(like.propagated, (theta.shape[0],) + like.propagated.shape).copy()
        cov[..., 0, 0] += like.rebound_var[..., 0]
        cov[..., 1, 1] += like.rebound_var[..., 1]
        ds, da = r.speed - like.speed, r.angle - like.angle
        det = cov[..., 0, 0] * cov[..., 1, 1] - cov[..., 0, 1] ** 2
        quad = (cov[..., 1, 1] * ds**2 - 2 * cov[..., 0, 1] * ds * da
                + cov[..., 0, 0] * da**2) / det
        ll = -0.5 * (quad + np.log(det)) - np.log(2 * np.pi)
        ll = np.where(r.ok, ll, -np.inf).sum(axis=1)
        return np.where(np.isnan(ll), -np.inf, ll)

    def logpost(theta):
        theta = np.atleast_2d(np.asarray(theta, dtype=float))
        lp = sum(p.logpdf(theta[:, i]) for i, p in enumerate(post.priors))
        inside = np.isfinite(lp)
        out = np.full(theta.shape[0], -np.inf)
        if inside.any():
            out[inside] = lp[inside] + loglike(theta[inside])
        return np.where(np.isnan(out), -np.inf, out)

    rng = np.random.default_rng(seed)
    t_mode = clock()
    mode, cov = find_mode(post, rng)
    t_mode = clock() - t_mode
    x = dispersed_starts(post, mode, cov, config.chains, rng, 2.0)
    lp = logpost(x)
    chol = np.linalg.cholesky(cov) * (2.38 / math.sqrt(d))
    normals = rng.standard_normal((iterations, config.chains, d)) @ chol.T
    log_u = np.log(rng.uniform(size=(iterations, config.chains)))
    log_scale = np.zeros(config.chains)
    keep = np.empty((iterations, config.chains, d))
    t0 = clock()
    for it in range(iterations):
        proposal = x + normals[it] * np.exp(log_scale)[:, None]
        lp_new = logpost(proposal)
        accept = log_u[it] < lp_new - lp
        x = np.where(accept[:, None], proposal, x)
        lp = np.where(accept, lp_new, lp)
        if it < config.burn_in:
            log_scale += (accept.astype(float) - 0.234) / math.sqrt(it + 1.0)
        k, r = divmod(it, config.thin)
        if r == config.thin - 1:
            keep[k] = x
    return t_mode + (clock() - t0) / iterations * config.iterations()


def mh_gaussian(exp, trials, n_baseline: int) -> dict:
    """(g): the paper's MH settings, gaussian likelihood, 55 trials at their own incidence, as a
    user runs it (wall clock, the model's default threads)."""
    config = MHConfig()
    result, infer_seconds = timed(lambda: infer(exp, trials, likelihood="gaussian",
                                                sampler="mh", seed=0, config=config))
    post, like = result.posterior, result.posterior.likelihood
    _, seconds = timed(lambda: sample_mh(post, config, np.random.default_rng(0)))
    baseline = baseline_mh_seconds(post, like, config, n_baseline, seed=0)
    print(f"(g) paper's MH, gaussian, {trials.n} trials at their own incidence: "
          f"{seconds:.2f} s for the sampler ({config.iterations()} iterations x {config.chains} "
          f"chains, one model call of {config.chains} x {trials.n} bounces each); infer end to "
          f"end {infer_seconds:.2f} s; baseline (previous NumPy design, same model) "
          f"{baseline:.2f} s, ratio {baseline / seconds:.1f}")
    return {"mh_gaussian_seconds": seconds, "mh_gaussian_infer_seconds": infer_seconds,
            "mh_gaussian_baseline_seconds": baseline,
            "mh_gaussian_ratio": baseline / seconds,
            "mh_gaussian_baseline_iterations_timed": n_baseline,
            "mh_gaussian_iterations": config.iterations()} | mh_gaussian_split(post, like,
                                                                                config, n_baseline)


def mh_gaussian_split(post, like, config: MHConfig, n_baseline: int) -> dict:
    """The same sampler on one thread in CPU seconds of this process, which a loaded machine
    does not inflate: as a user runs it (compiled chain blocks), then step by step through a
    timed model (a wrapped model takes that path) for the time inside the model and the rest
    (sampler and likelihood), the floor (that many bare model calls) and the previous
    design's."""
    cpu = time.process_time
    threads = numba.get_num_threads()
    numba.set_num_threads(1)
    compiled, compiled_cpu = timed(lambda: sample_mh(post, config, np.random.default_rng(0)),
                                   cpu)
    clock = TimedForward(like.forward, cpu)  # a wrapped model: the step-by-step path
    clocked = LogPosterior(post.names, post.priors, post.units,
                           dataclasses.replace(like, forward=clock), post.batch_rows)
    sample, total = timed(lambda: sample_mh(clocked, config, np.random.default_rng(0)), cpu)
    theta = sample.samples[:, -1, :].copy()
    _, floor = timed(lambda: [like.forward(theta) for _ in range(2000)], cpu)
    floor *= config.iterations() / 2000
    baseline = baseline_mh_seconds(post, like, config, n_baseline, seed=0, clock=cpu)
    numba.set_num_threads(threads)
    same = bool(np.array_equal(compiled.samples, sample.samples))
    print(f"    on one thread, CPU seconds: {compiled_cpu:.2f} s (compiled chain blocks); the "
          f"step-by-step path {total:.2f} s, of which the model {clock.seconds:.2f} s "
          f"({clock.calls} calls) and sampler + likelihood {total - clock.seconds:.2f} s; floor "
          f"(bare model calls) {floor:.2f} s; baseline {baseline:.2f} s, ratio "
          f"{baseline / compiled_cpu:.1f}; identical draws: {same}")
    return {"mh_gaussian_cpu_seconds": compiled_cpu, "mh_gaussian_stepwise_cpu_seconds": total,
            "mh_gaussian_model_cpu_seconds": clock.seconds,
            "mh_gaussian_own_cpu_seconds": total - clock.seconds,
            "mh_gaussian_model_calls": clock.calls, "mh_gaussian_floor_cpu_seconds": floor,
            "mh_gaussian_baseline_cpu_seconds": baseline,
            "mh_gaussian_ratio_cpu": baseline / compiled_cpu,
            "mh_gaussian_compiled_equals_stepwise": same}


LARGE_SCRIPT = """
import json, time
import numpy as np
from bouncebayes.data import demo_campaign, load_experiment, load_trials, make_trials
from bouncebayes.inference import MHConfig, infer
def rss(key):
    with open("/proc/self/status") as fh:
        return next(int(l.split()[1]) * 1024 for l in fh if l.startswith(key))
demo = demo_campaign()
exp = load_experiment(demo.experiment)
t = load_trials(demo.trials, exp)
n = 100_000
tile = lambda x: np.tile(x, -(-n // t.n))[:n]
big = make_trials(exp, rebound_speed=tile(t.rebound_speed), rebound_angle=tile(t.rebound_angle),
                  incidence_speed=tile(t.incidence_speed), incidence_angle=tile(t.incidence_angle),
                  se={k: tile(v) for k, v in t.se.items() if np.all(np.isfinite(v))})
config = MHConfig(draws=200, chains=2, burn_in=20, thin=1)
infer(exp, t, config=config)
base = rss("VmRSS")
t0 = time.perf_counter()
r = infer(exp, big, config=config, memory_budget=512 * 2**20)
print(json.dumps({"large_table_rows": n, "large_table_seconds": time.perf_counter() - t0,
                  "large_table_memory_budget_bytes": 512 * 2**20,
                  "large_table_rss_growth_bytes": rss("VmHWM") - base,
                  "large_table_settings": "MHConfig(draws=200, chains=2, burn_in=20, thin=1)"}))
"""


def large_table() -> dict:
    """(l): a 100,000-row table in a child process (its own resident-set high-water mark)."""
    import subprocess

    out = subprocess.run([sys.executable, "-c", LARGE_SCRIPT], capture_output=True, text=True,
                         check=True)
    result = json.loads(out.stdout.strip().splitlines()[-1])
    print(f"(l) {result['large_table_rows']} rows: {result['large_table_seconds']:.1f} s, "
          f"resident set grew {result['large_table_rss_growth_bytes'] / 2**20:.0f} MiB "
          f"(budget 512 MiB)")
    return result


def timed(fn, clock=time.perf_counter):
    t0 = clock()
    out = fn()
    return out, clock() - t0


def paper_kde_mh(exp, trials, n_base: int, rng) -> dict:
    """(a): the paper's MH run with the kde likelihood, against the SciPy baseline."""
    config = MHConfig()
    mh, mh_seconds = timed(lambda: infer(exp, trials, likelihood="kde", sampler="mh",
                                         seed=0, config=config))
    mh_evals = config.chains * config.iterations()
    print(f"(a) paper's MH (kde, {config.draws} draws, {config.chains} chains, burn-in "
          f"{config.burn_in}, thin {config.thin}): {mh_seconds:.2f} s end to end, "
          f"{mh_evals} proposals ({1e6 * mh_seconds / mh_evals:.1f} us each, all included)")
    flat = mh.draws.samples.reshape(-1, 2)
    points = flat[rng.choice(flat.shape[0], n_base, replace=False)]
    base_kde = kde_baseline(exp, trials, mh.likelihood_info["density"])
    per_mh, values = time_baseline(base_kde, points)
    diff_mh = float(np.max(np.abs(values - mh.posterior.likelihood(points))))
    mh_base = per_mh * mh_evals
    print(f"    baseline: {1e3 * per_mh:.2f} ms per point (RK45 rtol 1e-6 + scipy "
          f"gaussian_kde, {n_base} posterior draws), x {mh_evals} = {mh_base:.0f} s "
          f"extrapolated; ratio {mh_base / mh_seconds:.0f}; |log-likelihood difference| "
          f"<= {diff_mh:.2e}")
    return {"mh_seconds": mh_seconds, "mh_baseline_seconds_extrapolated": mh_base,
            "mh_ratio": mh_base / mh_seconds, "mh_evaluations": mh_evals,
            "mh_baseline_seconds_per_point": per_mh, "mh_baseline_points": n_base,
            "mh_baseline_max_abs_loglike_diff": diff_mh}


def grid_512(exp, trials, n_base: int, rng) -> dict:
    """(b): the default 2-D grid with the gaussian likelihood, against the SciPy baseline."""
    grid, grid_seconds = timed(lambda: infer(exp, trials, likelihood="gaussian",
                                             sampler="grid", seed=0, config=GridConfig()))
    n = grid.draws.info.grid_points
    grid_evals = n * n
    like = grid.posterior.likelihood
    centres = grid.draws.info.grid.centres
    _, kernel_seconds = timed(lambda: gaussian_grid(like, np.asarray(centres[0]),
                                                    np.asarray(centres[1])))
    print(f"(b) {n} x {n} grid (gaussian, {trials.n} trials): {grid_seconds:.2f} s end to end, "
          f"{kernel_seconds:.2f} s for the structured kernel alone "
          f"({1e9 * kernel_seconds / (grid_evals * trials.n):.0f} ns per cell and trial)")
    box = grid.posterior.box()
    points = box[:, 0] + rng.uniform(size=(n_base, 2)) * (box[:, 1] - box[:, 0])
    per_grid, values = time_baseline(gaussian_baseline(exp, trials, like), points)
    reference = like(points)
    diff_grid = float(np.max(np.abs(values - reference) / np.maximum(1.0, np.abs(reference))))
    grid_base = per_grid * grid_evals
    print(f"    baseline: {per_grid:.3f} s per point ({trials.n} RK45 bounces + normal "
          f"log-density, {n_base} uniform points of the box), x {grid_evals} = "
          f"{grid_base:.0f} s ({grid_base / 3600:.1f} h) extrapolated; ratio "
          f"{grid_base / grid_seconds:.0f}; relative log-likelihood difference <= "
          f"{diff_grid:.2e}")
    return {"grid_seconds": grid_seconds, "grid_baseline_seconds_extrapolated": grid_base,
            "grid_ratio": grid_base / grid_seconds, "grid_kernel_seconds": kernel_seconds,
            "grid_evaluations": grid_evals, "grid_baseline_seconds_per_point": per_grid,
            "grid_baseline_points": n_base, "grid_baseline_max_rel_loglike_diff": diff_grid}


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true",
                    help="smaller baseline subsets (the package runs stay full size)")
    ap.add_argument("--large", action="store_true",
                    help="also a 100,000-row table in a child process (minutes)")
    ap.add_argument("--out", type=Path, default=RESULTS, help="where to write the JSON")
    args = ap.parse_args(argv)
    n_mh_base, n_grid_base, n_gauss_base = (50, 3, 1000) if args.quick else (500, 20, 11350)
    t_start = time.perf_counter()
    demo = demo_campaign()
    exp = load_experiment(demo.experiment)
    trials = load_trials(demo.trials, exp)
    # numba warm-up (compilation or cache load) before anything is timed
    _, warm = timed(lambda: [infer(exp, trials, likelihood=lk, sampler=s,
                                   config=MHConfig(draws=200, burn_in=10) if s == "mh" else
                                   GridConfig(draws=200, points=16))
                             for lk, s in (("kde", "mh"), ("gaussian", "grid"),
                                           ("gaussian", "mh"))])
    print(f"numba warm-up: {warm:.2f} s; numba threads: {numba.get_num_threads()}")
    rng = np.random.default_rng(2016)
    summary = mh_gaussian(exp, trials, n_gauss_base)
    summary |= paper_kde_mh(exp, trials, n_mh_base, rng)
    summary |= grid_512(exp, trials, n_grid_base, rng)
    if args.large:
        summary |= large_table()
    summary |= {
        "n_trials": trials.n,
        "baseline": "(g) the previous NumPy design of the same MH on the same model; (a), (b) "
                    "Python loop; tests/reference_scipy.py reference_bounce (solve_ivp RK45, "
                    "rtol=atol=1e-6) + scipy.stats.gaussian_kde (kde) or a closed-form "
                    "bivariate normal (gaussian); per-point time x package evaluations",
        "numba_threads": numba.get_num_threads(), "quick": args.quick,
        "load_average_1min": os.getloadavg()[0], "cpus": os.cpu_count(),
        "python": platform.python_version(), "numpy": np.__version__,
        "generated_at": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "total_seconds": time.perf_counter() - t_start,
    }
    print(f"total {summary['total_seconds']:.1f} s")
    write_json(args.out, summary)
    print(json.dumps(summary))
    return summary


if __name__ == "__main__":
    main()
