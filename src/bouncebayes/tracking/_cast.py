"""The ball's own shadow on the wall behind it, where it hugs the ball's edge.

A lamp near the camera's axis casts the ball's shadow on a wall close behind it: a dark disk of
about the ball's size, offset from it away from the lamp, most of it hidden by the ball and the
rest a crescent against the ball's rim (a ring light round the lens: a thin halo all round,
which is not held: see ``CAST_MIN_OFFSET``). The
shadow moves with the ball, so the background model (a median over frames) does not hold it, and
where the crescent is narrow the wall beyond it is the background's, so the polar sectors that
:func:`._edge_kernel.foreign_sectors` leaves out do not see it either. The edge model then takes
the crescent for part of the ball (its shading holds a dark rim on that side): rendered bright
10 px balls (tests/render_pbr.py's ``cast``, shadows offset 0.14-0.57 radii, 60 % dark) came out
+5 to +10 % in radius, centres 0.4-1.7 px off towards the shadow, RMS residual up to 1.4 times a
clear ball's, with no warning; a concentric halo +1.5 %.

Here the shadow is a blurred disk on the wall: the wall's light ``B`` behind the ball becomes
``B (1 - d Phi((R_s - |p - c - delta|) / w))`` (offset ``delta`` from the ball's centre ``c``,
radius ``R_s``, penumbra ``w``, depth ``d``; a distant lamp and a wall parallel to the image:
the same in every frame). :func:`find_cast` looks for it on the edge model's free fits
(:func:`._edge.fit_radius`): first, cheaply, the cost that one shadow column (``R_s`` the
fitted radius, ``w`` 1 px) on a grid of offsets takes off each free fit, with the fit's
parameters held (projected on the fit's residual: one matrix product); where the median over
the frames reaches ``CAST_GATE`` residual variances, the ``CAST_FRAMES`` frames where it
found most are fitted again with the shadow (the ball's centre, radius and blur and the
shadow's offset, radius and penumbra free; SciPy's least_squares), from the shadow of the frame
that fits best and from its mirror image (:func:`_one_way_round`), and the shadow is kept where
it takes ``CAST_MIN_GAIN`` residual variances off most of them, darkens the wall, reaches
beyond the ball's rim and lies alike in most, off the ball's centre (:func:`_shape`; a frame
whose own shadow does not is fitted again with the others' shape held, :func:`_consensus`).
Its shape is the median over those frames; every fit after that reads the background with it
painted in (:func:`paint`, :func:`painted`). Written here because no library models a ball's
shadow on a wall.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np

CAST_MIN_RADIUS = 4.0  # px: smaller balls are not looked at
# a ball under SMALL_CAST_RADIUS (px) holds a shadow only SMALL_CAST_DEPTH dark or more: the
# paper's camera (224 x 64 px, a 5 px ball, tests/render_pbr.py), a clean MJPEG clip had one
# 0.06 dark "found" (its radius -1.3 -> 0.0 %, but said); its shadows 0.37-0.79 dark
SMALL_CAST_RADIUS = 8.0
SMALL_CAST_DEPTH = 0.2
# the least depth of the shadow held at any size (the median over the frames that agree; a
# small ball's frames each need SMALL_CAST_DEPTH): a faint ring about a ball out of focus (a
# disk PSF, which the model's Gaussian blur does not follow) was held as a shadow 0.18 dark,
# 1.2 radii, 0.07 radii off (benchmarks/tracking_accuracy.py, 10 px, blur 1.0 px: the radius
# +1.2 -> -2.6 %, centres 0.08 -> 0.17 px, and a halo said). The rendered shadows held (60 %
# dark) came out 0.40-0.92 but one nearly behind a 10 px ball under a 1.5 px blur, 0.205 (a
# thin margin: at 0.25 it was not held, its centres 0.11 -> 0.52 px) and two lying beside
# the ball, 1.17 radii off, 0.09 and 0.17 (not held; the radius within 0.9 % either way)
CAST_MIN_DEPTH = 0.2
# the least offset of the shadow held (the median over the frames that agree), in radii of the
# ball: one nearly concentric with it shows as a thin ring all round its rim, which the fits
# cannot tell from the ball's own dark rim. A striped ball turning about the camera's axis
# (the stripe a great circle through the centre, so it meets the rim at two opposite points;
# benchmarks/tracking_centres.py, 15 px) held a "shadow" 0.56 dark, 0.087 radii off (centres
# 0.217 -> 0.276 px, rebound angle z -0.18 -> -1.39), and the defocus ring above lay 0.07
# radii off. Every rendered shadow held lay 0.138 radii off or more (the sweeps in
# docs/tracking.md, offsets 0.14-1.17 radii), and none concentric was held (within 2.4 %)
CAST_MIN_OFFSET = 0.11
# the grid's median gain (residual variances) from which the frames are fitted with a shadow.
# Measured on rendered 10 px balls (three frames each; tests/render_pbr.py): clear balls,
# side-lit, glossy, striped and dark, 2-20 (median over frames <= 13); shadows offset 0.14-0.57
# radii 28-256 (median >= 28); a concentric halo (+1.5 % in radius) 10-28
CAST_GATE = 15.0
# ... and the least gain of the fits with the shadow over the free fits (residual variances,
# on the same pixels) in most of the frames for the shadow to be kept, with its offset within
# CAST_AGREE radii of their median in most of them (one lamp, one wall). A dark 10 px ball
# blurred by 1.5 px whose shadow hugs it: 18-20 in frames where the shadow was found right
CAST_MIN_GAIN = 15.0
CAST_AGREE = 0.15
# the least difference (residual variances a frame) between the frames fitted with the ball
# and its shadow one way round and the other (a dark ball's blurred shadow can look like the
# ball); below it, which is which is not clear and the shadow is not held
CAST_SIDE = 5.0
# a frame whose shadow is not plausible or lies apart from the others' is fitted again with the
# shape of each frame that agrees held, and takes the best where it gains CAST_MIN_GAIN and
# CAST_SHARE of what its own shadow gained (the paper's camera, a 5 px ball: one frame of four
# fitted a smaller shadow 1.2 px further out, gain 84; the others' shape held gained 70 there)
CAST_SHARE = 0.5
# free fits fitted again with the shadow (those where the grid found most): with 3 of 5 the
# benchmark's clip (tests/video_helpers.py, whose soft shadow darkens the ball too) had one
# held that made its centres 0.146 px off (0.051 with its sides left out); with all 5 none
CAST_FRAMES = 5
CAST_OFFSETS = (0.1, 0.2, 0.35, 0.5, 0.7)  # the grid's offsets, in radii ...
CAST_DIRECTIONS = 16                        # ... in this many directions (and none)
CAST_REACH = 10.0  # px beyond the rim the fits with the shadow read (the crescent's far side)
SIGMA_RANGE = (0.5, 1.3)  # the fits' blur, as fractions of the free fit's
START_SHRINK = 0.15  # the second start's ball: this fraction of the free fit's radius smaller


_Fitted = tuple[np.ndarray, float, float, float]  # what _fit gives: p, depth, costs


class CastShadow(NamedTuple):
    """The ball's shadow on the wall: its offset from the ball's centre ``(du, dv)``, radius and
    penumbra (SD of its blurred edge), px, and depth (the fraction of the wall's light it
    takes)."""

    du: float
    dv: float
    radius: float
    penumbra: float
    depth: float

    @property
    def offset(self) -> float:
        """How far the shadow's centre is from the ball's (px)."""
        return math.hypot(self.du, self.dv)


def paint(bg: np.ndarray, centre, cast: CastShadow) -> np.ndarray:
    """``bg`` (a background image) with the ball's shadow painted in, the ball at ``centre``
    (px); a new float64 array. The shadow's profile is the per-frame centre fits' own
    (:func:`._refine._shaded`), so the two read one shadow."""
    from ._refine import _shaded

    out = np.array(bg, dtype=np.float64)
    reach = cast.radius + 5.0 * cast.penumbra + 1.0
    cu, cv = centre[0] + cast.du, centre[1] + cast.dv
    h, w = out.shape
    u0, v0 = max(int(cu - reach), 0), max(int(cv - reach), 0)
    u1, v1 = min(int(cu + reach) + 2, w), min(int(cv + reach) + 2, h)
    if u1 > u0 and v1 > v0:
        vv, uu = np.mgrid[v0:v1, u0:u1].astype(np.float64)
        window = np.ascontiguousarray(out[v0:v1, u0:u1]).ravel()
        shaded = np.empty_like(window)
        _shaded(uu.ravel(), vv.ravel(), window, float(centre[0]), float(centre[1]),
                np.array(cast, dtype=np.float64), shaded)
        out[v0:v1, u0:u1] = shaded.reshape(v1 - v0, u1 - u0)
    return out


def painted(args: Sequence[tuple], cast: CastShadow | None) -> list[tuple[Any, Any, Any, Any]]:
    """The edge model's frames ``(img, bg, centre, velocity)`` with the shadow painted into each
    background at its centre (as given where ``cast`` is None)."""
    if cast is None:
        return list(args)
    return [(img, paint(bg, c, cast), c, v) for img, bg, c, v in args]


def _pixels(img, bg, fit, velocity):
    """The pixels a fit with the shadow reads: the rim's (:func:`._edge._rim_pixels`) out to
    ``CAST_REACH`` px beyond it; None where they leave the frame."""
    from . import _edge

    q = np.array([fit.cx, fit.cy, fit.r, fit.sigma, fit.exposure])
    b = _edge._blur(q, velocity)
    return _edge._pixels(img, bg, q[:2], velocity, fit.r, max(2.5 * b, _edge.INNER * fit.r),
                         CAST_REACH, False, None)


def _design(px, fit, centre, r: float, sigma: float) -> tuple[np.ndarray, np.ndarray]:
    """The edge model's design matrix and fixed part (:func:`._edge._design_numpy`) for the
    ball at ``centre`` with radius ``r`` and blur ``sigma``, exposure and light the fit's."""
    from ._edge import _design_numpy

    n = px.u.size
    at = px._replace(cx=np.full(n, centre[0]), cy=np.full(n, centre[1]))
    return _design_numpy(np.array([r, sigma, fit.exposure, fit.az, fit.el]), at)


