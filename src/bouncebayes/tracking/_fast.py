"""The per-frame tracking path compiled: numba kernels over all the frames of a video.

The same arithmetic as the Python path of :mod:`._measure` (``_Searcher.measure``, ``_edge_fit``)
and :func:`._quality.frame_quality`, kept as the reference (``tests/test_tracking_fast.py``
compares both on rendered clips: same frames found, same methods and flags, centres within
1e-6 px). The Python path costs ~1 ms of interpreter and NumPy call overhead per frame whatever
the frame size; here a frame costs its arithmetic only (docs/tracking.md, speed).

Written by hand, not with OpenCV, because numba cannot call OpenCV: the 8-connected component
labelling (``cv2.connectedComponentsWithStats``) and the Gaussian blur with reflected borders
(``cv2.GaussianBlur``) are re-implemented here, on the small windows the search looks at (the
tests compare them with OpenCV's). The frame-to-frame search is
sequential in time (each frame's window is predicted from the last two hits), so it is one
compiled loop over the frames.

Compiled on first use and cached on disk (``cache=True``); ``bouncebayes warmup`` compiles them
(:func:`warm`).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

_BLUR_SIGMA = 2.0   # px, the shadow correction's Gaussian (as ``_measure._coverage``)
_BLUR_RADIUS = 8    # taps either side: OpenCV's kernel size for float images, round(8 sigma + 1)


def gaussian_kernel() -> np.ndarray:
    """OpenCV's float64 Gaussian kernel of ``cv2.GaussianBlur(img, (0, 0), 2.0)``."""
    import cv2

    return cv2.getGaussianKernel(2 * _BLUR_RADIUS + 1, _BLUR_SIGMA, cv2.CV_64F).ravel()


# --------------------------------------------------------------------------- building blocks


@njit(cache=True)
def _reflect101(p, n):
    """``cv2.borderInterpolate(p, n, BORDER_REFLECT_101)`` (OpenCV's default border)."""
    if n == 1:
        return 0
    while p < 0 or p >= n:
        p = -p if p < 0 else 2 * n - p - 2
    return p


@njit(cache=True)
def _blur(src, kern, rows):
    """Separable Gaussian blur with reflected borders, rows then columns (``cv2.GaussianBlur``
    on a float64 image). Each sum runs over the taps in order, the loops over pixels inside
    (so that they vectorise); rows of ``src`` not marked in ``rows`` are zero, and skipped
    (their terms are zero)."""
    hh, ww = src.shape
    rad = (len(kern) - 1) // 2
    xi = np.empty(ww + 2 * rad, np.int64)
    for j in range(ww + 2 * rad):
        xi[j] = _reflect101(j - rad, ww)
    yi = np.empty(hh + 2 * rad, np.int64)
    for i in range(hh + 2 * rad):
        yi[i] = _reflect101(i - rad, hh)
    row = np.empty(ww + 2 * rad)
    tmp = np.zeros((hh, ww))
    for i in range(hh):
        if not rows[i]:
            continue
        for j in range(ww + 2 * rad):
            row[j] = src[i, xi[j]]
        for k in range(len(kern)):
            c = kern[k]
            for j in range(ww):
                tmp[i, j] += c * row[j + k]
    out = np.zeros((hh, ww))
    for i in range(hh):
        for k in range(len(kern)):
            c = kern[k]
            y = yi[i + k]
            if not rows[y]:
                continue
            for j in range(ww):
                out[i, j] += c * tmp[y, j]
    return out


@njit(cache=True)
def _find(parent, a):
    while parent[a] != a:
        parent[a] = parent[parent[a]]
        a = parent[a]
    return a


