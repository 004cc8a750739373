"""Reading frames: a video file or a folder of images -> grey ``uint8`` frames and their rate."""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from .._errors import InputFileError
from .._validate import check_choice, check_scalar

VIDEO_SUFFIXES = (".mp4", ".avi", ".mov", ".mkv", ".m4v", ".mpg", ".mpeg", ".wmv")
# what of a colour frame is tracked: "grey" its luma (BT.601, OpenCV's), or one colour channel;
# "auto": the luma unless the ball stands out far more clearly in a channel (_choose)
CHANNELS = ("auto", "grey", "red", "green", "blue")
_PLANES = ("grey", "red", "green", "blue")
IMAGE_SUFFIXES = (".png", ".tif", ".tiff", ".jpg", ".jpeg", ".bmp")


@dataclass(frozen=True)
class VideoSource:
    """Grey frames ``(n, height, width)`` uint8 (read-only) and their rate.

    ``name`` (the file's stem, or the folder's name) names the output files; ``fps_source`` is
    ``"file"`` or ``"argument"``; ``channel``: what of colour frames the grey frames are
    (``"grey"``: their luma, or grey frames; or ``"red"``, ``"green"``, ``"blue"``), and
    ``channel_note`` why a channel was chosen for ``"auto"`` (None where the luma was kept).
    """

    path: Path
    name: str
    frames: np.ndarray
    fps: float
    fps_source: str
    jpeg_quality: float | None = None  # of JPEG-coded frames (MJPEG, JPEG files): jpeg_quality()
    # a video file's size in bits per pixel of its frames: how hard it is compressed where the
    # codec's quantiser is not read (MPEG-4, H.264, ...; uncompressed grey video: 8)
    bits_per_pixel: float | None = None
    channel: str = "grey"
    channel_note: str | None = None


def read_frames(path: str | os.PathLike, *, fps: float | None = None,
                channel: str = "auto") -> VideoSource:
    """Read a video file or a folder of frames (sorted naturally: ``f2.png`` before ``f10.png``).

    Arguments:
        path: a video file (any format FFmpeg reads: mp4, avi, mov, mkv, ...) or a folder of
            PNG/TIFF/JPEG/BMP frames of one size (16-bit frames are scaled to 8 bits with one
            shift for the whole sequence).
        fps: the capture frame rate; overrides the file's. Required for image folders.
        channel: what of colour frames to track (``CHANNELS``): ``"grey"`` their luma,
            ``"red"``, ``"green"`` or ``"blue"`` one channel, ``"auto"`` the luma unless the
            ball stands out of the background ``CLEARER`` times as far in a channel (a red
            ball on a green wall as bright; ``CLEARER_CODED`` times for a video file or JPEG
            frames, whose codec keeps colour at half the resolution; :func:`_choose`).

    Raises:
        InputFileError: naming the file when it is missing, unreadable, has no frames, frames of
            different sizes, or no known frame rate.
    """
    path = Path(path)
    if fps is not None:
        fps = check_scalar("fps", fps, unit="frames/s", low=0.0, low_open=True)
    check_choice("channel", channel, CHANNELS)
    if not path.exists():
        raise InputFileError(path, "no such file or folder")
    planes: tuple[str, ...] = _PLANES if channel == "auto" else (channel,)
    frames, file_fps, planes = _read_folder(path, planes) if path.is_dir() else \
        _read_video(path, planes)
    lossless = path.is_dir() and all(f.suffix.lower() in LOSSLESS_SUFFIXES
                                     for f in _frame_files(path))
    frames, chosen, note = _choose(frames, planes, lossless)
    rate, source = (fps, "argument") if fps is not None else (file_fps, "file")
    if rate is None:
        what = "image folders store no frame rate" if path.is_dir() else \
            "the file stores no usable frame rate"
        raise InputFileError(path, f"frame rate unknown ({what}): give it with --fps")
    frames.setflags(write=False)
    name = path.name if path.is_dir() else path.stem
    bits = None if path.is_dir() else 8.0 * path.stat().st_size / frames.size
    return VideoSource(path=path, name=name, frames=frames, fps=float(rate), fps_source=source,
                       jpeg_quality=jpeg_quality(path), bits_per_pixel=bits, channel=chosen,
                       channel_note=note)


