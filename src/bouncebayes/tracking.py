"""Ball tracking in high-speed video: frames -> sub-pixel ball centres -> plane-frame trajectory.

The pipeline, one pure function per stage (paper §3 did this by hand in Tracker):

1. :func:`read_frames`: a video file (mp4, avi, mov, ...) or a folder of image frames, as grey
   ``uint8`` frames plus the frame rate (from the file, or ``fps=`` which always wins: high-speed
   cameras often store a playback rate such as 30 fps rather than the capture rate).
2. :func:`track_ball`: a background model (per-pixel temporal median), then in every frame a
   coarse search (downsampled background difference, largest blob) or a search in a window
   around the position predicted from the two previous frames, and a sub-pixel measurement:

   - every pixel gets a *coverage* ``alpha = (I - B) / (F - B)`` clipped to [0, 1], with ``B``
     the background model (scaled by each frame's overall brightness: lamp flicker) and ``F``
     the ball's grey level at its rim. Coverage is immune to a textured background and to the
     surface line (both are in ``B``), and to a shadow: darker than the background, it gets
     ``alpha = 0`` next to a bright ball, and where it runs under the ball's edge ``B`` is
     rescaled by the shadow's depth just outside the ball;
   - a ball wholly in the frame is measured by the coverage centroid (exact for a disk of any
     size and for a motion-blurred disk, whose coverage centroid is the mid-exposure centre for a
     straight path) and its radius by ``sqrt(sum(alpha) / pi)`` (blur conserves coverage);
   - a ball cut by the frame edge is measured by a least-squares fit of an anti-aliased disk of
     the video's median radius to the coverage of the pixels that are in the frame.

   Frames where no ball is found, or where less than ``min_visible`` of it is in view, or whose
   radius disagrees with the median, are marked (``method == NOT_FOUND``), never interpolated.
3. :class:`Calibration` (metres per pixel, from a reference length or the ball diameter) and
   :class:`Surface` (the surface line, from two points or :func:`detect_surface`).
4. :func:`to_plane_frame`: ``x`` along the surface in the direction of travel, ``y`` along the
   outward normal (the side of the ball), metres; then :func:`write_trajectory_csv` and
   :func:`overlay_image`. :func:`track_video` runs stages 1-4 for one input (the ``track``
   command calls it once per video).

Accuracy on the synthetic 1000 fps videos of ``tests/test_tracking.py`` (ball radius 12 px,
textured background, surface line): 0.01 px RMS on clean frames, 0.04 px with full-frame motion
blur, noise of 4 grey levels and a shadow, 0.02 px for a ball cut by the frame edge, 0.05-0.07 px
after MJPG/MPEG-4 compression; the radius, and so the ``--ball-diameter`` scale, to ~0.3%. The
errors are not white (they follow the background texture under the ball), ~0.05% of the speed
on clean video: below the kinematics' standard errors for noise of a few grey levels, above them
for nearly noise-free video.

Limits: one ball, darker or brighter than its surroundings all round its rim (``polarity``);
grey levels only (colour video is converted to grey); a ball radius of at least ~4 px; the ball
must move by more than a diameter over the video, or the median background contains it (give a
``background`` image of the empty scene then); all frames are held in memory (``n * h * w``
bytes).
"""

from __future__ import annotations

import functools
import math
import os
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal, NamedTuple, get_args

import cv2
import numpy as np

from ._errors import InputFileError
from ._io import write_text, write_with
from ._validate import check_choice, check_scalar

__all__ = ["CENTROID", "EDGE_FIT", "IMAGE_SUFFIXES", "METHOD_NAMES", "NOT_FOUND",
           "PAPER_BALL_DIAMETER", "POLARITIES", "VIDEO_SUFFIXES", "Calibration",
           "PlaneTrajectory", "Polarity", "Surface", "Track", "TrackedVideo", "TrackerConfig",
           "VideoSource", "background_model", "detect_surface", "overlay_image", "plane_axes",
           "read_frames", "read_image", "to_plane_frame", "track_ball", "track_video",
           "write_trajectory_csv"]

Polarity = Literal["auto", "bright", "dark"]
POLARITIES: tuple[str, ...] = get_args(Polarity)
VIDEO_SUFFIXES = (".mp4", ".avi", ".mov", ".mkv", ".m4v", ".mpg", ".mpeg", ".wmv")
IMAGE_SUFFIXES = (".png", ".tif", ".tiff", ".jpg", ".jpeg", ".bmp")

