"""Outputs of one tracked video: :func:`track_video` (stages 1-4 for one input) and
:func:`write_track_files` (the trajectory file with its per-frame quality, the tracking record
``<name>.track.json`` and the overlay image), which ``bouncebayes track`` and ``bouncebayes run``
both call."""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from .._errors import InputFileError
from .._io import write_json, write_with
from .._validate import check_choice
from .._version import __version__
from ._geometry import (
    EDGE_SHARE,
    Calibration,
    PlaneTrajectory,
    Surface,
    detect_surface,
    edge_share,
    plane_axes,
    to_plane_frame,
)
from ._camera import motion_px, rounded, shift_frames
from ._lens import LensBend, bend, bend_message, undistort, undistort_points
from ._edge import smear_radii
from ._measure import CENTROID, EDGE_FIT
from ._tone import tone_curve_label
from ._track import Track, TrackerConfig, background_model, timed_at_bounces, track_ball
from ._video import VideoSource, read_frames, read_image

PAPER_BALL_DIAMETER = 0.0256  # m, paper §3 (= bouncebayes.PAPER_BALL.diameter)


def overlay_image(frames: np.ndarray, track: Track, path: str | os.PathLike, *,
                  calibration: Calibration | None = None, surface: Surface | None = None,
                  title: str = "") -> Path:
    """PNG of the tracked positions over a superposition of frames (like the paper's Fig. 2).

    The superposition keeps, per pixel, the sampled frame farthest from the background on the
    ball's side (frames spaced so that the copies of the ball barely overlap). Drawn on it:
    every found centre (green: centroid, orange: disk fit at the frame edge, magenta: flagged,
    left out by the kinematics), on the sampled frames a circle of the ball's radius (the edge
    model's, which sets a ``--ball-diameter`` scale; else each frame's coverage radius, which a
    blur inflates), the surface line and
    plane axes (red; ``x`` along travel, ``y`` outward), a scale bar, a legend of the marks
    drawn, and the count of frames found and flagged. Written atomically.
    """
    picks = _spaced_frames(track)
    img = _superpose(frames, track, picks)
    zoom = int(min(4, max(1, math.ceil(800 / img.shape[1]))))
    out = cv2.resize(cv2.cvtColor(img, cv2.COLOR_GRAY2BGR), None, fx=zoom, fy=zoom,
                     interpolation=cv2.INTER_CUBIC if zoom > 1 else cv2.INTER_NEAREST)
    _draw_track(out, track, picks, zoom)
    if surface is not None and track.found.any():
        _draw_axes(out, track, surface, zoom)
    if calibration is not None:
        _draw_scale_bar(out, calibration, zoom)
    _draw_legend(out, track, surface is not None and bool(track.found.any()))
    label = f"{title}  " if title else ""
    label += f"{int(track.found.sum())}/{len(track.found)} frames found"
    if track.flag.any():
        label += f", {int(track.flag.sum())} flagged"
    (tw, th), _ = cv2.getTextSize(label, cv2.FONT_HERSHEY_SIMPLEX, 0.55, 1)
    cv2.rectangle(out, (4, 4), (12 + tw, 12 + th), (0, 0, 0), -1)
    cv2.putText(out, label, (8, 8 + th), cv2.FONT_HERSHEY_SIMPLEX, 0.55, (255, 255, 255), 1,
                cv2.LINE_AA)

    def write(tmp: Path) -> None:
        ok, buf = cv2.imencode(".png", out)
        if not ok:  # pragma: no cover - PNG encoding of a uint8 BGR image does not fail
            raise OSError(f"cannot encode the overlay for {path}")
        tmp.write_bytes(buf.tobytes())

    return write_with(path, write)


def _spaced_frames(track: Track) -> np.ndarray:
    """Found frames spaced so that the ball's copies barely overlap (at most 60)."""
    found = np.flatnonzero(track.found)
    if len(found) < 2:
        return found
    step = float(np.median(np.hypot(*np.diff(track.centre[found], axis=0).T)))
    radius = track.ball_radius if math.isfinite(track.ball_radius) else \
        float(np.nanmedian(track.radius))
    every = max(1, math.ceil(len(found) / 60), int(round(2.2 * radius / max(step, 1e-3))))
    return found[::every]


def _superpose(frames: np.ndarray, track: Track, picks: np.ndarray) -> np.ndarray:
    bg = track.background
    best = np.rint(bg).astype(np.uint8)
    if len(picks):
        sign = 1 if track.polarity == "bright" else -1
        score = np.zeros(bg.shape, np.float32)
        for k in picks:
            d = sign * (frames[k].astype(np.float32) - bg)
            better = d > np.maximum(score, track.threshold)
            best[better], score[better] = frames[k][better], d[better]
    return best


def _px(p, zoom: int) -> tuple[int, int]:
    """Sub-pixel drawing coordinates (4 fractional bits) of a pixel-centre position."""
    return (int(round((p[0] + 0.5) * zoom * 16 - 8)), int(round((p[1] + 0.5) * zoom * 16 - 8)))


_COLOURS = {CENTROID: (80, 220, 80), EDGE_FIT: (0, 160, 255)}
_FLAGGED = (255, 60, 255)
_SURFACE = (60, 60, 255)
_LEGEND = (("ball centre", _COLOURS[CENTROID], "dot"),
           ("cut by the frame edge", _COLOURS[EDGE_FIT], "dot"),
           ("flagged (left out)", _FLAGGED, "dot"),
           ("ball's radius (some frames)", (220, 220, 220), "ring"),
           ("surface; plane axes x, y", _SURFACE, "line"))