CLEARER = 2.0        # a channel where the ball stands out this many times as far as in the
CLEARER_CODED = 5.0  # luma is tracked; where the codec halved the colour's size, this many
_SAMPLE = 25    # frames (spread) on which the ball's standing out is measured
LOSSLESS_SUFFIXES = (".png", ".tif", ".tiff", ".bmp")  # frames whose colour is at full size


def _choose(frames: np.ndarray, planes: tuple[str, ...], lossless: bool
            ) -> tuple[np.ndarray, str, str | None]:
    """The frames of one plane from ``frames`` ``(n, k, h, w)`` (the ``planes`` named), its
    name, and why where a colour channel was chosen over the luma: where the ball stands out
    ``CLEARER`` times as far in it (``CLEARER_CODED`` unless the frames are ``lossless``: a
    codec's colour at half size blurs a channel's edges; a rendered 12 px ball, red on a green
    wall, standing out 4.1 times as far in red as in the luma: as PNG frames its centres 0.029
    px RMS in red and 0.40 in the luma, as MJPEG 0.43 and 0.53, and the surface there 0.57
    degrees off in red, 0.04 in the luma)."""
    if frames.shape[1] == 1:
        return frames[:, 0], planes[0], None
    score = [_standing_out(frames[:, k]) for k in range(frames.shape[1])]
    best = int(np.argmax(score[1:])) + 1
    if score[best] >= (CLEARER if lossless else CLEARER_CODED) * score[0]:
        note = (f"the ball stands out of the background by {score[0]:.1f} noise SDs in the "
                f"luma and {score[best]:.1f} in the {planes[best]} channel: tracked in it")
        return np.ascontiguousarray(frames[:, best]), planes[best], note
    return np.ascontiguousarray(frames[:, 0]), "grey", None


def _standing_out(frames: np.ndarray) -> float:
    """How far the ball stands out of the background (noise SDs): over ``_SAMPLE`` frames
    spread, the median of each frame's 30th largest difference from their per-pixel median,
    over the differences' robust SD."""
    idx = np.unique(np.linspace(0, len(frames) - 1, min(len(frames), _SAMPLE)).round()
                    ).astype(int)
    sample = frames[idx].astype(np.float32)
    diff = np.abs(sample - np.median(sample, axis=0)).reshape(len(idx), -1)
    noise = max(1.4826 * float(np.median(diff)), 0.5)
    k = min(30, diff.shape[1])
    top = np.partition(diff, diff.shape[1] - k, axis=1)[:, diff.shape[1] - k]
    return float(np.median(top)) / noise


# The IJG (libjpeg) luminance quantisation table at quality 50, ITU-T T.81 Annex K.1 (row by
# row); a JPEG stream stores its tables in zig-zag order (T.81 figure A.6)
_IJG_LUMA = np.array([16, 11, 10, 16, 24, 40, 51, 61, 12, 12, 14, 19, 26, 58, 60, 55,
                      14, 13, 16, 24, 40, 57, 69, 56, 14, 17, 22, 29, 51, 87, 80, 62,
                      18, 22, 37, 56, 68, 109, 103, 77, 24, 35, 55, 64, 81, 104, 113, 92,
                      49, 64, 78, 87, 103, 121, 120, 101, 72, 92, 95, 98, 112, 100, 103, 99],
                     float).reshape(8, 8)
_ZIGZAG = sorted(((i, j) for i in range(8) for j in range(8)),
                 key=lambda ij: (ij[0] + ij[1], ij[0] if (ij[0] + ij[1]) % 2 else ij[1]))
_IJG_LUMA_ZIGZAG = np.array([_IJG_LUMA[i, j] for i, j in _ZIGZAG])
_SCAN_BYTES = 1 << 22  # bytes of a video file searched for its first JPEG frames
_TABLES = 25  # frames whose tables are read (an encoder's rate control may vary them)


