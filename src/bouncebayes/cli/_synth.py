"""``bouncebayes synth``: a synthetic campaign from known parameters."""

from __future__ import annotations

import argparse
from pathlib import Path

from ._common import add_out_folder, check_out_folder, integer, record

HELP = "generate a synthetic campaign from known parameters"
DESCRIPTION = ("Generate a synthetic campaign from the experiment file: each bounce gets its own "
               "incidence ([incidence] with its *_sd spreads) and contact parameters ([contact] "
               "values with [synth] mu_sd, eta_sd); the trial table adds the [synth] measurement "
               "noise, trajectories are sampled at camera_rate_hz with position_noise_m. Writes "
               "DIR/trials.csv, DIR/truth.json and DIR/trajectories/*.csv (t,x,y in s and m, "
               "plane-aligned frame), replacing those of an earlier campaign in DIR together.")
OUTPUTS = ("trials.csv", "truth.json", "trajectories")


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Options of ``synth``."""
    p.add_argument("experiment", type=Path, metavar="EXPERIMENT.toml",
                   help="experiment file (see docs/experiment-file.md)")
    add_out_folder(p)
    p.add_argument("--n", type=integer(1), default=None,
                   help="number of bounces (default: [synth] n of the experiment file, 55)")
    p.add_argument("--seed", type=integer(0), default=0,
                   help="seed of the random generator (recorded in truth.json)")
    p.add_argument("--no-trajectories", action="store_true",
                   help="write only the trial table and the truth")


def run(args: argparse.Namespace) -> int:
    """Synthesize, write the campaign, print its summary."""
    from .._io import staged_output
    from .._provenance import stamp_tree
    from ..data import load_experiment, synthesize, write_campaign

    check_out_folder("--out", args.out)
    experiment = load_experiment(args.experiment)
    campaign = synthesize(experiment, seed=args.seed, n=args.n)
    stamp = record(args, {"experiment": args.experiment}, seed=args.seed)
    with staged_output(args.out, "entries", owned=OUTPUTS) as stage:
        paths = write_campaign(campaign, stage, trajectories=not args.no_trajectories)
        stamp_tree(stage, stamp)
    t, truth = campaign.trials, campaign.truth
    values = ", ".join(f"{k} = {v:g}{' ' + experiment.unit(k) if experiment.unit(k) else ''}"
                       for k, v in truth["population"].items())
    print(f"synthetic campaign: {t.n} bounces, seed {args.seed}, truth {values}")
    print(f"  rebound speed {_spread(t.rebound_speed)} m/s, rebound angle "
          f"{_spread(t.rebound_angle)} deg; {100 * truth['share_rolling']:.0f} % of bounces left "
          f"rolling")
    for name, path in paths.items():
        print(f"  {name}: {args.out / Path(path).relative_to(stage)}")
    return 0


def _spread(values) -> str:
    """``mean +- sd``, or the value alone for one bounce."""
    if len(values) < 2:
        return f"{values.mean():.4g}"
    return f"{values.mean():.4g} +- {values.std(ddof=1):.2g}"