@njit(cache=True)
def _largest_blob(mask):
    """The largest 8-connected component of ``mask`` (ties: the first in raster order, as
    OpenCV numbers them): its mask, area, centroid and bounding-box size.

    Union-find in two passes over the bounding box of the set pixels; a component's root is
    its smallest provisional label, which is that of its first pixel in raster order."""
    hh, ww = mask.shape
    blob = np.zeros((hh, ww), np.bool_)
    i0, i1, j0, j1 = hh, -1, ww, -1
    for i in range(hh):
        for j in range(ww):
            if mask[i, j]:
                i0, i1 = min(i0, i), max(i1, i)
                j0, j1 = min(j0, j), max(j1, j)
    if i1 < 0:
        return blob, 0, 0.0, 0.0, 0, 0
    bh, bw = i1 - i0 + 1, j1 - j0 + 1
    labels = np.zeros((bh, bw), np.int64)
    parent = np.empty(bh * bw + 1, np.int64)
    n = 0
    for i in range(bh):
        for j in range(bw):
            if not mask[i0 + i, j0 + j]:
                continue
            best = 0
            for di, dj in ((0, -1), (-1, -1), (-1, 0), (-1, 1)):
                y, x = i + di, j + dj
                if y < 0 or x < 0 or x >= bw or labels[y, x] == 0:
                    continue
                root = _find(parent, labels[y, x])
                if best == 0:
                    best = root
                elif root != best:
                    lo, hi = min(root, best), max(root, best)
                    parent[hi] = lo
                    best = lo
            if best == 0:
                n += 1
                parent[n] = n
                best = n
            labels[i, j] = best
    area = np.zeros(n + 1, np.int64)
    sx = np.zeros(n + 1, np.int64)
    sy = np.zeros(n + 1, np.int64)
    x0 = np.full(n + 1, ww, np.int64)
    x1 = np.full(n + 1, -1, np.int64)
    y0 = np.full(n + 1, hh, np.int64)
    y1 = np.full(n + 1, -1, np.int64)
    for i in range(bh):
        for j in range(bw):
            if labels[i, j] == 0:
                continue
            root = _find(parent, labels[i, j])
            labels[i, j] = root
            area[root] += 1
            sx[root] += j0 + j
            sy[root] += i0 + i
            x0[root], x1[root] = min(x0[root], j), max(x1[root], j)
            y0[root], y1[root] = min(y0[root], i), max(y1[root], i)
    pick = 1
    for lab in range(2, n + 1):
        if area[lab] > area[pick]:
            pick = lab
    for i in range(bh):
        for j in range(bw):
            blob[i0 + i, j0 + j] = labels[i, j] == pick
    a = area[pick]
    return blob, a, sx[pick] / a, sy[pick] / a, x1[pick] - x0[pick] + 1, y1[pick] - y0[pick] + 1


