"""A lens that bends straight lines, told by the surface's edge (a plumb line).

The tracker takes one scale over the frame: the camera square-on to the plane of the bounce,
its lens without distortion. A wide lens (an action camera, a phone's wide camera) bows
straight lines (barrel distortion), and the scale then falls towards the frame's edges: a
rendered clip (tests/render_pbr.py, 480 x 270 px, the ball bouncing in the lower left, the
frames bent by ``r_d = r_u (1 - 0.25 r_u^2)``, ``r`` in units of the frame's width from its
centre: the surface edge bowed by 6 px) gave the incidence angle 1.75 degrees off, the
speeds 1.4 SD off, and the flights' fall scattering beyond its errors, with no word of why.

The surface's edge is straight on the plane and spans the frame: its sub-pixel positions in the
background model (:func:`_edge_positions`, :func:`_follow`), fitted by a parabola across the
line (``bend``), show the bow. Where its sagitta is ``SAGITTA_PX`` or more, ``SIGNIFICANT``
standard errors, the bow the model below explains ``EXPLAINED`` of the positions' scatter, the
line is ``OFF_CENTRE`` from the centre, its positions spread along it (``SPREAD``), the bow's
vertex lies near the foot of the centre on it (``VERTEX``) and the edge follows the bow along
most of its length (``COVERAGE``), the lens is said to bend lines, with the one-parameter
division model that makes the edge straight (Fitzgibbon 2001:
``x_u = c + (x_d - c) / (1 + lam r_d^2)``, ``c`` the frame's centre, ``r_d`` the distance from
it in units of the half-diagonal) and what it means for the scale at the corners; and
:func:`.track_video` (``lens="auto"``) undistorts the frames by that model (:func:`undistort`,
the points given with them too: :func:`undistort_points`) and tracks them again. One edge fixes
one parameter about an assumed centre (the principal point taken as the frame's centre, no
higher orders): the same clip, its frames undistorted so, gave the incidence angle 40.05
degrees for 40 (z 0.5; 38.25 as bent) and the rebound angle z 0.8; with ``k1 = -0.08``, the
rebound angle z 0.8 (-4.8 as bent). A camera's own calibration (OpenCV's
``calibrateCamera`` and ``undistort``) does better, and ``lens="none"`` takes frames so
undistorted as they are. Written here because no library fits one plumb line in a tracked
video's background.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

SAGITTA_PX = 0.5    # the edge's bow (px) from which the lens is said to bend lines ...
SIGNIFICANT = 5.0   # ... where it is this many standard errors too ...
# ... and the division model straightening it explains EXPLAINED of the edge positions'
# variance across their line or more: a bow the lens makes is smooth and spans the edge; the
# texture of a wall over a faint surface step (a dark 15 px ball's scene,
# benchmarks/tracking_accuracy.py: Canny's edge in pieces with hooks) made, with Canny's pixels
# within 2 px of a refitted parabola (before _follow's RANSAC), a bow of 1.55 +- 0.31 px that
# explained 0.20 of it; a lens bending the rendered frames by 10 % at the corners, 0.92
EXPLAINED = 0.35
# ... and the line lies OFF_CENTRE half-diagonals or more from the frame's centre at its
# nearest: nearer, a lens bows a line too little to tell from an edge that wobbles (the
# synthetic 224 x 64 px scenes of tests/video_helpers.py, the surface 0.2 half-diagonals from
# the centre beside a plane's wavy stripes: a bow of 1.8-2.4 px, lambda -0.09, explained
# 0.6-0.7; the rendered lens clips' surface: 0.36)
OFF_CENTRE = 0.25
# ... and each third of the edge's length holds SPREAD of the positions that follow it or more:
# a bow set by positions at one end is not the lens's (a frame counter burned into the lower
# right corner, tests/render_pbr.py's 320 x 200 clip over a faint surface step: its box's top
# edge, 4 px under the surface, took 82 % of Canny's pixels, 3 % in the first third, and read
# as a bow of 7.3 +- 0.5 px, explained 0.89: the frames were "undistorted", the ball's radius
# came out +7.7 % and its picture shrinking by 20 %; the rendered lens clips, four lenses:
# 0.24-0.33)
SPREAD = 0.1
# ... and the parabola's vertex lies within VERTEX half-lengths of the edge from the foot of
# the perpendicular from the frame's centre on the line, where a lens centred on the frame puts
# it: a glossy 5 px ball's MJPEG clip (benchmarks/tracking_lens.py's "small" scene, seed 0:
# 160 x 96, the surface flat 8 px from the bottom over a faint step) had the wall's texture
# make an edge of its own 4 px above the surface along its first third, which with the
# surface's edge read as a barrel bow of 2.3 +- 0.3 px (explained 0.54): the frames were
# "undistorted" and the radius came out +7 %. Its vertex lay 0.64 from the foot, the rendered
# lenses' 0.01-0.25 on its larger scenes (24 clips) and up to 0.41 on the small one
VERTEX = 0.45
# ... and the bow is followed by the edge over COVERAGE of the whole pixels along it that hold
# a position or more: a lens bows the whole edge; the texture of a wall over a step no stronger
# than it (benchmarks/tracking_surface.py's backgrounds, no lens: a step of 8 grey levels under
# a texture of SD 8, isotropic or 1/f) can make a parabola that the positions follow over half
# of the edge: 3 of its 143 surfaces read as bows of 2.0-4.3 px (explained 0.57-0.84; 12 read
# from Canny's pixels, up to 6.1 px), followed over 0.44-0.53 of the edge; the rendered lenses
# of benchmarks/tracking_lens.py (72 clips) 0.81-0.99
COVERAGE = 0.7
SEARCH_PX = 8.0   # the edge's positions are looked for within this (px) of the line given ...
PEAK_SHARE = 0.25  # ... the slope's peaks this share of the median column's highest or more
INLIER_PX = 1.0   # ... and are those within this of the parabola most of them lie on
SAMPLES = 400     # ... of this many tried (_follow)
CORRELATION_PX = 4.0  # neighbouring positions, read from the smoothed image, are not independent


class LensBend(NamedTuple):
    """The surface edge's bow: ``sagitta_px`` (the parabola's depth over the edge's length,
    signed: positive where its middle lies away from the frame's centre against its ends, as
    a barrel lens bows a line: the ends, farther out, are drawn in more)
    and its standard error, the edge's ``length_px``, and ``lam``: the division model's
    parameter that makes the edge straight (negative for a barrel lens), with its SE."""

    sagitta_px: float
    sagitta_se_px: float
    length_px: float
    lam: float
    lam_se: float
    explained: float  # the fraction of the pixels' variance across a line that lam explains
    off_centre: float = 1.0  # the line's least distance from the frame's centre, half-diagonals
    spread: float = 1.0 / 3.0  # the least fraction of the pixels in a third of the edge's length
    vertex: float = 0.0  # the bow's vertex from the foot of the centre on the line, half-lengths
    coverage: float = 1.0  # the share of the edge's whole pixels along it that follow the bow

    @property
    def significant(self) -> bool:
        return abs(self.sagitta_px) >= SAGITTA_PX and self.explained >= EXPLAINED and \
            abs(self.sagitta_px) >= SIGNIFICANT * self.sagitta_se_px and \
            self.off_centre >= OFF_CENTRE and self.spread >= SPREAD and self.vertex <= VERTEX \
            and self.coverage >= COVERAGE


def _edge_positions(img: np.ndarray, point, direction
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The step's edge positions ``(u, v)`` (px) near the line through ``point`` along
    ``direction``, with their strength: at every pixel along the line where the frame holds
    it, the image read across it out to ``SEARCH_PX`` (:func:`._geometry._slopes`: smoothed
    as the surface line is read, in quarter pixels, cubic splines), and every peak of its
    slope that rises as the surface's step does (the sign of the slope on the line) and is
    ``PEAK_SHARE`` of the median column's highest or more, to a fraction of a sample (the
    vertex of the parabola through three)."""
    from ._geometry import _slopes

    img = np.asarray(img, dtype=np.float32)
    e = np.asarray(direction, dtype=float) / math.hypot(*direction)
    reach = math.ceil(math.hypot(*img.shape) + abs(point[0]) + abs(point[1]))
    a = np.arange(-reach, reach + 1, dtype=np.float64)
    s, slope, inside = _slopes(point, (float(e[0]), float(e[1])), img, a, reach=SEARCH_PX)
    mid = len(s) // 2
    on = inside[:, mid - 4:mid + 5].all(axis=1)  # the line within the frame, +-1 px
    a, slope = a[on], np.where(inside[on], slope[on], 0.0)
    if not a.size:
        return np.zeros(0), np.zeros(0), np.zeros(0)
    slope *= np.sign(np.median(slope[:, mid - 4:mid + 5].mean(axis=1))) or 1.0
    y0, y1, y2 = slope[:, :-2], slope[:, 1:-1], slope[:, 2:]
    peak = (y1 >= y0) & (y1 > y2) & (y1 > 0) & (y0 - 2 * y1 + y2 < 0)
    highest = np.where(peak, y1, 0.0).max(axis=1)
    if not (highest > 0).any():
        return np.zeros(0), np.zeros(0), np.zeros(0)
    rows, cols = np.nonzero(peak & (y1 >= PEAK_SHARE * np.median(highest[highest > 0])))
    p0, p1, p2 = y0[rows, cols], y1[rows, cols], y2[rows, cols]
    across = s[cols + 1] + 0.25 * 0.5 * (p0 - p2) / (p0 - 2 * p1 + p2)
    return (point[0] + a[rows] * e[0] - across * e[1], point[1] + a[rows] * e[1] + across * e[0],
            p1)


