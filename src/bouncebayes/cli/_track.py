"""``bouncebayes track``: videos in, ``DIR/<name>.csv`` trajectories and overlays out.

:func:`add_track_subcommand` registers the command on a sub-parser collection (for tests that
build their own parser); :func:`run` parses the option strings, calls
:func:`bouncebayes.tracking.track_video` once per input and writes the files of each video
together.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections import Counter
from pathlib import Path

from ._common import (Formatter, add_out_folder, add_quiet, add_readout, add_tone_curve,
                      check_out_folder, real, record, show_progress)

HELP = "track the ball in high-speed videos and write plane-frame trajectories"
DESCRIPTION = ("Find the ball in every frame of each video (sub-pixel; background model + "
               "coverage centroid, or a disk fit where the ball is cut by the frame edge), "
               "convert pixels to metres and rotate into the plane frame: x along the surface in "
               "the direction of travel, y along its outward normal. Writes DIR/<name>.csv "
               "(t,x,y in s and m, found frames only; t = frame index / fps, plus the centre's "
               "row's share of a rolling shutter's --readout), "
               "with the per-frame quality columns residual, visible and flag (flagged frames are "
               "left out by the kinematics), DIR/<name>.overlay.png (positions over a "
               "superposition of frames; flagged frames in magenta) and DIR/<name>.track.json "
               "(calibration with its relative SD, surface angle with its SD, per-frame pixels "
               "and quality, settings, provenance), the three together. Pixel coordinates have "
               "the origin at the top-left of the frame.")


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Options of ``track``."""
    from ..tracking import CHANNELS, LENS_MODES, PAPER_BALL_DIAMETER, POLARITIES, TrackerConfig

    p.add_argument("inputs", nargs="+", type=Path, metavar="INPUT",
                   help="video files (mp4, avi, mov, mkv, ...) or folders of image frames "
                        "(PNG, TIFF, JPEG, BMP; sorted naturally)")
    add_out_folder(p)
    p.add_argument("--fps", type=real, metavar="F",
                   help="capture frame rate; overrides the file's (high-speed cameras often "
                        "store a playback rate such as 30); required for image folders")
    scale = p.add_mutually_exclusive_group()
    scale.add_argument("--ball-diameter", type=real, default=PAPER_BALL_DIAMETER,
                       metavar="METRES",
                       help="scale from the ball's diameter and its median fitted radius "
                            "(the paper's ball by default)")
    scale.add_argument("--reference", metavar="X1,Y1,X2,Y2,METRES[,SD]",
                       help="scale from two pixel points a known distance apart, optionally "
                            "with the distance's standard deviation (m), which becomes the "
                            "scale's stated uncertainty")
    p.add_argument("--surface", metavar="X1,Y1,X2,Y2",
                   help="two pixel points on the surface line; if not given, it is detected as "
                        "the straight edge of the background that the ball does not cross and "
                        "comes nearest to touching")
    p.add_argument("--polarity", choices=POLARITIES, default=TrackerConfig.polarity,
                   help="ball brighter or darker than its surroundings, or decide from the "
                        "video")
    p.add_argument("--min-contrast", type=real, default=TrackerConfig.min_contrast,
                   metavar="GREY", help="smallest ball-background difference, grey levels "
                                        "(0-255)")
    p.add_argument("--threshold-sigma", type=real, default=TrackerConfig.threshold_sigma,
                   metavar="K", help="detection threshold in noise standard deviations (the "
                                     "threshold is the larger of this and --min-contrast)")
    p.add_argument("--background", type=Path, metavar="IMAGE",
                   help="an image of the scene without the ball; if not given, the per-pixel "
                        "median of frames (give one if the ball rests or moves slowly)")
    p.add_argument("--lens", choices=LENS_MODES, default="auto",
                   help="auto: where the surface edge bows clearly (a lens that bends straight "
                        "lines), undistort the frames by the one-parameter model that "
                        "straightens it and track them again; none: the frames as they are "
                        "(frames undistorted with the camera's own calibration)")
    p.add_argument("--channel", choices=CHANNELS, default="auto",
                   help="what of colour frames to track: their luma (grey), one colour channel, "
                        "or auto: the luma unless the ball stands out of the background twice "
                        "as clearly in a channel (five times for video files and JPEG frames, "
                        "whose colour is stored at half size; a red ball on a green wall)")
    add_tone_curve(p)
    add_readout(p)
    add_quiet(p)


