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
from .._validate import check_scalar

VIDEO_SUFFIXES = (".mp4", ".avi", ".mov", ".mkv", ".m4v", ".mpg", ".mpeg", ".wmv")
IMAGE_SUFFIXES = (".png", ".tif", ".tiff", ".jpg", ".jpeg", ".bmp")


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