def _draw_track(out, track: Track, picks: np.ndarray, zoom: int) -> None:
    for k in np.flatnonzero(track.found):
        colour = _FLAGGED if track.flag.size and track.flag[k] else \
            _COLOURS[int(track.method[k])]
        cv2.circle(out, _px(track.centre[k], zoom), 2 * 16, colour, -1, cv2.LINE_AA, 4)
        if k in picks:
            r = track.ball_radius if track.radius_fit is not None else track.radius[k]
            cv2.circle(out, _px(track.centre[k], zoom), int(r * zoom * 16), colour, 1,
                       cv2.LINE_AA, 4)


def _draw_legend(out, track: Track, surface: bool) -> None:
    """What the colours and marks mean, top right (only those drawn)."""
    present = [CENTROID in track.method, EDGE_FIT in track.method,
               bool(track.flag.size and track.flag.any()), bool(track.found.any()), surface]
    rows = [row for row, p in zip(_LEGEND, present, strict=True) if p]
    if not rows:
        return
    h, w = out.shape[:2]
    width = max(cv2.getTextSize(t, cv2.FONT_HERSHEY_SIMPLEX, 0.45, 1)[0][0] for t, _, _ in rows)
    x0 = w - width - 30
    cv2.rectangle(out, (x0 - 6, 4), (w - 4, 10 + 18 * len(rows)), (0, 0, 0), -1)
    for i, (text, colour, glyph) in enumerate(rows):
        y = 18 + 18 * i
        if glyph == "line":
            cv2.line(out, (x0, y - 4), (x0 + 11, y - 4), colour, 2, cv2.LINE_AA)
        else:
            cv2.circle(out, (x0 + 5, y - 4), 5, colour, -1 if glyph == "dot" else 1, cv2.LINE_AA)
        cv2.putText(out, text, (x0 + 16, y), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (255, 255, 255), 1,
                    cv2.LINE_AA)


def _draw_axes(out, track: Track, surface: Surface, zoom: int) -> None:
    e, n = plane_axes(track, surface)
    h, w = track.background.shape
    p = np.asarray(surface.point)
    length = float(np.hypot(w, h))
    cv2.line(out, _px(p - length * e, zoom), _px(p + length * e, zoom), _SURFACE, 1,
             cv2.LINE_AA, 4)
    first = track.centre[np.flatnonzero(track.found)[0]]
    origin = p + ((first - p) @ e) * e
    arrow = 0.12 * min(w, h)
    for axis, name in ((e, "x"), (n, "y")):
        tip = origin + arrow * axis
        cv2.arrowedLine(out, _px(origin, zoom), _px(tip, zoom), _SURFACE, 2, cv2.LINE_AA,
                        4, 0.15)
        cv2.putText(out, name, (int((tip[0] + 2) * zoom), int((tip[1] + 2) * zoom)),
                    cv2.FONT_HERSHEY_SIMPLEX, 0.7, _SURFACE, 2, cv2.LINE_AA)


def _draw_scale_bar(out, calibration: Calibration, zoom: int) -> None:
    h, w = out.shape[:2]
    target = 0.2 * w / zoom * calibration.metres_per_px  # metres of a bar 1/5 of the width
    exponent = math.floor(math.log10(target))
    nice = max(m for m in (1, 2, 5) if m * 10**exponent <= target) * 10**exponent
    length = int(round(nice / calibration.metres_per_px * zoom))
    x0, y0 = 12, h - 14
    cv2.rectangle(out, (x0 - 4, y0 - 22), (x0 + length + 4, y0 + 6), (0, 0, 0), -1)
    cv2.line(out, (x0, y0), (x0 + length, y0), (255, 255, 255), 3)
    label = f"{nice * 1e3:g} mm" if nice < 1 else f"{nice:g} m"
    cv2.putText(out, label, (x0, y0 - 8), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (255, 255, 255), 1,
                cv2.LINE_AA)


@dataclass(frozen=True)
class TrackedVideo:
    """Everything :func:`track_video` found for one input."""

    source: VideoSource
    track: Track
    calibration: Calibration
    surface: Surface
    trajectory: PlaneTrajectory
    lens: LensBend | None = None  # the surface edge's bow (:mod:`._lens`), None: not read
    # the division model's lambda the frames were undistorted by (None: taken as they are;
    # then ``source``'s frames, the track and the surface are the undistorted frames')
    undistorted: float | None = None