def _follow(u: np.ndarray, v: np.ndarray, strength: np.ndarray, point, direction
            ) -> tuple[np.ndarray, np.ndarray]:
    """Of the edge positions ``(u, v)``, those within ``INLIER_PX`` of the parabola across the
    line through ``point`` along ``direction`` that the strongest of them lie on (RANSAC:
    ``SAMPLES`` parabolas through a position of each third of the edge, seeded, their
    positions' strength summed; the best refitted to its positions once). Read from Canny's
    pixels (before 2026-11-29), counted, not weighed, the edges of a plane's stripes parallel
    to the surface and wavy (tests/video_helpers.py: 1.5 px over 250 px, 8 grey levels against
    the surface's 70) outnumbered the surface's and read as a bow of 2 px. Refitting a parabola
    to the positions within 2 px of the last one instead went over to an edge 3.4 px beside the
    surface's as the parabola turned (the lit strip along the surface of
    tests/video_helpers.py's synthetic scenes: a bow of 1.9-4.9 px on straight edges), and a
    walk along the edge from its middle wandered into a textured wall's edges (1.3 px on a
    straight one)."""
    e = np.asarray(direction, dtype=float) / math.hypot(*direction)
    a = (u - point[0]) * e[0] + (v - point[1]) * e[1]
    d = (u - point[0]) * e[1] - (v - point[1]) * e[0]
    if a.size < 20:
        return np.zeros(0), np.zeros(0)
    lo, hi = float(a.min()), float(a.max())
    thirds = [np.flatnonzero((a >= lo + k * (hi - lo) / 3) & (a <= lo + (k + 1) * (hi - lo) / 3))
              for k in range(3)]
    if any(t.size < 3 for t in thirds):
        return np.zeros(0), np.zeros(0)
    rng = np.random.default_rng(0)  # seeded: the same positions every time
    picks = np.column_stack([rng.choice(t, SAMPLES) for t in thirds])
    x = (a - 0.5 * (lo + hi)) / max(0.5 * (hi - lo), 1.0)
    xs, ds = x[picks], d[picks]
    vander = np.stack([np.ones_like(xs), xs, xs * xs], axis=-1)
    ok = np.abs(np.linalg.det(vander)) > 1e-9
    if not ok.any():
        return np.zeros(0), np.zeros(0)
    coef = np.linalg.solve(vander[ok], ds[ok][..., None])[..., 0]
    support = (np.abs(d[None, :] - coef @ np.vstack([np.ones_like(x), x, x * x])) <= INLIER_PX)
    inliers = support[int(np.argmax(support @ strength))]
    if inliers.sum() < 3:
        return np.zeros(0), np.zeros(0)
    refit = np.polyfit(x[inliers], d[inliers], 2)
    inliers = np.abs(d - np.polyval(refit, x)) <= INLIER_PX
    return u[inliers], v[inliers]