def jpeg_quality(path: str | os.PathLike) -> float | None:
    """The JPEG quality of a video's frames (MJPEG) or of a folder's first JPEG file: the median
    over up to ``_TABLES`` frames of the IJG quality (1-100) whose luminance table is as coarse
    as the frame's (the median ratio of the two tables, libjpeg's scaling ``S = 5000 / Q``
    below 50, ``200 - 2 Q`` above); None where the frames are not JPEG-coded (PNG, TIFF,
    MPEG-4, H.264, ...) or no table is found. Written here: OpenCV decodes the frames and hides their coding."""
    path = Path(path)
    try:
        if path.is_dir():
            jpgs = [p for p in _frame_files(path) if p.suffix.lower() in (".jpg", ".jpeg")]
            data = jpgs[0].read_bytes()[:_SCAN_BYTES] if jpgs else b""
        else:
            with path.open("rb") as f:
                data = f.read(_SCAN_BYTES)
    except OSError:
        return None
    qualities = [_ijg_quality(t) for t in _luma_tables(data, _TABLES)]
    return round(float(np.median(qualities)), 1) if qualities else None


def _ijg_quality(table: np.ndarray) -> float:
    """The IJG quality whose luminance table is as coarse as ``table`` (zig-zag order)."""
    keep = (table > 1) & (table < 255)  # clipped entries say nothing of the scale
    if keep.sum() < 8:
        return 100.0 if table.max() <= 1 else 1.0
    scale = float(np.median(100.0 * table[keep] / _IJG_LUMA_ZIGZAG[keep]))
    quality = 5000.0 / scale if scale > 100.0 else (200.0 - scale) / 2.0
    return min(max(quality, 1.0), 100.0)


def _luma_tables(data: bytes, limit: int) -> list[np.ndarray]:
    """The luminance (id 0) quantisation tables (zig-zag order) of up to ``limit`` JPEG
    images in ``data``, each found by following its chain of marker segments from the start of
    image (T.81 B.1.1) to a DQT, so that bytes of another codec that happen to read FF D8 FF
    are not taken for one."""
    tables: list[np.ndarray] = []
    start = data.find(b"\xff\xd8\xff")
    while start >= 0 and len(tables) < limit:
        if (table := _first_luma_table(data, start)) is not None:
            tables.append(table)
        start = data.find(b"\xff\xd8\xff", start + 3)
    return tables


def _first_luma_table(data: bytes, start: int) -> np.ndarray | None:
    """The luminance table of the JPEG image whose start-of-image marker is at ``start``."""
    i = start + 2
    while i + 4 <= len(data) and data[i] == 0xFF:
        marker, length = data[i + 1], int.from_bytes(data[i + 2:i + 4], "big")
        if marker in (0xD8, 0xD9, 0xDA) or length < 2 or i + 2 + length > len(data):
            break  # another start of image, its end, a scan: no table before it
        if marker == 0xDB:
            seg, k = data[i + 4:i + 2 + length], 0
            while k < len(seg):
                precision, ident = seg[k] >> 4, seg[k] & 15
                size = 128 if precision else 64
                if k + 1 + size > len(seg):
                    break
                raw = seg[k + 1:k + 1 + size]
                values = np.frombuffer(raw, ">u2" if precision else "u1").astype(float)
                if ident == 0:
                    return values
                k += 1 + size
        i += 2 + length
    return None


def _read_video(path: Path, planes: tuple[str, ...]
                ) -> tuple[np.ndarray, float | None, tuple[str, ...]]:
    """The frames' ``planes`` ``(n, k, h, w)``, the file's rate and the planes read (the
    luma alone where the first frame is grey: OpenCV decodes every video to colour)."""
    if path.suffix.lower() in IMAGE_SUFFIXES:
        raise InputFileError(path, "is a single image; give the folder that holds the frames")
    cap = cv2.VideoCapture(str(path))
    try:
        if not cap.isOpened():
            raise InputFileError(path, "cannot be opened as a video (readable: "
                                 f"{', '.join(VIDEO_SUFFIXES)} and other FFmpeg formats, or a "
                                 "folder of image frames)")
        file_fps = cap.get(cv2.CAP_PROP_FPS)
        frames: list[np.ndarray] = []
        while True:
            ok, img = cap.read()
            if not ok:
                break
            if not frames:
                planes = _planes_of(img, planes)
            frames.append(_to_planes(img, 0, planes))
    finally:
        cap.release()
    if not frames:
        raise InputFileError(path, "no frames could be decoded from this video")
    if any(f.shape != frames[0].shape for f in frames):
        raise InputFileError(path, "frame size changes within the video")
    usable = math.isfinite(file_fps) and 0.0 < file_fps < 1e7
    return np.stack(frames), (float(file_fps) if usable else None), planes


