"""Tracking the ball through the frames: settings, background model, per-frame results."""

from __future__ import annotations

import dataclasses

import functools
import math
from dataclasses import dataclass, field
from typing import Any, Literal, get_args

import numpy as np

from .._validate import check_choice, check_scalar
from ._edge import JOINT_FIT, SMALL_BALL_FIT, RadiusFit, spread
from ._camera import stabilise
from ._measure import CENTROID, EDGE_FIT, GAIN_GRID, NOT_FOUND, _edge_fit, _gain, _Searcher
from ._quality import edge_offset, fit_ball_radius, frame_quality, refit_misfit
from ._timing import FrameTiming, frame_timing, lost_at_bounces, same_picture
from ._tone import check_tone_curve, decode, decode_table

TIMING_SD_PX = 0.2  # the centres' SD taken for the frames' timing where the edge model has none

Polarity = Literal["auto", "bright", "dark"]
POLARITIES: tuple[str, ...] = get_args(Polarity)


@dataclass(frozen=True, kw_only=True)
class TrackerConfig:
    """Settings of :func:`track_ball`, checked on construction.

    Attributes:
        polarity: ``"bright"`` ball brighter than its surroundings, ``"dark"`` darker, or
            ``"auto"`` (the sign of the strongest background differences). With a dark ball,
            shadows cannot be told from the ball by grey level.
        background_frames: frames (evenly spaced) in the per-pixel median background model.
        threshold_sigma: detection threshold in units of the background-difference noise.
        min_contrast: detection threshold floor, and smallest ball-background contrast, in grey
            levels (of the frames decoded to light where ``tone_curve`` is not linear).
        min_visible: smallest fraction of the ball's area in the frame for a frame to count.
        max_radius_change: largest relative difference from the median radius for a ball wholly
            in the frame (a larger one means something else was found).
        edge_model: fit the ball's radius (and so the ``--ball-diameter`` scale) with the
            edge model of :mod:`bouncebayes.tracking._edge` on a subset of frames; False: the
            median coverage radius (biased by blur and uneven lighting).
        tone_curve: how the camera stored light as grey levels: ``"linear"`` (raw and most
            machine-vision cameras), ``"srgb"``, ``"rec709"`` (the BT.709 camera curve of
            consumer video) or a gamma from 1 to 4 (stored = light^(1/gamma)); the frames
            (and a ``background`` given) are decoded to light before anything else
            (:mod:`._tone`). None (not given): taken as linear, and a lossy-coded file scaled
            from the ball's diameter gets a warning (:func:`tone_curve_warning`). A curve
            taken as linear that is not scales a bright ball of 10-15 px 1-5 % large and a
            dark one 2-8 % small under lens blur, up to 15 % at 5 px (docs/tracking.md §3).
    """

    polarity: Polarity = "auto"
    background_frames: int = 25
    threshold_sigma: float = 5.0
    min_contrast: float = 12.0
    min_visible: float = 0.25
    max_radius_change: float = 0.25
    edge_model: bool = True
    tone_curve: str | float | None = None  # one of TONE_CURVES, a gamma, or None (checked)

    def __post_init__(self):
        check_choice("polarity", self.polarity, POLARITIES)
        if (isinstance(self.background_frames, bool)
                or not isinstance(self.background_frames, int) or self.background_frames < 3):
            raise ValueError("`background_frames` must be an integer >= 3; got "
                             f"{self.background_frames!r}")
        check_scalar("threshold_sigma", self.threshold_sigma, low=0.0, low_open=True)
        check_scalar("min_contrast", self.min_contrast, unit="grey levels", low=0.0,
                     low_open=True)
        check_scalar("min_visible", self.min_visible, low=0.0, high=1.0, low_open=True)
        check_scalar("max_radius_change", self.max_radius_change, low=0.0, low_open=True)
        if not isinstance(self.edge_model, bool):
            raise TypeError(f"`edge_model` must be True or False; got {self.edge_model!r}")
        object.__setattr__(self, "tone_curve", check_tone_curve("tone_curve", self.tone_curve))


