"""The evidence behind ``discrepancy = "auto"``: the adequacy check and the model-discrepancy
term on campaigns the model fits and on campaigns it cannot.

For each scenario of ``bouncebayes.studies.SCENARIOS`` (well specified; data made with another
normal law, Hunt-Crossley, and fitted with Kelvin-Voigt; spin scatter the table does not
mention at incidences that leave rolling; three trials corrupted by 12 standard errors),
``--campaigns`` synthetic campaigns of 55 bounces over 45 +- 12 deg and 3 +- 1 m/s are fitted
with ``discrepancy`` = none, normal and auto (mh, 4000 draws). Recorded per setting: how often
the adequacy check fails, how often the 90 % intervals hold the true ``mu`` (and ``eta`` where
the law is the fitted one), their mean widths, the seconds, and for none and normal the 5-fold
cross-validated coverage of the held-out bounces' rebound speed and angle by their 90 %
posterior predictive intervals (``bouncebayes.studies.kfold_coverage``).

``python benchmarks/discrepancy.py [--campaigns N] [--scheduler serial|local|tcp://...]``
writes ``benchmarks/results/discrepancy.json``; the last stdout line is the JSON summary.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy is imported

import argparse  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
from datetime import datetime, timezone  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from bouncebayes._io import write_json  # noqa: E402
from bouncebayes._version import __version__  # noqa: E402
from bouncebayes.studies import SCENARIOS, Task, discrepancy_campaign, run_tasks, task_seed  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results" / "discrepancy.json"
SETTINGS = ("none", "normal", "auto")


def tasks(campaigns: int, seed: int, n: int, folds: int) -> list[Task]:
    return [Task(f"{name.replace(' ', '-')}-{i:03d}", discrepancy_campaign,
                 (name, task_seed(seed, 1000 * s + i), n, folds, SETTINGS))
            for s, name in enumerate(SCENARIOS) for i in range(campaigns)]


def aggregate(rows: list[dict]) -> dict:
    out: dict = {}
    for name in SCENARIOS:
        mine = [r for r in rows if r["scenario"] == name]
        out[name] = {"campaigns": len(mine)}
        for setting in SETTINGS:
            recs = [r[setting] for r in mine]
            agg = {"adequacy_failed": float(np.mean([not x["adequate"] for x in recs])),
                   "mean_seconds": float(np.mean([x["seconds"] for x in recs]))}
            for p in ("mu", "eta"):
                hits = [x[p] for x in recs if p in x]
                if hits:
                    agg[f"{p}_coverage90"] = float(np.mean([h["covered"] for h in hits]))
                    agg[f"{p}_mean_width90"] = float(np.mean([h["width90"] for h in hits]))
            if setting == "auto":
                agg["refitted"] = float(np.mean([x["used"] != "none" for x in recs]))
            folds = [x["kfold"] for x in recs if "kfold" in x]
            if folds:
                held = sum(f["held_out"] for f in folds)
                for obs in ("rebound_speed", "rebound_angle"):
                    agg[f"kfold_coverage90_{obs}"] = sum(f[obs] * f["held_out"]
                                                         for f in folds) / held
            out[name][setting] = agg
    return out


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--campaigns", type=int, default=8, help="campaigns per scenario")
    ap.add_argument("--seed", type=int, default=20261125)
    ap.add_argument("--n", type=int, default=55, help="bounces per campaign")
    ap.add_argument("--folds", type=int, default=5)
    ap.add_argument("--scheduler", default="local")
    ap.add_argument("--out", type=Path, default=RESULTS)
    args = ap.parse_args(argv)
    outcome = run_tasks(tasks(args.campaigns, args.seed, args.n, args.folds),
                        scheduler=args.scheduler, log=print)
    rows = [r for r in outcome.results.values() if r is not None]
    result = {"study": __doc__.split("\n\n")[0], "settings": vars(args) | {"out": str(args.out)},
              "scenarios": aggregate(rows), "failed": outcome.failed,
              "seconds": outcome.seconds, "where": outcome.where,
              "bouncebayes": __version__, "python": platform.python_version(),
              "numpy": np.__version__,
              "generated_at": datetime.now(timezone.utc).isoformat(timespec="seconds")}
    write_json(args.out, result)
    print(json.dumps(result))
    return result


if __name__ == "__main__":
    main()