def _planes_of(img: np.ndarray, planes: tuple[str, ...]) -> tuple[str, ...]:
    """``planes``, or the luma alone where ``img`` is grey (its channels within 2 levels of
    each other: a grey video decoded to colour) and more than one was asked."""
    if len(planes) == 1 or img.ndim == 2 or img.shape[2] < 3:
        return planes if img.ndim == 3 and img.shape[2] >= 3 else ("grey",)
    c = img[..., :3].astype(np.int16)
    grey = int(np.abs(c[..., 0] - c[..., 1]).max()) <= 2 and \
        int(np.abs(c[..., 1] - c[..., 2]).max()) <= 2
    return ("grey",) if grey else planes


def _natural_key(p: Path) -> tuple:
    parts = re.split(r"(\d+)", p.name.lower())
    return tuple(int(s) if i % 2 else s for i, s in enumerate(parts))


def _frame_files(folder: Path) -> list[Path]:
    """The image frames of ``folder``, sorted naturally."""
    return sorted((p for p in folder.iterdir()
                   if p.is_file() and p.suffix.lower() in IMAGE_SUFFIXES), key=_natural_key)


def _read_folder(folder: Path, planes: tuple[str, ...]
                 ) -> tuple[np.ndarray, None, tuple[str, ...]]:
    files = _frame_files(folder)
    if not files:
        raise InputFileError(folder, f"no image frames ({', '.join(IMAGE_SUFFIXES)}) in this "
                                     "folder")
    first = _read_image(files[0])
    shift = max(0, int(first.max()).bit_length() - 8) if first.dtype == np.uint16 else 0
    planes = _planes_of(first, planes)
    frames = np.empty((len(files), len(planes)) + first.shape[:2], np.uint8)
    for i, f in enumerate(files):
        img = first if i == 0 else _read_image(f)
        if img.shape[:2] != first.shape[:2]:
            raise InputFileError(f, f"frame size {img.shape[1]}x{img.shape[0]} differs from "
                                    f"{first.shape[1]}x{first.shape[0]} of {files[0].name}")
        frames[i] = _to_planes(img, shift, planes)
    return frames, None, planes


def read_image(path: str | os.PathLike, channel: str = "grey") -> np.ndarray:
    """One image file as a grey ``uint8`` array (e.g. a background image of the empty scene):
    its luma, or the colour ``channel`` (``VideoSource.channel``) of a colour image."""
    check_choice("channel", channel, _PLANES)
    return _to_planes(_read_image(Path(path)), 0, (channel,))[0]


def _read_image(path: Path) -> np.ndarray:
    img = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if img is None:
        raise InputFileError(path, "cannot be read as an image")
    if img.dtype not in (np.uint8, np.uint16):
        raise InputFileError(path, f"pixel type {img.dtype} is not supported (8 or 16 bits)")
    return img


def _to_planes(img: np.ndarray, shift: int, planes: tuple[str, ...]) -> np.ndarray:
    """The ``planes`` (``_PLANES``' names) of an image read by OpenCV (BGR order), uint8
    ``(k, h, w)``; a grey image's one plane whatever is asked."""
    if img.dtype == np.uint16:
        img = np.minimum(img >> shift, 255).astype(np.uint8)
    if img.ndim == 2 or img.shape[2] < 3:
        return (img if img.ndim == 2 else img[..., 0])[None]
    out = []
    for name in planes:
        if name == "grey":
            code = cv2.COLOR_BGRA2GRAY if img.shape[2] == 4 else cv2.COLOR_BGR2GRAY
            out.append(cv2.cvtColor(img, code))
        else:
            out.append(img[..., {"blue": 0, "green": 1, "red": 2}[name]])
    return np.stack(out)
