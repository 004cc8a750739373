"""``bouncebayes report``: redraw the figures and rewrite the report of a run folder."""

from __future__ import annotations

import argparse
from pathlib import Path

from ._common import add_figure_formats, add_quiet, log, show_progress

HELP = "redraw the figures and write DIR/report.html of a run folder"
DESCRIPTION = ("Write DIR/report.html, one self-contained file (figures embedded) that opens "
               "offline, from the results in DIR (posterior.nc, summary.json, experiment.toml, "
               "trials.csv; the posterior is propagated first if DIR has no propagation yet). "
               "A damaged or missing file is named; DIR is replaced at once when the report is "
               "complete.")


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Options of ``report``."""
    p.add_argument("folder", type=Path, metavar="DIR", help="a run folder")
    add_figure_formats(p)
    add_quiet(p)


def run(args: argparse.Namespace) -> int:
    """Rebuild the report."""
    from ..pipeline import report_folder

    report = report_folder(args.folder, argv=args.argv, log=log, progress=show_progress(args),
                           figure_formats=args.figure_formats)
    print(f"report: {report}")
    return 0