@dataclass(frozen=True)
class Track:
    """Per-frame result of :func:`track_ball` (pixels; origin top-left, ``v`` down).

    ``centre`` ``(n, 2)`` and ``radius`` ``(n,)`` are NaN where ``method == NOT_FOUND``;
    ``method`` is ``CENTROID`` (ball wholly in view) or ``EDGE_FIT`` (cut by the frame edge);
    ``contrast`` is the ball's rim contrast against the background (grey levels); ``noise`` the
    background-difference noise (grey levels, robust standard deviation).

    Per-frame quality: ``residual`` (RMS misfit of a disk of the ball's radius to the frame's
    coverage, grey levels), ``visible`` (fraction of the ball's disk inside the frame) and
    ``flag`` (the ball model fits badly: part of the ball hidden or indistinguishable from the
    background -- an unlit rim against a lit band, a shadow, an occluder; or the per-frame
    centre fit's residual stands out, :func:`._quality.refit_misfit`); NaN / False where not
    found. ``radius_fit``: the ball's radius from its edge (:mod:`._edge`) with its standard
    error, None where no frame could be fitted (then :attr:`ball_radius` is the median
    coverage radius). ``centre_offset``: the shift (px) applied to every coverage centroid so
    that they agree with the edge fits (a constant bias of the centroid under side light).
    ``refined``: frames whose centre is a blurred, shaded disk fitted to the frame instead of
    the coverage centroid or the disk fit at the frame edge (:mod:`._refine`: a small ball's
    whole disk, a larger ball's rim; the centroids' offset does not apply to them);
    ``refined_offset``: the shift (px) applied to a larger ball's refined centres so that they
    agree with the edge fits (a small ball's: none). ``tone_curve``: the camera's tone curve
    the frames were decoded by (``TrackerConfig.tone_curve``, None: not given, taken as
    linear; ``background``, ``contrast``, ``noise`` and ``threshold`` are in decoded grey
    levels). ``camera_shift`` ``(n, 2)``: how far (px) the camera had moved in each frame
    against the background, the frames moved back by it before anything was measured
    (:mod:`._camera`; zeros where it did not move, and the centres are in the background's
    pixels); ``camera_turn`` ``(n, 2)``: how far it had turned (degrees, about the frame's
    centre) and zoomed (the field of view wider by, a fraction), moved back likewise
    (:func:`._camera.turn_and_zoom`). ``timing``: each frame's place in the camera's sequence
    where frames were lost or repeated (:mod:`._timing`; the repeated frames are flagged;
    None: every frame at ``k / fps``, as a track made before).
    """

    centre: np.ndarray
    radius: np.ndarray
    method: np.ndarray
    contrast: np.ndarray
    background: np.ndarray = field(repr=False)
    polarity: str
    noise: float
    threshold: float
    residual: np.ndarray = field(default_factory=lambda: np.zeros(0))
    visible: np.ndarray = field(default_factory=lambda: np.zeros(0))
    flag: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    radius_fit: RadiusFit | None = None
    centre_offset: tuple[float, float] = (0.0, 0.0)
    refined: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    refined_offset: tuple[float, float] = (0.0, 0.0)
    tone_curve: str | float | None = None
    camera_shift: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    camera_turn: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    timing: FrameTiming | None = None

    @property
    def found(self) -> np.ndarray:
        return self.method != NOT_FOUND

    @property
    def ball_radius(self) -> float:
        """The ball's radius (px): from its edge (``radius_fit``), else the median coverage
        radius over the frames where the ball is wholly in view."""
        if self.radius_fit is not None:
            return self.radius_fit.radius
        whole = self.method == CENTROID
        return float(np.median(self.radius[whole])) if whole.any() else math.nan

    @property
    def ball_radius_se(self) -> float:
        """Standard error of :attr:`ball_radius` (px); NaN where it has none."""
        return self.radius_fit.radius_se if self.radius_fit is not None else math.nan

    @property
    def trusted(self) -> np.ndarray:
        """Found and not flagged."""
        return self.found & ~self.flag if self.flag.size else self.found


def background_model(frames: np.ndarray, n_frames: int = 25) -> np.ndarray:
    """Per-pixel median of ``n_frames`` evenly spaced frames, float32 ``(h, w)``; where their
    brightness relative to it (``_measure._gain``) spreads by more than ``GAIN_SPREAD`` (lamp
    flicker), the median of the frames each divided by its brightness instead: the median of
    frames lit unequally is as uncertain as their spread (a rendered wall of 50 +- 10 grey
    levels under a +-12 % flicker at 100 Hz: the surface detected 0.28 degrees off, 2.3 times
    its SD; 0.10 degrees, 1.1 SD, with this)."""
    idx = _background_index(len(frames), n_frames)
    bg = _median_image([frames[int(i)] for i in idx])
    gains = np.array([_gain(frames[int(i)], bg) for i in idx])
    if np.ptp(gains) <= GAIN_SPREAD:
        return bg
    return _median_image([(frames[int(i)] / g).astype(np.float32)
                          for i, g in zip(idx, gains, strict=True)])


