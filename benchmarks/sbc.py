"""Simulation-based calibration (Talts et al. 2018, arXiv:1804.06788) of the gaussian likelihood.

The study is the library's (``bouncebayes.studies.run_sbc``, also ``bouncebayes sbc``): draw
``(mu, eta)`` from the prior, synthesise a campaign with ``bouncebayes.data.synthesize`` (the
package's own generator: per-bounce incidence scatter, measured incidence and rebound with
Gaussian noise, standard errors in the table), infer with the gaussian likelihood (noise given
by the table, incidence uncertainty propagated) and the grid sampler (exact quadrature: its
draws are independent, so no thinning is needed), and record the rank of the true value among
``draws`` posterior draws. If the inference is calibrated the ranks are uniform on
``0..draws`` and the 90 % intervals hold the truth in 90 % of the campaigns. Campaign ``i`` is
seeded with child ``i`` of ``numpy.random.SeedSequence(seed)``, so the result is the same
serially or on any Dask cluster.

Checks reported (and asserted by ``tests/test_sbc.py``):

- uniformity: Pearson chi-square test of the ranks in ``bins`` equal bins, p > 0.01 for each
  parameter;
- coverage: the share of 90 % intervals (5 % and 95 % quantiles of the draws) holding the truth
  lies inside the central 99 % binomial interval of Binomial(campaigns, 0.9) / campaigns.

Setup: the paper's experiment (3 m/s at 60 deg, 1 deg and 0.05 m/s bounce-to-bounce spread,
the demo's noise levels) with the prior box restricted to mu in [0, 0.2] (eta in [0, 5] kg/s, the
paper's) so that every campaign stays in the sliding regime: the smallest mu for which a bounce
leaves rolling is 0.219 (bisection on ``bb.simulate``: eta = 0, i.e. the highest restitution, and
57 deg, 3 sd below the nominal incidence; 0.246 at 60 deg). Campaigns with rolling bounces are
counted in the output (expected 0).
The same prior is used to draw the truth and to infer, as SBC requires.

``python benchmarks/sbc.py [--campaigns N] [--seed S] [--scheduler serial|local|tcp://...]``
runs it and writes ``benchmarks/results/sbc.json``; the last stdout line is the JSON summary.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy is imported

import argparse  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
from datetime import datetime, timezone  # noqa: E402
from pathlib import Path  # noqa: E402

from bouncebayes._io import write_json  # noqa: E402
from bouncebayes.studies import SBC_DEFAULTS, rank_test  # noqa: E402
from bouncebayes.studies import run_sbc as library_sbc  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results" / "sbc.json"
DEFAULTS = SBC_DEFAULTS
__all__ = ["DEFAULTS", "RESULTS", "rank_test", "run_sbc", "report", "main"]


def run_sbc(campaigns: int | None = None, *, seed: int | None = None, out: Path | None = RESULTS,
            scheduler: str = "local", log=print, **overrides) -> dict:
    """Run the study (on a local cluster by default); write the JSON to ``out`` (unless None)
    and return it."""
    result = library_sbc(campaigns, seed=seed, scheduler=scheduler, log=log, **overrides)
    result["generated_at"] = datetime.now(timezone.utc).isoformat(timespec="seconds")
    if out is not None:
        write_json(out, result)
    return result


def report(result: dict) -> str:
    s = result["settings"]
    lines = [f"SBC: {result['campaigns_done']} campaigns of {s['n_trials']} bounces, "
             f"{s['draws']} draws, {result['seconds']:.0f} s ({result['where']}, "
             f"{result['task_cpu_seconds']:.0f} s of CPU in the tasks); 99 % binomial band of "
             f"the 90 % coverage: [{result['coverage_bounds_99'][0]:.3f}, "
             f"{result['coverage_bounds_99'][1]:.3f}]; campaigns with rolling bounces: "
             f"{result['campaigns_with_rolling_bounces']}"]
    for name, p in result["parameters"].items():
        lines.append(f"  {name:<4} chi2 = {p['chi2']:.1f} ({p['chi2_dof']} dof), "
                     f"p = {p['chi2_p_value']:.3f}; coverage90 = {p['coverage90']:.3f}; "
                     f"ranks {p['rank_histogram']}")
    return "\n".join(lines)


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--campaigns", type=int, default=DEFAULTS["campaigns"])
    ap.add_argument("--seed", type=int, default=DEFAULTS["seed"])
    ap.add_argument("--scheduler", default="local")
    ap.add_argument("--out", type=Path, default=RESULTS)
    args = ap.parse_args(argv)
    result = run_sbc(args.campaigns, seed=args.seed, out=args.out, scheduler=args.scheduler,
                     log=lambda m: print(m, file=sys.stderr))
    print(report(result))
    print(f"written: {args.out}")
    print(json.dumps({"campaigns": result["campaigns_done"],
                      "seconds": round(result["seconds"], 1),
                      **{f"{k}_p_value": v["chi2_p_value"] for k, v in
                         result["parameters"].items()},
                      **{f"{k}_coverage90": v["coverage90"] for k, v in
                         result["parameters"].items()}}))
    return result


if __name__ == "__main__":
    main()
