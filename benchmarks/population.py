"""Population likelihood speed: 55 bounces, two parameters (mu, eta), against a baseline measured
in the same run.

Timed on one synthetic campaign of the paper's experiment with bounce-to-bounce spread and noise
(the campaign of ``docs/figures/population_readings.py``: 55 bounces, mu ~ N(0.16, 0.02),
eta ~ N(1.35, 0.25) kg/s, 0.02 m/s and 0.5 deg noise):

- ``infer_seconds`` / ``infer_cpu_seconds``: ``infer(likelihood="population")`` with the mh
  sampler at the paper's settings (15,000 draws over 4 chains, thinning 3; burn-in 2000, the
  population's minimum), end to end: the grid of each trial's likelihood, the sampling, the
  population predictive, per-bounce estimates, replicates and adequacy. Target: under 10 s on
  2 cores.
- ``likelihood_row_seconds``: one step of the sampler (4 rows: the 4 chains) of the package's
  likelihood (hat-function weights, then the compiled sum over each trial's truncated SVD).
- Baseline, the same integral without the factorisation: the hat-function weights against
  every node of every trial's grid likelihood (``numpy.einsum`` over trials x nodes, what the
  integral is by definition), timed on ``BASELINE_STEPS`` steps of 4 rows at posterior draws
  and extrapolated to the steps the sampler took; the two agree to rounding (checked).
- Context: ``infer(likelihood="gaussian")`` with the same sampler settings on the same table.

``python benchmarks/population.py``; the last stdout line is one JSON object, also written to
``benchmarks/results/population.json``.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy is imported

import json  # noqa: E402
import platform  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from datetime import datetime, timezone  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results" / "population.json"
BASELINE_STEPS = 300
sys.path.insert(0, str(ROOT / "docs" / "figures"))


def timed(fn, *args, **kwargs):
    wall, cpu = time.perf_counter(), time.process_time()
    out = fn(*args, **kwargs)
    return out, time.perf_counter() - wall, time.process_time() - cpu


def main() -> dict:
    import population_readings as campaign_source

    from bouncebayes._io import write_json
    from bouncebayes.inference import MHConfig, infer
    from bouncebayes.inference._population import grid_log_likelihood

    exp, c = campaign_source.campaign()
    trials = c.trials
    infer(exp, trials, likelihood="population", config=MHConfig(draws=200))  # compile
    r, wall, cpu = timed(infer, exp, trials, likelihood="population", sampler="mh", seed=1)
    _, g_wall, g_cpu = timed(infer, exp, trials, likelihood="gaussian", sampler="mh", seed=1,
                             discrepancy="none")
    like = r.posterior.likelihood
    flat = r.draws.samples.reshape(-1, 4)
    steps = r.config.iterations()
    pick = np.linspace(0, flat.shape[0] - 4, BASELINE_STEPS).astype(int)
    g = like.grid
    start = time.perf_counter()
    for i in pick:
        like(flat[i:i + 4])
    ours = (time.perf_counter() - start) / BASELINE_STEPS
    start = time.perf_counter()
    for i in pick:
        grid_log_likelihood(g.nodes, g.relative, g.log_max, like.domains, like.family,
                            flat[i:i + 4])
    base = (time.perf_counter() - start) / BASELINE_STEPS
    rows = flat[pick[:20]]
    agree = float(np.max(np.abs(like(rows) - grid_log_likelihood(
        g.nodes, g.relative, g.log_max, like.domains, like.family, rows))))
    out = {
        "n_trials": trials.n, "parameters": ["mu", "eta"],
        "grid_points": r.population.record["grid_points"],
        "infer_seconds": wall, "infer_cpu_seconds": cpu, "target_seconds": 10.0,
        "under_target": bool(wall < 10.0),
        "sampler_steps": steps, "likelihood_step_seconds": ours,
        "baseline_step_seconds": base,
        "baseline_sampling_seconds_extrapolated": base * steps * 1.0,
        "package_sampling_likelihood_seconds": ours * steps,
        "likelihood_speedup": base / ours,
        "baseline": "hat-function weights against every node of every trial's grid likelihood "
                    "(numpy.einsum, no factorisation), per sampler step of 4 rows",
        "baseline_max_abs_loglike_diff": agree,
        "gaussian_infer_seconds": g_wall, "gaussian_infer_cpu_seconds": g_cpu,
        "population_over_gaussian": wall / g_wall,
        "load_average_1min": os.getloadavg()[0], "cpus": os.cpu_count(),
        "python": platform.python_version(), "numpy": np.__version__,
        "generated_at": datetime.now(timezone.utc).isoformat(timespec="seconds"),
    }
    write_json(RESULTS, out)
    print(f"population infer: {wall:.2f} s wall ({cpu:.2f} s CPU), target < 10 s; "
          f"likelihood step {1e3 * ours:.3f} ms vs baseline {1e3 * base:.3f} ms "
          f"({base / ours:.1f}x); gaussian infer {g_wall:.2f} s")
    print(json.dumps(out))
    return out


if __name__ == "__main__":
    main()