PAPER_BALL_DIAMETER = 0.0256  # m, paper §3 (= bouncebayes.PAPER_BALL.diameter)
NOT_FOUND, CENTROID, EDGE_FIT = 0, 1, 2
METHOD_NAMES = {NOT_FOUND: "not found", CENTROID: "coverage centroid",
                EDGE_FIT: "disk fit at the frame edge"}


# --------------------------------------------------------------------------- reading frames


@dataclass(frozen=True)
class VideoSource:
    """Grey frames ``(n, height, width)`` uint8 (read-only) and their rate.

    ``name`` (the file's stem, or the folder's name) names the output files; ``fps_source`` is
    ``"file"`` or ``"argument"``.
    """

    path: Path
    name: str
    frames: np.ndarray
    fps: float
    fps_source: str


def read_frames(path: str | os.PathLike, *, fps: float | None = None) -> VideoSource:
    """Read a video file or a folder of frames (sorted naturally: ``f2.png`` before ``f10.png``).

    Arguments:
        path: a video file (any format FFmpeg reads: mp4, avi, mov, mkv, ...) or a folder of
            PNG/TIFF/JPEG/BMP frames of one size (16-bit frames are scaled to 8 bits with one
            shift for the whole sequence).
        fps: the capture frame rate; overrides the file's. Required for image folders.

    Raises:
        InputFileError: naming the file when it is missing, unreadable, has no frames, frames of
            different sizes, or no known frame rate.
    """
    path = Path(path)
    if fps is not None:
        fps = check_scalar("fps", fps, unit="frames/s", low=0.0, low_open=True)
    if not path.exists():
        raise InputFileError(path, "no such file or folder")
    frames, file_fps = _read_folder(path) if path.is_dir() else _read_video(path)
    rate, source = (fps, "argument") if fps is not None else (file_fps, "file")
    if rate is None:
        what = "image folders store no frame rate" if path.is_dir() else \
            "the file stores no usable frame rate"
        raise InputFileError(path, f"frame rate unknown ({what}): give it with --fps")
    frames.setflags(write=False)
    name = path.name if path.is_dir() else path.stem
    return VideoSource(path=path, name=name, frames=frames, fps=float(rate), fps_source=source)


def _read_video(path: Path) -> tuple[np.ndarray, float | None]:
    if path.suffix.lower() in IMAGE_SUFFIXES:
        raise InputFileError(path, "is a single image; give the folder that holds the frames")
    cap = cv2.VideoCapture(str(path))
    try:
        if not cap.isOpened():
            raise InputFileError(path, "cannot be opened as a video (readable: "
                                 f"{', '.join(VIDEO_SUFFIXES)} and other FFmpeg formats, or a "
                                 "folder of image frames)")
        file_fps = cap.get(cv2.CAP_PROP_FPS)
        frames = []
        while True:
            ok, img = cap.read()
            if not ok:
                break
            frames.append(_to_grey(img))
    finally:
        cap.release()
    if not frames:
        raise InputFileError(path, "no frames could be decoded from this video")
    if any(f.shape != frames[0].shape for f in frames):
        raise InputFileError(path, "frame size changes within the video")
    usable = math.isfinite(file_fps) and 0.0 < file_fps < 1e7
    return np.stack(frames), (float(file_fps) if usable else None)


def _natural_key(p: Path) -> tuple:
    parts = re.split(r"(\d+)", p.name.lower())
    return tuple(int(s) if i % 2 else s for i, s in enumerate(parts))


def _read_folder(folder: Path) -> tuple[np.ndarray, None]:
    files = sorted((p for p in folder.iterdir()
                    if p.is_file() and p.suffix.lower() in IMAGE_SUFFIXES), key=_natural_key)
    if not files:
        raise InputFileError(folder, f"no image frames ({', '.join(IMAGE_SUFFIXES)}) in this "
                                     "folder")
    first = _read_image(files[0])
    shift = max(0, int(first.max()).bit_length() - 8) if first.dtype == np.uint16 else 0
    frames = np.empty((len(files),) + first.shape[:2], np.uint8)
    for i, f in enumerate(files):
        img = first if i == 0 else _read_image(f)
        if img.shape[:2] != first.shape[:2]:
            raise InputFileError(f, f"frame size {img.shape[1]}x{img.shape[0]} differs from "
                                    f"{first.shape[1]}x{first.shape[0]} of {files[0].name}")
        frames[i] = _to_grey(img, shift)
    return frames, None


def read_image(path: str | os.PathLike) -> np.ndarray:
    """One image file as a grey ``uint8`` array (e.g. a background image of the empty scene)."""
    return _to_grey(_read_image(Path(path)), 0)