def track_video(path: str | os.PathLike, *, fps: float | None = None,
                config: TrackerConfig | None = None, ball_diameter: float | None = None,
                reference: tuple[Sequence[float], Sequence[float], float]
                | tuple[Sequence[float], Sequence[float], float, float | None] | None = None,
                surface: Surface | None = None,
                background: np.ndarray | str | os.PathLike | None = None,
                readout: float = 0.0, channel: str = "auto", lens: str = "auto"
                ) -> TrackedVideo:
    """Read, track, calibrate and rotate one video into the plane frame.

    Arguments:
        path: a video file or a folder of image frames, as :func:`read_frames`.
        fps: frames per second, as :func:`read_frames`.
        config: as :func:`track_ball` (default: ``TrackerConfig()``).
        background: as :func:`track_ball`, or an image file of the empty scene.
        ball_diameter: metres; the scale is this over twice ``Track.ball_radius``. Used when
            ``reference`` is not given (default then: the paper's 25.6 mm ball).
        reference: ``(p1, p2, metres)`` or ``(p1, p2, metres, sd_metres)``: two pixel points a
            known distance apart, and the distance's stated standard deviation.
        surface: the surface line; default :func:`detect_surface` on the background model.
        readout: a rolling shutter's readout time, s from the top row to the bottom (0: a
            global shutter); each centre is timed by its row (:func:`to_plane_frame`).
        channel: what of colour frames to track, as :func:`read_frames` (a background image
            file is read the same way).
        lens: ``"auto"``: where the surface edge bows clearly (a lens that bends straight
            lines, :mod:`._lens`), the frames (and the points and background given) are
            undistorted by the division model that straightens it and tracked again;
            ``"none"``: the frames as they are (the bow is said all the same).

    Raises:
        InputFileError: naming the file, for unreadable input, unknown fps, no ball found (or
            in fewer than 3 frames), no surface line detected.
    """
    source = read_frames(path, fps=fps, channel=channel)
    if not 0.0 <= readout <= 1.0 / source.fps:  # before the tracking's work
        raise InputFileError(source.path, f"a rolling shutter's readout of {readout:g} s is "
                             f"not from 0 to the frame interval, {1.0 / source.fps:g} s at "
                             f"{source.fps:g} frames/s")
    check_choice("lens", lens, LENS_MODES)
    if isinstance(background, str | os.PathLike):
        background = _background_file(background, source)
    config = config or TrackerConfig()
    video = _tracked(source, config, ball_diameter, reference, surface, background, readout)
    # the surface edge's bow, read once: on the frames as they are
    bent = bend(video.track.background, video.surface.point, video.surface.direction)
    if lens == "none" or bent is None or not bent.significant:
        return dataclasses.replace(video, lens=bent)
    # a lens that bends lines: the frames, and what was given in their pixels, undistorted
    lam, shape = bent.lam, source.frames.shape[1:]
    frames = undistort(source.frames, lam)
    frames.setflags(write=False)
    source = dataclasses.replace(source, frames=frames)
    if reference is not None:
        p1, p2 = undistort_points([reference[0], reference[1]], lam, shape)
        reference = (tuple(p1), tuple(p2), *reference[2:])
    if surface is not None:
        a, b = undistort_points([surface.point, np.add(surface.point, surface.direction)],
                                lam, shape)
        surface = Surface.from_points(a, b)
    background = None if background is None else undistort(background, lam)
    again = _tracked(source, config, ball_diameter, reference, surface, background, readout)
    return dataclasses.replace(again, lens=bent, undistorted=lam)


LENS_MODES = ("auto", "none")


def _tracked(source: VideoSource, config: TrackerConfig, ball_diameter, reference,
             surface: Surface | None, background, readout: float) -> TrackedVideo:
    """:func:`track_video` on the frames of ``source`` as they are (the lens not read)."""
    track = track_ball(source.frames, config=config, background=background)
    n_found = int(track.found.sum())
    if n_found < 3:
        raise InputFileError(source.path, _not_found_message(track, n_found))
    if not math.isfinite(track.ball_radius):
        raise InputFileError(source.path, "the ball is never wholly in view, so its radius "
                                          "(and the --ball-diameter scale) cannot be measured")
    if reference is not None:
        calibration = Calibration.from_reference(*reference)
    else:
        diameter = PAPER_BALL_DIAMETER if ball_diameter is None else ball_diameter
        calibration = Calibration.from_track(diameter, track, source.jpeg_quality,
                                             source.bits_per_pixel)
    if surface is None:
        surface = _detected_surface(track, source, background, config.background_frames)
        if surface is None:
            raise InputFileError(source.path, "no surface line detected in the background (it "
                                 "must be a straight edge that the ball does not cross, "
                                 "spanning 30% of the width): give two points on it with "
                                 "--surface X1,Y1,X2,Y2")
    track = timed_at_bounces(track, *plane_axes(track, surface))
    trajectory = to_plane_frame(track, calibration, surface, source.fps, readout)
    return TrackedVideo(source=source, track=track, calibration=calibration, surface=surface,
                        trajectory=trajectory)


def _background_file(path: str | os.PathLike, source: VideoSource) -> np.ndarray:
    image = read_image(path, source.channel)
    if image.shape != source.frames.shape[1:]:
        (h, w), (fh, fw) = image.shape, source.frames.shape[1:]
        raise InputFileError(path, f"background image is {w}x{h} but the frames of "
                                   f"{source.path} are {fw}x{fh}")
    return image


def _detected_surface(track: Track, source: VideoSource, background,
                      n_frames: int) -> Surface | None:
    """:func:`detect_surface` on the track's background; where the frames were decoded by a
    tone curve and none is found there, again on the background as stored (the given image, or
    the median of ``n_frames`` stored frames, as the track's): a curve moves no edge, but the stored levels can show the
    surface's step more plainly than light does (a rendered sRGB clip, a plane of 30 under a
    wall of 50 +- 14 in light: found as stored, 3.00 deg for the truth 3, not in light)."""
    near = {"centres": track.centre[track.trusted], "radius": track.ball_radius}
    surface = detect_surface(track.background, **near)
    if surface is None and track.tone_curve not in (None, "linear"):
        frames = source.frames
        if track.camera_shift.any() or track.camera_turn.any():  # as the track's frames were
            frames = rounded(shift_frames(frames, camera_motion(track)))
        stored = background_model(frames, n_frames) if background is None else background
        surface = detect_surface(stored, **near)
    return surface


