"""The camera's motion: each frame's shift, turn and zoom against the background model, and
the frames moved back onto the background's pixels.

A camera standing on the table the ball strikes shakes after the impact; a hand-held one
drifts and turns. The background model (a per-pixel median) then matches no frame: the
background differences fill with the wall's texture, and the centres carry the camera's motion
(the kinematics reject such a flight: a smooth pattern in its residuals). Each frame's motion
and brightness ``g`` against the background ``B``, ``I(p) = g B(p + m(p))`` with ``m(p) = d +
t J q + z q`` (the shift ``d``, px; the turn ``t`` and zoom ``z`` about the frame's centre, as
the px they move the frame at its half-diagonal; ``q`` the pixel's offset from the centre in
half-diagonals and ``J q`` that turned a quarter: first order in the turn and zoom, which a
camera held still moves by a few tenths of a degree and per cent), are fitted on a grid of
about ``GRID`` pixels by a Gauss-Newton step from no motion (Lucas & Kanade 1981: the
background's gradient), with the grid's pixels that misfit by more than ``OUTLIER`` robust SDs
(the ball, its shadow) left out and a ridge that holds at zero a motion the background does not
show (a plain wall shows a shift only across its edges). Where frames moved (:func:`moved`),
the motion is fitted again on ``FINE_GRID`` pixels (a shift's error falls as one over the root
of the pixels: on a rendered wall of 50 +- 10 grey levels, noise 2 grey levels, 0.04-0.06 px
per frame from 2000 pixels, which moved every frame's centres by as much), every frame that
moved by ``SIGNIFICANT`` standard errors is resampled (cubic convolution) back onto the
background's pixels, the background model made again from the moved frames and the remaining
motion fitted against it, up to ``ROUNDS`` times (one Gauss-Newton step is ~10 % short of a
shift of 0.5 px): the centres are then in the scene's pixels, and ``Track.camera_shift`` and
``Track.camera_turn`` hold each frame's shift, and turn and zoom (:func:`turn_and_zoom`).

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
from typing import Any

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
    """Each frame's motion against the background ``bg`` and its standard error, ``(n, 4)``
    each: the shift ``d`` (px) and the turn and zoom as the px they move the frame at its
    half-diagonal (``I(p) = g B(p + d + t J q + z q)``, ``q = (p - c) / L`` the pixel's offset
    from the frame's centre ``c`` in half-diagonals ``L``, ``J q = (-q_v, q_u)``): one
    Gauss-Newton step from no motion, ``g`` the frame's median ratio to ``bg``, on a grid of
    about ``grid`` pixels."""
    n, h, w = frames.shape
    step = max(1, math.ceil(math.sqrt(h * w / grid)))
    ys, xs = np.mgrid[MARGIN:h - MARGIN:step, MARGIN:w - MARGIN:step]
    ys, xs = ys.ravel(), xs.ravel()
    if ys.size < 16:
        return np.zeros((n, 4)), np.full((n, 4), math.inf)
    b64 = np.asarray(bg, dtype=np.float64)
    gy, gx = (np.asarray(a) for a in np.gradient(b64))
    bx, by = gx[ys, xs], gy[ys, xs]
    (cu, cv), half = _centre(bg.shape), _half_diagonal(bg.shape)
    qu, qv = (xs - cu) / half, (ys - cv) / half
    cols = np.column_stack([b64[ys, xs], bx, by, by * qu - bx * qv, bx * qu + by * qv])
    out = [_shifts(frames[k:k + CHUNK, ys, xs].astype(np.float64), cols)
           for k in range(0, n, CHUNK)]
    return np.concatenate([o[0] for o in out]), np.concatenate([o[1] for o in out])


def _centre(shape: tuple[int, ...]) -> tuple[float, float]:
    """The frame's centre (px: column, row), which the camera turns and zooms about."""
    return 0.5 * (shape[1] - 1), 0.5 * (shape[0] - 1)


def _half_diagonal(shape: tuple[int, ...]) -> float:
    """Half the frame's diagonal (px): the turn's and zoom's unit in :func:`frame_shifts`."""
    return 0.5 * math.hypot(shape[1] - 1, shape[0] - 1)


def _shifts(f: np.ndarray, cols: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`frame_shifts` of the frames' grid values ``f`` ``(n, m)``: ``cols`` ``(m, 5)``
    the background ``b`` there and its derivatives along the shift, turn and zoom (px of
    motion). The gain's start and the residuals' robust SD from every ``SPARSE``-th of them
    (the gain is fitted with the motion)."""
    n, b = len(f), cols[:, 0]
    ok = b > 8.0
    ok[np.arange(b.size) % SPARSE != 0] = False
    g = np.median(f[:, ok] / b[ok], axis=1) if ok.sum() > 16 else np.ones(n)
    r = f - g[:, None] * b
    scale = 1.4826 * np.median(np.abs(r[:, ::SPARSE]), axis=1) + 1e-6
    keep = np.abs(r) <= OUTLIER * scale[:, None]
    rk = np.where(keep, r, 0.0)
    # the normal equations of (dg, g d, g t, g z): sums over each frame's kept pixels
    weighted = keep[:, :, None] * cols[None]  # (n, m, 5)
    normal = np.swapaxes(weighted, 1, 2) @ cols
    unit = np.concatenate([np.ones((n, 1)), np.repeat(g[:, None], 4, axis=1)], axis=1)
    normal *= unit[:, :, None] * unit[:, None, :]
    noise2 = scale**2
    normal[:, np.arange(1, 5), np.arange(1, 5)] += (noise2 / PRIOR_PX**2)[:, None]
    rhs = (rk @ cols) * unit
    try:
        delta = np.linalg.solve(normal, rhs[..., None])[..., 0]
        cov = np.linalg.inv(normal)
    except np.linalg.LinAlgError:
        return np.zeros((n, 4)), np.full((n, 4), math.inf)
    se = np.sqrt(noise2[:, None] * np.diagonal(cov, axis1=1, axis2=2)[:, 1:])
    return delta[:, 1:], se


SPARSE = 4  # every SPARSE-th grid pixel for the gain's start and the residuals' robust SD


def moved(shifts: np.ndarray, se: np.ndarray) -> bool:
    """Whether the camera moved: ``MOVED_FRAMES`` frames or more shifted, turned or zoomed
    by more than ``MOVED_PX`` (the turn and zoom: px at the half-diagonal) and ``MOVED_SE``
    standard errors."""
    size = np.abs(shifts)
    return int(np.any((size > MOVED_PX) & (size > MOVED_SE * se), axis=1).sum()) >= MOVED_FRAMES


def shift_frames(frames: np.ndarray, shifts: np.ndarray) -> np.ndarray:
    """Each frame resampled onto the background's pixels (float32): frame ``k`` at ``p -
    m_k(p)``, so that a frame with ``I(p) = g B(p + m(p))`` becomes ``g B(p)``; ``shifts``
    ``(n, 2)`` the shifts ``d`` (px), or ``(n, 4)`` with the turn and zoom as
    :func:`frame_shifts` gives them. Keys' cubic convolution (``a = -0.5``; separable where the
    frame only shifted), the frame's edge replicated; a frame not moved as it is. By hand
    because OpenCV's ``warpAffine`` and ``remap`` place their samples to 1/32 px only (a frame
    shifted by 0.005 px moved by 0.03, and a still camera's centres with it)."""
    out = frames.astype(np.float32)
    for k, motion in enumerate(np.asarray(shifts, dtype=np.float64)):
        du, dv = float(motion[0]), float(motion[1])
        if motion[2:].any():
            out[k] = _warped(out[k], motion)
        elif du != 0.0 or dv != 0.0:
            out[k] = _cubic_shift(_cubic_shift(out[k], du, axis=1), dv, axis=0)
    return out


def _keys(t: Any) -> tuple[Any, ...]:
    """Keys' cubic convolution weights (``a = -0.5``) of the four samples around ``t`` in
    [0, 1) past the second."""
    return (((-0.5 * t + 1.0) * t - 0.5) * t, (1.5 * t - 2.5) * t * t + 1.0,
            ((-1.5 * t + 2.0) * t + 0.5) * t, (0.5 * t - 0.5) * t * t)


def _warped(img: np.ndarray, motion: np.ndarray) -> np.ndarray:
    """``img`` at ``p - m(p)`` (``motion`` as :func:`frame_shifts`'), by Keys' cubic
    convolution in two dimensions, the edge replicated."""
    h, w = img.shape
    (cu, cv), half = _centre(img.shape), _half_diagonal(img.shape)
    v, u = np.mgrid[:h, :w].astype(np.float64)
    qu, qv = (u - cu) / half, (v - cv) / half
    du, dv, turn, zoom = (float(x) for x in motion)
    x = u - (du - turn * qv + zoom * qu)
    y = v - (dv + turn * qu + zoom * qv)
    x0, y0 = np.floor(x).astype(np.int64), np.floor(y).astype(np.int64)
    wx, wy = _keys(x - x0), _keys(y - y0)
    out = np.zeros((h, w))
    for i, wyi in enumerate(wy):
        rows = np.clip(y0 - 1 + i, 0, h - 1)
        for j, wxj in enumerate(wx):
            out += wyi * wxj * img[rows, np.clip(x0 - 1 + j, 0, w - 1)]
    return out.astype(np.float32)


def _cubic_shift(img: np.ndarray, d: float, axis: int) -> np.ndarray:
    """``img`` moved by ``d`` px along ``axis``: ``out[p] = img[p - d]`` by cubic convolution."""
    s = -d
    n = math.floor(s)
    w = _keys(np.float64(s - n))
    pad = abs(n) + 2
    wide = np.pad(img, [(pad, pad) if a == axis else (0, 0) for a in range(2)], mode="edge")
    size = img.shape[axis]
    out = np.zeros_like(img)
    for j, wj in enumerate(w):
        start = pad + n - 1 + j
        out += np.float32(wj) * np.take(wide, np.arange(start, start + size), axis=axis)
    return out


def stabilise(frames: np.ndarray, background: Callable[[np.ndarray], np.ndarray]
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The frames moved back onto the background's pixels where the camera moved, the
    background model ``background(frames)`` of them, each frame's shift (px, ``(n, 2)``) and
    its turn and zoom (degrees and a fraction, ``(n, 2)``, :func:`turn_and_zoom`); zeros and
    the frames as given where it did not move."""
    bg = background(frames)
    total = np.zeros((len(frames), 4))
    if not moved(*frame_shifts(frames, bg)):
        return frames, bg, total[:, :2], total[:, 2:]
    moved_frames = None
    shifts, se = frame_shifts(frames, bg, FINE_GRID)
    for _ in range(ROUNDS):
        # a frame moved first where its motion tells (a still camera's frames stay as they
        # are), and then by all its motion measured again: what a round leaves is below
        # SIGNIFICANT SEs but alike in neighbouring frames (one Gauss-Newton step falls short
        # of a smooth motion by a like fraction), which a second round takes out
        told = np.abs(shifts) > SIGNIFICANT * se
        if not told.any():
            break
        step = np.where(told | total.any(axis=1, keepdims=True), shifts, 0.0)
        total += step
        # the rounds on unrounded frames: rounded to grey levels, a shift of a few hundredths
        # of a pixel vanishes from a wall's gentle texture (0.01 px: none of it measured
        # again; 0.05 px: 0.015), and the rounds could not take out what the first left
        moved_frames = shift_frames(frames, total)
        bg = background(moved_frames)
        shifts, se = frame_shifts(moved_frames, bg, FINE_GRID)
    turn = turn_and_zoom(total[:, 2:], bg.shape)
    if moved_frames is None:  # no frame's fine motion tells: as given
        return frames, bg, total[:, :2], turn
    out = rounded(moved_frames)
    return out, background(out), total[:, :2], turn


def turn_and_zoom(motion: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    """The turn and zoom of :func:`frame_shifts` (px at the half-diagonal, ``(n, 2)``) as
    degrees (the camera turned from the image's ``u`` axis towards its ``v`` axis about the
    frame's centre; the picture the other way) and a fraction (the field of view wider by;
    the picture smaller), for frames of ``shape``."""
    half = _half_diagonal(shape)
    return np.column_stack([np.degrees(motion[:, 0] / half), motion[:, 1] / half])


def motion_px(shift: np.ndarray, turn: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    """The inverse of :func:`turn_and_zoom` with the shift: ``(n, 4)`` as
    :func:`frame_shifts` gives it, for :func:`shift_frames`."""
    half = _half_diagonal(shape)
    turn = np.asarray(turn, dtype=np.float64).reshape(-1, 2)
    return np.column_stack([shift, np.radians(turn[:, 0]) * half, turn[:, 1] * half])


def rounded(frames: np.ndarray) -> np.ndarray:
    """Frames moved back (:func:`shift_frames`) as the grey levels the tracker reads (uint8)."""
    return np.clip(np.rint(frames), 0, 255).astype(np.uint8)