def add_track_subcommand(subparsers) -> argparse.ArgumentParser:
    """Register ``track`` on ``subparsers`` (``parser.add_subparsers()``)."""
    p = subparsers.add_parser("track", help=HELP, description=DESCRIPTION,
                              formatter_class=Formatter)
    add_arguments(p)
    p.set_defaults(run=run)
    return p


def parse_numbers(option: str, text: str, names: tuple[str, ...]) -> list[float]:
    """``"1,2.5,3"`` -> floats, one per name; ``ValueError`` naming the option otherwise."""
    form = ",".join(names)
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        values = []
    if len(values) != len(names) or not all(math.isfinite(v) for v in values):
        raise ValueError(f"`{option}` must be {form} ({len(names)} numbers separated by "
                         f"commas); got {text!r}")
    return values


def _settings(args: argparse.Namespace) -> dict:
    """The tracker's options, checked, as keyword arguments of ``track_video``."""
    from .._validate import check_scalar
    from ..tracking import Surface, TrackerConfig

    config = TrackerConfig(polarity=args.polarity, min_contrast=args.min_contrast,
                           threshold_sigma=args.threshold_sigma, tone_curve=args.tone_curve)
    reference = surface = None
    if args.reference is not None:
        names: tuple[str, ...] = ("X1", "Y1", "X2", "Y2", "METRES")
        if args.reference.count(",") == 5:
            names += ("SD",)
        x1, y1, x2, y2, metres, *sd = parse_numbers("--reference", args.reference, names)
        reference = ((x1, y1), (x2, y2), metres, sd[0] if sd else None)
        from ..tracking import Calibration
        try:
            Calibration.from_reference(*reference)
        except ValueError as exc:
            raise ValueError(f"`--reference` {args.reference}: {exc}") from None
    if args.surface is not None:
        surface = Surface.from_text(args.surface)
    if args.fps is not None:
        check_scalar("--fps", args.fps, unit="frames/s", low=0.0, low_open=True)
    check_scalar("--ball-diameter", args.ball_diameter, unit="m", low=0.0, low_open=True)
    check_scalar("--readout", args.readout, unit="s", low=0.0)
    return dict(fps=args.fps, config=config, ball_diameter=args.ball_diameter,
                reference=reference, surface=surface, background=args.background,
                readout=args.readout, channel=args.channel, lens=args.lens)


def run(args: argparse.Namespace) -> int:
    """Track every input; the files of each tracked video are written together."""
    from .._io import staged_output

    settings = _settings(args)
    check_unique_names(args.inputs)
    check_out_folder("--out", args.out)
    failed: list[str] = []
    with staged_output(args.out, "entries") as stage:
        lines = [_track_one(path, settings, stage, args, failed)
                 for path in _bar(args.inputs, show_progress(args))]
    for line in filter(None, lines):
        print(line)
    if failed:
        raise ValueError(f"{len(failed)} of {len(args.inputs)} inputs could not be tracked "
                         f"({', '.join(failed)}); see the messages above")
    return 0


def _bar(inputs: list[Path], show: bool):
    if not show or len(inputs) < 2:
        return inputs
    from tqdm.auto import tqdm

    return tqdm(inputs, desc="videos", unit="video", leave=False)


def _track_one(path: Path, settings: dict, stage: Path, args: argparse.Namespace,
               failed: list[str]) -> str | None:
    from .._provenance import stamp
    from ..tracking import track_video

    try:
        result = track_video(path, **settings)
    except ValueError as exc:  # InputFileError included: it names the file
        if len(args.inputs) == 1:
            raise
        print(f"bouncebayes track: skipped {exc}", file=sys.stderr)
        failed.append(str(path))
        return None
    files = write_outputs(result, stage, args)
    provenance = record(args, {"video": path, "background": args.background})
    for key in ("overlay", "record"):  # the trajectory keeps `t,x,y` as its first line
        stamp(files[key], provenance)
    gravity = json.loads(files["record"].read_text(encoding="utf-8")).get("gravity")
    return summary_line(result, {k: args.out / v.name for k, v in files.items()},
                        gravity=None if gravity is None else gravity["summary"])


