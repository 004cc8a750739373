"""Finding and measuring the ball in one frame: search, coverage, sub-pixel centroid, disk fit
at the frame edge."""

from __future__ import annotations

import math
from typing import NamedTuple

import cv2
import numpy as np

NOT_FOUND, CENTROID, EDGE_FIT = 0, 1, 2
METHOD_NAMES = {NOT_FOUND: "not found", CENTROID: "coverage centroid",
                EDGE_FIT: "disk fit at the frame edge"}


GAIN_GRID = 2000  # pixels in the grid of the frame's gain (whatever the frame's size)


def _gain(frame: np.ndarray, bg: np.ndarray) -> float:
    """Frame brightness relative to the background (lamp flicker at 100/120 Hz), from a sparse
    grid of about ``GAIN_GRID`` pixels: the ball covers too few of them to matter, and the
    median of 2000 ratios has a standard error of 0.08 % (1.25 x 3 / 100 / sqrt(2000): noise of
    3 grey levels on a background of 100)."""
    step = max(1, math.ceil(math.sqrt(frame.size / GAIN_GRID)))
    f, b = frame[::step, ::step], bg[::step, ::step]
    ok = b > 8.0
    return float(np.median(f[ok] / b[ok].astype(np.float64))) if ok.sum() > 16 else 1.0


class _Measure(NamedTuple):
    cx: float
    cy: float
    r: float
    contrast: float
    border: bool      # the ball (r + 1 px) reaches the frame edge: centroid is biased


class _Window(NamedTuple):
    """A window of one frame around the ball, and the largest above-threshold blob in it."""

    img: np.ndarray    # grey levels, float32
    bg: np.ndarray     # background, scaled by the frame's gain
    d: np.ndarray      # sign * (img - bg): positive on the ball
    blob: np.ndarray   # bool mask of the blob
    xs: np.ndarray     # pixel columns (frame coordinates)
    ys: np.ndarray     # pixel rows
    cx: float          # blob centroid and sqrt(area / pi)
    cy: float
    r: float
    extent: float      # half the blob's longest bounding-box side (px)


