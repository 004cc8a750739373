"""Lost and repeated frames: where a video is not every frame the camera took, once each.

A camera that drops frames (a consumer camera writing to a slow card, a USB camera, a screen
recording), a file converted to another frame rate (a copy of a frame put in where one is
missing or to fill the new rate), or a variable-rate phone video exported at a constant rate:
the frames are then not at ``k / fps``, and nothing in the pictures says so. The ball's motion
does: in free flight its step from one frame to the next changes by ``a / fps^2`` (gravity,
drag: a few per cent of the step), so

- a step 2 (3, ...) times the steps on either side, which agree, is a frame (two, ...) lost
  there: every later frame is one (two, ...) interval later than its number says;
- a step of nothing after a step of the ball in motion is a repeated picture: followed by a
  step like the one before, a copy put in (every later frame one interval earlier than its
  number says), followed by twice that step, a copy in a lost frame's place (no shift).

Rendered (tests/render_pbr.py, a 12 px ball at 1.2-3 px a frame) with every 10th frame lost:
the rebound speed came out +11.8 % (8.7 SE) and the incidence speed +10 %, the frame rate
given; with every 5th frame a copy of the one before, the centres of the copies 0.8-2.2 px off
where the ball was when they should have been taken. The frames where the ball is slower than
``MIN_STEP_PX`` a frame, or near a bounce (the steps either side differ), tell nothing and are
taken as they come. Written here because no library reads a frame's time from a tracked
object's motion.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

MIN_STEP_PX = 1.0  # the ball's step (px a frame) below which a frame's time is not told
AGREE_REL = 0.1    # two steps agree within this fraction of their size (gravity at 240 fps,
#                    2 m/s: 4 %) ...
AGREE_SD = 6.0     # ... plus this many SDs of a step (the centres' SD times sqrt 2)
MAX_LOST = 3       # at most this many frames lost in one place are told
CLEAR = 10.0       # ... and only where the ball's step is this many SDs of a step: a lost frame
#                    doubles it, and noise must not (a 5 px glossy ball under a 1.5 px blur,
#                    MJPEG, 1.5 px a frame, centres 0.3-0.6 px off: a step of twice its
#                    neighbours by chance, with the stated SD alone)


class FrameTiming(NamedTuple):
    """Each frame's place in the camera's sequence, in frame intervals (``place``; ``k`` where
    nothing was lost or repeated), the frames lost just before each frame (``lost``), and the
    frames whose picture repeats the frame before (``repeated``)."""

    place: np.ndarray
    lost: np.ndarray
    repeated: np.ndarray


def _agree(a: np.ndarray, b: np.ndarray, sd: float) -> bool:
    """Whether steps ``a`` and ``b`` (px) agree (``AGREE_REL``, ``AGREE_SD``)."""
    size = max(math.hypot(*a), math.hypot(*b))
    return math.hypot(*(a - b)) <= AGREE_REL * size + AGREE_SD * math.sqrt(2.0) * sd


def frame_timing(centre: np.ndarray, usable: np.ndarray, centre_sd: float) -> FrameTiming:
    """The frames' timing (:class:`FrameTiming`) from the ball's centres ``(n, 2)`` (px) in
    the frames that are ``usable`` (found, not flagged), each with an SD of ``centre_sd``
    px."""
    n = len(centre)
    lost, repeated = np.zeros(n, np.int64), np.zeros(n, bool)
    shift = np.zeros(n, np.int64)  # frames put in (a copy) before each frame: -1 from there
    step = np.full((n, 2), np.nan)
    ok = usable[1:] & usable[:-1]
    step[1:][ok] = centre[1:][ok] - centre[:-1][ok]  # step[j]: from frame j - 1 to frame j
    step = np.vstack([step, np.full((1, 2), np.nan)])  # no step after the last frame
    # the centres' SD: the stated one, or as their second differences scatter (a flight's
    # change of step is a few per cent of it; bounces, lost frames: a median leaves them out;
    # steps of nothing, a repeated picture's, are not counted)
    moved = np.where(np.hypot(*step.T)[:, None] >= 0.5 * MIN_STEP_PX, step, np.nan)
    turn = moved[2:] - moved[1:-1]
    turn = turn[np.isfinite(turn).all(axis=1)]
    if len(turn) >= 8:
        centre_sd = max(centre_sd, 1.4826 * float(np.median(np.abs(turn))) / math.sqrt(6.0))
    least = max(MIN_STEP_PX, CLEAR * math.sqrt(2.0) * centre_sd)
    # the frames worth a look, at once (a loop over every frame cost 18 us a frame): the step
    # before clear, and the step here next to nothing or longer than it
    size = np.hypot(*step.T)  # NaN where there is no step: compared, False
    look = (size[1:n - 1] >= least) & ((size[2:n] <= 0.5 * MIN_STEP_PX)
                                       | (size[2:n] >= 1.1 * size[1:n - 1]))
    for j in (2 + np.flatnonzero(look)).tolist():
        before, here, after = step[j - 1], step[j], step[j + 1]
        if repeated[j - 1]:
            continue  # after a copy, the step covers its place
        still = AGREE_REL * math.hypot(*before) + AGREE_SD * math.sqrt(2.0) * centre_sd
        if math.hypot(*here) <= min(still, 0.5 * MIN_STEP_PX):  # the ball did not move
            if j == n - 1:  # the last frame: a copy (its place does not matter)
                repeated[j] = True
            elif _agree(after, before, centre_sd):  # a copy put in
                repeated[j], shift[j] = True, 1
            elif _agree(after, 2.0 * before, centre_sd):  # a copy in a lost frame's place
                repeated[j] = True
            continue
        if not np.isfinite(after).all():
            continue
        if not _agree(before, after, centre_sd):
            continue  # a bounce, or the ball's step changing: nothing to tell
        mean = 0.5 * (before + after)
        m = round(float(here @ mean) / float(mean @ mean))
        if 2 <= m <= MAX_LOST + 1 and _agree(here, m * mean, centre_sd):
            lost[j] = m - 1
    index = np.arange(n) + np.cumsum(lost) - np.cumsum(shift)
    return FrameTiming(index.astype(np.float64), lost, repeated)


def timing_message(timing: FrameTiming) -> str | None:
    """In words, where frames were lost or repeated and what was done; None where none."""
    lost, repeated = np.flatnonzero(timing.lost), np.flatnonzero(timing.repeated)
    if not lost.size and not repeated.size:
        return None
    parts = []
    if lost.size:
        parts.append(f"{int(timing.lost.sum())} frame(s) lost before frame(s) {_list(lost)} "
                     "(the ball's step there is a whole multiple of the steps either side): "
                     "the times of the frames after each are later by as many frame intervals")
    if repeated.size:
        parts.append(f"frame(s) {_list(repeated)} repeat the picture of the frame before: "
                     "left out (flagged), and where a copy was put in the times after it are "
                     "earlier by one frame interval")
    return ("frames: " + "; ".join(parts) + ". The video is not every frame the camera took: "
            "use the camera's own file, and check --fps")


def _list(frames: np.ndarray, most: int = 8) -> str:
    """Frame numbers, the first ``most`` and a count of the rest."""
    shown = ", ".join(str(int(k)) for k in frames[:most])
    return shown + (f" and {len(frames) - most} more" if len(frames) > most else "")