def _grid_gain(px, fit) -> tuple[float, tuple[float, float]]:
    """The most cost (in residual variances) that one shadow column on the grid of offsets
    takes off the fit ``fit``'s, its parameters held (each column projected on the residual
    space of the fit's design, by its QR factors), and that column's offset (px)."""
    a, fixed = _design(px, fit, (fit.cx, fit.cy), fit.r, fit.sigma)
    y = px.grey - fixed
    qm, _ = np.linalg.qr(a)
    e = y - qm @ (qm.T @ y)
    var = float(e @ e) / max(y.size - a.shape[1], 1)
    offsets = [(0.0, 0.0)] + [(m * fit.r * math.cos(t), m * fit.r * math.sin(t))
                              for m in CAST_OFFSETS
                              for t in np.arange(CAST_DIRECTIONS) * (2 * math.pi / CAST_DIRECTIONS)]
    g = np.column_stack([_column(px, a, (fit.cx, fit.cy, 0.0, 0.0, du, dv, fit.r, 1.0))
                         for du, dv in offsets])
    g -= qm @ (qm.T @ g)
    norm = np.einsum("ij,ij->j", g, g)
    gain = np.where(norm > 1e-9, (g.T @ e) ** 2 / np.maximum(norm, 1e-12) / max(var, 1e-12),
                    0.0)
    best = int(np.argmax(gain))
    return float(gain[best]), offsets[best]