def output_name(path: Path) -> str:
    """The ``<name>`` of an input's output files."""
    return path.name if path.is_dir() else path.stem


def check_unique_names(inputs: list[Path]) -> None:
    """Two inputs must not write the same files."""
    names = Counter(output_name(p) for p in inputs)
    clash = [str(p) for p in inputs if names[output_name(p)] > 1]
    if clash:
        raise ValueError(f"inputs {', '.join(clash)} would write the same DIR/<name>.csv: "
                         "rename or track them in separate runs")


def write_outputs(result, out: Path, args: argparse.Namespace) -> dict[str, Path]:
    """``<name>.csv``, ``<name>.overlay.png`` and ``<name>.track.json`` of one video
    (:func:`bouncebayes.tracking.write_track_files`, as ``bouncebayes run`` writes them)."""
    from ..tracking import write_track_files

    return write_track_files(result, out, settings=settings_record(args))


def settings_record(args: argparse.Namespace) -> dict:
    """The tracker's options as the record stores them."""
    from ..tracking import tone_curve_label

    return {"polarity": args.polarity, "min_contrast": args.min_contrast,
            "threshold_sigma": args.threshold_sigma, "fps": args.fps,
            "tone_curve": tone_curve_label(args.tone_curve), "readout_s": args.readout,
            "channel": args.channel,
            "ball_diameter_m": None if args.reference else args.ball_diameter,
            "reference": args.reference, "surface": args.surface,
            "background": str(args.background) if args.background else
            "per-pixel median of frames"}


def summary_line(result, files: dict[str, Path], gravity: str | None = None) -> str:
    """What was found in one video, and where it went (and a warning where the scale comes
    from the ball's radius and that is unreliable or uncertain, and where the frames are
    strongly compressed); ``gravity``: the flights' fall against the scale, in words."""
    from ..tracking import (EDGE_FIT, camera_message, cast_message, compression_warning,
                            depth_warning, lens_warning, radius_warning, surface_warning,
                            timing_warning, tone_curve_warning)

    src, tr, cal, srf = result.source, result.track, result.calibration, result.surface
    n, found = len(tr.found), int(tr.found.sum())
    edge = int((tr.method == EDGE_FIT).sum())
    flagged = int(tr.flag.sum())
    unc = f" +- {100 * cal.relative_sd:.2g}%" if cal.relative_sd is not None else ""
    angle = f" +- {srf.angle_sd_deg:.2g}" if srf.angle_sd_deg is not None else ""
    return (f"{src.name}: ball in {found}/{n} frames ({edge} cut by the frame edge, "
            f"{n - found} not found, {flagged} flagged), radius {tr.ball_radius:.2f} px, "
            f"{cal.metres_per_px * 1e3:.4g} mm/px{unc} ({cal.source}), surface at "
            f"{srf.angle:.2f}{angle} deg ({srf.source}), {src.fps:g} fps ({src.fps_source})\n"
            f"  -> {files['trajectory']}  {files['overlay']}  {files['record']}"
            + (f"\n  warning: {warning}" if cal.source != "reference"
               and (warning := radius_warning(tr)) else "")
            + (f"\n  warning: {coded}" if (coded := compression_warning(src)) else "")
            + (f"\n  warning: {tone}" if (tone := tone_curve_warning(result)) else "")
            + (f"\n  warning: {timing}" if (timing := timing_warning(tr)) else "")
            + (f"\n  warning: {lens}" if (lens := lens_warning(result)) else "")
            + (f"\n  warning: {line}" if (line := surface_warning(result)) else "")
            + (f"\n  warning: {depth}" if (depth := depth_warning(tr)) else "")
            + (f"\n  {camera}" if (camera := camera_message(tr)) else "")
            + (f"\n  {cast}" if (cast := cast_message(tr)) else "")
            + (f"\n  colour: {src.channel_note}" if src.channel_note else "")
            + (f"\n  {gravity}" if gravity else ""))