class _Searcher:
    """Frame-to-frame search state: the background (full and downsampled) and the last hits.

    The grey levels of the search and the coverage are float64, so that the compiled path
    (:mod:`._fast`) does the same arithmetic (float32 sums differ with their order by ~1e-5 px
    in the centre)."""

    def __init__(self, bg: np.ndarray, sign: int, threshold: float):
        h, w = bg.shape
        self.bg, self.sign, self.threshold = bg, sign, threshold
        self.bg64 = bg.astype(np.float64)
        self.f = max(1, min(h, w) // 240)  # coarse search: finds balls of radius >= ~f px
        self.small_size = (w // self.f, h // self.f)
        self.bg_small = self._shrink(bg)
        self.history: list[tuple[float, float, float] | None] = []
        self.gains: list[float] = []

    def _shrink(self, img: np.ndarray) -> np.ndarray:
        """Mean of ``f`` x ``f`` blocks (float64)."""
        f, (ws, hs) = self.f, self.small_size
        if f == 1:
            return img.astype(np.float64)
        return img[:hs * f, :ws * f].astype(np.float64).reshape(hs, f, ws, f).mean(axis=(1, 3))

    def measure(self, frame: np.ndarray) -> _Measure | None:
        gain = _gain(frame, self.bg)
        self.gains.append(gain)
        guess = self._predict()
        m = _measure(frame, self, gain, *guess) if guess is not None else None
        if m is None:
            coarse = self._coarse(frame, gain)
            m = _measure(frame, self, gain, *coarse) if coarse is not None else None
        self.history.append(None if m is None else (m.cx, m.cy, m.r))
        return m

    def _predict(self) -> tuple[float, float, float] | None:
        """Centre and window half-size from the last two frames (constant velocity)."""
        last = self.history[-2:]
        if len(last) < 1 or last[-1] is None:
            return None
        cx, cy, r = last[-1]
        vx, vy = (cx - last[0][0], cy - last[0][1]) if len(last) == 2 and last[0] else (0, 0)
        return cx + vx, cy + vy, 1.3 * r + 6.0 + 1.5 * math.hypot(vx, vy)

    def _coarse(self, frame: np.ndarray, gain: float) -> tuple[float, float, float] | None:
        """Largest blob of the downsampled background difference: centre, window half-size."""
        d = self.sign * (self._shrink(frame) - gain * self.bg_small)
        n, _, stats, cents = cv2.connectedComponentsWithStats((d > self.threshold).view(np.uint8),
                                                              connectivity=8)
        if n < 2:
            return None
        i = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
        if stats[i, cv2.CC_STAT_AREA] < 3:
            return None
        f = self.f
        cx, cy = cents[i] * f + (f - 1) / 2
        half = max(stats[i, cv2.CC_STAT_WIDTH], stats[i, cv2.CC_STAT_HEIGHT]) * f / 2
        return cx, cy, half + 2.0 * f + 4.0


def _window(frame, s: _Searcher, gain: float, cx, cy, half) -> _Window | None:
    """The window of half-size ``half`` around ``(cx, cy)`` and its largest blob."""
    h, w = frame.shape
    u0, v0 = max(int(cx - half), 0), max(int(cy - half), 0)
    u1, v1 = min(int(cx + half) + 2, w), min(int(cy + half) + 2, h)
    if u1 - u0 < 3 or v1 - v0 < 3:
        return None
    img = frame[v0:v1, u0:u1].astype(np.float64)
    bg = gain * s.bg64[v0:v1, u0:u1]
    d = s.sign * (img - bg)
    n, labels, stats, cents = cv2.connectedComponentsWithStats((d > s.threshold).view(np.uint8),
                                                               connectivity=8)
    if n < 2:
        return None
    i = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    area = stats[i, cv2.CC_STAT_AREA]
    if area < 12:
        return None
    extent = max(stats[i, cv2.CC_STAT_WIDTH], stats[i, cv2.CC_STAT_HEIGHT]) / 2
    return _Window(img, bg, d, labels == i, np.arange(u0, u1, dtype=np.float64),
                   np.arange(v0, v1, dtype=np.float64), cents[i][0] + u0, cents[i][1] + v0,
                   math.sqrt(area / math.pi), extent)


def _rings(win: _Window, cx, cy, r) -> tuple[np.ndarray, ...]:
    """Masks of the ball's two outermost full rings and of a ring just outside it."""
    rho2 = (win.xs - cx)[None, :] ** 2 + (win.ys - cy)[:, None] ** 2
    a, b, c = (max(r - k, 0.0) ** 2 for k in (2.5, 1.5, 0.5))
    inner = (rho2 >= a) & (rho2 < b) & win.blob
    outer = (rho2 >= b) & (rho2 <= c) & win.blob
    return inner, outer, (rho2 >= (r + 1.0) ** 2) & (rho2 <= (r + 4.0) ** 2)


def _median(a: np.ndarray) -> float:
    """Median of a small 1-D array (``np.median`` costs more in overhead than in work)."""
    k = (len(a) - 1) // 2
    part = np.partition(a, (k, len(a) // 2))
    return 0.5 * float(part[k] + part[len(a) // 2])


def _coverage(win: _Window, s: _Searcher, cx, cy, r, *,
              shadow: bool = True) -> tuple[np.ndarray, float]:
    """Coverage ``alpha = (I - B) / (F - B)`` in [0, 1] and the rim contrast ``F - B``.

    ``F`` is the grey level at the rim, extrapolated linearly from the ball's two outermost
    full rings (limb darkening). ``B`` is corrected for a shadow next to the ball: near the edge
    it is scaled by the smoothed ratio ``I / B`` of the pixels just outside the ball, where that
    ratio is on the side opposite to the ball (darker, for a bright ball).
    """
    inner, outer, around = _rings(win, cx, cy, r)
    if outer.sum() >= 8 and inner.sum() >= 8:
        f1, f2 = _median(win.img[outer]), _median(win.img[inner])
        grey = f1 - s.sign * max(0.0, s.sign * (f2 - f1))
    else:
        grey = _median(win.img[win.blob])
    bg = win.bg
    weight = around.astype(np.float64)
    if shadow and weight.sum() >= 8:
        ratio = np.where(around, win.img / np.maximum(bg, 1.0), 0.0)
        num = cv2.GaussianBlur(ratio, (0, 0), 2.0)
        den = cv2.GaussianBlur(weight, (0, 0), 2.0)
        q = np.where(den > 0.05, num / np.maximum(den, 1e-6), 1.0)
        bg = bg * (np.minimum(q, 1.0) if s.sign > 0 else np.maximum(q, 1.0))
    contrast = np.maximum(s.sign * (grey - bg), s.threshold)
    alpha = np.clip(s.sign * (win.img - bg) / contrast, 0.0, 1.0)
    return alpha, _median(contrast[outer]) if outer.any() else float(contrast.mean())


def _centroid(alpha, xs, ys, cx, cy, radius, n_iter=3) -> tuple[float, float, float]:
    """Coverage centroid and ``sqrt(mass / pi)`` inside a disk re-centred at each iteration."""
    mass = 0.0
    for _ in range(n_iter):
        disk = (xs - cx)[None, :] ** 2 + (ys - cy)[:, None] ** 2 <= radius**2
        m = np.where(disk, alpha, 0.0)
        mass = float(m.sum())
        if mass <= 0:
            return cx, cy, 0.0
        cx, cy = float(m.sum(axis=0) @ xs) / mass, float(m.sum(axis=1) @ ys) / mass
    return cx, cy, math.sqrt(mass / math.pi)


def _measure(frame, s: _Searcher, gain: float, cx, cy, half) -> _Measure | None:
    """Sub-pixel centre by the coverage centroid; re-centres the window if the ball leaves it."""
    h, w = frame.shape
    for _ in range(3):
        win = _window(frame, s, gain, cx, cy, half)
        if win is None:
            return None
        reach = win.r + 2.0 + max(0.0, win.extent - win.r)
        alpha, _ = _coverage(win, s, win.cx, win.cy, win.r, shadow=False)
        cx, cy, r = _centroid(alpha, win.xs, win.ys, win.cx, win.cy, reach, n_iter=2)
        if r <= 0:
            return None
        alpha, contrast = _coverage(win, s, cx, cy, r)
        cx, cy, r = _centroid(alpha, win.xs, win.ys, cx, cy, reach)
        if r <= 0:
            return None
        inside = (cx - reach >= win.xs[0] or win.xs[0] == 0) and \
                 (cx + reach <= win.xs[-1] or win.xs[-1] == w - 1) and \
                 (cy - reach >= win.ys[0] or win.ys[0] == 0) and \
                 (cy + reach <= win.ys[-1] or win.ys[-1] == h - 1)
        if inside:
            break
        half = reach + 4.0
    border = cx - r < 1.0 or cy - r < 1.0 or cx + r > w - 2.0 or cy + r > h - 2.0
    return _Measure(cx, cy, r, contrast, border)


def _edge_fit(frame, s: _Searcher, gain: float, c0, r: float, min_visible: float):
    """Centre of a disk of radius ``r`` fitted to the in-frame coverage: coarse-to-fine ramp
    widths from ``c0``, then again with the coverage recomputed around the fitted centre."""
    win = _window(frame, s, gain, c0[0], c0[1], 1.5 * r + 6.0)
    if win is None:
        return None
    c = np.asarray(c0, dtype=float)
    x, y = np.meshgrid(win.xs, win.ys)
    for widths in ((max(r / 3, 1.0), max(r / 6, 1.0), 2.0, 1.0), (1.0,)):
        alpha, _ = _coverage(win, s, c[0], c[1], r)
        if alpha.sum() < min_visible * math.pi * r * r:
            return None
        for width in widths:
            for _ in range(4):
                stepped = _disk_step(alpha, x, y, c, r, width)
                if stepped is None or math.dist(stepped, c0) > r:  # diverged: not a disk of r
                    return None
                c = stepped
    return c


def _disk_step(alpha, x, y, c, r, width) -> np.ndarray | None:
    """One Gauss-Newton step of the centre of a disk with a linear edge ramp ``width`` wide."""
    dx, dy = x - c[0], y - c[1]
    rho = np.maximum(np.sqrt(dx * dx + dy * dy), 1e-9)
    ramp = (r - rho) / width + 0.5
    on = (ramp > 0) & (ramp < 1)
    res = (alpha - np.clip(ramp, 0.0, 1.0))[on]
    jx, jy = dx[on] / (rho[on] * width), dy[on] / (rho[on] * width)
    jtj = np.array([[jx @ jx, jx @ jy], [jx @ jy, jy @ jy]])
    if not np.isfinite(jtj).all() or np.linalg.cond(jtj) > 1e8:
        return None
    return c + np.linalg.solve(jtj, [jx @ res, jy @ res])
