"""From pixels to the plane frame: image scale, the surface line, the rotation."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import NamedTuple

import cv2
import numpy as np

from .._validate import check_choice, check_scalar
from ._edge import (
    EDGE_MODEL,
    JOINT_FIT,
    SMALL_BALL_FIT,
    depth_told,
    radius_relative_sd,
    smear_radii,
)
from ._track import Track


@dataclass(frozen=True, kw_only=True)
class Calibration:
    """Image scale, metres per pixel; ``source`` says where it came from; ``relative_sd`` its
    relative standard deviation (None: not known), shared by every length of the video."""

    metres_per_px: float
    source: str
    relative_sd: float | None = None

    def __post_init__(self):
        check_scalar("metres_per_px", self.metres_per_px, unit="m/px", low=0.0, low_open=True)
        if self.relative_sd is not None:
            check_scalar("relative_sd", self.relative_sd, low=0.0)

    @classmethod
    def from_reference(cls, p1: Sequence[float], p2: Sequence[float], length: float,
                       length_sd: float | None = None) -> Calibration:
        """Two pixel points ``length`` metres apart (Tracker's calibration stick), with the
        length's stated standard deviation ``length_sd`` (m) if known."""
        length = check_scalar("reference length", length, unit="m", low=0.0, low_open=True)
        if length_sd is not None:
            length_sd = check_scalar("reference length SD", length_sd, unit="m", low=0.0)
        pixels = math.dist(_point("reference point 1", p1), _point("reference point 2", p2))
        if pixels == 0.0:
            raise ValueError(f"the two reference points must differ; got {tuple(p1)} twice")
        return cls(metres_per_px=length / pixels, source="reference",
                   relative_sd=None if length_sd is None else length_sd / length)

    @classmethod
    def from_ball_diameter(cls, diameter: float, radius_px: float,
                           radius_se_px: float | None = None,
                           blur_px: float | None = None,
                           method: str = EDGE_MODEL,
                           jpeg_quality: float | None = None,
                           bits_per_pixel: float | None = None,
                           foreign: float = 0.0, depth: float = 0.0,
                           smear: float = 0.0) -> Calibration:
        """The ball's known diameter (m) against its measured radius (px), e.g.
        ``Track.ball_radius``; ``radius_se_px`` its standard error (``Track.ball_radius_se``),
        to which the systematic error of what measured it is added in quadrature
        (:func:`radius_relative_sd`: ``method`` ``"edge model"``, with the fitted blur
        ``blur_px``, ``"small-ball fit"`` or ``"frames' joint fit"``;
        ``Track.radius_fit.method``; and the frames' JPEG quality,
        ``VideoSource.jpeg_quality``, or the video's bits per pixel,
        ``VideoSource.bits_per_pixel``, where known; ``foreign``, the fraction of the
        frames fitted with sides of the rim left out, ``RadiusFit.foreign``; ``depth``,
        how much the ball's picture grew over the frames, :func:`._edge.depth_told`; and
        ``smear``, the exposure's smear over the radius, :func:`._edge.smear_radii`)."""
        diameter = check_scalar("ball diameter", diameter, unit="m", low=0.0, low_open=True)
        radius_px = check_scalar("ball radius", radius_px, unit="px", low=0.0, low_open=True)
        method = check_choice("method", method, (EDGE_MODEL, SMALL_BALL_FIT, JOINT_FIT))
        rel = None
        if radius_se_px is not None and math.isfinite(radius_se_px):
            rel = radius_relative_sd(radius_px, radius_se_px, blur_px, method, jpeg_quality,
                                     bits_per_pixel, foreign, depth, smear)
        return cls(metres_per_px=diameter / (2.0 * radius_px), source="ball diameter",
                   relative_sd=rel)

    @classmethod
    def from_track(cls, diameter: float, track: Track, jpeg_quality: float | None = None,
                   bits_per_pixel: float | None = None) -> Calibration:
        """:meth:`from_ball_diameter` with the radius, its standard error, the fitted blur and
        the method of ``track`` (``Track.radius_fit``; without one, the edge model's terms and
        no blur), and the frames' coding (``VideoSource.jpeg_quality``, ``bits_per_pixel``)."""
        fit = track.radius_fit
        return cls.from_ball_diameter(diameter, track.ball_radius, track.ball_radius_se,
                                      fit.sigma if fit is not None else None,
                                      fit.method if fit is not None else EDGE_MODEL,
                                      jpeg_quality, bits_per_pixel,
                                      fit.foreign if fit is not None else 0.0,
                                      depth_told(fit), smear_radii(fit, track.centre))


def _point(name: str, p) -> tuple[float, float]:
    arr = np.asarray(p, dtype=float)
    if arr.shape != (2,) or not np.isfinite(arr).all():
        raise ValueError(f"`{name}` must be two finite pixel coordinates (x, y); got {p!r}")
    return float(arr[0]), float(arr[1])


@dataclass(frozen=True, kw_only=True)
class Surface:
    """The surface line in the image: a point and a unit direction (pixels, ``v`` down)."""

    point: tuple[float, float]
    direction: tuple[float, float]
    source: str
    angle_sd_deg: float | None = None  #: standard error of the detected line's angle

    @classmethod
    def from_points(cls, p1: Sequence[float], p2: Sequence[float]) -> Surface:
        """Two points on the surface line, pixel coordinates with the origin top-left."""
        a, b = _point("surface point 1", p1), _point("surface point 2", p2)
        length = math.dist(a, b)
        if length == 0.0:
            raise ValueError(f"the two surface points must differ; got {a} twice")
        return cls(point=a, direction=((b[0] - a[0]) / length, (b[1] - a[1]) / length),
                   source="points")

    @classmethod
    def from_text(cls, text: str, option: str = "--surface") -> Surface:
        """``"X1,Y1,X2,Y2"`` (as the command line's ``option`` gives it): two points on the
        surface line. ``ValueError`` naming the option and what was received otherwise."""
        try:
            values = [float(v) for v in str(text).split(",")]
        except ValueError:
            values = []
        if len(values) != 4 or not all(math.isfinite(v) for v in values):
            raise ValueError(f"`{option}` must be X1,Y1,X2,Y2 (4 numbers separated by commas); "
                             f"got {text!r}")
        try:
            return cls.from_points(values[:2], values[2:])
        except ValueError as exc:
            raise ValueError(f"`{option}` {text}: {exc}") from None

    @property
    def angle(self) -> float:
        """Inclination in the image, degrees in (-90, 90], counter-clockwise from the +x axis
        as seen on the screen (``v`` up)."""
        deg = math.degrees(math.atan2(-self.direction[1], self.direction[0]))
        return deg - 180.0 if deg > 90.0 else deg + 180.0 if deg <= -90.0 else deg


def detect_surface(background: np.ndarray, *, min_length: float = 0.3,
                   centres: np.ndarray | None = None, radius: float = math.nan
                   ) -> Surface | None:
    """The surface line: a straight edge of the background image (the longest, or the one the
    ball touches, below), refined by a line fit to its edge pixels; ``None`` if no straight
    edge spans ``min_length`` of the frame's width.

    With the ball's ``centres`` (px, ``(n, 2)``; NaN rows skipped) and ``radius`` (px), only
    an edge the ball bounces off can be the surface: one with every centre on the same side of
    it, at least half a radius away (the ball does not pass through the surface), and of
    those the one the ball comes nearest to touching (:func:`_pick`). The strongest edges
    first (Canny's thresholds at the 98th percentile of the gradient, the image smoothed by
    1.5 px); where none of them is one the ball comes within ``CONTACT`` of its radius of
    touching, fainter ones too (the 90th), then both on the image smoothed by 3 px: a soft
    surface edge under a textured wall, smeared by a codec (a rendered H.264 clip: the wall's
    texture made a 45-degree "edge" through the ball's path; the surface, a ramp of 22 grey
    levels over ~6 px, was found smoothed by 3 px); then the same with gaps of
    ``BROKEN_GAPS`` px bridged, steps only (:func:`_step_sides`); where only those or none
    give one, the lines across the whole frame read for a step as well (:func:`_step_line`),
    the more consistent step kept.

    Limits: the surface must be a straight edge in view that the ball does not cross (without
    the ball: the longest; ruler edges, table edges or the plane's far border can be picked
    instead: check the overlay, or give the points).
    """
    img = np.clip(np.asarray(background, dtype=np.float32), 0, 255).astype(np.uint8)
    ball = None if centres is None else np.asarray(centres, dtype=float).reshape(-1, 2)
    if ball is not None:
        ball = ball[np.isfinite(ball).all(axis=1)]
    tries = ((1.5, 98.0),) if ball is None else ((1.5, 98.0), (1.5, 90.0), (3.0, 98.0),
                                                 (3.0, 90.0))
    # the longer gaps only where the first finds no edge the ball touches: an edge broken
    # into pieces by a textured wall's light and dark patches (tests/render_pbr.py's default
    # wall, 50 +- 10 grey levels, over a plane of 30: Canny kept 43-52 % of the edge's length).
    # Bridging longer gaps joins the wall's texture into long "lines" too, so those must be
    # steps: the same side brighter along SAME_SIDE of them (_step_sides)
    steps = [(gap, blur, level) for gap in BROKEN_GAPS for blur, level in tries]
    if ball is None:
        for gap, blur, level in steps[:len(tries)]:
            segments, edges, _ = _segments(img, blur, level, gap, min_length)
            if segments:
                return _refined(max(segments, key=_length), edges, img)
        return None
    found: list[tuple[tuple[float, ...], np.ndarray, int]] = []
    for k, (gap, blur, level) in enumerate(steps):
        segments, edges, smooth = _segments(img, blur, level, gap, min_length)
        found += [(s, edges, k) for s in segments if _beside(s, ball, radius) and (
            gap == BROKEN_GAPS[0] or _step_sides(s, smooth) >= SAME_SIDE)]
        if found:
            best = _pick(found, ball, radius)[0]
            if _bounces_off(best, ball) and _off_contact(best, ball, radius) <= CONTACT * radius:
                break
    picked = _pick(found, ball, radius) if found else None
    if picked is None or picked[2] >= len(tries):  # only over the longer gaps: a faint step?
        step = _step_line(img, ball, radius, min_length)
        smooth = cv2.GaussianBlur(img, (0, 0), STEP_BLUR_PX)
        if step is not None and (picked is None or _step_sides(step, smooth)
                                 > _step_sides(picked[0], smooth)):
            return _along_step(step, img)
    return None if picked is None else _refined(picked[0], picked[1], img)


# Where the line search finds the surface only over the longer gaps, or not at all, the lines
# of the image smoothed by STEP_BLUR_PX within STEP_ANGLE_DEG of its rows (every
# STEP_ANGLE_STEP_DEG) are read for a step too: the mean grey level along each line, and
# across them the difference STEP_REACH_PX either side (:func:`_step_line`). A faint step
# under a textured wall (a rendered MJPEG clip, 240 x 140: a wall of 40 +- 8 grey levels over
# a plane of 32, the surface at 1 degree) made no straight Canny edge, and a line of the
# wall's texture at 39 degrees that the ball passed, the same side brighter along 0.85 of it,
# was taken for the surface (+- 0.34 degrees: the kinematics turned by 40 degrees). Along
# the whole width of the frame a texture's differences cancel and a step's add up: the
# surface 0.97 the same side brighter, found at -1.06 +- 0.10 degrees for -1
# (test_a_faint_step_that_makes_no_edge_is_found). Read only where the line search finds the
# surface over the longer gaps alone, or none (a faint step): always, a wall's bright bar
# along the ball's path (test_an_edge_along_the_balls_path_is_not_the_surface) gave a line
# 2 degrees off it that the ball came within half a radius of and bounced off, the same side
# brighter along more of it than the plane's edge, which spans less than half the frame. Taken
# where it is the same side brighter along more of it than the edge found. ~0.3 s for 640 x
# 480 px.
STEP_BLUR_PX = 3.0
STEP_ANGLE_DEG = 45.0
STEP_ANGLE_STEP_DEG = 0.5
STEP_REACH_PX = 3
STEP_PEAKS = 3  # the strongest steps of each angle tried


# An edge the ball bounces off (_bounces_off) and comes within CONTACT of its radius of
# touching (its centres' least distance from it) ends the search: the surface. Else fainter
# edges and longer gaps are tried too, and of all the edges found the one nearest to the
# contact is taken (_pick).
CONTACT = 0.5


def _step_line(img: np.ndarray, ball: np.ndarray, radius: float, min_length: float
               ) -> tuple[float, float, float, float] | None:
    """The strongest step of ``img`` (uint8; see ``STEP_BLUR_PX``) along a straight line
    spanning ``min_length`` of its width, the ball's centres ``ball`` on one side of it
    (:func:`_beside`), bouncing off it (:func:`_bounces_off`) within ``CONTACT`` of its
    ``radius`` (px) and the same side brighter along ``SAME_SIDE`` of it; as a segment across
    the frame, or None. A Radon transform of the image, which OpenCV does not give: each
    angle's lines binned by their offset (``np.bincount``)."""
    smooth = cv2.GaussianBlur(img.astype(np.float32), (0, 0), STEP_BLUR_PX)
    h, w = img.shape
    vs, us = np.mgrid[:h, :w].astype(np.float64)
    r, candidates = STEP_REACH_PX, []
    for theta in np.radians(np.arange(-STEP_ANGLE_DEG, STEP_ANGLE_DEG + 1e-9,
                                      STEP_ANGLE_STEP_DEG)):
        rho = vs * math.cos(theta) - us * math.sin(theta)  # the normal (-sin, cos)
        bins = np.floor(rho - rho.min()).astype(np.intp).ravel()
        count = np.bincount(bins)
        mean = np.bincount(bins, smooth.ravel()) / np.maximum(count, 1)
        spans = count >= min_length * w
        step = np.zeros(mean.size)
        step[r:-r] = np.where(spans[2 * r:] & spans[:-2 * r], np.abs(mean[2 * r:] - mean[:-2 * r]),
                              0.0)
        for k in np.argsort(step)[::-1][:STEP_PEAKS]:
            if step[k] > 0:
                candidates.append((float(step[k]), theta, float(rho.min() + k + 0.5)))
    for _, theta, rho in sorted(candidates, reverse=True):
        segment = _across_frame(theta, rho, w, h)
        if segment is not None and _beside(segment, ball, radius) and _bounces_off(
                segment, ball) and _off_contact(segment, ball, radius) <= CONTACT * radius \
                and _step_sides(segment, smooth) >= SAME_SIDE:
            return segment
    return None


def _across_frame(theta: float, rho: float, w: int, h: int
                  ) -> tuple[float, float, float, float] | None:
    """The part within a ``w`` x ``h`` frame of the line ``v cos(theta) - u sin(theta) =
    rho`` (px), as ``(x1, y1, x2, y2)``; None where under 2 px of it is."""
    t = np.arange(-(w + h), w + h, 0.5)
    u = -rho * math.sin(theta) + t * math.cos(theta)
    v = rho * math.cos(theta) + t * math.sin(theta)
    inside = np.flatnonzero((u >= 0) & (u <= w - 1) & (v >= 0) & (v <= h - 1))
    if inside.size < 4:
        return None
    a, b = inside[0], inside[-1]
    return float(u[a]), float(v[a]), float(u[b]), float(v[b])


def _along_step(segment, img: np.ndarray) -> Surface | None:
    """The surface line read along ``segment`` (:func:`_settled`, :func:`_with_scales`)."""
    x1, y1, x2, y2 = segment
    length = math.dist((x1, y1), (x2, y2))
    settled = _settled((x1, y1), ((x2 - x1) / length, (y2 - y1) / length), img, 0.0, length)
    return None if settled is None else _with_scales(*settled, img)


def _bounces_off(segment, ball: np.ndarray) -> bool:
    """Whether the centres ``ball`` (in time order) come nearest to the line through
    ``segment`` between their ends, with ``BOUNCE_SAMPLES`` or more on each side and both
    ends at least 1 px farther: a bounce off it. A line of a wall's texture parallel to the
    ball's path can lie a radius from it too, the centres nearest where the track starts or
    ends (a rendered clip under flickering light: a texture line at 28 degrees, 0.6 px off
    the contact, nearest at the last frame, was taken for the surface)."""
    if len(ball) < 2 * BOUNCE_SAMPLES + 1:
        return True
    d = np.abs(_across(segment, ball[:, 0], ball[:, 1]))
    k = int(np.argmin(d))
    return BOUNCE_SAMPLES <= k < len(d) - BOUNCE_SAMPLES and min(d[0], d[-1]) >= d[k] + 1.0


BOUNCE_SAMPLES = 3


def _length(segment) -> float:
    return math.dist(segment[:2], segment[2:])


def _off_contact(segment, ball: np.ndarray, radius: float) -> float:
    """How far (px) the centres' least distance from the line through ``segment`` is from
    the ball's ``radius`` (0: the ball touches it)."""
    if len(ball) == 0 or not math.isfinite(radius):
        return 0.0
    return abs(float(np.min(np.abs(_across(segment, ball[:, 0], ball[:, 1])))) - radius)


def _pick(found, ball: np.ndarray, radius: float):
    """The surface among ``found`` ((segment, edges, try) triples): an edge the ball bounces
    off (:func:`_bounces_off`) before one it does not, then the edge the ball comes nearest
    to touching (:func:`_off_contact`, to the pixel), of those the first try's (the stronger
    edges, the shorter gaps), of those the longest. A wall's textured edge the ball
    passes without crossing can be longer than the surface's broken edge (a rendered MJPEG
    clip: a 151 px line at 23 degrees, the centres 18.7 px from it at their nearest, beat the
    124 px surface at 11.7 px from a 12.3 px ball, and the kinematics would have been turned
    by 21 degrees)."""
    return min(found, key=lambda f: (not _bounces_off(f[0], ball),
                                     round(_off_contact(f[0], ball, radius)), f[2],
                                     -_length(f[0])))


# the gaps (px) the line search bridges: the first always, the others where it finds no
# surface, for a step only (detect_surface): the same side brighter along SAME_SIDE of it,
# the differences summed 2, 4 and 6 px either side. Measured on tests/render_pbr.py's textured
# walls (five clips, 2026-11-28): the surface 0.90-1.00, the texture's long lines beside the
# ball's path 0.50-0.73. (With one offset of 3 px and 0.9, a wall of 50 +- 14 grey levels over
# a plane of 30 had its surface at 0.89, and no surface was found.)
BROKEN_GAPS = (6, 12, 20)
SAME_SIDE = 0.85


def canny_edges(img: np.ndarray, blur: float = 1.5, level: float = 98.0
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Canny's edges of ``img`` (uint8) smoothed by ``blur`` px, the high threshold at the
    ``level`` percentile of the gradient (the low at half of it); the smoothed image, and its
    gradient's magnitude (Sobel, float32)."""
    smooth = cv2.GaussianBlur(img, (0, 0), blur)
    grad = np.hypot(cv2.Sobel(smooth, cv2.CV_32F, 1, 0), cv2.Sobel(smooth, cv2.CV_32F, 0, 1))
    high = float(np.percentile(grad, level))
    return cv2.Canny(smooth, 0.5 * high, high), smooth, grad


def _segments(img: np.ndarray, blur: float, level: float, gap: int, min_length: float
              ) -> tuple[list[tuple[float, ...]], np.ndarray, np.ndarray]:
    """Straight segments of ``img`` (uint8) spanning ``min_length`` of its width: Canny edges of
    the image smoothed by ``blur`` px, the high threshold at the ``level`` percentile of the
    gradient, then a probabilistic Hough transform bridging ``gap`` px; and the edges and the
    smoothed image."""
    w = img.shape[1]
    edges, smooth, _ = canny_edges(img, blur, level)
    lines = cv2.HoughLinesP(edges, 1, np.pi / 720, threshold=int(0.15 * w),
                            minLineLength=min_length * w, maxLineGap=gap)
    segments = [] if lines is None else [tuple(float(v) for v in s) for s in lines.reshape(-1, 4)]
    return segments, edges, smooth


def _step_sides(segment, smooth: np.ndarray, offsets: tuple[float, ...] = (2.0, 4.0, 6.0)
                ) -> float:
    """The fraction of the points along ``segment`` (one a pixel) where the same side of it is
    the brighter, ``smooth`` sampled ``offsets`` px either side (bilinear) and the differences
    summed over them: 1 for a step, ~0.5 for a line that a wall's texture makes."""
    x1, y1, x2, y2 = segment
    length = math.dist((x1, y1), (x2, y2))
    a = np.linspace(0.0, 1.0, max(int(length), 2))
    u, v = x1 + a * (x2 - x1), y1 + a * (y2 - y1)
    img = smooth.astype(np.float32)

    def at(du: float, dv: float) -> np.ndarray:
        return cv2.remap(img, (u + du).astype(np.float32)[None, :],
                         (v + dv).astype(np.float32)[None, :], cv2.INTER_LINEAR,
                         borderMode=cv2.BORDER_REPLICATE)[0]

    diff = np.zeros(u.size, np.float32)
    for o in offsets:
        nu, nv = -(y2 - y1) / length * o, (x2 - x1) / length * o
        diff += at(nu, nv) - at(-nu, -nv)
    return float(max(np.mean(diff > 0), np.mean(diff < 0)))


def _beside(segment, centres: np.ndarray, radius: float) -> bool:
    """Whether every one of ``centres`` lies on the same side of the line through
    ``segment = (x1, y1, x2, y2)``, at least half of ``radius`` (px) from it."""
    side = _across(segment, centres[:, 0], centres[:, 1])
    margin = 0.5 * radius if math.isfinite(radius) else 0.0
    return len(side) == 0 or bool(np.all(side > margin) or np.all(side < -margin))


def _across(segment, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Signed distance (px) of the points ``(u, v)`` from the line through ``segment = (x1,
    y1, x2, y2)``."""
    x1, y1, x2, y2 = segment
    return ((u - x1) * (y2 - y1) - (v - y1) * (x2 - x1)) / math.dist((x1, y1), (x2, y2))


def _refined(segment, edges: np.ndarray, img: np.ndarray | None = None) -> Surface:
    """The line through ``segment`` fitted (Huber) to the edge pixels within 2 px of it, then
    again to those within 2 px of the line fitted, until the pixels no longer change (at most
    ``REFIT_ROUNDS`` times). Once was not enough where the Hough segment is a short piece of a
    broken edge, tilted: on a rendered MJPEG clip (a 14 px ball, wall 50 +- 12 grey levels,
    the surface at 3 degrees) its pixels gave 2.46 +- 0.11 degrees, 5 SDs off; the rounds
    2.64, 2.73, 2.82, 2.87, 2.92, 2.97 +- 0.08 (the pixels at the ends only come within 2 px
    of the line as it turns)."""
    vs, us = np.nonzero(edges)
    near = np.abs(_across(segment, us, vs)) <= 2.0
    for _ in range(REFIT_ROUNDS):
        pts = np.column_stack([us[near], vs[near]]).astype(np.float32)
        dx, dy, px, py = cv2.fitLine(pts, cv2.DIST_HUBER, 0, 0.01, 0.01).ravel()
        line = (float(px), float(py), float(px + dx), float(py + dy))
        again = np.abs(_across(line, us, vs)) <= 2.0
        if np.array_equal(again, near) or again.sum() < 2:
            break
        near = again
    point, direction = (float(px), float(py)), (float(dx), float(dy))
    if img is not None:
        along = (pts - np.array([px, py], np.float32)) @ np.array([dx, dy], np.float32)
        settled = _settled(point, direction, img, float(along.min()), float(along.max()))
        if settled is not None:
            return _with_scales(*settled, img)
    return Surface(point=point, direction=direction, source="detected",
                   angle_sd_deg=_angle_sd(pts, (dx, dy), (px, py)))


SUBPIXEL_REACH = 2.5  # px either side of the line the image is read across it
SETTLE_PX = 0.5  # the line is read again along the line found where that is this far off ...
SETTLE_ROUNDS = 3  # ... at either end, up to this many times (_settled) ...
WIDE_REACH = 6.0  # ... the first time read out to this (px) either side of the line given
SMOOTH_PX = 1.0  # the image is smoothed by this (px) before it is read ...
OTHER_SMOOTH_PX = (0.5, 2.0)  # ... and by these for the angle's systematic SE (_with_scales)


def _settled(point, direction, img: np.ndarray, lo: float, hi: float
             ) -> tuple[Surface, tuple[float, float], tuple[float, float], float, float] | None:
    """:func:`_subpixel`'s line read along ``point``, ``direction`` from ``lo`` to ``hi`` (px
    along it) and settled (:func:`_settle`), and the same from the line read out to
    ``WIDE_REACH`` either side: of the two, the one whose edge positions more of agree
    (:func:`_consensus`); with the line it was read along and its ends. Read only within
    ``SUBPIXEL_REACH`` of the line given, a line that the wall's texture tilted stayed so (a
    rendered MJPEG clip, 160 x 96, the surface flat and 8 px from the bottom under a wall of 50
    +- 10 over a plane of 30: the Hough segment 3 px off at one end, the line -2.17 +- 0.46
    degrees; the surface's edge out of reach along a fifth of it). Read that wide alone, a
    strong edge near the surface took the line (a frame counter's box 4 px under a faint
    step: -5.6 degrees for -2)."""
    tries = [_settle(point, direction, lo, hi, img)]
    wide = _subpixel(point, direction, img, lo, hi, reach=WIDE_REACH)
    if wide is not None:
        tries.append(_settle(*_moved(point, direction, lo, hi, wide), img))
    found = [t for t in tries if t is not None]
    return max(found, key=lambda t: t[0])[1:] if found else None


def _moved(point, direction, lo: float, hi: float, line: Surface
           ) -> tuple[tuple[float, float], tuple[float, float], float, float]:
    """``line``'s point and direction, and the ends of the line through ``point`` along
    ``direction`` from ``lo`` to ``hi`` (px) as positions along it."""
    ends = [np.asarray(point) + t * np.asarray(direction) for t in (lo, hi)]
    lo, hi = (float((end - np.asarray(line.point)) @ np.asarray(line.direction)) for end in ends)
    return line.point, line.direction, lo, hi


def _settle(point, direction, lo: float, hi: float, img: np.ndarray
            ) -> tuple[int, Surface, tuple[float, float], tuple[float, float], float, float] | None:
    """:func:`_subpixel`'s line read along ``point``, ``direction`` from ``lo`` to ``hi``,
    read again along the line it finds where that departs by ``SETTLE_PX`` or more at either
    end (at most ``SETTLE_ROUNDS`` times); with the number of edge positions the last read was
    fitted to, that read's line, and the line it was read along and its ends."""
    for _ in range(SETTLE_ROUNDS):
        read = _read_line(point, direction, img, lo, hi)
        if read is None:
            return None
        fine, support = read
        ends = [np.asarray(point) + t * np.asarray(direction) for t in (lo, hi)]
        line = (*fine.point, fine.point[0] + fine.direction[0], fine.point[1] + fine.direction[1])
        if max(abs(float(_across(line, *end))) for end in ends) < SETTLE_PX:
            break
        point, direction, lo, hi = _moved(point, direction, lo, hi, fine)
    return support, fine, point, direction, lo, hi


def _with_scales(fine: Surface, point, direction, lo: float, hi: float, img: np.ndarray
                 ) -> Surface:
    """``fine`` (:func:`_subpixel`) with, in quadrature in its angle's SE, half the range of
    the angles found with the image smoothed by ``OTHER_SMOOTH_PX`` as well: a wall's texture
    beside a faint step moves the slope's peak by its curvature, which the smoothing's scale
    changes, and bends the edge along the line slowly enough to pass for a tilt that no
    scatter about the line shows (a rendered 320 x 200 clip, the surface at 2 degrees between
    a wall of 50 +- 10 grey levels and a plane of 30: -1.80 +- 0.03 degrees, z 6.8; smoothed by
    0.5 and 2 px -1.88 and -1.69; with this +- 0.10, z 2.0). Over the rendered surfaces of
    docs/tracking.md §1 (480 x 200 at 3 degrees, MJPEG; 240 x 120 at 2 degrees, MPEG-4; 20
    walls each) the z RMS 1.30 and 1.24 -> 0.90 and 0.81, the largest 3.05 and 2.38 -> 2.27
    and 1.76; the SE 1.29 times as large (median; 1.0-3.7)."""
    angles = [fine.angle] + [other.angle for s in OTHER_SMOOTH_PX
                             if (other := _subpixel(point, direction, img, lo, hi, s))
                             is not None]
    systematic = 0.5 * (max(angles) - min(angles))
    return replace(fine, angle_sd_deg=math.hypot(fine.angle_sd_deg or 0.0,
                                                  systematic))


def _subpixel(point: tuple[float, float], direction: tuple[float, float], img: np.ndarray,
              lo: float, hi: float, smooth_px: float = SMOOTH_PX, reach: float | None = None
              ) -> Surface | None:
    """:func:`_read_line`'s line alone."""
    read = _read_line(point, direction, img, lo, hi, smooth_px, reach)
    return None if read is None else read[0]


def _read_line(point: tuple[float, float], direction: tuple[float, float], img: np.ndarray,
               lo: float, hi: float, smooth_px: float = SMOOTH_PX, reach: float | None = None
               ) -> tuple[Surface, int] | None:
    """The line through ``point`` along ``direction`` (a unit vector) fitted again to the
    edge's sub-pixel positions: at every pixel along it from
    ``lo`` to ``hi`` (px from its point), the image (smoothed by ``smooth_px``) read across it
    out to ``reach`` px (default ``SUBPIXEL_REACH``; in quarter pixels, cubic splines: read
    bilinearly the slope is flat between pixels and its peak locks to them), and the peak of
    its slope, to a fraction of a sample (the vertex of the parabola through the three samples
    about it), taken for the edge; the positions whose peak is under half the median peak (the
    edge broken there) left out, and those the others do not agree with (:func:`_consensus`);
    a Huber line through the rest, its angle's SE as :func:`_angle_sd`'s, and how many
    positions it was fitted to. None where under 20 positions are left. The whole-pixel Canny
    edges gave rendered surfaces a line flatter than the truth (their z mean +0.5 to +0.7); a
    centroid of the slope's strongest part out to 4 px took in the wall's texture (a 240 x 120
    clip: 0.13 degrees off)."""
    (px, py), (dx, dy) = point, direction
    a = np.arange(math.ceil(lo), math.floor(hi) + 1, dtype=np.float64)
    s, slope, in_frame = _slopes(point, direction, img, a, smooth_px, reach)
    slope, inside = np.abs(slope), np.all(in_frame, axis=1)
    at = np.clip(slope.argmax(axis=1), 1, len(s) - 2)
    rows = np.arange(len(a))
    y0, y1, y2 = slope[rows, at - 1], slope[rows, at], slope[rows, at + 1]
    peak = y1
    keep = inside & (peak >= 0.5 * np.median(peak[inside])) if inside.any() else inside
    keep &= (y1 >= y0) & (y1 >= y2) & (y0 - 2 * y1 + y2 < 0)
    if keep.sum() < 20:
        return None
    # the slope's peak to a fraction of a sample: the vertex of the parabola through three
    y0, y1, y2, at = y0[keep], y1[keep], y2[keep], at[keep]
    edge = s[at] + 0.25 * 0.5 * (y0 - y2) / (y0 - 2 * y1 + y2)
    pts = np.column_stack([a[keep], edge]).astype(np.float32)
    pts = pts[_consensus(pts, y1)]
    if len(pts) < 20:
        return None
    ex, ey, ox, oy = cv2.fitLine(pts, cv2.DIST_HUBER, 0, 0.01, 0.01).ravel()
    # back to the image: along the line ``a`` and across it ``s`` (normal (-dy, dx))
    p0 = np.array([px + ox * dx - oy * dy, py + ox * dy + oy * dx])
    d = np.array([ex * dx - ey * dy, ex * dy + ey * dx])
    d /= np.hypot(*d)
    if d @ np.array([dx, dy]) < 0:
        d = -d
    return Surface(point=(float(p0[0]), float(p0[1])), direction=(float(d[0]), float(d[1])),
                   source="detected", angle_sd_deg=_angle_sd(pts, (ex, ey), (ox, oy))), len(pts)


def _slopes(point, direction, img: np.ndarray, a: np.ndarray, smooth_px: float = SMOOTH_PX,
            reach: float | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The image's slope across the line through ``point`` along ``direction`` (a unit
    vector; grey levels a px along its normal ``(-dy, dx)``): at the positions ``a`` along it
    (px), the image smoothed by ``smooth_px`` read out to ``reach`` px either side (default
    ``SUBPIXEL_REACH``) every quarter pixel (cubic splines); with the offsets across it and
    whether each sample lies in the frame."""
    from scipy import ndimage

    smooth = cv2.GaussianBlur(img.astype(np.float32), (0, 0), smooth_px)
    (px, py), (dx, dy) = point, direction
    reach = SUBPIXEL_REACH if reach is None else reach
    s = np.arange(-reach, reach + 0.25, 0.25)
    u = px + a[:, None] * dx - s[None, :] * dy  # normal (-dy, dx)
    v = py + a[:, None] * dy + s[None, :] * dx
    inside = (u >= 0) & (u <= img.shape[1] - 1) & (v >= 0) & (v <= img.shape[0] - 1)
    prof = ndimage.map_coordinates(smooth, [v, u], order=3, mode="nearest")
    return s, np.gradient(prof, s, axis=1), inside


# A line found in a faint step under a textured wall can be the texture's, some degrees off,
# with an SE that does not cover it: the edge then lies on it along only part of the frame.
# benchmarks/tracking_surface.py (143 surfaces found, no ball in the background): the three
# 1-2 degrees off (z 6.8-28.7, a 1/f wall over a step as large as its SD) had the image's
# strongest rise as the step's within CONSENSUS_PX of the line, and above its noise, along
# 0.31-0.46 of the frame's width; of the others, two had 0.46-0.49 (z -2.5 and -3.0) and the
# rest 0.57 or more; the rendered clips of benchmarks/tracking_lens.py (24, no lens) 0.76 or
# more. Under EDGE_SHARE it is said (surface_warning)
EDGE_SHARE = 0.53
SHARE_NOISE = 5.0  # ... counting a rise this many times the slope the image's noise makes


def edge_share(background: np.ndarray, surface: Surface) -> float:
    """The share of the whole pixels along ``surface``'s line, within the frame, where the
    image's strongest rise across it (:func:`_slopes`), of the step's sign (the median slope
    on the line), lies within ``CONSENSUS_PX`` of it and is ``SHARE_NOISE`` times the slope
    the image's noise (:func:`_noise_grey`) makes or more."""
    img = np.asarray(background, dtype=np.float32)
    reach = math.hypot(*img.shape) + abs(surface.point[0]) + abs(surface.point[1])
    a = np.arange(-math.ceil(reach), math.ceil(reach) + 1, dtype=np.float64)
    direction = np.asarray(surface.direction, dtype=float) / math.hypot(*surface.direction)
    s, slope, in_frame = _slopes(surface.point, tuple(direction), img, a)
    inside = np.all(in_frame, axis=1)
    if not inside.any():
        return 0.0
    slope = slope[inside] * (np.sign(np.median(slope[inside, len(s) // 2])) or 1.0)
    at, peak = slope.argmax(axis=1), slope.max(axis=1)
    # a rise the image's noise could make is no edge: the slope of noise of SD sigma smoothed
    # by SMOOTH_PX has an SD of sigma / (sqrt(8 pi) SMOOTH_PX^2) (the derivative of a Gaussian,
    # squared and integrated over the plane)
    floor = SHARE_NOISE * _noise_grey(img) / (math.sqrt(8 * math.pi) * SMOOTH_PX ** 2)
    return float(np.mean((np.abs(s[at]) <= CONSENSUS_PX) & (at > 0) & (at < len(s) - 1)
                         & (peak >= floor)))


def _noise_grey(img: np.ndarray) -> float:
    """The image's noise SD (grey levels) by Immerkaer's estimator (1996): the mean magnitude
    of a Laplacian difference that cancels planes and slow texture, ``sqrt(pi / 2) / 6`` of
    it. Written here: OpenCV and SciPy have no noise estimator (scikit-image's is not a
    dependency)."""
    mask = np.array([[1, -2, 1], [-2, 4, -2], [1, -2, 1]], np.float32)
    response = cv2.filter2D(np.asarray(img, np.float32), -1, mask)[1:-1, 1:-1]
    return float(math.sqrt(math.pi / 2) / 6 * np.mean(np.abs(response)))


REFIT_ROUNDS = 10
CONSENSUS_PX = 1.0  # the edge's positions this far (px) from the line most lie near ...
CONSENSUS_TRIES = 300  # ... of this many through two of them (_consensus)


def _consensus(pts: np.ndarray, weight: np.ndarray) -> np.ndarray:
    """Which of the edge's positions ``pts`` (``(n, 2)``: along, across the line, px) lie
    within ``CONSENSUS_PX`` across of the line through two of them that most do
    (``CONSENSUS_TRIES`` pairs, seeded: the same every time). A Huber line through all of them
    was tilted by a stretch where the wall's texture, darker over the step, made an edge of its
    own 4 px above the surface's and hid it (a rendered MJPEG clip: a third of a 160 px edge,
    the line -2.2 degrees for 0, z 4.7). Written here because OpenCV's robust line fits
    (``fitLine``) keep every point and its RANSAC fits (``estimateAffine2D``) fit no line."""
    rng = np.random.default_rng(0)
    i, j = rng.integers(0, len(pts), (2, CONSENSUS_TRIES))
    i, j = i[pts[i, 0] != pts[j, 0]], j[pts[i, 0] != pts[j, 0]]
    if i.size == 0:
        return np.ones(len(pts), bool)
    slope = (pts[j, 1] - pts[i, 1]) / (pts[j, 0] - pts[i, 0])
    off = pts[None, :, 1] - pts[i, 1, None] - slope[:, None] * (pts[None, :, 0] - pts[i, 0, None])
    near = np.abs(off) <= CONSENSUS_PX
    return near[int(np.argmax(near @ weight))]


def _angle_sd(pts: np.ndarray, direction, point) -> float:
    """Standard error (deg) of a line's angle fitted to edge pixels ``pts``: the slope's
    least-squares error ``s / sqrt(sum (a - mean a)^2)`` (``a`` the position along the line,
    ``s`` the robust scatter across it, at least the 1/sqrt(12) px of integer pixel positions),
    with the pixels counted in runs of ``CORRELATION_PX`` (neighbouring edge pixels of Canny's
    one-pixel-wide edges are not independent); or, where larger, the same from the median
    offsets of ``BLOCKS`` stretches of the line (:func:`_block_sd`)."""
    d = pts - np.asarray(point, dtype=np.float32)
    along = d @ np.asarray(direction)
    across = d[:, 0] * direction[1] - d[:, 1] * direction[0]
    scatter = max(1.4826 * float(np.median(np.abs(across - np.median(across)))),
                  1 / math.sqrt(12))
    spread = float(np.sum((along - along.mean()) ** 2))
    if spread <= 0:
        return math.nan
    return max(math.degrees(scatter / math.sqrt(spread) * math.sqrt(CORRELATION_PX)),
               _block_sd(along, across))


CORRELATION_PX = 4.0
BLOCKS = 12  # stretches of the surface line whose offsets tell its wander


def _block_sd(along: np.ndarray, across: np.ndarray) -> float:
    """Standard error (deg) of a line's slope from the median offsets across it of ``BLOCKS``
    equal stretches along it (at least 3 pixels each; 0 with under 5 stretches): a wall's
    texture bends the edge's pixels over tens of pixels, alike within a stretch, which the
    pixels' own scatter misses (rendered 320 x 160 clips, the surface at 1 degree, 30 walls:
    z RMS 1.31, two beyond 3, with that alone; 0.88 and none with this)."""
    cut = np.linspace(along.min(), along.max(), BLOCKS + 1)
    block = np.clip(np.digitize(along, cut) - 1, 0, BLOCKS - 1)
    a, r = [], []
    for i in range(BLOCKS):
        sel = block == i
        if sel.sum() >= 3:
            a.append(float(along[sel].mean()))
            r.append(float(np.median(across[sel])))
    if len(a) < 5:
        return 0.0
    am, rm = np.array(a) - np.mean(a), np.array(r)
    slope = float(am @ (rm - rm.mean()) / (am @ am))
    res = rm - rm.mean() - slope * am
    return math.degrees(math.sqrt(float(res @ res) / (len(a) - 2) / float(am @ am)))


class PlaneTrajectory(NamedTuple):
    """Found frames only: time (s, frame index / fps) and position (m) in the plane frame."""

    t: np.ndarray
    x: np.ndarray
    y: np.ndarray


def plane_axes(track: Track, surface: Surface) -> tuple[np.ndarray, np.ndarray]:
    """Image unit vectors of ``x`` (along the surface, direction of travel) and ``y`` (outward
    normal, towards the ball's side)."""
    c = track.centre[track.found]
    if len(c) == 0:
        raise ValueError("the track has no found frames")
    e = np.asarray(surface.direction, dtype=float)
    n = np.array([e[1], -e[0]])
    rel = c - np.asarray(surface.point)
    if np.median(rel @ n) < 0:
        n = -n
    if (rel[-1] - rel[0]) @ e < 0:
        e = -e
    return e, n


def to_plane_frame(track: Track, calibration: Calibration, surface: Surface,
                   fps: float, readout: float = 0.0) -> PlaneTrajectory:
    """Found centres in metres, ``x`` along the surface from the first found position, ``y``
    the height of the ball centre above the surface line; each at the time frame ``k``'s
    rows through its centre were read: ``k / fps`` (``k`` the frame's place in the camera's
    sequence where frames were lost or repeated: ``Track.timing``), plus ``readout v /
    height`` for a rolling shutter that reads the ``height`` rows top to bottom in
    ``readout`` seconds (``v`` the centre's row, px from the top; 0: a global shutter). To
    first order the centre of a ball so read, sheared by its motion, is where the ball was
    when its centre's row was read."""
    fps = check_scalar("fps", fps, unit="frames/s", low=0.0, low_open=True)
    readout = check_scalar("readout", readout, unit="s", low=0.0, high=1.0 / fps)
    e, n = plane_axes(track, surface)
    k = np.flatnonzero(track.found)
    rel = track.centre[k] - np.asarray(surface.point)
    x, y = rel @ e, rel @ n
    s = calibration.metres_per_px
    place = track.timing.place[k] if track.timing is not None else k
    t = place / fps + readout * track.centre[k, 1] / track.background.shape[0]
    return PlaneTrajectory(t=t, x=(x - x[0]) * s, y=y * s)