def _not_found_message(track: Track, n_found: int) -> str:
    n = len(track.found)
    where = "in none" if n_found == 0 else f"in only {n_found}"
    return (f"ball found {where} of the {n} frames (needs 3; looked for a {track.polarity} ball "
            f"at least {track.threshold:.0f} grey levels from the background, noise "
            f"{track.noise:.1f}): check that the ball moves and is wholly in view in some "
            "frames, or set --polarity / --min-contrast / --background")


def _floats(a, digits: int = 6) -> list:
    return [None if not math.isfinite(v) else round(float(v), digits) for v in np.ravel(a)]


def _optional(v: float | None, digits: int = 6) -> float | None:
    return None if v is None or not math.isfinite(v) else round(float(v), digits)


def _ball_record(tr: Track) -> dict[str, object]:
    """The track record's ``ball`` section."""
    fit = tr.radius_fit
    light = [None, None] if fit is None else [_optional(math.degrees(a), 1) for a in fit.light]
    return {"radius_px": _optional(tr.ball_radius, 4),
            "radius_se_px": _optional(tr.ball_radius_se, 4),
            "method": fit.method if fit is not None else "coverage (median)",
            "edge_frames": list(fit.frames) if fit is not None else [],
            "blur_sigma_px": _optional(fit.sigma, 3) if fit is not None else None,
            "exposure": _optional(fit.exposure, 3) if fit is not None else None,
            # the exposure's smear over the radius (_edge.smear_radii)
            "smear_radii": round(smear_radii(fit, tr.centre), 3),
            "edge_rms_grey": _optional(fit.rms, 3) if fit is not None else None,
            # the direction of the light whose shadow the edge model (or, for a small ball,
            # the small-ball fit) holds (degrees; 90: lit from the camera, no shadow at the rim)
            "light_azimuth_deg": light[0], "light_elevation_deg": light[1],
            "centre_sd_px": _optional(fit.centre_sd, 4) if fit is not None else None,
            # the fraction of the frames fitted where the wall beside the ball is not the
            # background's on some side (those sides left out)
            "foreign_fraction": _optional(fit.foreign, 3) if fit is not None else None,
            "warning": radius_warning(tr), **_depth_record(tr), "cast_shadow": _cast_record(tr)}


def _cast_record(tr: Track) -> dict[str, object] | None:
    """The ``ball`` section's shadow of the ball on the wall that the edge model held (px; the
    offset from the ball's centre, image axes), with :func:`cast_message`; None where none."""
    cast = None if tr.radius_fit is None else tr.radius_fit.cast
    if cast is None:
        return None
    return {"offset_px": [_optional(cast.du, 3), _optional(cast.dv, 3)],
            "radius_px": _optional(cast.radius, 3), "penumbra_px": _optional(cast.penumbra, 3),
            "depth": _optional(cast.depth, 3), "note": cast_message(tr)}


def _depth_record(tr: Track) -> dict[str, object]:
    """The ``ball`` section's growth of the ball's picture over the frames fitted (a
    fraction, :func:`._edge.depth_change`) with its SE, and :func:`depth_warning`."""
    from ._edge import depth_change

    fit = tr.radius_fit
    change = None if fit is None else depth_change(fit.frames, fit.radii)
    return {"picture_growth": None if change is None else round(change[0], 5),
            "picture_growth_se": None if change is None else round(change[1], 5),
            "depth_warning": _depth_words(fit, change)}


def depth_warning(track: Track) -> str | None:
    """In words, where the ball's picture grows or shrinks over the frames (it moves along
    the camera's axis: :func:`._edge.depth_told`) and what that does; None where it does not
    clearly."""
    from ._edge import depth_change

    fit = track.radius_fit
    return _depth_words(fit, None if fit is None else depth_change(fit.frames, fit.radii))


def _depth_words(fit, change: tuple[float, float] | None) -> str | None:
    """:func:`depth_warning` from the radius fit and its picture's growth (fraction, SE)."""
    from ._edge import depth_is_told

    if fit is None or change is None or not depth_is_told(change):
        return None
    grow, se = change
    way = "grows" if grow > 0 else "shrinks"
    towards = "towards" if grow > 0 else "away from"
    return (f"the ball's picture {way} by {100 * abs(grow):.1f} +- {100 * se:.1f} % from frame "
            f"{min(fit.frames)} to frame {max(fit.frames)} (its radius fitted frame by frame): "
            f"it moves {towards} the camera, by about that fraction of its distance. The "
            "trajectory is its picture, not its path in the plane, and the speeds and angles "
            "read from it are off beyond their stated uncertainty (rendered, a picture growing "
            "2.4 %: the angles 0.3 degrees, 6 SE, off, with nothing else amiss); the scale from "
            f"its diameter holds at one distance only (+-{50 * abs(grow):.1f} % in its stated "
            "uncertainty). Film with the ball moving square to the camera's axis, its picture "
            "the same size in every frame")


# JPEG quality below which the frames are called strongly compressed: rendered (tests/
# render_pbr.py, each frame a JPEG; docs/tracking.md §3) at quality 70 every scale had |z| <=
# 1.9 over 54 scenes, at 50 a 5 px ball's up to 3.6 and at 40 a 10 px ball's 4.7 (+7.6 %)
STRONG_COMPRESSION = 60.0
# ... and, for other codecs (MPEG-4, H.264, ...), a video file of fewer bits per pixel than
# LOW_BITS: there rendered balls came out up to 0.76 px off (0.05-0.1 bits per pixel) and more
# below (._edge.CODEC_PX; docs/tracking.md §3)
LOW_BITS = 0.1