@njit(cache=True)
def _gain(frame, bg, grid):
    """``_measure._gain``: median of ``frame / bg`` on a grid of about ``grid`` pixels where
    ``bg > 8``."""
    h, w = frame.shape
    step = max(1, math.ceil(math.sqrt(h * w / grid)))
    buf = np.empty(((h + step - 1) // step) * ((w + step - 1) // step))
    n = 0
    for i in range(0, h, step):
        for j in range(0, w, step):
            b = bg[i, j]
            if b > 8.0:
                buf[n] = frame[i, j] / b
                n += 1
    return _median(buf[:n]) if n > 16 else 1.0


@njit(cache=True)
def _select(a, k):
    """Reorder ``a`` in place so that ``a[k]`` is its k-th smallest value, no larger value
    before it and no smaller after it (Hoare's quickselect, median-of-three pivot)."""
    lo, hi = 0, len(a) - 1
    while hi > lo:
        mid = (lo + hi) // 2
        if a[mid] < a[lo]:
            a[mid], a[lo] = a[lo], a[mid]
        if a[hi] < a[lo]:
            a[hi], a[lo] = a[lo], a[hi]
        if a[hi] < a[mid]:
            a[hi], a[mid] = a[mid], a[hi]
        pivot = a[mid]
        i, j = lo, hi
        while i <= j:
            while a[i] < pivot:
                i += 1
            while a[j] > pivot:
                j -= 1
            if i <= j:
                a[i], a[j] = a[j], a[i]
                i += 1
                j -= 1
        if k <= j:
            hi = j
        elif k >= i:
            lo = i
        else:
            break
    return a[k]


@njit(cache=True)
def _median(a):
    """``np.median`` of a 1-D scratch array (reordered): the mean of the middle two values for
    an even length."""
    n = len(a)
    k = (n - 1) // 2
    lo = _select(a, k)
    if n % 2:
        return lo
    hi = a[k + 1]
    for i in range(k + 2, n):
        hi = min(hi, a[i])
    return (lo + hi) / 2


@njit(cache=True)
def ball_free_background(frames, idx, gains, out, count, done, centre, reach, min_clear, around,
                         half, tile):
    """The background model ``out`` (float64, in place) with the ball left out, within ``half``
    (px) of the points ``around`` (``(m, 2)``, NaN rows skipped; where the fits will look) and
    not ``done`` (bool, in place: set where computed): each pixel there within ``reach`` (px)
    of the ball's centre in one of the frames ``idx`` (``centre`` their tracked centres, NaN
    where not found) gets the median of ``frame / gain`` over the frames of ``idx`` where the
    ball is farther than ``reach`` from it, if at least ``min_clear`` are, and ``count`` (in
    place) the number of those frames; every other pixel keeps its values.

    The plain median takes in the frames the ball covers: a pixel on the ball's path is
    covered in ~1/4 of the frames of a 1.5 px-per-frame bounce, which moves the median by ~0.3
    noise SD towards the ball (1 grey level, the ball's side, on a flat wall with noise 3), in
    a band along the path. The edge model fits that band as the ball's rim: +5.8 % on the
    radius of a dark 15 px ball blurred by 1.5 px on a flat wall (docs/tracking.md §1). The
    work goes tile by tile (``tile`` px square): a tile's pixels are first copied frame by
    frame (contiguous rows), so the per-pixel pass over the frames reads from the cache and
    not across whole frames."""
    n = len(idx)
    h, w = out.shape
    need = np.zeros((h, w), np.bool_)
    h2 = half * half
    for k in range(around.shape[0]):
        cx, cy = around[k, 0], around[k, 1]
        if math.isnan(cx):
            continue
        for i in range(max(0, int(math.floor(cy - half))), min(h, int(math.ceil(cy + half)) + 1)):
            for j in range(max(0, int(math.floor(cx - half))),
                           min(w, int(math.ceil(cx + half)) + 1)):
                if not done[i, j] and (j - cx) ** 2 + (i - cy) ** 2 <= h2:
                    need[i, j] = True
    buf = np.empty(n)
    block = np.empty((n, tile, tile))
    r2 = reach * reach
    for i0 in range(0, h, tile):
        for j0 in range(0, w, tile):
            i1, j1 = min(h, i0 + tile), min(w, j0 + tile)
            if not need[i0:i1, j0:j1].any():
                continue
            for t in range(n):
                g = gains[idx[t]]
                for i in range(i0, i1):
                    for j in range(j0, j1):
                        block[t, i - i0, j - j0] = frames[idx[t], i, j] / g if g > 0 else np.nan
            for i in range(i0, i1):
                for j in range(j0, j1):
                    if not need[i, j]:
                        continue
                    done[i, j] = True
                    m = 0
                    for t in range(n):
                        ox, oy = centre[t, 0], centre[t, 1]
                        v = block[t, i - i0, j - j0]
                        if (math.isnan(ox) or (j - ox) ** 2 + (i - oy) ** 2 > r2) and v == v:
                            buf[m] = v  # (a frame of gain 0, a black frame, is left out)
                            m += 1
                    if m < n and m >= min_clear:  # the ball near the pixel in some frame
                        out[i, j] = _median(buf[:m])
                        count[i, j] = m


@njit(cache=True)
def _window(frame, bg, gain, sign, threshold, cx, cy, half):
    """``_measure._window``: the window around ``(cx, cy)`` and its largest blob."""
    h, w = frame.shape
    u0, v0 = max(int(cx - half), 0), max(int(cy - half), 0)
    u1, v1 = min(int(cx + half) + 2, w), min(int(cy + half) + 2, h)
    empty = np.zeros((1, 1))
    if u1 - u0 < 3 or v1 - v0 < 3:
        return False, 0, 0, empty, empty, np.zeros((1, 1), np.bool_), 0.0, 0.0, 0.0, 0.0
    img = np.empty((v1 - v0, u1 - u0))
    bgw = np.empty((v1 - v0, u1 - u0))
    mask = np.empty((v1 - v0, u1 - u0), np.bool_)
    for i in range(v1 - v0):
        for j in range(u1 - u0):
            img[i, j] = frame[v0 + i, u0 + j]
            bgw[i, j] = gain * bg[v0 + i, u0 + j]
            mask[i, j] = sign * (img[i, j] - bgw[i, j]) > threshold
    blob, area, bx, by, bw, bh = _largest_blob(mask)
    if area < 12:
        return False, 0, 0, empty, empty, blob, 0.0, 0.0, 0.0, 0.0
    return (True, u0, v0, img, bgw, blob, bx + u0, by + v0, math.sqrt(area / math.pi),
            max(bw, bh) / 2)


@njit(cache=True)
def _coverage(img, bgw, blob, u0, v0, sign, threshold, cx, cy, r, shadow, kern, alpha):
    """``_measure._coverage``: fills ``alpha``, returns the rim contrast."""
    hh, ww = img.shape
    rho2 = np.empty((hh, ww))
    for i in range(hh):
        dy2 = (v0 + i - cy) ** 2
        for j in range(ww):
            rho2[i, j] = (u0 + j - cx) ** 2 + dy2
    a, b, c = max(r - 2.5, 0.0) ** 2, max(r - 1.5, 0.0) ** 2, max(r - 0.5, 0.0) ** 2
    lo, hi = (r + 1.0) ** 2, (r + 4.0) ** 2
    inner = np.empty(hh * ww)
    outer = np.empty(hh * ww)
    ni = no = na = 0
    for i in range(hh):
        for j in range(ww):
            q = rho2[i, j]
            if blob[i, j] and q >= a and q < b:
                inner[ni] = img[i, j]
                ni += 1
            if blob[i, j] and q >= b and q <= c:
                outer[no] = img[i, j]
                no += 1
            if q >= lo and q <= hi:
                na += 1
    if no >= 8 and ni >= 8:
        f1, f2 = _median(outer[:no]), _median(inner[:ni])
        grey = f1 - sign * max(0.0, sign * (f2 - f1))
    else:
        nb = 0
        for i in range(hh):
            for j in range(ww):
                if blob[i, j]:
                    inner[nb] = img[i, j]
                    nb += 1
        grey = _median(inner[:nb])
    bg = bgw
    if shadow and na >= 8:
        ratio = np.zeros((hh, ww))
        weight = np.zeros((hh, ww))
        rows = np.zeros(hh, np.bool_)
        for i in range(hh):
            for j in range(ww):
                if rho2[i, j] >= lo and rho2[i, j] <= hi:
                    ratio[i, j] = img[i, j] / max(bgw[i, j], 1.0)
                    weight[i, j] = 1.0
                    rows[i] = True
        num, den = _blur(ratio, kern, rows), _blur(weight, kern, rows)
        bg = np.empty((hh, ww))
        for i in range(hh):
            for j in range(ww):
                q = num[i, j] / max(den[i, j], 1e-6) if den[i, j] > 0.05 else 1.0
                bg[i, j] = bgw[i, j] * (min(q, 1.0) if sign > 0 else max(q, 1.0))
    total = 0.0
    nc = 0
    for i in range(hh):
        for j in range(ww):
            con = max(sign * (grey - bg[i, j]), threshold)
            alpha[i, j] = min(max(sign * (img[i, j] - bg[i, j]) / con, 0.0), 1.0)
            total += con
            q = rho2[i, j]
            if blob[i, j] and q >= b and q <= c:
                outer[nc] = con
                nc += 1
    return _median(outer[:nc]) if nc > 0 else total / (hh * ww)


@njit(cache=True)
def _centroid(alpha, u0, v0, cx, cy, radius, n_iter):
    """``_measure._centroid``: coverage centroid and ``sqrt(mass / pi)`` in a disk re-centred
    at each iteration."""
    hh, ww = alpha.shape
    r2 = radius ** 2
    mass = 0.0
    for _ in range(n_iter):
        mass = sx = sy = 0.0
        for i in range(hh):
            y = float(v0 + i)
            dy2 = (y - cy) ** 2
            for j in range(ww):
                x = float(u0 + j)
                if (x - cx) ** 2 + dy2 <= r2:
                    m = alpha[i, j]
                    mass += m
                    sx += m * x
                    sy += m * y
        if mass <= 0:
            return cx, cy, 0.0
        cx, cy = sx / mass, sy / mass
    return cx, cy, math.sqrt(mass / math.pi)


@njit(cache=True)
def _measure(frame, bg, gain, sign, threshold, cx, cy, half, kern):
    """``_measure._measure``: found, centre, coverage radius, rim contrast, at the border."""
    h, w = frame.shape
    r = contrast = 0.0
    for _ in range(3):
        ok, u0, v0, img, bgw, blob, wcx, wcy, wr, extent = _window(frame, bg, gain, sign,
                                                                   threshold, cx, cy, half)
        if not ok:
            return False, 0.0, 0.0, 0.0, 0.0, False
        hh, ww = img.shape
        u1, v1 = u0 + ww - 1, v0 + hh - 1  # last column and row
        reach = wr + 2.0 + max(0.0, extent - wr)
        alpha = np.empty((hh, ww))
        _coverage(img, bgw, blob, u0, v0, sign, threshold, wcx, wcy, wr, False, kern, alpha)
        cx, cy, r = _centroid(alpha, u0, v0, wcx, wcy, reach, 2)
        if r <= 0:
            return False, 0.0, 0.0, 0.0, 0.0, False
        contrast = _coverage(img, bgw, blob, u0, v0, sign, threshold, cx, cy, r, True, kern,
                             alpha)
        cx, cy, r = _centroid(alpha, u0, v0, cx, cy, reach, 3)
        if r <= 0:
            return False, 0.0, 0.0, 0.0, 0.0, False
        inside = ((cx - reach >= u0 or u0 == 0) and (cx + reach <= u1 or u1 == w - 1)
                  and (cy - reach >= v0 or v0 == 0) and (cy + reach <= v1 or v1 == h - 1))
        if inside:
            break
        half = reach + 4.0
    border = cx - r < 1.0 or cy - r < 1.0 or cx + r > w - 2.0 or cy + r > h - 2.0
    return True, cx, cy, r, contrast, border


@njit(cache=True)
def _coarse(frame, bg_small, f, gain, sign, threshold):
    """``_Searcher._coarse``: the largest blob of the block-averaged background difference."""
    hs, ws = bg_small.shape
    mask = np.empty((hs, ws), np.bool_)
    for i in range(hs):
        for j in range(ws):
            s = 0
            for a in range(f):
                for b in range(f):
                    s += frame[i * f + a, j * f + b]
            mask[i, j] = sign * (s / (f * f) - gain * bg_small[i, j]) > threshold
    _, area, bx, by, bw, bh = _largest_blob(mask)
    if area < 3:
        return False, 0.0, 0.0, 0.0
    return True, bx * f + (f - 1) / 2, by * f + (f - 1) / 2, max(bw, bh) * f / 2 + 2.0 * f + 4.0


@njit(cache=True)
def measure_frames(frames, bg, bg_small, f, sign, threshold, kern, grid):
    """``_Searcher.measure`` on every frame in turn: ``(n, 4)`` centre x, y, coverage radius,
    rim contrast (NaN where not found), ``border`` and ``gains`` per frame."""
    n = frames.shape[0]
    out = np.full((n, 4), np.nan)
    border = np.zeros(n, np.bool_)
    gains = np.empty(n)
    for k in range(n):
        frame = frames[k]
        gain = _gain(frame, bg, grid)
        gains[k] = gain
        ok = False
        cx = cy = r = con = 0.0
        at_edge = False
        if k >= 1 and not math.isnan(out[k - 1, 0]):
            px, py, pr = out[k - 1, 0], out[k - 1, 1], out[k - 1, 2]
            vx = vy = 0.0
            if k >= 2 and not math.isnan(out[k - 2, 0]):
                vx, vy = px - out[k - 2, 0], py - out[k - 2, 1]
            ok, cx, cy, r, con, at_edge = _measure(
                frame, bg, gain, sign, threshold, px + vx, py + vy,
                1.3 * pr + 6.0 + 1.5 * math.hypot(vx, vy), kern)
        if not ok:
            hit, gx, gy, gh = _coarse(frame, bg_small, f, gain, sign, threshold)
            if hit:
                ok, cx, cy, r, con, at_edge = _measure(frame, bg, gain, sign, threshold, gx, gy,
                                                       gh, kern)
        if ok:
            out[k, 0], out[k, 1], out[k, 2], out[k, 3] = cx, cy, r, con
            border[k] = at_edge
    return out, border, gains


# --------------------------------------------------------------------------- edge fit, quality


@njit(cache=True)
def _disk_step(alpha, u0, v0, cx, cy, r, width):
    """``_measure._disk_step``: one Gauss-Newton step of a disk's centre; ok, new centre."""
    hh, ww = alpha.shape
    a = b = c = gx = gy = 0.0
    for i in range(hh):
        dy = (v0 + i) - cy
        for j in range(ww):
            dx = (u0 + j) - cx
            rho = max(math.sqrt(dx * dx + dy * dy), 1e-9)
            ramp = (r - rho) / width + 0.5
            if ramp > 0 and ramp < 1:
                res = alpha[i, j] - ramp
                jx, jy = dx / (rho * width), dy / (rho * width)
                a += jx * jx
                b += jx * jy
                c += jy * jy
                gx += jx * res
                gy += jy * res
    if not (math.isfinite(a) and math.isfinite(b) and math.isfinite(c)):
        return False, cx, cy
    # condition number of the symmetric 2 x 2 matrix (numpy: by its SVD), above 1e8: refused
    disc = math.hypot(0.5 * (a - c), b)
    big = 0.5 * (a + c) + disc
    if big <= 0.0:
        return False, cx, cy
    small = abs((a * c - b * b) / big)
    if small * 1e8 < big:
        return False, cx, cy
    # LU with partial pivoting (as LAPACK's gesv)
    if abs(a) >= abs(b):
        m = b / a
        y = (gy - m * gx) / (c - m * b)
        x = (gx - b * y) / a
    else:
        m = a / b
        y = (gx - m * gy) / (b - m * c)
        x = (gy - c * y) / b
    return True, cx + x, cy + y


@njit(cache=True)
def edge_fits(frames, bg, gains, sign, threshold, idx, centre, r, min_visible, kern):
    """``_measure._edge_fit`` on frames ``idx``: ``(len(idx), 2)`` centres, NaN where refused."""
    out = np.full((len(idx), 2), np.nan)
    wide = (max(r / 3, 1.0), max(r / 6, 1.0), 2.0, 1.0)
    for n in range(len(idx)):
        k = idx[n]
        x0, y0 = centre[k, 0], centre[k, 1]
        ok, u0, v0, img, bgw, blob, _, _, _, _ = _window(frames[k], bg, gains[k], sign,
                                                         threshold, x0, y0, 1.5 * r + 6.0)
        if not ok:
            continue
        alpha = np.empty(img.shape)
        cx, cy = x0, y0
        good = True
        for stage in range(2):
            _coverage(img, bgw, blob, u0, v0, sign, threshold, cx, cy, r, True, kern, alpha)
            if alpha.sum() < min_visible * math.pi * r * r:
                good = False
                break
            for wi in range(4 if stage == 0 else 1):
                width = wide[wi] if stage == 0 else 1.0
                for _ in range(4):
                    stepped, nx, ny = _disk_step(alpha, u0, v0, cx, cy, r, width)
                    if not stepped or math.hypot(nx - x0, ny - y0) > r:
                        good = False
                        break
                    cx, cy = nx, ny
                if not good:
                    break
            if not good:
                break
        if good:
            out[n, 0], out[n, 1] = cx, cy
    return out


@njit(cache=True)
def quality_misfit(frames, bg, gains, sign, threshold, idx, centre, contrast, r, ramp):
    """``frame_quality``'s relative misfit of frames ``idx`` (NaN where no window)."""
    rel = np.full(len(idx), np.nan)
    h, w = frames.shape[1], frames.shape[2]
    half = r + 3.0
    side = 2 * int(half) + 6  # > the window's rows and columns
    av = np.empty(side * side)
    mv = np.empty(side * side)
    for n in range(len(idx)):
        k = idx[n]
        cx, cy = centre[k, 0], centre[k, 1]
        u0, v0 = max(int(cx - half), 0), max(int(cy - half), 0)
        u1, v1 = min(int(cx + half) + 2, w), min(int(cy + half) + 2, h)
        if u1 <= u0 or v1 <= v0:
            continue
        c = max(contrast[k], threshold)
        g = gains[k]
        count = 0
        aa = am = 0.0
        for i in range(v0, v1):
            dy2 = (i - cy) ** 2
            for j in range(u0, u1):
                rho = math.sqrt((j - cx) ** 2 + dy2)
                if rho <= half:
                    a = min(max(sign * (frames[k, i, j] - g * bg[i, j]) / c, 0.0), 1.0)
                    m = min(max((r - rho) / ramp + 0.5, 0.0), 1.0)
                    av[count], mv[count] = a, m
                    aa += a * a
                    am += a * m
                    count += 1
        scale = am / aa if aa > 0 else 1.0
        ss = 0.0
        for q in range(count):
            ss += (scale * av[q] - mv[q]) ** 2
        rel[n] = math.sqrt(ss / count) if count > 0 else np.nan
    return rel


def warm() -> None:
    """Compile (or load from numba's on-disk cache) every kernel here, through
    :func:`.track_ball` on a tiny clip: a bright ball entering from the left edge (so the edge
    fit runs too), with the argument types a video gives them, writable or read-only, with
    and without the edge model of the ball's radius (:mod:`._edge_kernel`) and the small-ball
    fit that follows it (:mod:`._refine`)."""
    from ._track import TrackerConfig, _track_ball

    n, h, w = 12, 48, 64
    yy, xx = np.mgrid[:h, :w]
    frames = np.full((n, h, w), 40, np.uint8)
    for k in range(n):
        frames[k][(xx - 4.0 * k) ** 2 + (yy - 24.0) ** 2 <= 36.0] = 200
    _track_ball(frames, TrackerConfig(edge_model=False), None, compiled=True)
    # the edge model's kernel too, and the small-ball fit (:mod:`._refine`: this ball's radius
    # is 6 px), on writable and read-only frames
    _track_ball(frames, TrackerConfig(), None, compiled=True)
    frames.setflags(write=False)  # numba compiles read-only arrays (a memory map) separately
    _track_ball(frames, TrackerConfig(edge_model=False), None, compiled=True)
    _track_ball(frames, TrackerConfig(), None, compiled=True)
