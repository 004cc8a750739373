"""Outputs of one tracked video: the trajectory CSV, the overlay image, and :func:`track_video`
(stages 1-4 for one input)."""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from .._errors import InputFileError
from .._io import write_text, write_with
from ._geometry import (
    Calibration,
    PlaneTrajectory,
    Surface,
    detect_surface,
    plane_axes,
    to_plane_frame,
)
from ._measure import CENTROID, EDGE_FIT
from ._track import Track, TrackerConfig, track_ball
from ._video import VideoSource, read_frames, read_image

PAPER_BALL_DIAMETER = 0.0256  # m, paper §3 (= bouncebayes.PAPER_BALL.diameter)


def write_trajectory_csv(path: str | os.PathLike, t, x, y) -> Path:
    """``t,x,y`` (s, m, m), one row per found frame, written atomically."""
    cols = [np.asarray(v, dtype=float) for v in (t, x, y)]
    if len({c.shape for c in cols}) != 1 or cols[0].ndim != 1:
        raise ValueError(f"`t`, `x`, `y` must be 1-D and of one length; got shapes "
                         f"{[c.shape for c in cols]}")
    if not all(np.isfinite(c).all() for c in cols):
        raise ValueError("`t`, `x`, `y` must be finite (write found frames only)")
    rows = "".join(f"{a:.10g},{b:.10g},{c:.10g}\n" for a, b, c in zip(*cols, strict=True))
    return write_text(path, "t,x,y\n" + rows)


def overlay_image(frames: np.ndarray, track: Track, path: str | os.PathLike, *,
                  calibration: Calibration | None = None, surface: Surface | None = None,
                  title: str = "") -> Path:
    """PNG of the tracked positions over a superposition of frames (like the paper's Fig. 2).

    The superposition keeps, per pixel, the sampled frame farthest from the background on the
    ball's side (frames spaced so that the copies of the ball barely overlap). Drawn on it:
    every found centre (green: centroid, orange: edge fit), the fitted circle of the sampled
    frames, the surface line and plane axes (red; ``x`` along travel, ``y`` outward), a scale bar,
    and the count of frames found. Written atomically.
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
    label = f"{title}  " if title else ""
    label += f"{int(track.found.sum())}/{len(track.found)} frames found"
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


def _draw_track(out, track: Track, picks: np.ndarray, zoom: int) -> None:
    colours = {CENTROID: (80, 220, 80), EDGE_FIT: (0, 160, 255)}
    for k in np.flatnonzero(track.found):
        colour = colours[int(track.method[k])]
        cv2.circle(out, _px(track.centre[k], zoom), 2 * 16, colour, -1, cv2.LINE_AA, 4)
        if k in picks:
            cv2.circle(out, _px(track.centre[k], zoom), int(track.radius[k] * zoom * 16),
                       colour, 1, cv2.LINE_AA, 4)


def _draw_axes(out, track: Track, surface: Surface, zoom: int) -> None:
    e, n = plane_axes(track, surface)
    h, w = track.background.shape
    p = np.asarray(surface.point)
    length = float(np.hypot(w, h))
    cv2.line(out, _px(p - length * e, zoom), _px(p + length * e, zoom), (60, 60, 255), 1,
             cv2.LINE_AA, 4)
    first = track.centre[np.flatnonzero(track.found)[0]]
    origin = p + ((first - p) @ e) * e
    arrow = 0.12 * min(w, h)
    for axis, name in ((e, "x"), (n, "y")):
        tip = origin + arrow * axis
        cv2.arrowedLine(out, _px(origin, zoom), _px(tip, zoom), (60, 60, 255), 2, cv2.LINE_AA,
                        4, 0.15)
        cv2.putText(out, name, (int((tip[0] + 2) * zoom), int((tip[1] + 2) * zoom)),
                    cv2.FONT_HERSHEY_SIMPLEX, 0.7, (60, 60, 255), 2, cv2.LINE_AA)


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


def track_video(path: str | os.PathLike, *, fps: float | None = None,
                config: TrackerConfig | None = None, ball_diameter: float | None = None,
                reference: tuple[Sequence[float], Sequence[float], float] | None = None,
                surface: Surface | None = None,
                background: np.ndarray | str | os.PathLike | None = None) -> TrackedVideo:
    """Read, track, calibrate and rotate one video into the plane frame.

    Arguments:
        path: a video file or a folder of image frames, as :func:`read_frames`.
        fps: frames per second, as :func:`read_frames`.
        config: as :func:`track_ball` (default: ``TrackerConfig()``).
        background: as :func:`track_ball`, or an image file of the empty scene.
        ball_diameter: metres; the scale is this over twice ``Track.ball_radius``. Used when
            ``reference`` is not given (default then: the paper's 25.6 mm ball).
        reference: ``(p1, p2, metres)``, two pixel points a known distance apart.
        surface: the surface line; default :func:`detect_surface` on the background model.

    Raises:
        InputFileError: naming the file, for unreadable input, unknown fps, no ball found (or
            in fewer than 3 frames), no surface line detected.
    """
    source = read_frames(path, fps=fps)
    if isinstance(background, str | os.PathLike):
        background = _background_file(background, source)
    track = track_ball(source.frames, config=config or TrackerConfig(), background=background)
    n_found = int(track.found.sum())
    if n_found < 3:
        raise InputFileError(source.path, _not_found_message(track, n_found))
    if reference is not None:
        calibration = Calibration.from_reference(*reference)
    else:
        diameter = PAPER_BALL_DIAMETER if ball_diameter is None else ball_diameter
        calibration = Calibration.from_ball_diameter(diameter, track.ball_radius)
    if surface is None:
        surface = detect_surface(track.background)
        if surface is None:
            raise InputFileError(source.path, "no surface line detected in the background (it "
                                 "must be the longest straight edge, spanning 30% of the "
                                 "width): give two points on it with --surface X1,Y1,X2,Y2")
    trajectory = to_plane_frame(track, calibration, surface, source.fps)
    return TrackedVideo(source=source, track=track, calibration=calibration, surface=surface,
                        trajectory=trajectory)


def _background_file(path: str | os.PathLike, source: VideoSource) -> np.ndarray:
    image = read_image(path)
    if image.shape != source.frames.shape[1:]:
        (h, w), (fh, fw) = image.shape, source.frames.shape[1:]
        raise InputFileError(path, f"background image is {w}x{h} but the frames of "
                                   f"{source.path} are {fw}x{fh}")
    return image


def _not_found_message(track: Track, n_found: int) -> str:
    n = len(track.found)
    where = "in none" if n_found == 0 else f"in only {n_found}"
    return (f"ball found {where} of the {n} frames (needs 3; looked for a {track.polarity} ball "
            f"at least {track.threshold:.0f} grey levels from the background, noise "
            f"{track.noise:.1f}): check that the ball moves and is wholly in view in some "
            "frames, or set --polarity / --min-contrast / --background")