def compression_warning(source: VideoSource) -> str | None:
    """A sentence where the frames are JPEG-coded (MJPEG, JPEG files) at a quality below
    ``STRONG_COMPRESSION`` (:func:`._video.jpeg_quality`), or, coded otherwise (MPEG-4, H.264,
    ...), the video file holds fewer than ``LOW_BITS`` bits per pixel; None otherwise."""
    from ._edge import compression_px

    q, bits = source.jpeg_quality, source.bits_per_pixel
    if q is None and bits is not None and bits < LOW_BITS:
        return (f"the video is compressed to {bits:.2g} bits per pixel (an MPEG-4 or H.264 "
                f"codec's quantiser is not read; below {LOW_BITS:g} it smears and rings at the "
                "ball's edge): the stated uncertainty of the --ball-diameter scale allows "
                f"{compression_px(None, bits):.2g} px of the ball's radius for it (rendered balls "
                "came out up to 0.6-2.0 px off below 0.1 bits per pixel), and the centres may be "
                "off by more than stated; give --reference, and record with less compression "
                "(a higher bit rate, or MJPEG or lossless frames) if you can")
    if q is None or q >= STRONG_COMPRESSION:
        return None

    return (f"the frames are JPEG-compressed at quality ~{q:.0f} (below "
            f"{STRONG_COMPRESSION:.0f}): the codec rings at the ball's edge; the stated "
            f"uncertainty of the --ball-diameter scale allows {compression_px(q):.2g} px of the "
            "ball's radius for it (rendered balls of 5-10 px came out up to 8-14 % off at "
            "quality 30-60), and the centres may be off by more than stated; give --reference, "
            "and film with less compression if you can")


def tone_curve_warning(video: TrackedVideo) -> str | None:
    """A sentence where the frames were taken as linear in light without being told
    (``TrackerConfig.tone_curve`` None), the scale comes from the ball's diameter and the file
    is lossy-coded (MJPEG, MPEG-4, H.264, JPEG frames: what consumer cameras write, most of
    them through a tone curve, which the file does not say); None otherwise."""
    src = video.source
    if video.track.tone_curve is not None or video.calibration.source == "reference" \
            or (src.jpeg_quality is None and src.bits_per_pixel is None):
        return None
    return ("the frames were taken as linear in light (no --tone-curve given); a camera that "
            "stores them through a tone curve (most consumer cameras: sRGB or BT.709) makes a "
            "bright ball look "
            "1-5 % larger and a dark one 2-8 % smaller under lens blur (rendered balls of "
            "10-15 px, more than the --ball-diameter scale's stated uncertainty there; up to "
            "15 % at 5 px): give the camera's curve with --tone-curve (linear, srgb, rec709 or "
            "a gamma; a codec's errors after the curve stay, up to ~6 % for a ball of ~5 px), "
            "or --reference")


def _smear_words(smear: float) -> str:
    """:func:`radius_warning`'s sentence for a ball smeared by ``smear`` radii."""
    from ._edge import SMEAR_RADII, smear_share

    return (f"the ball moves {smear:.2g} of its radius during an exposure: the edge model "
            "holds the smear as a blur, which holds less well as the smear grows (rendered: "
            "the radius 5 % too large at 0.9 radii, 11-12 % at 1.3), so the --ball-diameter "
            f"scale is uncertain by +-{100 * smear_share(smear):.2g} % on that account (in its "
            "stated uncertainty)" + (" and the centres by a pixel or more"
                                     if smear >= SMEAR_RADII else "")
            + "; give --reference, or film with a shorter exposure (a faster shutter) or a "
            "higher frame rate")


def radius_warning(track: Track) -> str | None:
    """A sentence where the ball's radius from its edge, and so the scale from its diameter, is
    unreliable (blurred for its size) or uncertain by more than ``UNCERTAIN_RADIUS`` (smeared
    by its motion over much of its radius, blurred enough that the blur's shape matters, or a
    small ball); None where neither."""
    from ._edge import (
        EDGE_MODEL,
        FOREIGN_REL_SD,
        FOREIGN_WARNING,
        JOINT_FIT,
        PSF_SHAPE_FROM,
        UNCERTAIN_RADIUS,
        UNRELIABLE_BLUR,
        radius_relative_sd,
        smear_share,
    )

    fit = track.radius_fit
    if fit is None:
        return ("the ball's radius is the median coverage radius (the edge model could not be "
                "fitted): biased by blur and uneven light; give --reference")
    if smear_share(smear := smear_radii(fit, track.centre)) > UNCERTAIN_RADIUS:
        return _smear_words(smear)
    if fit.sigma > UNRELIABLE_BLUR * fit.radius and fit.method != JOINT_FIT:
        return (f"the ball is blurred by {fit.sigma:.2g} px for a radius of {fit.radius:.3g} "
                "px: its radius, and the --ball-diameter scale, may be off by several percent "
                "(the stated uncertainty allows for it); give --reference for a better scale")
    if fit.foreign >= FOREIGN_WARNING:
        return (f"in {100 * fit.foreign:.0f} % of the frames fitted the wall beside the ball "
                "is not the background model's on some side (a shadow of the ball cast on the "
                "wall by a lamp, a reflection, a lit patch that moves with it): that side of its "
                "edge was left out, but its radius and centres can still be off by a few per "
                f"cent and a few tenths of a pixel (+-{100 * FOREIGN_REL_SD:.1f} % in the "
                "stated uncertainty of the --ball-diameter scale); light the scene so that the "
                "ball casts no shadow beside it, or give --reference")
    rel = radius_relative_sd(fit.radius, fit.radius_se, fit.sigma, fit.method,
                             foreign=fit.foreign)
    if rel > UNCERTAIN_RADIUS and fit.method == EDGE_MODEL \
            and fit.sigma > PSF_SHAPE_FROM * fit.radius:
        return (f"the ball's edge is blurred by {fit.sigma:.2g} px for a radius of "
                f"{fit.radius:.3g} px: its radius depends on the blur's shape (a lens out of "
                "focus blurs into a disk, not a Gaussian), so the --ball-diameter scale is "
                f"uncertain by +-{100 * rel:.2g} % on that account (in its stated uncertainty); "
                "give --reference for a better scale")
    if rel > UNCERTAIN_RADIUS:
        return (f"the ball is {fit.radius:.3g} px in radius: too few pixels at its edge to "
                f"tell its radius from the blur and shading better than +-{100 * rel:.2g} % "
                "(in the stated uncertainty of the --ball-diameter scale); give --reference for a "
                "better scale")
    return _misfit_words(track)


