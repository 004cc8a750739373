"""The ``bouncebayes`` command line: a thin shell that parses, calls the library, writes files.

Each sub-command is an ``add_<name>_subcommand(subparsers)`` plus a ``run_<name>(args)``.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import warnings
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from ._cli_track import add_track_subcommand
from ._version import __version__
from .model import (HERTZ_OVERLAP_LIMIT, NORMAL_LAWS, PAPER_BALL, STANDARD_GRAVITY, Ball,
                    SimulationWarning, simulate, simulate_history)

# Quantities printed by `simulate`, with units.
_SIMULATE_ROWS = (
    ("rebound_speed", "rebound speed", "m/s", "{:.6g}"),
    ("rebound_angle", "rebound angle (from the normal)", "deg", "{:.6g}"),
    ("rebound_spin", "rebound spin (CCW +)", "rad/s", "{:.6g}"),
    ("contact_time", "contact time", "ms", "{:.6g}"),
    ("peak_normal_force", "peak normal force", "N", "{:.6g}"),
    ("peak_friction_force", "peak friction force", "N", "{:.6g}"),
    ("max_overlap", "maximum overlap", "mm", "{:.6g}"),
    ("regime", "contact point at separation", "", "{}"),
)
_JSON_KEYS = ("rebound_speed", "rebound_angle", "rebound_spin", "contact_time",
              "peak_normal_force", "peak_friction_force", "regime")


class UserError(Exception):
    """An error in what the user asked for; printed without a traceback."""


def _formatter(prog: str) -> argparse.HelpFormatter:
    return argparse.ArgumentDefaultsHelpFormatter(prog, max_help_position=34, width=100)


def add_ball_arguments(parser: argparse.ArgumentParser) -> None:
    """Ball and surface options shared by the commands that simulate."""
    g = parser.add_argument_group("ball and surface (SI units; defaults: the paper's 25.6 mm "
                                  "polybutadiene ball, see README 'Default ball')")
    g.add_argument("--diameter", type=float, default=PAPER_BALL.diameter, metavar="M",
                   help="ball diameter in m")
    g.add_argument("--mass", type=float, default=PAPER_BALL.mass, metavar="KG",
                   help="ball mass in kg")
    g.add_argument("--modulus", type=float, default=PAPER_BALL.youngs_modulus, metavar="PA",
                   help="Young's modulus E in Pa")
    g.add_argument("--poisson", type=float, default=PAPER_BALL.poisson_ratio, metavar="NU",
                   help="Poisson ratio, in (-1, 0.5]")
    g.add_argument("--inertia-factor", type=float, default=PAPER_BALL.inertia_factor,
                   metavar="K", help="I = K m r^2: 0.4 solid sphere, 0.667 thin shell")
    g.add_argument("--inclination", type=float, default=0.0, metavar="DEG",
                   help="plane inclination to the horizontal in degrees, in (-90, 90); "
                        "positive when the ball travels down-slope")
    g.add_argument("--gravity", type=float, default=STANDARD_GRAVITY, metavar="M/S2",
                   help="gravitational acceleration in m/s^2")
    g.add_argument("--normal-law", choices=NORMAL_LAWS, default="kelvin-voigt",
                   help="normal force: Hertz + linear viscous (kelvin-voigt, the paper's; "
                        "eta in kg/s) or Hunt-Crossley (eta in s/m)")


def ball_from_args(args: argparse.Namespace) -> Ball:
    return Ball.from_diameter(args.diameter, mass=args.mass, youngs_modulus=args.modulus,
                              poisson_ratio=args.poisson, inertia_factor=args.inertia_factor)


def add_simulate_subcommand(sub) -> None:
    p = sub.add_parser("simulate", formatter_class=_formatter,
                       help="simulate one bounce and print its rebound, forces, contact time",
                       description="Simulate one oblique bounce of a ball on a rigid plane "
                                   "(Hertz contact, viscous damping, Coulomb friction) and print "
                                   "the rebound, the contact time and the peak forces. Incident "
                                   "values are those at first contact; rebound values those at "
                                   "separation.")
    p.add_argument("--mu", type=float, default=0.16, help="Coulomb friction coefficient (-)")
    p.add_argument("--eta", type=float, default=1.35,
                   help="damping coefficient: kg/s (kelvin-voigt) or s/m (hunt-crossley)")
    p.add_argument("--speed", type=float, default=3.0, metavar="M/S",
                   help="incident speed in m/s")
    p.add_argument("--angle", type=float, default=60.0, metavar="DEG",
                   help="incident angle from the plane normal in degrees, in [0, 90)")
    p.add_argument("--spin", type=float, default=0.0, metavar="RAD/S",
                   help="incident spin in rad/s, counter-clockwise positive with x along the "
                        "direction of travel and y the outward normal")
    add_ball_arguments(p)
    p.add_argument("--json", action="store_true",
                   help="print one JSON object instead of the table")
    p.add_argument("--plot", metavar="FILE", type=Path,
                   help="write a figure of the trajectory near contact and the force histories "
                        "(.png, .svg or .pdf)")
    p.set_defaults(run=run_simulate)


def check_figure_path(path: Path | None) -> None:
    """Fail before any work if a figure path has a format we cannot write."""
    from .plots import FIGURE_FORMATS

    if path is not None and path.suffix.lower() not in FIGURE_FORMATS:
        raise UserError(f"figure file {str(path)!r} must end in one of "
                        f"{', '.join(FIGURE_FORMATS)}")


def run_simulate(args: argparse.Namespace) -> int:
    check_figure_path(args.plot)
    ball = ball_from_args(args)
    kwargs = dict(mu=args.mu, eta=args.eta, speed=args.speed, angle=args.angle, spin=args.spin,
                  inclination=args.inclination, normal_law=args.normal_law,
                  gravity=args.gravity)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SimulationWarning)  # reported below as an error
        result = simulate(ball, **kwargs)
    if result.n_failed:
        raise UserError(f"the bounce could not be solved: {result.failure_summary()}")
    row = result.item()
    if not row["hertz_valid"]:
        print(f"bouncebayes simulate: warning: the maximum overlap, "
              f"{row['max_overlap'] * 1e3:.4g} mm, exceeds {HERTZ_OVERLAP_LIMIT:.0%} of the ball's "
              f"radius ({ball.radius * 1e3:.4g} mm): beyond the small strains of Hertz's contact, "
              f"so these numbers are the model's, not a real ball's", file=sys.stderr)
    if args.json:
        print(json.dumps({k: row[k] for k in _JSON_KEYS}))
    else:
        print(format_bounce_table(row, args))
    if args.plot:
        from .plots import plot_bounce, save_figure

        history = simulate_history(ball, **kwargs)
        title = (f"mu = {args.mu:g}, eta = {args.eta:g}, V = {args.speed:g} m/s, "
                 f"angle = {args.angle:g} deg, spin = {args.spin:g} rad/s")
        path = save_figure(plot_bounce(history, title=title), args.plot)
        print(f"figure written to {path}", file=sys.stderr)
    return 0


def format_bounce_table(row: dict, args: argparse.Namespace) -> str:
    scale = {"contact_time": 1e3, "max_overlap": 1e3}
    lines = [f"bounce: mu = {args.mu:g}, eta = {args.eta:g}, incident {args.speed:g} m/s at "
             f"{args.angle:g} deg, spin {args.spin:g} rad/s ({args.normal_law})"]
    for key, label, unit, fmt in _SIMULATE_ROWS:
        value = row[key] * scale[key] if key in scale else row[key]
        lines.append(f"  {label:<34} {fmt.format(value):>12} {unit}")
    return "\n".join(lines)


def add_synth_subcommand(sub) -> None:
    p = sub.add_parser("synth", formatter_class=_formatter,
                       help="generate a synthetic campaign from known parameters",
                       description="Generate a synthetic campaign from the experiment file: "
                                   "each bounce gets its own incidence ([incidence] with its "
                                   "*_sd spreads) and contact parameters ([contact] values with "
                                   "[synth] mu_sd, eta_sd); the trial table adds the [synth] "
                                   "measurement noise, trajectories are sampled at "
                                   "camera_rate_hz with position_noise_m. Writes DIR/trials.csv, "
                                   "DIR/truth.json and DIR/trajectories/*.csv (t,x,y in s and "
                                   "m, plane-aligned frame).")
    p.add_argument("experiment", type=Path, metavar="EXPERIMENT.toml",
                   help="experiment file (see docs/experiment-file.md)")
    p.add_argument("--out", type=Path, required=True, metavar="DIR", help="output folder")
    p.add_argument("--n", type=int, default=None,
                   help="number of bounces (default: [synth] n of the experiment file, 55)")
    p.add_argument("--seed", type=int, default=0,
                   help="seed of the random generator (recorded in truth.json)")
    p.add_argument("--no-trajectories", action="store_true",
                   help="write only the trial table and the truth")
    p.set_defaults(run=run_synth)


def run_synth(args: argparse.Namespace) -> int:
    from .data import load_experiment, synthesize, write_campaign

    experiment = load_experiment(args.experiment)
    campaign = synthesize(experiment, seed=args.seed, n=args.n)
    paths = write_campaign(campaign, args.out, trajectories=not args.no_trajectories)
    t, truth = campaign.trials, campaign.truth
    print(f"synthetic campaign: {t.n} bounces, seed {args.seed}, truth mu = "
          f"{truth['population']['mu']:g}, eta = {truth['population']['eta']:g} "
          f"{experiment.unit('eta')}")
    print(f"  rebound speed {t.rebound_speed.mean():.4g} +- {t.rebound_speed.std(ddof=1):.2g}"
          f" m/s, rebound angle {t.rebound_angle.mean():.4g} +- "
          f"{t.rebound_angle.std(ddof=1):.2g} deg; "
          f"{100 * truth['share_rolling']:.0f} % of bounces left rolling")
    for name, path in paths.items():
        print(f"  {name}: {path}")
    return 0


def add_kinematics_subcommand(sub) -> None:
    p = sub.add_parser("kinematics", formatter_class=_formatter,
                       help="turn a folder of tracked trajectories into a trial table",
                       description="Fit the free flight before and after the impact of every "
                                   "trajectory file in a folder (CSV with header t,x,y or "
                                   "t,x,y,z in s and m, or Tracker's exported data text) and "
                                   "write one row per bounce: incidence and rebound speed (m/s) "
                                   "and angle (deg from the normal) with standard errors. Files "
                                   "that cannot be used are listed with the reason; the others "
                                   "are still processed. Exit status 0: all files used; 1: some "
                                   "were skipped; 2: nothing could be done.")
    p.add_argument("folder", type=Path, metavar="TRAJECTORY_DIR",
                   help="folder of trajectory files (*.csv, *.txt)")
    p.add_argument("--experiment", type=Path, required=True, metavar="EXPERIMENT.toml",
                   help="experiment file: its [trajectories] table gives the camera-to-plane "
                        "rotation (deg), the length unit and the drag model")
    p.add_argument("--out", type=Path, required=True, metavar="TRIALS.csv",
                   help="trial table to write")
    p.add_argument("--min-points", type=int, default=5,
                   help="free-flight samples needed on each side of the impact")
    p.add_argument("--contact-guard", type=int, default=1,
                   help="samples next to the impact left out of the fits on each side (they "
                        "may be in contact: a 2 ms contact spans 2 samples at 1000 Hz)")
    p.set_defaults(run=run_kinematics)


def run_kinematics(args: argparse.Namespace) -> int:
    from .data import load_experiment
    from .density import summarize
    from .kinematics import trial_table_from_folder

    experiment = load_experiment(args.experiment)
    found, results = trial_table_from_folder(args.folder, experiment, args.out,
                                             min_points=args.min_points,
                                             contact_guard=args.contact_guard)
    speed = [k.rebound_speed for k in results]
    angle = [k.rebound_angle for k in results]
    incidence = [k.incidence_speed for k in results]
    print(f"trial table: {args.out} ({len(speed)} bounces)")
    print(f"  incidence speed {np.mean(incidence):.4g} +- {np.std(incidence, ddof=1):.2g} m/s"
          if len(speed) > 1 else "")
    if len(speed) > 1:
        summary = summarize(speed, angle)
        d = summary.to_dict()
        print(f"  rebound speed {summary.speed.mean:.4g} +- {summary.speed.sd:.2g} m/s, "
              f"rebound angle {summary.angle.mean:.4g} +- {summary.angle.sd:.2g} deg")
        print(f"  Pearson correlation of speed and angle: {summary.correlation.text()}")
        for warning in d["warnings"]:
            print(f"  warning: {warning}")
    return 1 if found.failures else 0


def add_infer_subcommand(sub) -> None:
    from .inference import LIKELIHOODS, SAMPLERS, SamplerConfig

    d = SamplerConfig()
    p = sub.add_parser("infer", formatter_class=_formatter,
                       help="posterior of the contact parameters from a trial table",
                       description="Bayesian calibration: the posterior of the parameters listed "
                                   "under [parameters] in the experiment file, given the "
                                   "rebounds of a trial table. Writes DIR/posterior.nc (ArviZ "
                                   "InferenceData) and DIR/summary.json, and prints a table. "
                                   "Same seed and inputs: identical draws.")
    p.add_argument("experiment", type=Path, metavar="EXPERIMENT.toml", help="experiment file")
    p.add_argument("trials", type=Path, metavar="TRIALS.csv",
                   help="trial table (rebound_speed in m/s, rebound_angle in deg, ...)")
    p.add_argument("--out", type=Path, required=True, metavar="DIR", help="output folder")
    p.add_argument("--likelihood", choices=LIKELIHOODS, default="gaussian",
                   help="gaussian: every bounce = model + measurement noise (the uncertainty "
                        "of one true value); kde: the paper's (density of the measured "
                        "rebounds at the simulated one); consistent: data-consistent inversion "
                        "(the parameters' bounce-to-bounce distribution)")
    p.add_argument("--sampler", choices=SAMPLERS, default="mh",
                   help="mh: the paper's Metropolis-Hastings; ensemble: emcee; grid: exact "
                        "quadrature (up to 3 parameters)")
    p.add_argument("--seed", type=int, default=0, help="random seed (recorded in the outputs)")
    p.add_argument("--noise", choices=("auto", "given", "inferred"), default="auto",
                   help="gaussian likelihood: the table's standard errors (given), noise levels "
                        "inferred as extra parameters, or given when every trial has them")
    p.add_argument("--draws", type=int, default=d.draws, help="posterior draws kept in all")
    p.add_argument("--chains", type=int, default=d.chains, help="mh chains")
    p.add_argument("--burn-in", type=int, default=d.burn_in,
                   help="mh iterations discarded per chain (proposal tuned meanwhile)")
    p.add_argument("--thin", type=int, default=d.thin, help="mh: keep every THIN-th iteration")
    p.add_argument("--walkers", type=int, default=d.walkers, help="ensemble walkers")
    p.add_argument("--grid-points", type=int, default=None,
                   help="grid points per parameter (default 2048 / 512 / 96 for 1 / 2 / 3 "
                        "parameters)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(run=run_infer)


def run_infer(args: argparse.Namespace) -> int:
    from .data import load_experiment, load_trials
    from .inference import SamplerConfig, format_table, infer, write_outputs

    experiment = load_experiment(args.experiment)
    trials = load_trials(args.trials, experiment)
    config = SamplerConfig(draws=args.draws, chains=args.chains, burn_in=args.burn_in,
                           thin=args.thin, walkers=args.walkers, grid_points=args.grid_points)
    result = infer(experiment, trials, likelihood=args.likelihood, sampler=args.sampler,
                   seed=args.seed, config=config, noise=args.noise,
                   progress=not args.quiet and sys.stderr.isatty())
    paths = write_outputs(result, args.out)
    print(format_table(result))
    print("\n".join(f"{name}: {path}" for name, path in paths.items()))
    return 0


def _add_run_options(p) -> None:
    from .inference import LIKELIHOODS, SAMPLERS

    p.add_argument("--likelihood", choices=LIKELIHOODS, default="gaussian",
                   help="see `bouncebayes infer --help`")
    p.add_argument("--sampler", choices=SAMPLERS, default="mh",
                   help="see `bouncebayes infer --help`")
    p.add_argument("--seed", type=int, default=0, help="random seed (recorded in the outputs)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def add_run_subcommand(sub) -> None:
    p = sub.add_parser("run", formatter_class=_formatter,
                       help="the whole job: data -> kinematics -> inference -> propagation -> "
                            "figures -> report",
                       description="Run every stage on DATA and put all results in DIR: "
                                   "trial table, posterior.nc, summary.json, propagation, "
                                   "figures (PNG and SVG) and report.html. DATA is a trial "
                                   "table (CSV), a folder of trajectory files (t,x,y in s and m, "
                                   "or Tracker text), or a folder of videos (mp4, avi, mov, or "
                                   "sub-folders of PNG/TIFF frames).")
    p.add_argument("experiment", type=Path, metavar="EXPERIMENT.toml", help="experiment file")
    p.add_argument("data", type=Path, metavar="DATA",
                   help="trial table, trajectory folder or video folder")
    p.add_argument("--out", type=Path, required=True, metavar="DIR", help="output folder")
    p.add_argument("--fps", type=float, default=None, metavar="HZ",
                   help="frame rate of the videos in frames/s (needed for folders of image "
                        "frames; overrides the rate stored in a video file, which high-speed "
                        "cameras often set to the playback rate)")
    _add_run_options(p)
    p.set_defaults(run=run_run)


def _run(experiment, data, args, truth=None) -> int:
    from .pipeline import run

    def log(message):
        print(message, file=sys.stderr)

    outcome = run(experiment, data, args.out, likelihood=args.likelihood, sampler=args.sampler,
                  seed=args.seed, progress=not args.quiet and sys.stderr.isatty(), log=log,
                  truth=truth, fps=getattr(args, "fps", None))
    print(outcome.table)
    print(outcome.verdict)
    total = sum(outcome.stage_seconds.values())
    print(f"\nreport: {outcome.report}  (all results in {outcome.folder}; {total:.1f} s)")
    return 0


def run_run(args: argparse.Namespace) -> int:
    return _run(args.experiment, args.data, args)


def add_report_subcommand(sub) -> None:
    p = sub.add_parser("report", formatter_class=_formatter,
                       help="redraw the figures and write DIR/report.html of a run folder",
                       description="Write DIR/report.html, one self-contained file (figures "
                                   "embedded) that opens offline, from the results in DIR "
                                   "(posterior.nc, summary.json, experiment.toml, trials.csv; "
                                   "the posterior is propagated first if DIR has no "
                                   "propagation yet).")
    p.add_argument("folder", type=Path, metavar="DIR", help="a run folder")
    p.set_defaults(run=run_report)


def run_report(args: argparse.Namespace) -> int:
    from .pipeline import report_folder

    print(f"report: {report_folder(args.folder)}")
    return 0


def add_demo_subcommand(sub) -> None:
    p = sub.add_parser("demo", formatter_class=_formatter,
                       help="run the whole job on the bundled demo campaign",
                       description="Run the whole job (kinematics, inference, propagation, "
                                   "figures, report) on the bundled demo campaign: 55 synthetic "
                                   "bounces of the paper's setup (trajectories at 1000 Hz) "
                                   "generated with mu = 0.16 and eta = 1.35 kg/s, which the "
                                   "report shows beside the results.")
    p.add_argument("--out", type=Path, default=Path("demo-output"), metavar="DIR",
                   help="output folder")
    _add_run_options(p)
    p.set_defaults(run=run_demo)


def run_demo(args: argparse.Namespace) -> int:
    from .data import demo_campaign

    demo = demo_campaign()
    print(f"demo campaign: {demo.truth['n']} bounces from {demo.folder} (true mu = "
          f"{demo.truth['population']['mu']:g}, eta = {demo.truth['population']['eta']:g} "
          f"kg/s)", file=sys.stderr)
    return _run(demo.experiment, demo.trajectories, args, truth=demo.folder / "truth.json")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="bouncebayes", formatter_class=_formatter,
        description="Contact parameters (friction, viscous damping) of a ball from how it "
                    "bounces. Units are SI, angles in degrees.")
    parser.add_argument("--version", action="version", version=f"bouncebayes {__version__}")
    parser.add_argument("--traceback", action="store_true",
                        help="show the full traceback of an error (for bug reports)")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    add_simulate_subcommand(sub)
    add_synth_subcommand(sub)
    add_kinematics_subcommand(sub)
    add_infer_subcommand(sub)
    add_track_subcommand(sub)
    add_run_subcommand(sub)
    add_report_subcommand(sub)
    add_demo_subcommand(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``bouncebayes`` command; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    # numba's threads beside a multi-threaded BLAS oversubscribe the cores (10x slowdown measured).
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    with threadpool_limits(limits=1, user_api="blas"):
        try:
            return args.run(args)
        except (UserError, ValueError, TypeError) as exc:
            if args.traceback:
                raise
            print(f"bouncebayes {args.command}: error: {exc}", file=sys.stderr)
            return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