def _off_line(u: np.ndarray, v: np.ndarray, lam: float, centre, scale: float) -> np.ndarray:
    """The signed distances (px) of the points undistorted by ``lam`` from their straight line
    (the principal axis through their mean)."""
    du, dv = u - centre[0], v - centre[1]
    g = 1.0 / (1.0 + lam * (du * du + dv * dv) / (scale * scale))
    x, y = du * g, dv * g
    x, y = x - x.mean(), y - y.mean()
    normal = np.linalg.eigh(np.cov(np.vstack([x, y])))[1][:, 0]
    return x * normal[0] + y * normal[1]


def _straightness(u: np.ndarray, v: np.ndarray, lam: float, centre, scale: float) -> float:
    """The RMS distance (px) of the points undistorted by ``lam`` from their straight line."""
    return float(np.sqrt(np.mean(_off_line(u, v, lam, centre, scale) ** 2)))


def bend(img: np.ndarray, point, direction) -> LensBend | None:
    """The bow of the surface's step edge through ``point`` along ``direction`` (px) in
    ``img`` (the background model), read from the edge's sub-pixel positions
    (:func:`_edge_positions`, :func:`_follow`), or None where fewer than 50 follow it. Read
    from Canny's whole-pixel edges instead, a 160 x 96 glossy clip's faint textured edge
    (benchmarks/tracking_lens.py, "small") bowed by -1.8 to +1.8 px through a lens that bows
    it by -0.9 px, and one without a lens flipped between straight and a pincushion bow of
    1.5 px as its line moved by 0.03 degrees."""
    found = _edge_positions(img, point, direction)
    u, v = _follow(*found, point, direction)
    if u.size < 50:
        return None
    centre, scale = _frame_centre(np.shape(img))
    e = np.asarray(direction, dtype=float) / math.hypot(*direction)
    along = (u - point[0]) * e[0] + (v - point[1]) * e[1]
    across = (u - point[0]) * e[1] - (v - point[1]) * e[0]
    mid = 0.5 * (along.min() + along.max())
    half = 0.5 * (along.max() - along.min())
    x = (along - mid) / half
    design = np.column_stack([np.ones_like(x), x, x * x])
    coef, *_ = np.linalg.lstsq(design, across, rcond=None)
    res = across - design @ coef
    # the positions' robust scatter, no less than a whole pixel's rounding (as when the bow
    # was read from Canny's pixels: the sub-pixel positions do not make the SE smaller)
    scatter = max(1.4826 * float(np.median(np.abs(res - np.median(res)))), 1 / math.sqrt(12))
    cov = np.linalg.inv(design.T @ design) * scatter ** 2 * CORRELATION_PX
    # the parabola's middle against its ends (x = 0 against x = +-1) is -coef[2] across the
    # line; signed away from the frame's centre (``towards`` its side), coef[2] * towards
    middle = np.array([point[0] + mid * e[0], point[1] + mid * e[1]])
    towards = np.sign((centre[0] - middle[0]) * e[1] - (centre[1] - middle[1]) * e[0]) or 1.0
    sagitta, sagitta_se = float(coef[2]) * towards, math.sqrt(float(cov[2, 2]))
    # the division model's parameter that makes the edge straight (a 1-D search: the RMS
    # distance from a line is smooth in it), with its SE from the cost's curvature
    from scipy.optimize import minimize_scalar

    cost = lambda lam: _straightness(u, v, lam, centre, scale) ** 2  # noqa: E731
    lam = float(minimize_scalar(cost, bounds=(-0.6, 0.6), method="bounded",
                                options={"xatol": 1e-5}).x)
    step = 0.01
    curv = (cost(lam + step) - 2 * cost(lam) + cost(lam - step)) / step ** 2
    lam_se = math.sqrt(2 * scatter ** 2 * CORRELATION_PX / u.size / curv) if curv > 0 \
        else math.inf
    straight = cost(0.0)
    explained = 1.0 - cost(lam) / straight if straight > 0 else 0.0
    off = abs((centre[0] - point[0]) * e[1] - (centre[1] - point[1]) * e[0]) / scale
    spread = float(min(np.mean(x < -1 / 3), np.mean(np.abs(x) <= 1 / 3), np.mean(x > 1 / 3)))
    foot = ((centre[0] - point[0]) * e[0] + (centre[1] - point[1]) * e[1] - mid) / half
    vertex = abs(-0.5 * float(coef[1]) / float(coef[2]) - foot) if coef[2] != 0 else math.inf
    steps = np.unique(np.rint((found[0] - point[0]) * e[0] + (found[1] - point[1]) * e[1]))
    coverage = np.unique(np.rint(along)).size / steps.size
    return LensBend(sagitta, sagitta_se, 2.0 * half, lam, lam_se, explained, off, spread,
                    vertex, coverage)