# a fifth or more of the frames found flagged (the ball model fits them badly) is said with the
# radius: over the 88 clear scenes of benchmarks/tracking_accuracy.py 0-1 of 90 frames were
# flagged; a side-lit 10-15 px ball with a dark logo turning near its rim (tests/render_pbr.py's
# spot) 8, 20 and 35 of 90 on the three clips counted, its radius from the edge off by up to
# 2.8 % over the 8 of benchmarks/tracking_centres.py (an MJPEG clip: -3.3 % at a stated 1.1 %),
# and the --ball-diameter scale with it, which the stated SD did not cover. Since the edge
# model leaves out the sides of the rim that misfit (_edge.EDGE_MISFIT) those came out within
# 1.2 % (|z| <= 1.35; the MJPEG clip +0.45 % at 0.72 %), but a mark unlike those rendered may
# still move it: the warning stays (docs/tracking.md §1)
MISFIT_WARNING = 0.2


def _misfit_words(track: Track) -> str | None:
    """A sentence where ``MISFIT_WARNING`` or more of the frames the ball was found in are
    flagged; None where fewer."""
    n_found = int(track.found.sum())
    n_flag = n_found - int(track.trusted.sum())
    if n_found == 0 or n_flag < MISFIT_WARNING * n_found:
        return None
    return (f"{n_flag} of the {n_found} frames the ball was found in do not fit the ball model "
            "(part of it hidden, a mark or logo on it, a shadow or a lit band beside it) and "
            "are left out of the kinematics; its radius from the edge, and so the "
            "--ball-diameter scale, rests on the sides of its rim that fit and may be off by "
            "more than stated (rendered 10-15 px balls with a logo or stripe near the rim: "
            "within 1.2 %, 2.8 % before those sides were left out); give --reference for the "
            "scale")


def _coding_record(video: TrackedVideo) -> dict[str, object]:
    """The track record's entries on how the frames were stored: the JPEG quality of MJPEG or
    JPEG frames (None: not JPEG-coded, or not read), the video file's bits per pixel (None: a
    folder of images) and a warning where low; the tone curve the frames were decoded by, and a
    warning where it was taken as linear for a lossy-coded file scaled from the ball."""
    src = video.source
    return {"jpeg_quality": src.jpeg_quality, "bits_per_pixel": _optional(src.bits_per_pixel, 4),
            "compression_warning": compression_warning(src),
            "tone_curve": tone_curve_label(video.track.tone_curve),
            "tone_curve_warning": tone_curve_warning(video)}


def camera_shift_max(track: Track) -> float:
    """How far (px) the camera had moved the picture in any frame, at most: its shift plus
    what its turn and zoom moved the frame's corners by (0: it did not move)."""
    if not track.camera_shift.size:
        return 0.0
    m = camera_motion(track)
    return float((np.hypot(m[:, 0], m[:, 1]) + np.hypot(m[:, 2], m[:, 3])).max())


def camera_motion(track: Track) -> np.ndarray:
    """Each frame's shift, turn and zoom as :func:`._camera.shift_frames` takes them."""
    n = len(track.centre)
    shift = track.camera_shift if track.camera_shift.size else np.zeros((n, 2))
    turn = track.camera_turn if track.camera_turn.size else np.zeros((n, 2))
    return motion_px(shift, turn, track.background.shape)


def cast_message(track: Track) -> str | None:
    """In words, where the ball's own shadow on the wall hugs its edge and the edge model held
    it (:mod:`._cast`); None where it found none."""
    fit = track.radius_fit
    cast = None if fit is None else fit.cast
    if cast is None:
        return None
    return (f"shadow: the ball casts a shadow on the wall behind it that hugs its edge (its "
            f"centre {cast.offset:.1f} px from the ball's, {_towards(cast)}, "
            f"{100 * cast.depth:.0f} % dark, {cast.radius:.1f} px in radius); the edge model "
            "held it (left alone it takes the shadow for part of the ball: rendered, the radius "
            "5-10 % large and the centres up to 1.7 px towards it). A wall further behind "
            "the ball, or a lamp further from the camera's axis, moves the shadow clear of it")


def _towards(cast) -> str:
    """The image direction of the shadow's offset in words (v runs down)."""
    if cast.offset < 0.5:
        return "a halo all round it"
    names = ("the right", "the lower right", "the bottom", "the lower left", "the left",
             "the upper left", "the top", "the upper right")
    return "towards " + names[round(math.degrees(math.atan2(cast.dv, cast.du)) / 45.0) % 8]


