"""The camera's motion: each frame's shift against the background model, and the frames moved
back onto the background's pixels.

A camera standing on the table the ball strikes shakes after the impact; a hand-held one
drifts. The background model (a per-pixel median) then matches no frame: the background
differences fill with the wall's texture, and the centres carry the camera's motion (the
kinematics reject such a flight: a smooth pattern in its residuals). Each frame's shift ``d``
(px) and brightness ``g`` against the background ``B``, ``I(p) = g B(p + d)``, are fitted on a
grid of about ``GRID`` pixels by a Gauss-Newton step from ``d = 0`` (Lucas & Kanade 1981: the
background's gradient), with the grid's pixels that misfit by more than ``OUTLIER`` robust SDs
(the ball, its shadow) left out and a ridge that holds a shift the background does not show
at zero (a plain wall shows a shift only across its edges). Where frames moved (:func:`moved`),
the shifts are fitted again on
``FINE_GRID`` pixels (a shift's error falls as one over the root of the pixels: on a rendered
wall of 50 +- 10 grey levels, noise 2 grey levels, 0.04-0.06 px per frame from 2000 pixels,
which moved every frame's centres by as much), every frame that moved by ``SIGNIFICANT``
standard errors is resampled (bicubic) back onto the background's pixels, the background model
made again from the moved frames and the remaining shifts fitted against it, up to ``ROUNDS``
times (one Gauss-Newton step is ~10 % short of a shift of 0.5 px): the centres are then in
the scene's pixels, and ``Track.camera_shift`` holds each frame's shift.

Where the camera moved, the frames are held as float32 while they are moved (four times their
memory as grey uint8) and rounded back at the end.

Written here because OpenCV's registration (``findTransformECC``, ``phaseCorrelate``) works on
whole images, ~5-20 ms a frame at 640 x 480: the whole budget of the tracker's 1000 frames/s;
this reads 2000 pixels of each frame (25-50 us a frame at 224 x 64 and 640 x 480), and the
whole frames only where the camera moved.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

GRID = 2000       # pixels of each frame the shift is looked for on
FINE_GRID = 40000  # ... and fitted on where the camera moved
CHUNK = 32        # frames fitted at a time (the grid's values of CHUNK frames in memory)
MARGIN = 3        # px: the grid keeps this far from the frame's edge
OUTLIER = 4.0     # robust SDs: a grid pixel that misfits by more is left out (the ball)
PRIOR_PX = 2.0    # px: the ridge's scale, a shift's prior SD in each round
# The camera moved where MOVED_FRAMES frames or more shifted by more than MOVED_PX and MOVED_SE
# standard errors. Still cameras on tests/render_pbr.py's scenes (radius 5-15 px, blur 0-1.5
# px, three lightings, textured and plain walls, MJPEG and MPEG-4; 39 clips) reach 5.3 standard
# errors (0.3-0.55 px on a plain wall, where the ball's path left in the median background is
# all the texture there is; a textured wall's at most 0.12 px)
MOVED_PX = 0.05
MOVED_SE = 8.0
MOVED_FRAMES = 2
ROUNDS = 4        # resampling rounds at most; they stop once no frame moves significantly:
SIGNIFICANT = 3.0  # by more than this many standard errors


def frame_shifts(frames: np.ndarray, bg: np.ndarray, grid: int = GRID
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Each frame's shift ``d`` (px, ``(n, 2)``: ``I(p) = g B(p + d)``) against the background
    ``bg`` and its standard error ``(n, 2)``: one Gauss-Newton step from ``d = 0, g`` the
    frame's median ratio to ``bg``, on a grid of about ``grid`` pixels."""
    n, h, w = frames.shape
    step = max(1, math.ceil(math.sqrt(h * w / grid)))
    ys, xs = np.mgrid[MARGIN:h - MARGIN:step, MARGIN:w - MARGIN:step]
    ys, xs = ys.ravel(), xs.ravel()
    if ys.size < 16:
        return np.zeros((n, 2)), np.full((n, 2), math.inf)
    b64 = np.asarray(bg, dtype=np.float64)
    gy, gx = (np.asarray(a) for a in np.gradient(b64))
    b, bx, by = b64[ys, xs], gx[ys, xs], gy[ys, xs]
    out = [_shifts(frames[k:k + CHUNK, ys, xs].astype(np.float64), b, bx, by)
           for k in range(0, n, CHUNK)]
    return np.concatenate([o[0] for o in out]), np.concatenate([o[1] for o in out])