def _column(px, a: np.ndarray, p) -> np.ndarray:
    """The shadow's column of the design ``a`` (its wall term ``(1 - S) B``, ``a[:, -3]``,
    darkened by the blurred disk): for the ball at ``p[:2]`` and the shadow ``p[4:8] = (du,
    dv, R_s, w)`` (px), its coefficient minus the depth."""
    from scipy.special import ndtr

    dist = np.hypot(px.u - p[0] - p[4], px.v - p[1] - p[5])
    return a[:, -3] * px.bg * ndtr((p[6] - dist) / p[7])


def _starts(fit, offset: tuple[float, float]) -> list[np.ndarray]:
    """Where the fits with the shadow start ``(cx, cy, r, sigma, du, dv, R_s, w)``: the free
    fit's ball with the grid's best ``offset`` (px) of the shadow, and a ball ``START_SHRINK``
    smaller moved away from the shadow (where the free fit took the shadow in, a dark ball's
    blurred by 1.5 px: +28 %, the fits from its ball stayed there in three frames of five)."""
    r, size = fit.r, math.hypot(*offset)
    away = np.zeros(2) if size == 0 else -np.asarray(offset) / size * (START_SHRINK * r)
    small = (1 - START_SHRINK) * r
    return [np.array([fit.cx, fit.cy, r, fit.sigma, *offset, r, 1.0]),
            np.array([fit.cx + away[0], fit.cy + away[1], small, fit.sigma,
                      *(np.asarray(offset) - away), small, 1.0])]