def camera_message(track: Track) -> str | None:
    """In words, where the camera moved: how far, in which frames, and what was done."""
    shift, turn = track.camera_shift, track.camera_turn
    shifted, turned = shift.size and shift.any(), turn.size and turn.any()
    if not shifted and not turned:
        return None
    size = np.hypot(*shift.T) if shift.size else np.zeros(len(turn))
    moved = np.flatnonzero((size > 0) | (turn.any(axis=1) if turn.size else False))
    what = [f"by up to {size.max():.2f} px"] if shifted else []
    if turned:
        what.append(f"turned by up to {np.abs(turn[:, 0]).max():.3f} deg and zoomed by up "
                    f"to {100 * np.abs(turn[:, 1]).max():.2f} % (about the frame's centre)")
    return (f"camera: moved {' and '.join(what)} (in {len(moved)} frames, "
            f"{moved[0]}-{moved[-1]}); those frames were moved back onto the background "
            "before tracking (per-frame camera_du_px / camera_dv_px / camera_turn_deg / "
            "camera_zoom in the record)")


def surface_warning(video: TrackedVideo) -> str | None:
    """In words, where the surface line was detected and the edge lies on it along under
    ``EDGE_SHARE`` of the frame (:func:`._geometry.edge_share`): a faint edge, whose line may
    be a texture's some degrees off; None otherwise, and for a line given by points."""
    return _surface_words(video.surface.source,
                          edge_share(video.track.background, video.surface))


def _surface_words(source: str, share: float) -> str | None:
    """:func:`surface_warning` for a line from ``source`` whose edge share is ``share``."""
    if source != "detected" or share >= EDGE_SHARE:
        return None
    return (f"surface: the edge lies on the line found along only {100 * share:.0f} % of the "
            "frame: where the surface spans the frame, a faint edge, or a wall's texture taken "
            "for it, can put the line some degrees off, beyond its stated SD. Check the red "
            "line on the overlay against the surface, and give --surface X1,Y1,X2,Y2 (two "
            "points on it, px) where it is off")


def lens_warning(video: TrackedVideo) -> str | None:
    """In words, where the surface edge bows: a lens that bends straight lines
    (:func:`._lens.bend_message`); None where it does not clearly, or was not read."""
    return bend_message(video.lens, corrected=video.undistorted is not None)


def _lens_record(video: TrackedVideo) -> dict[str, object] | None:
    """The record's surface edge bow (px) with its SE, the least fraction of its positions in a
    third of its length, its vertex from the foot of the frame's centre (half-lengths), the
    share of the edge that follows it, the division model's lambda with its SE, and the
    warning; None where the edge was not read."""
    lens = video.lens
    if lens is None:
        return None
    return {"edge_sagitta_px": round(lens.sagitta_px, 3),
            "edge_sagitta_se_px": round(lens.sagitta_se_px, 3),
            "edge_length_px": round(lens.length_px, 1), "edge_spread": round(lens.spread, 3),
            "edge_vertex": round(lens.vertex, 3) if math.isfinite(lens.vertex) else None,
            "edge_coverage": round(lens.coverage, 3),
            "division_lambda": round(lens.lam, 5), "division_lambda_se": round(lens.lam_se, 5),
            "undistorted": video.undistorted is not None, "warning": lens_warning(video)}


def timing_warning(track: Track) -> str | None:
    """In words, where frames were lost or repeated and what was done (:mod:`._timing`);
    None where none were (or the track has no timing)."""
    from ._timing import timing_message

    return timing_message(track.timing) if track.timing is not None else None


def _timing_record(track: Track) -> dict[str, object]:
    """The record's frames lost and repeated (frame numbers; how many lost before each) and
    its warning (:func:`timing_warning`)."""
    timing = track.timing
    lost = np.flatnonzero(timing.lost) if timing is not None else np.zeros(0, int)
    return {"lost_before_frames": lost.tolist(),
            "lost_counts": timing.lost[lost].tolist() if timing is not None else [],
            "lost_at_bounce_before_frames": np.flatnonzero(timing.at_bounce).tolist()
            if timing is not None else [],
            "repeated_frames": np.flatnonzero(timing.repeated).tolist()
            if timing is not None else [],
            "warning": timing_warning(track)}


def _camera_columns(track: Track, n: int) -> dict[str, list]:
    """The record's per-frame camera shift (px), zeros where it did not move."""
    shift = track.camera_shift if track.camera_shift.size else np.zeros((n, 2))
    turn = track.camera_turn if track.camera_turn.size else np.zeros((n, 2))
    return {"camera_du_px": _floats(shift[:, 0], 4), "camera_dv_px": _floats(shift[:, 1], 4),
            "camera_turn_deg": _floats(turn[:, 0], 5), "camera_zoom": _floats(turn[:, 1], 6)}


def _per_frame(tr: Track, n: int) -> dict[str, object]:
    """The record's per-frame columns of the ``n`` frames: centre, radius, method, quality,
    whether refined, the frame's place in the camera's sequence, the camera's shift."""
    from ._measure import METHOD_NAMES

    return {"u_px": _floats(tr.centre[:, 0]), "v_px": _floats(tr.centre[:, 1]),
            "radius_px": _floats(tr.radius), "method": tr.method.tolist(),
            "methods": {str(k): v for k, v in METHOD_NAMES.items()},
            "residual_grey": _floats(tr.residual, 3),
            "visible": _floats(tr.visible, 4), "flag": tr.flag.astype(int).tolist(),
            "refined": tr.refined.astype(int).tolist() if tr.refined.size else [0] * n,
            "place": (_floats(tr.timing.place, 1) if tr.timing is not None
                      else [float(k) for k in range(n)]),
            **_camera_columns(tr, n)}