def _shifts(f: np.ndarray, b: np.ndarray, bx: np.ndarray, by: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray]:
    """:func:`frame_shifts` of the frames' grid values ``f`` ``(n, m)``, the background's
    ``b`` and its gradient ``bx, by`` there ``(m,)``. The gain's start and the residuals'
    robust SD from every ``SPARSE``-th of them (the gain is fitted with the shift)."""
    n = len(f)
    ok = b > 8.0
    ok[np.arange(b.size) % SPARSE != 0] = False
    g = np.median(f[:, ok] / b[ok], axis=1) if ok.sum() > 16 else np.ones(n)
    r = f - g[:, None] * b
    scale = 1.4826 * np.median(np.abs(r[:, ::SPARSE]), axis=1) + 1e-6
    keep = np.abs(r) <= OUTLIER * scale[:, None]
    rk = np.where(keep, r, 0.0)
    k = keep.astype(np.float64)
    # the normal equations of (dg, g du, g dv): sums over the kept pixels, one product each
    bb, bu, bv = k @ (b * b), k @ (b * bx), k @ (b * by)
    uu, uv, vv = k @ (bx * bx), k @ (bx * by), k @ (by * by)
    normal = np.stack([np.stack([bb, bu, bv], -1), np.stack([bu, uu, uv], -1),
                       np.stack([bv, uv, vv], -1)], -2)
    normal[:, 1:, 1:] *= g[:, None, None] ** 2
    normal[:, 0, 1:] *= g[:, None]
    normal[:, 1:, 0] *= g[:, None]
    noise2 = scale**2
    normal[:, 1, 1] += noise2 / PRIOR_PX**2
    normal[:, 2, 2] += noise2 / PRIOR_PX**2
    rhs = np.stack([rk @ b, g * (rk @ bx), g * (rk @ by)], -1)
    try:
        delta = np.linalg.solve(normal, rhs[..., None])[..., 0]
        cov = np.linalg.inv(normal)
    except np.linalg.LinAlgError:
        return np.zeros((n, 2)), np.full((n, 2), math.inf)
    se = np.sqrt(noise2[:, None] * np.stack([cov[:, 1, 1], cov[:, 2, 2]], axis=1))
    return delta[:, 1:], se


SPARSE = 4  # every SPARSE-th grid pixel for the gain's start and the residuals' robust SD


def moved(shifts: np.ndarray, se: np.ndarray) -> bool:
    """Whether the camera moved: ``MOVED_FRAMES`` frames or more shifted by more than
    ``MOVED_PX`` and ``MOVED_SE`` standard errors."""
    size = np.abs(shifts)
    return int(np.any((size > MOVED_PX) & (size > MOVED_SE * se), axis=1).sum()) >= MOVED_FRAMES


def shift_frames(frames: np.ndarray, shifts: np.ndarray) -> np.ndarray:
    """Each frame resampled onto the background's pixels (float32): frame ``k`` at ``p -
    d_k``, so that a frame with ``I(p) = g B(p + d)`` becomes ``g B(p)``; Keys' cubic
    convolution (``a = -0.5``), separable, the frame's edge replicated; a frame not moved as
    it is. By hand because OpenCV's ``warpAffine`` places its samples to 1/32 px only (a frame
    shifted by 0.005 px moved by 0.03, and a still camera's centres with it)."""
    out = frames.astype(np.float32)
    for k, (du, dv) in enumerate(shifts):
        if du != 0.0 or dv != 0.0:
            out[k] = _cubic_shift(_cubic_shift(out[k], float(du), axis=1), float(dv), axis=0)
    return out


def _cubic_shift(img: np.ndarray, d: float, axis: int) -> np.ndarray:
    """``img`` moved by ``d`` px along ``axis``: ``out[p] = img[p - d]`` by cubic convolution."""
    s = -d
    n = math.floor(s)
    t = s - n
    w = (((-0.5 * t + 1.0) * t - 0.5) * t, (1.5 * t - 2.5) * t * t + 1.0,
         ((-1.5 * t + 2.0) * t + 0.5) * t, (0.5 * t - 0.5) * t * t)
    pad = abs(n) + 2
    wide = np.pad(img, [(pad, pad) if a == axis else (0, 0) for a in range(2)], mode="edge")
    size = img.shape[axis]
    out = np.zeros_like(img)
    for j, wj in enumerate(w):
        start = pad + n - 1 + j
        out += np.float32(wj) * np.take(wide, np.arange(start, start + size), axis=axis)
    return out


def stabilise(frames: np.ndarray, background: Callable[[np.ndarray], np.ndarray]
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The frames moved back onto the background's pixels where the camera moved, the
    background model ``background(frames)`` of them, and each frame's shift (px, ``(n, 2)``;
    zeros and the frames as given where it did not move)."""
    bg = background(frames)
    total = np.zeros((len(frames), 2))
    if not moved(*frame_shifts(frames, bg)):
        return frames, bg, total
    moved_frames = None
    shifts, se = frame_shifts(frames, bg, FINE_GRID)
    for _ in range(ROUNDS):
        # a frame moved only where its shift tells: a still camera's frames stay as they are
        step = np.where(np.abs(shifts) > SIGNIFICANT * se, shifts, 0.0)
        if not step.any():
            break
        total += step
        # the rounds on unrounded frames: rounded to grey levels, a shift of a few hundredths
        # of a pixel vanishes from a wall's gentle texture (0.01 px: none of it measured
        # again; 0.05 px: 0.015), and the rounds could not take out what the first left
        moved_frames = shift_frames(frames, total)
        bg = background(moved_frames)
        shifts, se = frame_shifts(moved_frames, bg, FINE_GRID)
    if moved_frames is None:  # no frame's fine shift tells: as given
        return frames, bg, total
    out = rounded(moved_frames)
    return out, background(out), total


def rounded(frames: np.ndarray) -> np.ndarray:
    """Frames moved back (:func:`shift_frames`) as the grey levels the tracker reads (uint8)."""
    return np.clip(np.rint(frames), 0, 255).astype(np.uint8)
