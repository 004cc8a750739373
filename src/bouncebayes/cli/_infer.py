"""``bouncebayes infer``: the posterior of the contact parameters from a trial table."""

from __future__ import annotations

import argparse
from pathlib import Path

from ._common import (add_out_folder, add_sampler_arguments, check_out_folder, flag_names,
                      inference_options, record, sampler_config, show_progress)

HELP = "posterior of the contact parameters from a trial table"
DESCRIPTION = ("Bayesian calibration: the posterior of the parameters listed under [parameters] "
               "in the experiment file, given the rebounds of a trial table. Writes "
               "DIR/posterior.nc (ArviZ InferenceData) and DIR/summary.json (with the grid "
               "sampler also DIR/grid.npz), all replaced together, and prints a table. An "
               "earlier run's propagation, figures and report in DIR are removed: they "
               "described another posterior. Same seed and inputs: identical draws.")
# what a new posterior replaces in DIR (written or, if not written this time, removed)
OUTPUTS = ("posterior.nc", "summary.json", "grid.npz", "propagation.json", "propagation.npz",
           "figures", "report.html")


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Options of ``infer``."""
    p.add_argument("experiment", type=Path, metavar="EXPERIMENT.toml", help="experiment file")
    p.add_argument("trials", type=Path, metavar="TRIALS.csv",
                   help="trial table (rebound_speed in m/s, rebound_angle in deg, ...)")
    add_out_folder(p)
    add_sampler_arguments(p)


def run(args: argparse.Namespace) -> int:
    """Sample, write the outputs, print the table."""
    from .._io import staged_output
    from .._provenance import stamp_tree
    from ..data import load_experiment, load_trials
    from ..inference import format_table, infer, write_outputs

    check_out_folder("--out", args.out)
    experiment = load_experiment(args.experiment)
    trials = load_trials(args.trials, experiment)
    config = sampler_config(args, experiment)
    result = infer(experiment, trials, sampler=args.sampler, seed=args.seed, config=config,
                   progress=show_progress(args), **inference_options(args))
    stamp = record(args, {"experiment": args.experiment, "trials": args.trials},
                   seed=args.seed, config=run_settings(result, config))
    with staged_output(args.out, "entries", owned=OUTPUTS) as stage:
        paths = write_outputs(result, stage)
        stamp_tree(stage, stamp)
    print(flag_names(format_table(result), args.flags))
    print("\n".join(f"{name}: {args.out / Path(path).name}" for name, path in paths.items()))
    return 0


def run_settings(result, config) -> dict:
    """The inference settings recorded in the provenance (as used: flags, else the
    experiment's [inference] table)."""
    return {"likelihood": result.likelihood, "sampler": result.sampler,
            "noise": result.likelihood_info.get("noise"), "discrepancy": result.discrepancy,
            "sampler_config": config}
