"""``bouncebayes run`` and ``bouncebayes demo``: the whole job into one run folder."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ._common import (add_figure_formats, add_readout, add_sampler_arguments, add_tone_curve,
                      check_out_folder, flag_names, inference_options, log, real,
                      sampler_config, show_progress)

HELP = "the whole job: data -> kinematics -> inference -> propagation -> figures -> report"
DESCRIPTION = ("Run every stage on DATA and put all results in DIR: trial table, posterior.nc, "
               "summary.json, propagation, figures (PNG; SVG/PDF with --figure-formats) and report.html. DATA is a "
               "trial table (CSV), a folder of trajectory files (t,x,y in s and m, or Tracker "
               "text), or a folder of videos (mp4, avi, mov, or sub-folders of PNG/TIFF "
               "frames). DIR changes all at once: the results are made in a staging folder "
               "beside it and replace an earlier run's only when every stage has succeeded.")
DEMO_HELP = "run the whole job on a bundled campaign (the paper's setup, or Kharaz 2001)"
DEMO_DESCRIPTION = ("Run the whole job (kinematics, inference, propagation, figures, report) on "
                    "a bundled campaign. paper (the default): 55 synthetic bounces of the "
                    "paper's setup (trajectories at 1000 Hz) generated with mu = 0.16 and eta = "
                    "1.35 kg/s, which the report shows beside the results. kharaz: the "
                    "measurements of Kharaz, Gorham & Salman (2001), 5 mm alumina spheres on "
                    "glass at 3.9 m/s from 2 to 85 deg, with a Mindlin tangential spring; the "
                    "DEM community's friction coefficient for it is 0.092. Its folder also "
                    "holds candidate models for `bouncebayes compare`. Every kharaz bounce is an ODE "
                    "solution: the default Metropolis-Hastings run takes about two CPU-minutes; "
                    "`--sampler grid --grid-points 64` about half a minute.")
DEMO_OUT = {"paper": Path("demo-output"), "kharaz": Path("demo-kharaz-output")}


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Options of ``run``."""
    p.add_argument("experiment", type=Path, metavar="EXPERIMENT.toml", help="experiment file")
    p.add_argument("data", type=Path, metavar="DATA",
                   help="trial table, trajectory folder or video folder")
    p.add_argument("--out", type=Path, required=True, metavar="DIR",
                   help="run folder (new, empty, or an earlier run's)")
    p.add_argument("--fps", type=real, default=None, metavar="HZ",
                   help="frame rate of the videos in frames/s (needed for folders of image "
                        "frames; overrides the rate stored in a video file, which high-speed "
                        "cameras often set to the playback rate)")
    p.add_argument("--surface", metavar="X1,Y1,X2,Y2",
                   help="videos: two pixel points on the surface line, the same in every video "
                        "(one camera set-up); if not given, it is detected in each video as the "
                        "straight edge of its background that the ball does not cross and "
                        "comes nearest to touching")
    add_tone_curve(p)
    add_readout(p)
    add_figure_formats(p)
    add_sampler_arguments(p)


def add_demo_arguments(p: argparse.ArgumentParser) -> None:
    """Options of ``demo``."""
    p.add_argument("--campaign", choices=tuple(DEMO_OUT), default="paper",
                   help="which bundled campaign: the paper's setup (synthetic, known truth) or "
                        "Kharaz et al. (2001) (measured, mu = 0.092 in DEM reproductions)")
    p.add_argument("--out", type=Path, default=None, metavar="DIR",
                   help="run folder (new, empty, or an earlier run's; default demo-output, "
                        "or demo-kharaz-output for --campaign kharaz)")
    add_figure_formats(p)
    add_sampler_arguments(p)


def run(args: argparse.Namespace) -> int:
    """``run``: every stage on the user's data."""
    return _run(args.experiment, args.data, args)


def run_demo(args: argparse.Namespace) -> int:
    """``demo``: every stage on the bundled campaign."""
    from ..data import demo_campaign

    demo = demo_campaign(args.campaign)
    if args.out is None:
        args.out = DEMO_OUT[args.campaign]
    if demo.truth is not None:
        log(f"demo campaign: {demo.truth['n']} bounces from {demo.folder} (true mu = "
            f"{demo.truth['population']['mu']:g}, eta = {demo.truth['population']['eta']:g} "
            f"kg/s)")
        return _run(demo.experiment, demo.data, args, truth=demo.folder / "truth.json")
    log(f"demo campaign: Kharaz et al. (2001), {demo.trials} (the DEM community's mu = 0.092); "
        f"compare its candidate models with `bouncebayes compare {demo.experiment} "
        f"{demo.trials} --out kharaz-comparison`")
    return _run(demo.experiment, demo.data, args)


def _run(experiment: Path, data: Path, args: argparse.Namespace, truth: Path | None = None
         ) -> int:
    from .._validate import check_scalar
    from ..pipeline import run

    check_out_folder("--out", args.out)
    if getattr(args, "fps", None) is not None:
        check_scalar("--fps", args.fps, unit="frames/s", low=0.0, low_open=True)
    check_scalar("--readout", getattr(args, "readout", 0.0), unit="s", low=0.0)
    surface = getattr(args, "surface", None)
    if surface is not None:
        from ..tracking import Surface

        Surface.from_text(surface)  # checked before any work
    config = sampler_config(args, experiment)
    outcome = run(experiment, data, args.out, sampler=args.sampler, seed=args.seed,
                  config=config, progress=show_progress(args), log=log, truth=truth,
                  fps=getattr(args, "fps", None), surface=surface,
                  tone_curve=getattr(args, "tone_curve", None),
                  readout=getattr(args, "readout", 0.0), argv=args.argv,
                  figure_formats=args.figure_formats, **inference_options(args))
    print(flag_names(outcome.table, args.flags))
    print(flag_names(outcome.verdict, args.flags))
    times = ", ".join(f"{k} {v:.1f}" for k, v in outcome.stage_seconds.items())
    total = sum(outcome.stage_seconds.values())
    print(f"\nreport: {outcome.report}  (all results in {outcome.folder}; {total:.1f} s: "
          f"{times})")
    sys.stdout.flush()
    return 0
