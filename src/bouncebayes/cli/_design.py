"""``bouncebayes design``: plan an experiment before filming it."""

from __future__ import annotations

import argparse
from pathlib import Path

from ._batch import add_cluster_arguments
from ._common import (UserError, add_memory_budget, add_out_folder, check_out_folder, integer,
                      log, record, show_progress)

HELP = "plan an experiment: expected posterior widths for candidate angles, bounces, cameras"
DESCRIPTION = ("For every combination of candidate incidence angles, speeds, numbers of "
               "bounces, frame rates and position noises, simulate campaigns with truths drawn "
               "from the experiment's priors and compute their exact grid posteriors: the "
               "expected posterior sd of every inferred parameter, the probability that mu is "
               "identified (every bounce slides throughout) and the expected information gain. "
               "The trial table's standard errors come from the kinematics fit of simulated "
               "trajectories at each frame rate and position noise (or, with --table-errors, "
               "the experiment's [synth] noise). Writes DIR/design.json, DIR/design.png and "
               ".svg; campaigns are written to DIR/campaigns-HASH/ as they arrive and a rerun "
               "resumes. Cost of a design: bounces x frame rate / 1000 frames/s.")
OUTPUTS = ("design.json", "design.png", "design.svg")
SPACE_FLAGS = {"angles_deg": "--angles", "speeds_m_s": "--speeds", "n_bounces": "--bounces",
               "frame_rates_hz": "--frame-rates", "position_noise_m": "--position-noise",
               "errors": "--table-errors"}


def _numbers(kind=float):
    def parse(text: str) -> tuple:
        try:
            if ":" in text:
                a, b, step = (float(x) for x in text.split(":"))
                if step <= 0 or b < a:
                    raise ValueError
                n = int(round((b - a) / step)) + 1
                return tuple(kind(round(a + i * step, 10)) for i in range(n))
            return tuple(kind(x) for x in text.split(","))
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"must be comma-separated numbers or START:STOP:STEP; got {text!r}") from None
    parse.__name__ = "list of numbers"
    return parse


def _targets(text: str) -> dict[str, float]:
    out = {}
    for part in text.split(","):
        name, _, value = part.partition("=")
        try:
            out[name.strip()] = float(value)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"must be NAME=SD pairs, e.g. mu=0.01,eta=0.1; got {text!r}") from None
    return out


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Options of ``design``."""
    p.add_argument("experiment", type=Path, metavar="EXPERIMENT.toml",
                   help="experiment file: ball, priors, nominal incidence and [synth] camera")
    add_out_folder(p)
    g = p.add_argument_group("candidate designs")
    g.add_argument("--angles", type=_numbers(), default=None, metavar="DEG",
                   help="incidence angles from the normal, deg (list or START:STOP:STEP; "
                        "default 20:80:5)")
    g.add_argument("--speeds", type=_numbers(), metavar="M/S",
                   help="incidence speeds, m/s (default: the experiment's)")
    g.add_argument("--bounces", type=_numbers(int), default=(10, 25, 55), metavar="N",
                   help="numbers of bounces (default 10,25,55)")
    g.add_argument("--frame-rates", type=_numbers(), metavar="HZ",
                   help="frame rates, frames/s (default: [synth] camera_rate_hz)")
    g.add_argument("--position-noise", type=_numbers(), metavar="M",
                   help="sd of the tracked positions, m (default: [synth] position_noise_m)")
    g.add_argument("--table-errors", action="store_true",
                   help="use the experiment's [synth] measurement noise as the trial table's "
                        "standard errors instead of deriving them from the camera")
    g.add_argument("--campaigns", type=integer(2), default=16, metavar="N",
                   help="simulated campaigns per design")
    g.add_argument("--target", type=_targets, default=None, metavar="NAME=SD,...",
                   help="target posterior sd, e.g. mu=0.01,eta=0.1: recommend the cheapest "
                        "design reaching them")
    g.add_argument("--seed", type=integer(0), default=0, help="seed of the study")
    add_memory_budget(g)
    add_cluster_arguments(p)


def run(args: argparse.Namespace) -> int:
    """Evaluate the designs, write design.json and the figure, print the table."""
    import tomllib

    from .._io import staged_output, write_json
    from .._provenance import stamp_tree
    from ..data import load_experiment
    from ..design import DesignSpace, design_figure, run_design, study_key

    check_out_folder("--out", args.out)
    experiment = load_experiment(args.experiment)
    doc = tomllib.loads(args.experiment.read_text(encoding="utf-8"))
    try:
        space = DesignSpace.for_experiment(
            experiment, angles_deg=args.angles, speeds_m_s=args.speeds, n_bounces=args.bounces,
            frame_rates_hz=args.frame_rates, position_noise_m=args.position_noise,
            campaigns=args.campaigns, errors="table" if args.table_errors else "trajectories")
    except ValueError as exc:
        message = str(exc)
        for name, flag in SPACE_FLAGS.items():
            message = message.replace(f"`{name}`", f"`{flag}`")
        raise UserError(message) from None
    store = args.out / f"campaigns-{study_key(doc, space, args.seed)}"
    try:
        result = run_design(doc, space, seed=args.seed, targets=args.target, store=store,
                            scheduler=args.scheduler, workers=args.workers,
                            progress=show_progress(args), log=log,
                            memory_budget=args.memory_budget)
    except ValueError as exc:
        message = str(exc).replace("`target`", "`--target`")
        for name, flag in SPACE_FLAGS.items():
            message = message.replace(f"`{name}`", f"`{flag}`")
        raise UserError(message) from None
    stamp = record(args, {"experiment": args.experiment}, seed=args.seed)
    with staged_output(args.out, "entries", owned=OUTPUTS) as stage:
        write_json(stage / "design.json", result | {"provenance": stamp})
        design_figure(result, stage / "design.png")
        stamp_tree(stage, stamp)
    print(_table(result))
    print(f"written: {args.out / 'design.json'}, {args.out / 'design.png'}")
    if result["failed"]:
        raise UserError(f"{len(result['failed'])} campaigns failed (first: "
                        f"{next(iter(result['failed'].values()))}); rerun to retry them")
    return 0


def _table(result: dict) -> str:
    names = list(result["parameters"])
    head = (f"{'angle':>6} {'speed':>6} {'bounces':>7} {'fps':>6} {'cost':>6} "
            + " ".join(f"{'sd(' + n + ')':>11}" for n in names) + f" {'P(mu id)':>8} "
            f"{'gain':>6}")
    lines = [head]
    for d in result["designs"]:
        p = d["p_mu_identified"]
        lines.append(f"{d['angle_deg']:>6g} {d['speed_m_s']:>6g} {d['n_bounces']:>7d} "
                     f"{d['frame_rate_hz']:>6g} {d['cost']:>6g} "
                     + " ".join(f"{d['expected_sd'][n]:>11.3g}" for n in names)
                     + f" {'-' if p is None else format(p, '.2f'):>8} "
                     f"{d['information_gain']:>6.2f}")
    rec = result["recommended"]
    from ..design import describe

    if rec["design"] is not None:
        lines.append(f"recommended: {describe(rec['design'])} ({rec['reason']})")
    else:
        lines.append(f"recommended: none: {rec['reason']}")
    b = result["boundary"].get("contact_mu")
    if b and b["angle_deg"] is not None:
        lines.append(f"bounces with mu = {b['mu']:g} slide throughout above "
                     f"{b['angle_deg']:.1f} deg at {result['boundary']['speed_m_s']:g} m/s")
    return "\n".join(lines)
