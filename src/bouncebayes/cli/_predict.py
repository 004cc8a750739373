"""``bouncebayes predict``: the calibrated model's prediction of new bounces."""

from __future__ import annotations

import argparse
from pathlib import Path

from ._common import add_quiet, check_out_file, integer, record, show_progress

HELP = "predict the rebound of new bounces from a run's posterior"
DESCRIPTION = (
    "For every row of TRIALS.csv (a trial table: incidence_speed m/s, incidence_angle deg, "
    "incidence_spin rad/s, each the experiment's nominal value where absent; rebound columns "
    "optional), the posterior predictive mean and 5 %, 50 % and 95 % quantiles of rebound speed "
    "(m/s), angle (deg), spin (rad/s) and contact time (s), from a seeded subset of the run's "
    "draws simulated at that incidence. Rebound speed and angle carry what a measurement of them "
    "would: the row's standard errors (*_se columns), the noise levels or model discrepancy the "
    "run inferred, the row's scale_rel_sd; spin and contact time carry the parameters' "
    "uncertainty only. Where a row has a measured rebound, the output also holds it and the "
    "predictive CDF at it (*_pit: uniform for a calibrated model). Writes PRED.csv with a "
    "provenance line.")


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Options of ``predict``."""
    p.add_argument("folder", type=Path, metavar="RUN_DIR",
                   help="a run folder (from `bouncebayes run` or `demo`)")
    p.add_argument("trials", type=Path, metavar="TRIALS.csv",
                   help="the incidences to predict (a trial table; rebound columns optional)")
    p.add_argument("--out", type=Path, required=True, metavar="PRED.csv",
                   help="the predictions (CSV)")
    p.add_argument("--draws", type=integer(20), default=2000, metavar="N",
                   help="posterior draws simulated per row (default 2000)")
    p.add_argument("--seed", type=integer(0), default=None,
                   help="seed of the draws and noise (default: the run's)")
    add_quiet(p)


def run(args: argparse.Namespace) -> int:
    """Predict, write the table, print a summary."""
    from ..data import load_trials
    from ..propagation import predict_bounces, write_predictions
    from ..report import load_result

    check_out_file("--out", args.out, (".csv",))
    result = load_result(args.folder)
    trials = load_trials(args.trials, result.experiment, rebound_required=False)
    pred = predict_bounces(result, trials, n_draws=args.draws, seed=args.seed,
                           progress=show_progress(args))
    stamp = record(args, {"run_folder": args.folder, "trials": args.trials}, seed=pred.seed,
                   config={"draws": pred.n_draws, "includes": pred.includes})
    write_predictions(pred, args.out, stamp)
    print(f"predictions: {args.out} ({trials.n} rows, {pred.n_draws} draws each; rebound "
          f"speed and angle include {pred.includes})")
    if pred.n_failed:
        print(f"  {pred.n_failed} simulated bounces failed and are left out of the summaries")
    return 0
