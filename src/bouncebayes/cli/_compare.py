"""``bouncebayes compare``: candidate contact models judged on the same trials."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ._common import (UserError, add_figure_formats, add_quiet, check_out_folder, flag_names,
                      integer, log, show_progress)

HELP = "compare candidate contact models ([models.NAME] tables) on the same trials"
DESCRIPTION = ("Infer every candidate model of the experiment file's [models.NAME] tables (a "
               "contact law with its parameters and priors) on the trial table DATA, with the "
               "same fixed settings (gaussian likelihood, no model discrepancy), and compare "
               "them: the evidence of each (exact grid quadrature where the dimension allows, "
               "nested sampling with dynesty otherwise, with its numerical uncertainty), "
               "PSIS-LOO from ArviZ, the adequacy check, Bayes factors in words (Kass & "
               "Raftery) and a verdict. Writes DIR/comparison.json, DIR/report.html, a figure "
               "of every model's band against the incidence angle, and each model's run folder "
               "DIR/models/NAME (docs/comparison.md).")


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Options of ``compare``."""
    from ..compare import EVIDENCE_METHODS, LIVE_POINTS

    p.add_argument("experiment", type=Path, metavar="EXPERIMENT.toml",
                   help="experiment file with [models.NAME] tables")
    p.add_argument("data", type=Path, metavar="DATA", help="trial table (CSV)")
    p.add_argument("--models", type=_names, default=None, metavar="A,B,...",
                   help="the candidates to compare, comma-separated (default: all of "
                        "[models])")
    p.add_argument("--out", type=Path, required=True, metavar="DIR",
                   help="comparison folder (new, empty, or an earlier comparison's)")
    p.add_argument("--evidence", choices=EVIDENCE_METHODS, default="auto",
                   help="grid: exact quadrature (up to 3 parameters); nested: dynesty; auto: "
                        "the grid up to 3 parameters (2 with a tangential spring), else nested")
    p.add_argument("--seed", type=integer(0), default=0,
                   help="random seed of every model's inference and evidence (recorded)")
    p.add_argument("--grid-points", type=integer(8), default=None, metavar="N",
                   help="grid points per parameter (default by dimension: 2048 / 512 / 96 for "
                        "1 / 2 / 3 parameters, 512 / 96 with a tangential spring)")
    p.add_argument("--draws", type=integer(100), default=None, metavar="N",
                   help="posterior draws per model (default 4000 from a grid, 15000 by mh)")
    p.add_argument("--live-points", type=integer(10), default=LIVE_POINTS, metavar="N",
                   help="live points of nested sampling")
    add_figure_formats(p)
    add_quiet(p)


def _names(text: str) -> tuple[str, ...]:
    names = tuple(t.strip() for t in text.split(",") if t.strip())
    if not names:
        raise argparse.ArgumentTypeError(f"must name candidate models, comma-separated; got "
                                         f"{text!r}")
    return names


def run(args: argparse.Namespace) -> int:
    """Compare the candidates."""
    from ..compare import compare_folder

    check_out_folder("--out", args.out)
    if args.data.is_dir():
        raise UserError(f"DATA {args.data}: is a folder; compare reads a trial table, the same "
                        f"for every candidate (make one with `bouncebayes kinematics`)")
    outcome = compare_folder(args.experiment, args.data, args.out, args.models, seed=args.seed,
                             evidence=args.evidence, grid_points=args.grid_points,
                             draws=args.draws, live_points=args.live_points,
                             progress=show_progress(args), log=log, argv=args.argv,
                             figure_formats=args.figure_formats)
    for name, m in outcome.comparison.models.items():  # type: ignore[attr-defined]
        print(f"  {name:<12} log evidence {m['log_evidence']:10.4g} ± "
              f"{m['log_evidence_se']:.2g}   elpd_loo {m['elpd_loo']:9.4g} ± "
              f"{m['elpd_loo_se']:.2g}   {'reproduces the data' if m['adequate'] else 'MISFITS'}")
    print(flag_names(outcome.verdict, args.flags))
    print(f"\nreport: {outcome.report}  (each model's run in {args.out / 'models'})")
    sys.stdout.flush()
    return 0
