"""``bouncebayes sbc``: simulation-based calibration of the gaussian likelihood, on Dask."""

from __future__ import annotations

import argparse
import json

from ._batch import add_cluster_arguments
from ._common import (add_memory_budget, add_out_folder, check_out_folder, integer, log, record,
                      show_progress)

HELP = "simulation-based calibration of the gaussian likelihood (many synthetic campaigns)"
DESCRIPTION = ("Simulation-based calibration (Talts et al. 2018): draw (mu, eta) from the "
               "prior, synthesise a campaign of the paper's setup, infer with the gaussian "
               "likelihood and the grid sampler, and record the rank of the truth among the "
               "draws; calibrated inference gives uniform ranks and 90 % intervals that hold "
               "the truth 90 % of the time. Campaign i is seeded with child i of numpy's "
               "SeedSequence(--seed), so the result is identical serially, on a local or on a "
               "remote cluster. Writes DIR/sbc.json; each campaign's result is written to "
               "DIR/campaigns/ as it arrives and a rerun with the same settings resumes.")


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Options of ``sbc``."""
    from ..studies import SBC_DEFAULTS as D

    add_out_folder(p)
    p.add_argument("--campaigns", type=integer(1), default=D["campaigns"], metavar="N",
                   help="synthetic campaigns")
    p.add_argument("--seed", type=integer(0), default=D["seed"], help="seed of the study")
    p.add_argument("--n-trials", type=integer(1), default=D["n_trials"], metavar="N",
                   help="bounces per campaign")
    p.add_argument("--draws", type=integer(100), default=D["draws"], metavar="N",
                   help="posterior draws per campaign (draws + 1 must be a multiple of 20)")
    p.add_argument("--grid-points", type=integer(16), default=D["grid_points"], metavar="N",
                   help="grid points per parameter of each posterior")
    add_memory_budget(p)
    add_cluster_arguments(p)


def run(args: argparse.Namespace) -> int:
    """Run the study, write DIR/sbc.json, print the verdicts."""
    from .._io import write_json
    from ..studies import run_sbc

    check_out_folder("--out", args.out)
    if (args.draws + 1) % 20:
        raise ValueError(f"`--draws` + 1 must be a multiple of 20 (the rank histogram's "
                         f"bins); got {args.draws}")
    result = run_sbc(args.campaigns, seed=args.seed, store=args.out / "campaigns",
                     scheduler=args.scheduler, workers=args.workers,
                     progress=show_progress(args), log=log, n_trials=args.n_trials,
                     draws=args.draws, grid_points=args.grid_points,
                     memory_budget=args.memory_budget)
    result["provenance"] = record(args, {}, seed=args.seed)
    path = write_json(args.out / "sbc.json", result)
    print(f"SBC: {result['campaigns_done']} of {args.campaigns} campaigns "
          f"({result['resumed']} from earlier), {result['seconds']:.0f} s")
    for name, p in result["parameters"].items():
        print(f"  {name}: rank chi-square p = {p['chi2_p_value']:.3f} "
              f"({'uniform' if p['uniform_ok'] else 'NOT uniform'}); 90 % coverage "
              f"{p['coverage90']:.3f} ({'ok' if p['coverage_ok'] else 'outside the 99 % band'})")
    for key, message in result["failed"].items():
        print(f"  {key} failed: {message}")
    print(f"written: {path}")
    print(json.dumps({k: result[k] for k in ("campaigns_done", "seconds")}))
    return 1 if result["failed"] else 0
