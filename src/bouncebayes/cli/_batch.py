"""``bouncebayes batch``: many runs from a manifest, through dask.distributed; also the
cluster flags that ``design`` and ``sbc`` share."""

from __future__ import annotations

import argparse
from pathlib import Path

from ._common import add_quiet, integer, log, show_progress

HELP = "many runs from a manifest (TOML [[run]] tables), on a local or remote Dask cluster"
DESCRIPTION = ("Run `bouncebayes run` for every [[run]] table of MANIFEST.toml (keys: "
               "experiment, data, out, paths relative to the manifest; optional likelihood, "
               "sampler, seed, draws; a top-level `seed` seeds the runs that give none: run i gets "
               "child i of numpy's SeedSequence(seed)). Runs go through dask.distributed: a "
               "local cluster of processes by default, or an existing one with --scheduler. "
               "Each finished run writes OUT/batch.json; a rerun skips the runs whose inputs "
               "and settings have not changed. A failed run is retried once, then reported; "
               "the others are kept. Exit status 1 if some runs failed.")


def add_cluster_arguments(p: argparse.ArgumentParser) -> None:
    """``--scheduler``, ``--workers``, ``--quiet``."""
    g = p.add_argument_group("where the tasks run")
    g.add_argument("--scheduler", default="local", metavar="ADDRESS",
                   help="'local' (a local cluster of processes, started for this command), "
                        "'serial' (this process, one task after the other) or the address of "
                        "a running dask.distributed scheduler, tcp://HOST:PORT (see "
                        "docs/cluster.md); results are identical")
    g.add_argument("--workers", type=integer(1), default=None, metavar="N",
                   help="processes of the local cluster (default: the machine's cores)")
    add_quiet(p)


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Options of ``batch``."""
    p.add_argument("manifest", type=Path, metavar="MANIFEST.toml",
                   help="the manifest: [[run]] tables with experiment, data, out")
    add_cluster_arguments(p)


def run(args: argparse.Namespace) -> int:
    """Run the manifest; print one line per run."""
    from ..studies import batch_tasks, run_tasks

    tasks = batch_tasks(args.manifest)
    outcome = run_tasks(tasks, scheduler=args.scheduler, workers=args.workers,
                        progress=show_progress(args), log=log, desc="runs")
    for task in tasks:
        out = task.args[0]["out"]
        if task.key in outcome.failed:
            print(f"{task.key}: FAILED ({outcome.failed[task.key]}); {out} is unchanged")
            continue
        state = "done earlier, skipped" if task.key in outcome.resumed else "done"
        verdict = outcome.results[task.key]["verdict"].splitlines()
        print(f"{task.key}: {state}: {out} (seed {task.args[1]})"
              + (f": {verdict[0]}" if verdict else ""))
    print(f"{len(tasks) - len(outcome.failed)} of {len(tasks)} runs complete "
          f"({len(outcome.resumed)} from earlier; {outcome.seconds:.1f} s, where: "
          f"{outcome.where})")
    return 1 if outcome.failed else 0