def track_record(video: TrackedVideo, settings: dict, outputs: dict[str, Path]) -> dict:
    """The tracking record of one video (``<name>.track.json``): input, calibration with its
    uncertainty, surface with its angle's uncertainty, per-frame pixels and quality, a quality
    summary, the settings and the version. ``calibration.relative_sd`` and
    ``surface.angle_sd_deg`` are read by :func:`bouncebayes.data.read_track_sidecar`."""
    src, tr, cal, srf = video.source, video.track, video.calibration, video.surface
    n, h, w = src.frames.shape
    found = tr.found
    res = tr.residual[found] if tr.residual.size else np.zeros(0)
    share = edge_share(tr.background, srf)
    return {
        "input": str(src.path),
        "bouncebayes_version": __version__,
        "frames": n, "width": w, "height": h,
        "fps": src.fps, "fps_source": src.fps_source,
        "channel": src.channel, "channel_note": src.channel_note,
        **_coding_record(video),
        "tracker": {"polarity": tr.polarity, "noise_grey": round(tr.noise, 3),
                    "threshold_grey": round(tr.threshold, 3),
                    "centre_offset_px": [round(v, 4) for v in tr.centre_offset],
                    "refined_offset_px": [round(v, 4) for v in tr.refined_offset],
                    "camera_shift_max_px": round(camera_shift_max(tr), 4)},
        "settings": settings,
        "timing": _timing_record(tr),
        "lens": _lens_record(video),
        "ball": _ball_record(tr),
        "ball_radius_px": _optional(tr.ball_radius, 4),
        "calibration": {"metres_per_pixel": cal.metres_per_px,
                        "metres_per_px": cal.metres_per_px,
                        "relative_sd": _optional(cal.relative_sd, 6), "source": cal.source},
        "surface": {"point_px": list(srf.point), "direction": list(srf.direction),
                    "angle_deg": srf.angle, "angle_sd_deg": _optional(srf.angle_sd_deg, 6),
                    "source": srf.source,
                    "edge_share": round(share, 3), "warning": _surface_words(srf.source, share)},
        "quality": {"found": int(found.sum()), "flagged": int(tr.flag.sum()),
                    "flagged_frames": np.flatnonzero(tr.flag).tolist(),
                    "not_found_frames": np.flatnonzero(~found).tolist(),
                    "edge_fit_frames": np.flatnonzero(tr.method == EDGE_FIT).tolist(),
                    "refined_frames": int(tr.refined.sum()),
                    "residual_median_grey": _optional(float(np.nanmedian(res)), 3)
                    if res.size and np.isfinite(res).any() else None,
                    "residual_max_grey": _optional(float(np.nanmax(res)), 3)
                    if res.size and np.isfinite(res).any() else None},
        "found": int(found.sum()),
        "not_found_frames": np.flatnonzero(~found).tolist(),
        "edge_fit_frames": np.flatnonzero(tr.method == EDGE_FIT).tolist(),
        "per_frame": _per_frame(tr, n),
        "outputs": {k: str(v) for k, v in outputs.items()},
    }


def write_track_files(video: TrackedVideo, folder: str | os.PathLike, *,
                      overlay_folder: str | os.PathLike | None = None,
                      settings: dict | None = None) -> dict[str, Path]:
    """Write ``<name>.csv`` (the trajectory with its per-frame quality: ``residual``,
    ``visible``, ``flag``; :func:`bouncebayes.data.write_trajectory`), ``<name>.track.json``
    beside it (:func:`track_record`: the kinematics read its calibration uncertainty) and
    ``<name>.overlay.png`` (in ``overlay_folder``, default ``folder``). Returns the paths."""
    from ..data import write_trajectory

    folder = Path(folder)
    name = video.source.name
    files = {"trajectory": folder / f"{name}.csv",
             "overlay": Path(overlay_folder or folder) / f"{name}.overlay.png",
             "record": folder / f"{name}.track.json"}
    tr, traj = video.track, video.trajectory
    k = np.flatnonzero(tr.found)
    quality = {"residual": tr.residual[k], "visible": np.clip(tr.visible[k], 0.0, 1.0),
               "flag": tr.flag[k].astype(float)}
    write_trajectory(files["trajectory"], traj.t, traj.x, traj.y, quality=quality)
    overlay_image(video.source.frames, tr, files["overlay"], calibration=video.calibration,
                  surface=video.surface,
                  title=name + (", frames undistorted for the lens" if video.undistorted
                                is not None else ""))
    record = track_record(video, settings or {}, files)
    write_json(files["record"], record)
    # the flights' fall, read as the kinematics read the files just written (the record's
    # centre SD included), then kept in the record
    check = gravity_check(files["trajectory"], video.calibration.relative_sd)
    write_json(files["record"], record | {"gravity": None if check is None else check.record()})
    return files


def gravity_check(trajectory: str | os.PathLike, stated: float | None):
    """The video's scale against the fall of its free flights (standard gravity, no air drag:
    :func:`bouncebayes.kinematics.gravity_scale`), or None where no bounce of the trajectory
    gives two fitted flights. ``stated``: the calibration's relative SD."""
    from ..kinematics import fit_bounces, gravity_scale, read_trajectory
    from ..model import STANDARD_GRAVITY

    try:
        fits = fit_bounces(read_trajectory(trajectory))
    except ValueError:  # no bounce, too few samples: nothing falls freely enough to say
        return None
    falls = [k.fall for k in fits if not isinstance(k, Exception) and k.fall is not None]
    return gravity_scale(falls, STANDARD_GRAVITY, [stated]) if falls else None