GAIN_SPREAD = 0.01  # the frames' gains spread by more: the background's median of frames / gain


def _median_image(rows: list[np.ndarray]) -> np.ndarray:
    """Per-pixel median of the images ``rows`` (all uint8 or all float32), float32. Equal to
    ``np.median(rows, axis=0)``, 8x faster: a sorting network of element-wise minima and
    maxima (Batcher's odd-even merge sort, pruned to the middle elements)."""
    n = len(rows)
    size, pairs = _median_network(n)
    top = 255 if rows[0].dtype == np.uint8 else np.inf
    rows = list(rows) + [np.full(rows[0].shape, top, rows[0].dtype)] * (size - n)
    for a, b in pairs:
        rows[a], rows[b] = np.minimum(rows[a], rows[b]), np.maximum(rows[a], rows[b])
    return (rows[(n - 1) // 2].astype(np.float32) + rows[n // 2]) / 2


def _background_index(n_frames: int, n: int) -> np.ndarray:
    """The frames of the background model: ``n`` evenly spaced over ``n_frames``."""
    return spread(n_frames, n)


MIN_CLEAR = 5  # frames clear of the ball a pixel's ball-free background needs (else the median)
# Frames (evenly spaced) of the ball-free background: more than the median's 25, because the
# edge model's cost falls where the background's noise is left out (the pixels the ball covers
# do not see it), so that noise pushes the radius up along the cost's flat direction: dark
# ball, radius 10 px, blur 1.5 px, plain wall, noise 3.3 grey levels: +5.4 % with 25 frames,
# +0.5 % with 75, +0.2 % with 90 (benchmarks/tracking_accuracy.py; docs/tracking.md §3). What
# noise remains (pi / (2 m) of a frame's variance, m the frames clear of the pixel) the edge
# model's weights take in (._edge_kernel.varpro, the map from :func:`median_variance`).
CLEAN_FRAMES = 75
TILE = 32  # px: the ball-free background is computed tile by tile (a tile's frames copied)


def median_variance(m):
    """The variance of the median of ``m`` samples of a normal noise, in units of one
    sample's: ``pi / (2 m)`` (its large-``m`` limit; within 10 % of the exact one from ``m =
    5``, 0.287 against 0.314)."""
    return 0.5 * math.pi / np.asarray(m, np.float64)


def _ball_free_background(frames, bg64, gains, centre, radius, config):
    """A function ``clean(centres)``: the background model (float64) recomputed around the
    ball's positions ``centres`` (px; within ``1.25 r + 12 px`` of them, where the edge and
    centre fits read; each pixel once over the calls, the same array returned), and its
    variance in units of a frame's noise variance (:func:`median_variance` of the frames
    each pixel's median took; a map, for the edge model's weights), from
    ``CLEAN_FRAMES`` evenly spaced frames in which the ball is clear of the pixel
    (:func:`._fast.ball_free_background`): farther than ``1.25 r + 6 px + d / 2`` from its
    centre (``r`` the median coverage radius, ``d`` the largest move between frames:
    the blur's and the exposure's reach beyond the rim). Where the ball is found in fewer than
    two frames, the background model as it is."""
    from . import _fast

    # each pixel's count of frames in its median: the background model's own until recomputed
    count = np.full(bg64.shape, float(min(config.background_frames, len(frames))))
    kappa = median_variance(count)  # kept: updated in place as pixels are computed
    found = ~np.isnan(centre[:, 0])
    if found.sum() < 2:
        return lambda centres: (bg64, kappa)
    r = float(np.nanmedian(radius))
    step = np.hypot(*np.diff(centre[found], axis=0).T)
    reach = 1.25 * r + 6.0 + 0.5 * float(np.max(step, initial=0.0))
    idx = _background_index(len(frames), max(config.background_frames, CLEAN_FRAMES))
    frames = np.ascontiguousarray(frames)
    at = np.ascontiguousarray(centre[idx])
    half = 1.25 * r + 12.0
    out, done = bg64.copy(), np.zeros(bg64.shape, bool)  # kept: each pixel computed once

    def clean(centres: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        around = np.ascontiguousarray(np.asarray(centres, np.float64).reshape(-1, 2))
        _fast.ball_free_background(frames, idx, gains, out, count, done, at, reach, MIN_CLEAR,
                                   around, half, TILE)
        kappa[:] = median_variance(count)
        return out, kappa

    return clean


@functools.lru_cache
def _median_network(n: int) -> tuple[int, tuple[tuple[int, int], ...]]:
    """Comparators of an odd-even merge sort of ``n`` values padded (with the largest value)
    to a power of two, keeping only those that decide the middle elements."""
    size = 1 << max(0, (n - 1).bit_length())
    pairs = []
    p = 1
    while p < size:
        k = p
        while k >= 1:
            for j in range(k % p, size - k, 2 * k):
                pairs += [(i + j, i + j + k) for i in range(min(k, size - j - k))
                          if (i + j) // (2 * p) == (i + j + k) // (2 * p)]
            k //= 2
        p *= 2
    need, kept = {(n - 1) // 2, n // 2}, []
    for a, b in reversed(pairs):
        if a in need or b in need:
            kept.append((a, b))
            need |= {a, b}
    return size, tuple(reversed(kept))


def track_ball(frames: np.ndarray, *, config: TrackerConfig = TrackerConfig(),
               background: np.ndarray | None = None) -> Track:
    """Find the ball in every frame with sub-pixel accuracy (see the package docstring).

    Arguments:
        frames: grey frames ``(n, height, width)`` uint8, e.g. ``read_frames(path).frames``.
        config: detection settings.
        background: an image of the scene without the ball ``(height, width)``; default: the
            per-pixel median of ``config.background_frames`` frames.
    """
    return _track_ball(frames, config, background, compiled=True)


def _track_ball(frames, config: TrackerConfig, background, *, compiled: bool) -> Track:
    """:func:`track_ball`; ``compiled``: the per-frame path of :mod:`._fast`, else the Python
    path of :mod:`._measure` (the reference it is tested against, and the benchmark's)."""
    frames, background = _decoded(frames, background, config)
    # the frames moved back onto the background's pixels where the camera moved (._camera)
    frames, bg, camera, turn = stabilise(frames,
                                         functools.partial(_background, background, config))
    noise, sign = _noise_and_polarity(frames, bg, config)
    threshold = max(config.threshold_sigma * noise, config.min_contrast)
    state = _Searcher(bg, sign, threshold)
    if compiled:
        from . import _fast

        frames = np.ascontiguousarray(frames)
        kern = _fast.gaussian_kernel()
        # fixed argument types: numba compiles (and caches) one version of each kernel
        raw, border, gains = _fast.measure_frames(frames, state.bg64, state.bg_small,
                                                  int(state.f), int(sign), float(threshold),
                                                  kern, GAIN_GRID)
        state.gains = gains.tolist()

        def edge_fit(idx, centre, r_med):
            return _fast.edge_fits(frames, state.bg64, gains, int(sign), float(threshold),
                                   idx.astype(np.int64), np.ascontiguousarray(centre),
                                   float(r_med), float(config.min_visible), kern)
    else:
        measures = [state.measure(frame) for frame in frames]
        raw = np.array([(m.cx, m.cy, m.r, m.contrast) if m else (np.nan,) * 4
                        for m in measures]).reshape(-1, 4)
        border = np.array([m is not None and m.border for m in measures], bool)

        def edge_fit(idx, centre, r_med):
            fits = [_edge_fit(frames[k], state, state.gains[k], centre[k], r_med,
                              config.min_visible) for k in idx.tolist()]
            return np.array([(np.nan, np.nan) if c is None else c for c in fits]).reshape(-1, 2)
    centre, radius, method, contrast = _finish(raw, border, edge_fit, config)
    residual, visible, flag = frame_quality(frames, state, centre, radius, method, contrast,
                                            compiled=compiled)
    fitted, misfit = _fit_ball(frames, state, background is not None, centre, radius, method,
                               flag, contrast, config, noise)
    flag = flag | misfit
    # lost and repeated frames, told by the ball's steps (the repeated ones flagged)
    timing = _frame_timing(frames, centre, radius, (method != NOT_FOUND) & ~flag,
                           fitted["radius_fit"], noise)
    flag = flag | timing.repeated
    for a in (centre, radius, method, contrast, residual, visible, flag, fitted["refined"],
              camera, turn, *timing):
        a.setflags(write=False)
    return Track(centre=centre, radius=radius, method=method, contrast=contrast, background=bg,
                 polarity="bright" if sign > 0 else "dark", noise=noise, threshold=threshold,
                 residual=residual, visible=visible, flag=flag, tone_curve=config.tone_curve,
                 camera_shift=camera, camera_turn=turn, timing=timing, **fitted)


def _frame_timing(frames: np.ndarray, centre: np.ndarray, radius: np.ndarray,
                  usable: np.ndarray, fit: RadiusFit | None, noise: float) -> FrameTiming:
    """:func:`._timing.frame_timing` of the centres of the ``usable`` frames, with the edge
    fits' SD, and the pixels about the ball (the edge model's radius, or the median found) to
    tell a repeated picture by."""
    found = radius[np.isfinite(radius)]
    typical = fit.radius if fit is not None else float(np.median(found)) if found.size else 10.0
    return frame_timing(centre, usable, _timing_sd(fit), same_picture(frames, centre, typical,
                                                                      noise))


def _timing_sd(fit: RadiusFit | None) -> float:
    """The centres' SD (px) the frames' timing takes: the edge fits', else ``TIMING_SD_PX``."""
    return fit.centre_sd if fit is not None else TIMING_SD_PX


def timed_at_bounces(track: Track, along: np.ndarray, normal: np.ndarray) -> Track:
    """``track`` with the frames lost at its bounces told (:func:`._timing.lost_at_bounces`;
    ``along`` and ``normal``: image unit vectors along the surface and normal to it)."""
    if track.timing is None:
        return track
    timing = lost_at_bounces(track.timing, track.centre, track.found & ~track.flag, along,
                             normal, _timing_sd(track.radius_fit))
    if timing is track.timing:
        return track
    for a in timing:
        a.setflags(write=False)
    return dataclasses.replace(track, timing=timing)


def _decoded(frames, background, config: TrackerConfig
             ) -> tuple[np.ndarray, np.ndarray | None]:
    """The frames and the background given (or None), checked, and decoded to light by the
    tone curve where one is given (:mod:`._tone`)."""
    frames = _check_frames(frames)
    if background is not None:
        background = _check_background(background, frames.shape[1:])
    if (table := decode_table(config.tone_curve)) is not None:  # light, not grey (._tone)
        frames = table[frames]
        if background is not None:
            background = decode(background, config.tone_curve).astype(np.float32)
    return frames, background


def _background(given: np.ndarray | None, config: TrackerConfig, frames: np.ndarray
                ) -> np.ndarray:
    """The background ``given``, else the model of ``frames`` (:func:`background_model`)."""
    return given if given is not None else background_model(frames, config.background_frames)


def _fit_ball(frames, state, given: bool, centre, radius, method, flag, contrast, config,
              noise: float) -> tuple[dict[str, Any], np.ndarray]:
    """The fits after the search, on ``centre`` (moved in place): the edge model's radius
    (:func:`._quality.fit_ball_radius`; ``noise`` the frames', grey levels), its centres'
    offset to the centroids, and the per-frame centre fits (:func:`._refine.refine_centres`). They get the background with the
    ball left out around where they look (:func:`_ball_free_background`), or the one given
    (``given``) as it is. Returns :class:`Track`'s fields of them: ``radius_fit``,
    ``centre_offset`` (the centroids'), ``refined`` (the mask of refined frames) and
    ``refined_offset``; and the mask of the frames whose per-frame fit misfits (to be flagged:
    :func:`._quality.refit_misfit`)."""
    from ._refine import SMALL_RADIUS, refine_centres, stated_centre_sd

    gains = np.asarray(state.gains, np.float64)
    shift = (0.0, 0.0)
    # a background given is taken as exact (its noise is not known)
    clean = (lambda centres: (state.bg64, np.zeros(state.bg64.shape))) if given else \
        _ball_free_background(frames, state.bg64, gains, centre, radius, config)
    fit, offset = fit_ball_radius(frames, clean, gains, centre, method, flag, radius,
                                  noise) if \
        config.edge_model else (None, (0.0, 0.0))
    centre[method == CENTROID] += offset
    small = refine_centres(frames, clean, gains, centre, method, fit)
    refined, misfit = small.done, refit_misfit(small.rms, contrast)
    if refined.any() and fit is not None:
        # the refined centres' SD, not the centroids' (of all of them: SE_FACTOR was set so;
        # without the frames flagged for their misfit, the paper's camera's clips of
        # benchmarks/paper_camera.py had their rebound angles' z up to 2.5 against 2.2)
        fit = fit._replace(centre_sd=stated_centre_sd(small.se[refined]))
        if fit.radius > SMALL_RADIUS:
            # a larger ball keeps the edge model's radius, and its refined centres take the
            # edge fits' mean position (the cut-down shading leaves a constant bias: a glossy
            # ball's highlight 0.1-0.4 px), as the centroids do
            # (the frames flagged for their misfit left out: partly hidden, they disagree)
            shift, spread_px = edge_offset(fit, centre, refined & ~misfit)
            centre[refined] += shift
            # their stated SD at least their disagreement with the edge fits' centres, which
            # the formal errors miss where the model does not hold (a mark on the ball)
            fit = fit._replace(centre_sd=max(fit.centre_sd, spread_px))
        else:
            # a small ball's radius is the small-ball fit's (at 5 px RMS error 1.7 % against
            # the edge model's 3.6 %: SMALL_FIT_SYSTEMATIC_PX), and its light; but not where
            # its frames fitted together with the blur free held it (JOINT_FIT: 5 px under a
            # 1.5 px blur on a textured wall, the small-ball fit at that blur -2.0 % where the
            # joint fit was -0.6 %)
            if math.isfinite(small.radius_se) and fit.method != JOINT_FIT:
                fit = fit._replace(radius=small.radius, radius_se=small.radius_se,
                                   method=SMALL_BALL_FIT)
            if small.light is not None and small.light[1] < fit.light[1]:
                fit = fit._replace(light=small.light)
    return {"radius_fit": fit, "centre_offset": offset, "refined": refined,
            "refined_offset": shift}, misfit


def _check_frames(frames) -> np.ndarray:
    if not isinstance(frames, np.ndarray) or frames.dtype != np.uint8 or frames.ndim != 3:
        desc = (f"an array of dtype {frames.dtype} and shape {frames.shape}"
                if isinstance(frames, np.ndarray) else type(frames).__name__)
        raise TypeError(f"`frames` must be a uint8 array (n_frames, height, width) of grey "
                        f"frames; got {desc}")
    if min(frames.shape) < 1:
        raise ValueError(f"`frames` is empty; got shape {frames.shape}")
    return frames


def _check_background(background, shape) -> np.ndarray:
    bg = np.asarray(background, dtype=np.float32)
    if bg.shape != tuple(shape):
        raise ValueError(f"`background` must have the frames' shape {tuple(shape)} (height, "
                         f"width); got {bg.shape}")
    return bg


def _noise_and_polarity(frames, bg, config) -> tuple[float, int]:
    """Robust noise of ``frame - background`` and the ball's sign (+1 bright, -1 dark)."""
    idx = np.linspace(0, len(frames) - 1, min(len(frames), 9)).round().astype(int)
    sub = bg[::2, ::2]
    diff = np.stack([frames[k, ::2, ::2].astype(np.float32) - _gain(frames[k], bg) * sub
                     for k in idx])
    noise = float(1.4826 * np.median(np.abs(diff)))
    if config.polarity != "auto":
        return noise, 1 if config.polarity == "bright" else -1
    strong = np.abs(diff) > max(config.threshold_sigma * noise, config.min_contrast)
    energy = np.where(strong, diff * diff, 0.0)
    return noise, 1 if energy[diff > 0].sum() >= energy[diff < 0].sum() else -1



def _finish(raw: np.ndarray, border: np.ndarray, edge_fit, config: TrackerConfig):
    """Arrays from the per-frame measures (``raw``: centre x, y, coverage radius, contrast;
    NaN where not found); edge fits (``edge_fit(idx, centre, radius)``: centres, NaN where
    refused) for balls cut by the frame edge; checks."""
    found = ~np.isnan(raw[:, 0])
    centre = raw[:, :2].copy()
    radius = raw[:, 2].copy()
    contrast = raw[:, 3].copy()
    method = np.where(found, np.where(border, EDGE_FIT, CENTROID), NOT_FOUND).astype(np.int8)
    whole = method == CENTROID
    if not whole.any():
        method[:] = NOT_FOUND
    else:
        r_med = float(np.median(radius[whole]))
        bad = whole & (np.abs(radius / r_med - 1.0) > config.max_radius_change)
        method[bad] = NOT_FOUND
        idx = np.flatnonzero(method == EDGE_FIT)
        if len(idx):
            fits = edge_fit(idx, centre, r_med)
            refused = np.isnan(fits[:, 0])
            method[idx[refused]] = NOT_FOUND
            centre[idx[~refused]], radius[idx[~refused]] = fits[~refused], r_med
    lost = method == NOT_FOUND
    centre[lost], radius[lost] = np.nan, np.nan
    return centre, radius, method, contrast