def _coefficients(a: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The least-squares coefficients of ``y`` on the columns of ``a``: by the normal equations
    with the columns scaled to unit length (a twentieth of the time NumPy's SVD-based lstsq
    took, which was two thirds of the fits'), by lstsq where they are singular."""
    norm = np.sqrt(np.einsum("ij,ij->j", a, a))
    norm[norm == 0] = 1.0
    b = a / norm
    try:
        from scipy.linalg import cho_factor, cho_solve

        return cho_solve(cho_factor(b.T @ b + 1e-12 * np.eye(b.shape[1])), b.T @ y) / norm
    except np.linalg.LinAlgError:
        return np.linalg.lstsq(a, y, rcond=None)[0]


def _fit(px, fit, starts: Sequence[np.ndarray], held: bool = False) -> _Fitted | None:
    """The frame fitted with the shadow: ``(cx, cy, r, sigma, du, dv, R_s, w)``, its depth, and
    the costs without and with it (residual variances of the fit without: the gain's unit);
    the best from ``starts``; ``held``: the shadow's shape held as the starts have it (only
    the ball's four fitted). None where it fails."""
    from scipy.optimize import least_squares

    memo: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}

    def residual(p: np.ndarray, shape: np.ndarray | None = None) -> np.ndarray:
        p = p if shape is None else np.concatenate([p, shape])
        # the ball's design depends on its four parameters only: the finite differences in
        # the shadow's four reuse it (4865 -> 3347 designs, find_cast 2.1-2.3 -> 1.8-2.1 CPU
        # s, on the 640 x 480 clip of benchmarks/tracking.py)
        key = p[:4].tobytes()
        if key not in memo:
            memo.clear()
            memo[key] = _design(px, fit, p[:2], p[2], p[3])
        a, fixed = memo[key]
        if p.size > 4:
            a = np.column_stack([a, _column(px, a, p)])
        y = px.grey - fixed
        return y - a @ _coefficients(a, y)

    r = fit.r
    base = np.array([fit.cx, fit.cy, fit.r, fit.sigma])
    e0 = residual(base)
    var = float(e0 @ e0) / e0.size
    # the blur within SIGMA_RANGE of the free fit's (free, it traded against the shadow's
    # penumbra and depth under a 1.5 px blur: 2.9 px, the shadow darker than black)
    lo = np.array([fit.cx - 3, fit.cy - 3, 0.7 * r, SIGMA_RANGE[0] * fit.sigma, -1.2 * r,
                   -1.2 * r, 0.5 * r, 0.2])
    hi = np.array([fit.cx + 3, fit.cy + 3, 1.3 * r, SIGMA_RANGE[1] * fit.sigma + 0.1, 1.2 * r,
                   1.2 * r, 1.6 * r, 0.4 * r])
    best, p = None, np.empty(0)
    for p0 in starts:
        p0 = np.clip(p0, lo + 1e-6, hi - 1e-6)
        # held: the shadow's (du, dv, R_s, w) as the start has it, the ball's four fitted
        n, shape = (4, p0[4:]) if held else (8, None)
        try:
            sol = least_squares(residual, p0[:n], bounds=(lo[:n], hi[:n]), x_scale=0.05,
                                max_nfev=60, args=(shape,))
        except (np.linalg.LinAlgError, ValueError):
            continue
        if best is None or sol.cost < best.cost:
            best, p = sol, (sol.x if shape is None else np.concatenate([sol.x, shape]))
    if best is None:
        return None
    a, fixed = _design(px, fit, p[:2], p[2], p[3])
    beta = _coefficients(np.column_stack([a, _column(px, a, p)]), px.grey - fixed)
    return p, float(-beta[-1]), float(e0 @ e0) / var, 2.0 * float(best.cost) / var


def find_cast(args: Sequence[tuple], first: dict
              ) -> tuple[CastShadow, dict[int, np.ndarray], float] | None:
    """The ball's shadow on the wall (:class:`CastShadow`) from the edge model's free fits
    ``first`` (frame index -> :class:`._edge.EdgeFit` or None) of the frames ``args`` (``(img,
    bg, centre, velocity)``), with the ball's centre in each frame where it was found and its
    median radius there (px), or None where none hugs the ball (module docstring)."""
    ok = {i: f for i, f in first.items() if f is not None}
    if len(ok) < 3 or np.median([f.r for f in ok.values()]) < CAST_MIN_RADIUS:
        return None
    pxs = {i: px for i, f in ok.items()
           if (px := _pixels(args[i][0], args[i][1], f, args[i][3])) is not None}
    grid = {i: _grid_gain(px, ok[i]) for i, px in pxs.items()}
    if len(grid) < 3 or float(np.median([g for g, _ in grid.values()])) < CAST_GATE:
        return None
    # the fits with the shadow on the CAST_FRAMES frames where the grid found most
    top = sorted(grid, key=lambda i: -grid[i][0])[:CAST_FRAMES]
    pxs = {i: pxs[i] for i in top}
    got = {i: g for i in top if (g := _fit(pxs[i], ok[i], _starts(ok[i], grid[i][1])))}
    if not got:
        return None
    sided = _one_way_round(pxs, ok, got)
    return None if sided is None else _shape(_consensus(pxs, ok, sided), len(top))


def _one_way_round(pxs: dict, ok: dict, got: dict[int, _Fitted]) -> dict[int, _Fitted] | None:
    """One lamp, one wall: every frame of ``pxs`` fitted again from the shadow of the frame
    that ``got`` fits best, placed alike about each frame's free fit ``ok`` (the grid's offsets
    pointed the wrong way in two frames of a dark ball's five, where the free fits took the
    shadow in), and from its mirror image, the ball where that frame's shadow is and the shadow
    where its ball is (a dark ball and its shadow under a 1.5 px blur: one frame of five fitted
    best with the two swapped); the fits of the way round that fits the frames better, None
    where it is not clear by ``CAST_SIDE`` residual variances a frame."""
    b = max(got, key=lambda i: (_plausible(*got[i][:2]), got[i][2] - got[i][3]))
    pb, fb = got[b][0], ok[b]
    sides: list[dict[int, _Fitted]] = []
    for mirror in (False, True):
        side: dict[int, _Fitted] = {}
        for i, px in pxs.items():
            f = ok[i]
            centre = (f.cx + pb[0] - fb.cx, f.cy + pb[1] - fb.cy)
            start = np.array([*centre, *pb[2:]]) if not mirror else np.array(
                [centre[0] + pb[4], centre[1] + pb[5], pb[2], pb[3], -pb[4], -pb[5], *pb[6:]])
            fits = [g for g in (_fit(px, f, [start]), None if mirror else got.get(i)) if g]
            if fits:
                side[i] = min(fits, key=_cost)
        sides.append(side)
    costs = [sum(_cost(g) for g in side.values()) for side in sides]
    if len(sides[0]) != len(sides[1]) or abs(costs[0] - costs[1]) < CAST_SIDE * len(sides[0]):
        return None  # which is the ball and which its shadow is not clear
    return sides[int(costs[1] < costs[0])]


def _consensus(pxs: dict, ok: dict, sided: dict[int, _Fitted]) -> dict[int, _Fitted]:
    """One lamp, one wall: each frame of ``sided`` whose shadow is not plausible or lies more
    than ``CAST_AGREE`` radii from the median offset of the plausible ones fitted again with
    the shape of each of those that lie within it held (from its ball as fitted with the
    shadow and as its free fit ``ok`` found it), the best kept where it is plausible and gains
    ``CAST_MIN_GAIN`` and ``CAST_SHARE`` of what the frame's own shadow gained."""
    fits = {i: g[0] for i, g in sided.items() if _plausible(*g[:2])}
    if not fits:
        return sided
    middle = np.median(np.array([p[4:6] for p in fits.values()]), axis=0)
    agree = {i: p[4:] for i, p in fits.items()
             if math.hypot(*(p[4:6] - middle)) <= CAST_AGREE * p[2]}
    out = dict(sided)
    for i, g in sided.items():
        if i in agree:
            continue
        p, f = g[0], ok[i]
        tries = [t for shape in agree.values() for ball in (p[:4], (f.cx, f.cy, f.r, f.sigma))
                 if (t := _fit(pxs[i], f, [np.concatenate([ball, shape])], held=True))
                 and _plausible(*t[:2])]
        best = min(tries, key=_cost, default=None)
        if best is not None and best[2] - best[3] >= max(CAST_MIN_GAIN,
                                                         CAST_SHARE * (g[2] - _cost(g))):
            out[i] = best
    return out


def _cost(g: _Fitted) -> float:
    """A frame's cost (residual variances) with the shadow a fit ``g`` found where it can be one
    (:func:`_plausible`), without it where not: what the frames are judged by.

    Judged by the cost with the shadow alone, a fit whose "shadow" brightens the wall beat a
    plausible one and was then left out: on the paper's camera (5 px, a shadow 0.36 radii off,
    60 % dark) two frames of four fitted one 1.2-23 times brighter than the wall, the shadow
    was not held and the radius came out +9.5 %, z 3.9.
    """
    return g[3] if _plausible(*g[:2]) else g[2]


def _shape(got: dict[int, _Fitted], n_frames: int
           ) -> tuple[CastShadow, dict[int, np.ndarray], float] | None:
    """The shadow (the median shape) of the frames ``got`` whose fits with it gain
    ``CAST_MIN_GAIN`` and are plausible, where they are most of the ``n_frames``, most of
    them place it within ``CAST_AGREE`` radii of their median, it takes ``CAST_MIN_DEPTH`` of
    the wall's light or more and lies ``CAST_MIN_OFFSET`` radii or more from the ball's
    centre; their ball centres and median radius. None where not."""
    kept = {i: (*p[4:], depth, p[2]) for i, (p, depth, cost0, cost1) in got.items()
            if cost0 - cost1 >= CAST_MIN_GAIN and _plausible(p, depth)}
    if 2 * len(kept) <= n_frames:
        return None
    shape = np.median(np.array(list(kept.values())), axis=0)
    agree = [i for i, k in kept.items()
             if math.hypot(k[0] - shape[0], k[1] - shape[1]) <= CAST_AGREE * shape[5]]
    if 2 * len(agree) <= n_frames:
        return None
    du, dv, radius, penumbra, depth, ball = (
        float(x) for x in np.median(np.array([kept[i] for i in agree]), axis=0))
    if depth < CAST_MIN_DEPTH or math.hypot(du, dv) < CAST_MIN_OFFSET * ball:
        return None
    return (CastShadow(du, dv, radius, penumbra, depth), {i: got[i][0][:2] for i in agree},
            ball)


def _plausible(p: np.ndarray, depth: float) -> bool:
    """Whether a fit's shadow ``p[4:]`` (px) with ``depth`` can be one: it darkens the wall
    (not beyond black; a small ball's by ``SMALL_CAST_DEPTH`` at least) and shows beyond the
    ball's rim ``p[2]``."""
    least = SMALL_CAST_DEPTH if p[2] < SMALL_CAST_RADIUS else 0.05
    return least <= depth <= 1.0 and math.hypot(p[4], p[5]) + p[6] > p[2] + p[7]


def at_centres(args: Sequence[tuple], centres: dict[int, np.ndarray]
               ) -> tuple[list[tuple[Any, Any, Any, Any]], np.ndarray]:
    """The frames ``args`` (``(img, bg, centre, velocity)``) with each centre the one found with
    the shadow (``centres``) or, elsewhere, moved by their median offset from the centres
    given; and that offset (px)."""
    shift = np.median([np.asarray(c, dtype=float) - np.asarray(args[i][2], dtype=float)
                       for i, c in centres.items()], axis=0)
    moved = [(img, bg, np.asarray(centres.get(i, np.asarray(c, dtype=float) + shift)), v)
             for i, (img, bg, c, v) in enumerate(args)]
    return moved, shift