def _read_image(path: Path) -> np.ndarray:
    img = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if img is None:
        raise InputFileError(path, "cannot be read as an image")
    if img.dtype not in (np.uint8, np.uint16):
        raise InputFileError(path, f"pixel type {img.dtype} is not supported (8 or 16 bits)")
    return img


def _to_grey(img: np.ndarray, shift: int = 0) -> np.ndarray:
    if img.ndim == 3:
        code = cv2.COLOR_BGRA2GRAY if img.shape[2] == 4 else cv2.COLOR_BGR2GRAY
        img = cv2.cvtColor(img, code) if img.shape[2] > 1 else img[..., 0]
    if img.dtype == np.uint16:
        img = np.minimum(img >> shift, 255).astype(np.uint8)
    return img


# --------------------------------------------------------------------------- tracking


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
            levels.
        min_visible: smallest fraction of the ball's area in the frame for a frame to count.
        max_radius_change: largest relative difference from the median radius for a ball wholly
            in the frame (a larger one means something else was found).
    """

    polarity: Polarity = "auto"
    background_frames: int = 25
    threshold_sigma: float = 5.0
    min_contrast: float = 12.0
    min_visible: float = 0.25
    max_radius_change: float = 0.25

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


@dataclass(frozen=True)
class Track:
    """Per-frame result of :func:`track_ball` (pixels; origin top-left, ``v`` down).

    ``centre`` ``(n, 2)`` and ``radius`` ``(n,)`` are NaN where ``method == NOT_FOUND``;
    ``method`` is ``CENTROID`` (ball wholly in view) or ``EDGE_FIT`` (cut by the frame edge);
    ``contrast`` is the ball's rim contrast against the background (grey levels); ``noise`` the
    background-difference noise (grey levels, robust standard deviation).
    """

    centre: np.ndarray
    radius: np.ndarray
    method: np.ndarray
    contrast: np.ndarray
    background: np.ndarray = field(repr=False)
    polarity: str
    noise: float
    threshold: float

    @property
    def found(self) -> np.ndarray:
        return self.method != NOT_FOUND

    @property
    def ball_radius(self) -> float:
        """Median radius (px) over the frames where the ball is wholly in view."""
        whole = self.method == CENTROID
        return float(np.median(self.radius[whole])) if whole.any() else math.nan


def background_model(frames: np.ndarray, n_frames: int = 25) -> np.ndarray:
    """Per-pixel median of ``n_frames`` evenly spaced frames, float32 ``(h, w)``.

    Equal to ``np.median(frames[idx], axis=0)``, 8x faster: a sorting network of element-wise
    minima and maxima (Batcher's odd-even merge sort, pruned to the middle elements).
    """
    idx = np.unique(np.linspace(0, len(frames) - 1, min(len(frames), n_frames)).round())
    n = len(idx)
    size, pairs = _median_network(n)
    rows = [frames[int(i)] for i in idx] + [np.full(frames.shape[1:], 255, np.uint8)] * (size - n)
    for a, b in pairs:
        rows[a], rows[b] = np.minimum(rows[a], rows[b]), np.maximum(rows[a], rows[b])
    return (rows[(n - 1) // 2].astype(np.float32) + rows[n // 2]) / 2


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
    """Find the ball in every frame with sub-pixel accuracy (see the module docstring).

    Arguments:
        frames: grey frames ``(n, height, width)`` uint8, e.g. ``read_frames(path).frames``.
        config: detection settings.
        background: an image of the scene without the ball ``(height, width)``; default: the
            per-pixel median of ``config.background_frames`` frames.
    """
    frames = _check_frames(frames)
    bg = background_model(frames, config.background_frames) if background is None else \
        _check_background(background, frames.shape[1:])
    noise, sign = _noise_and_polarity(frames, bg, config)
    threshold = max(config.threshold_sigma * noise, config.min_contrast)
    state = _Searcher(bg, sign, threshold)
    raw = [state.measure(frame) for frame in frames]
    centre, radius, method, contrast = _finish(frames, state, raw, config)
    for a in (centre, radius, method, contrast):
        a.setflags(write=False)
    return Track(centre=centre, radius=radius, method=method, contrast=contrast, background=bg,
                 polarity="bright" if sign > 0 else "dark", noise=noise, threshold=threshold)


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


def _gain(frame: np.ndarray, bg: np.ndarray) -> float:
    """Frame brightness relative to the background (lamp flicker at 100/120 Hz), from a sparse
    grid of pixels: the ball covers too few of them to matter."""
    step = max(1, min(frame.shape) // 60)
    f, b = frame[::step, ::step], bg[::step, ::step]
    ok = b > 8.0
    return float(np.median(f[ok] / b[ok])) if ok.sum() > 16 else 1.0


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
    """Frame-to-frame search state: the background (full and downsampled) and the last hits."""

    def __init__(self, bg: np.ndarray, sign: int, threshold: float):
        h, w = bg.shape
        self.bg, self.sign, self.threshold = bg, sign, threshold
        self.f = max(1, min(h, w) // 240)  # coarse search: finds balls of radius >= ~f px
        self.small_size = (w // self.f, h // self.f)
        self.bg_small = self._shrink(bg)
        self.history: list[tuple[float, float, float] | None] = []
        self.gains: list[float] = []

    def _shrink(self, img: np.ndarray) -> np.ndarray:
        if self.f == 1:
            return img.astype(np.float32)
        cut = img[:self.small_size[1] * self.f, :self.small_size[0] * self.f]
        return cv2.resize(cut, self.small_size, interpolation=cv2.INTER_AREA).astype(np.float32)

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
    img = frame[v0:v1, u0:u1].astype(np.float32)
    bg = gain * s.bg[v0:v1, u0:u1]
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
    weight = around.astype(np.float32)
    if shadow and weight.sum() >= 8:
        ratio = np.where(around, win.img / np.maximum(bg, 1.0), 0.0).astype(np.float32)
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


def _finish(frames, s: _Searcher, raw: Sequence[_Measure | None], config: TrackerConfig):
    """Arrays from the per-frame measures; edge fits for balls cut by the frame edge; checks."""
    n = len(raw)
    centre = np.full((n, 2), np.nan)
    radius = np.full(n, np.nan)
    method = np.zeros(n, np.int8)
    contrast = np.full(n, np.nan)
    for k, m in enumerate(raw):
        if m is not None:
            centre[k], radius[k], contrast[k] = (m.cx, m.cy), m.r, m.contrast
            method[k] = EDGE_FIT if m.border else CENTROID
    whole = method == CENTROID
    if not whole.any():
        method[:] = NOT_FOUND
    else:
        r_med = float(np.median(radius[whole]))
        bad = whole & (np.abs(radius / r_med - 1.0) > config.max_radius_change)
        method[bad] = NOT_FOUND
        for k in np.flatnonzero(method == EDGE_FIT):
            fit = _edge_fit(frames[k], s, s.gains[k], centre[k], r_med, config.min_visible)
            if fit is None:
                method[k] = NOT_FOUND
            else:
                centre[k], radius[k] = fit, r_med
    lost = method == NOT_FOUND
    centre[lost], radius[lost] = np.nan, np.nan
    return centre, radius, method, contrast


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
                c = _disk_step(alpha, x, y, c, r, width)
                if c is None or math.dist(c, c0) > r:  # diverged: not a disk of radius r
                    return None
    return c


def _disk_step(alpha, x, y, c, r, width) -> np.ndarray | None:
    """One Gauss-Newton step of the centre of a disk with a linear edge ramp ``width`` wide."""
    dx, dy = x - c[0], y - c[1]
    rho = np.maximum(np.hypot(dx, dy), 1e-9)
    ramp = (r - rho) / width + 0.5
    on = (ramp > 0) & (ramp < 1)
    res = (alpha - np.clip(ramp, 0.0, 1.0))[on]
    jx, jy = dx[on] / (rho[on] * width), dy[on] / (rho[on] * width)
    jtj = np.array([[jx @ jx, jx @ jy], [jx @ jy, jy @ jy]])
    if not np.isfinite(jtj).all() or np.linalg.cond(jtj) > 1e8:
        return None
    return c + np.linalg.solve(jtj, [jx @ res, jy @ res])


# --------------------------------------------------------------------------- calibration, frame


@dataclass(frozen=True, kw_only=True)
class Calibration:
    """Image scale, metres per pixel; ``source`` says where it came from."""

    metres_per_px: float
    source: str

    def __post_init__(self):
        check_scalar("metres_per_px", self.metres_per_px, unit="m/px", low=0.0, low_open=True)

    @classmethod
    def from_reference(cls, p1: Sequence[float], p2: Sequence[float],
                       length: float) -> Calibration:
        """Two pixel points ``length`` metres apart (Tracker's calibration stick)."""
        length = check_scalar("reference length", length, unit="m", low=0.0, low_open=True)
        pixels = math.dist(_point("reference point 1", p1), _point("reference point 2", p2))
        if pixels == 0.0:
            raise ValueError(f"the two reference points must differ; got {tuple(p1)} twice")
        return cls(metres_per_px=length / pixels, source="reference")

    @classmethod
    def from_ball_diameter(cls, diameter: float, radius_px: float) -> Calibration:
        """The ball's known diameter (m) against its measured radius (px), e.g.
        ``Track.ball_radius``."""
        diameter = check_scalar("ball diameter", diameter, unit="m", low=0.0, low_open=True)
        radius_px = check_scalar("ball radius", radius_px, unit="px", low=0.0, low_open=True)
        return cls(metres_per_px=diameter / (2.0 * radius_px), source="ball diameter")


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

    @classmethod
    def from_points(cls, p1: Sequence[float], p2: Sequence[float]) -> Surface:
        """Two points on the surface line, pixel coordinates with the origin top-left."""
        a, b = _point("surface point 1", p1), _point("surface point 2", p2)
        length = math.dist(a, b)
        if length == 0.0:
            raise ValueError(f"the two surface points must differ; got {a} twice")
        return cls(point=a, direction=((b[0] - a[0]) / length, (b[1] - a[1]) / length),
                   source="points")

    @property
    def angle(self) -> float:
        """Inclination in the image, degrees in (-90, 90], counter-clockwise from the +x axis
        as seen on the screen (``v`` up)."""
        deg = math.degrees(math.atan2(-self.direction[1], self.direction[0]))
        return deg - 180.0 if deg > 90.0 else deg + 180.0 if deg <= -90.0 else deg


def detect_surface(background: np.ndarray, *, min_length: float = 0.3) -> Surface | None:
    """The longest straight edge of the background image, refined by a line fit to its edge
    pixels; ``None`` if no straight edge spans ``min_length`` of the frame's width.

    Limits: the surface must be the longest straight edge in view (ruler edges, table edges or
    the plane's far border can be picked instead: check the overlay, or give the points).
    """
    img = np.clip(np.asarray(background, dtype=np.float32), 0, 255).astype(np.uint8)
    smooth = cv2.GaussianBlur(img, (0, 0), 1.5)
    grad = np.hypot(cv2.Sobel(smooth, cv2.CV_32F, 1, 0), cv2.Sobel(smooth, cv2.CV_32F, 0, 1))
    high = float(np.percentile(grad, 98))
    edges = cv2.Canny(smooth, 0.5 * high, high)
    h, w = img.shape
    lines = cv2.HoughLinesP(edges, 1, np.pi / 720, threshold=int(0.15 * w),
                            minLineLength=min_length * w, maxLineGap=6)
    if lines is None:
        return None
    longest = max(lines.reshape(-1, 4), key=lambda s: math.dist(s[:2], s[2:]))
    x1, y1, x2, y2 = (float(v) for v in longest)
    direction = np.array([x2 - x1, y2 - y1]) / math.dist((x1, y1), (x2, y2))
    vs, us = np.nonzero(edges)
    dist = (us - x1) * direction[1] - (vs - y1) * direction[0]
    near = np.abs(dist) <= 2.0
    pts = np.column_stack([us[near], vs[near]]).astype(np.float32)
    dx, dy, px, py = cv2.fitLine(pts, cv2.DIST_HUBER, 0, 0.01, 0.01).ravel()
    return Surface(point=(float(px), float(py)), direction=(float(dx), float(dy)),
                   source="detected")


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
                   fps: float) -> PlaneTrajectory:
    """Found centres in metres, ``x`` along the surface from the first found position, ``y``
    the height of the ball centre above the surface line."""
    fps = check_scalar("fps", fps, unit="frames/s", low=0.0, low_open=True)
    e, n = plane_axes(track, surface)
    k = np.flatnonzero(track.found)
    rel = track.centre[k] - np.asarray(surface.point)
    x, y = rel @ e, rel @ n
    s = calibration.metres_per_px
    return PlaneTrajectory(t=k / fps, x=(x - x[0]) * s, y=y * s)


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


# --------------------------------------------------------------------------- overlay


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


# --------------------------------------------------------------------------- one video


@dataclass(frozen=True)
class TrackedVideo:
    """Everything :func:`track_video` found for one input."""

    source: VideoSource
    track: Track
    calibration: Calibration
    surface: Surface
    trajectory: PlaneTrajectory


def track_video(path: str | os.PathLike, *, fps: float | None = None,
                config: TrackerConfig = TrackerConfig(), ball_diameter: float | None = None,
                reference: tuple[Sequence[float], Sequence[float], float] | None = None,
                surface: Surface | None = None,
                background: np.ndarray | str | os.PathLike | None = None) -> TrackedVideo:
    """Read, track, calibrate and rotate one video into the plane frame.

    Arguments:
        path, fps: as :func:`read_frames`.
        config: as :func:`track_ball`.
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
    track = track_ball(source.frames, config=config, background=background)
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
