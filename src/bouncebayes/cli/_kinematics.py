"""``bouncebayes kinematics``: a folder of tracked trajectories -> a trial table."""

from __future__ import annotations

import argparse
from pathlib import Path

from ._common import add_quiet, check_out_file, integer, record, show_progress

HELP = "turn a folder of tracked trajectories into a trial table"
DESCRIPTION = ("Fit the free flight before and after the impact of every trajectory file in a "
               "folder (CSV with header t,x,y or t,x,y,z in s and m, or Tracker's exported data "
               "text) and write one row per bounce: incidence and rebound speed (m/s) and angle "
               "(deg from the normal) with standard errors. Files that cannot be used are listed "
               "with the reason; the others are still processed. Exit status 0: all files used; "
               "1: some were skipped; 2: nothing could be done.")


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Options of ``kinematics``."""
    p.add_argument("folder", type=Path, metavar="TRAJECTORY_DIR",
                   help="folder of trajectory files (*.csv, *.txt)")
    p.add_argument("--experiment", type=Path, required=True, metavar="EXPERIMENT.toml",
                   help="experiment file: its [trajectories] table gives the camera-to-plane "
                        "rotation (deg), the length unit and the drag model")
    p.add_argument("--out", type=Path, required=True, metavar="TRIALS.csv",
                   help="trial table to write")
    p.add_argument("--min-points", type=integer(), default=5,
                   help="free-flight samples needed on each side of the impact")
    p.add_argument("--contact-guard", type=integer(), default=1,
                   help="samples next to the impact left out of the fits on each side (they "
                        "may be in contact: a 2 ms contact spans 2 samples at 1000 Hz)")
    add_quiet(p)


def run(args: argparse.Namespace) -> int:
    """Fit every file, write the table, print a summary."""
    import numpy as np

    from .._io import staged_output
    from .._provenance import stamp
    from ..data import load_experiment
    from ..pipeline import trial_table

    check_out_file("--out", args.out)
    experiment = load_experiment(args.experiment)
    stamp_record = record(args, {"experiment": args.experiment, "trajectories": args.folder})
    with staged_output(args.out, "file") as stage:
        table = stage / args.out.name
        found, results = trial_table(args.folder, experiment, table, log=print,
                                     progress=show_progress(args), min_points=args.min_points,
                                     contact_guard=args.contact_guard)
        stamp(table, stamp_record)
    print(f"trial table: {args.out} ({len(results)} bounces)")
    if len(results) > 1:
        incidence = [k.incidence_speed for k in results]
        print(f"  incidence speed {np.mean(incidence):.4g} +- {np.std(incidence, ddof=1):.2g} "
              f"m/s")
        _print_rebound_summary(results)
    return 1 if found.failures else 0


def _print_rebound_summary(results) -> None:
    from ..density import summarize

    summary = summarize([k.rebound_speed for k in results], [k.rebound_angle for k in results])
    print(f"  rebound speed {summary.speed.mean:.4g} +- {summary.speed.sd:.2g} m/s, "
          f"rebound angle {summary.angle.mean:.4g} +- {summary.angle.sd:.2g} deg")
    print(f"  Pearson correlation of speed and angle: {summary.correlation.text()}")
    for warning in summary.to_dict()["warnings"]:
        print(f"  warning: {warning}")