def _frame_centre(shape: tuple[int, ...]) -> tuple[np.ndarray, float]:
    """The division model's centre (the frame's, px) and unit of distance (its half-diagonal,
    px) for frames of ``shape`` ``(h, w)``."""
    h, w = shape[-2:]
    return np.array([(w - 1) / 2.0, (h - 1) / 2.0]), math.hypot(w, h) / 2.0


def _source(points: np.ndarray, lam: float, shape: tuple[int, int]) -> np.ndarray:
    """Where the undistorted ``points`` (px, ``(..., 2)``) lie in the frame as taken: ``r_d``
    from ``r_u = r_d / (1 + lam r_d^2)``, the root that is ``r_u`` at ``lam = 0``."""
    centre, scale = _frame_centre(shape)
    d = np.asarray(points, dtype=np.float64) - centre
    ru = np.hypot(d[..., 0], d[..., 1]) / scale
    disc = np.sqrt(np.maximum(1.0 - 4.0 * lam * ru * ru, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        g = np.where(abs(lam) * ru * ru > 1e-12, (1.0 - disc) / (2.0 * lam * ru * ru), 1.0)
    return centre + d * g[..., None]


def undistort_points(points, lam: float, shape: tuple[int, int]) -> np.ndarray:
    """Points of the frame as taken (px, ``(..., 2)``) in the frame undistorted by the division
    model ``lam`` (the frame ``shape`` ``(h, w)`` sets its centre and scale)."""
    centre, scale = _frame_centre(shape)
    d = np.asarray(points, dtype=np.float64) - centre
    r2 = (d[..., 0] ** 2 + d[..., 1] ** 2) / scale ** 2
    return centre + d / (1.0 + lam * r2)[..., None]


def undistort(images: np.ndarray, lam: float) -> np.ndarray:
    """Frames (``(n, h, w)`` uint8) or one image (``(h, w)``, float) undistorted by the
    division model ``lam``: each pixel sampled where it lies in the frame as taken (Keys'
    cubic, OpenCV's ``remap``; the border's pixels repeated), uint8 frames rounded."""
    import cv2

    images = np.asarray(images)
    h, w = images.shape[-2:]
    vv, uu = np.mgrid[:h, :w].astype(np.float64)
    src = _source(np.stack([uu, vv], axis=-1), lam, (h, w)).astype(np.float32)

    def one(img: np.ndarray) -> np.ndarray:
        return cv2.remap(img, src[..., 0], src[..., 1], cv2.INTER_CUBIC,
                         borderMode=cv2.BORDER_REPLICATE)

    if images.ndim == 2:
        return one(images.astype(np.float32))
    return np.stack([one(f) for f in images])


def bend_message(lens: LensBend | None, corrected: bool = False) -> str | None:
    """In words, where the surface edge bows (a lens that bends straight lines), and whether
    the frames were undistorted for it (``corrected``); None where it does not clearly."""
    if lens is None or not lens.significant:
        return None
    kind = "barrel: a wide lens" if lens.sagitta_px > 0 else "pincushion"
    said = (f"lens: the surface edge bows by {abs(lens.sagitta_px):.1f} +- "
            f"{lens.sagitta_se_px:.1f} px over its {lens.length_px:.0f} px ({kind}): the lens "
            "bends straight lines")
    model = f"division model lambda {lens.lam:+.3f} +- {lens.lam_se:.3f}"
    if corrected:
        return (said + f" (as taken, lengths near the frame's corners {100 * lens.lam:+.0f} "
                f"%; {model}); the frames were undistorted by that model (about the frame's "
                "centre) and tracked again. A calibration of the camera does better: undistort "
                "the frames with it (OpenCV: calibrateCamera, undistort) and give --lens none")
    return (said + ", and one scale does not hold over the frame (lengths near its corners "
            f"come out about {100 * lens.lam:+.0f} % off, {model}); positions, speeds and "
            "angles away from the frame's centre are off with them. Undistort the frames with "
            "the camera's calibration first (OpenCV: calibrateCamera, undistort), or give "
            "--lens auto, or film the bounce near the frame's centre")
