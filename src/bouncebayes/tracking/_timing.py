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
  number says), followed by twice that step, a copy in a lost frame's place (no shift); next
  to a bounce, where the steps either side differ, a repeated picture where the pixels about
  the ball are the frame before's (:func:`same_picture`), put in or not as the flights either
  side tell (:func:`lost_at_bounces`).

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
from collections.abc import Callable
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


SAME_NOISE = 0.3  # a frame's picture is the one before again where the median difference
#                   about the ball is this fraction of the noise or less (two frames the
#                   camera took: 0.95 of it, their noise differing)


def same_picture(frames: np.ndarray, centre: np.ndarray, radius: float, noise: float
                 ) -> Callable[[int], bool]:
    """``same`` for :func:`frame_timing`: whether frame ``j``'s pixels within two radii of
    the ball are frame ``j - 1``'s (their median absolute difference at most ``SAME_NOISE``
    of the frames' ``noise``, grey levels)."""
    h, w = frames.shape[1:]
    reach = int(math.ceil(2.0 * radius)) + 2

    def same(j: int) -> bool:
        u, v = (int(round(float(a))) for a in centre[j])
        win = (slice(max(v - reach, 0), min(v + reach + 1, h)),
               slice(max(u - reach, 0), min(u + reach + 1, w)))
        a, b = frames[j][win].astype(np.float64), frames[j - 1][win].astype(np.float64)
        return a.size > 0 and float(np.median(np.abs(a - b))) <= SAME_NOISE * max(noise, 0.5)

    return same


class FrameTiming(NamedTuple):
    """Each frame's place in the camera's sequence, in frame intervals (``place``; ``k`` where
    nothing was lost or repeated), the frames lost just before each frame (``lost``), the
    frames whose picture repeats the frame before (``repeated``), and the frames whose lost
    frames before were told by a bounce's flights (``at_bounce``, :func:`lost_at_bounces`)."""

    place: np.ndarray
    lost: np.ndarray
    repeated: np.ndarray
    at_bounce: np.ndarray


def _agree(a: np.ndarray, b: np.ndarray, sd: float) -> bool:
    """Whether steps ``a`` and ``b`` (px) agree (``AGREE_REL``, ``AGREE_SD``)."""
    size = max(math.hypot(*a), math.hypot(*b))
    return math.hypot(*(a - b)) <= AGREE_REL * size + AGREE_SD * math.sqrt(2.0) * sd


def _steps(centre: np.ndarray, usable: np.ndarray) -> np.ndarray:
    """The ball's step (px, ``(n, 2)``) into each frame from the one before, NaN where either
    is not ``usable`` (and into the first)."""
    step = np.full((len(centre), 2), np.nan)
    ok = usable[1:] & usable[:-1]
    step[1:][ok] = centre[1:][ok] - centre[:-1][ok]
    return step


def _centre_sd(step: np.ndarray, stated: float) -> float:
    """The centres' SD (px): the ``stated`` one, or as their second differences scatter (a
    flight's change of step is a few per cent of it; bounces, lost frames: a median leaves
    them out; steps of nothing, a repeated picture's, are not counted); ``step`` ``(n, 2)``
    the steps between frames, NaN where there is none."""
    moved = np.where(np.hypot(*step.T)[:, None] >= 0.5 * MIN_STEP_PX, step, np.nan)
    turn = moved[2:] - moved[1:-1]
    turn = turn[np.isfinite(turn).all(axis=1)]
    if len(turn) >= 8:
        return max(stated, 1.4826 * float(np.median(np.abs(turn))) / math.sqrt(6.0))
    return stated


def frame_timing(centre: np.ndarray, usable: np.ndarray, centre_sd: float,
                 same: Callable[[int], bool] | None = None) -> FrameTiming:
    """The frames' timing (:class:`FrameTiming`) from the ball's centres ``(n, 2)`` (px) in
    the frames that are ``usable`` (found, not flagged), each with an SD of ``centre_sd``
    px; ``same(j)``: whether frame ``j``'s picture is frame ``j - 1``'s again (asked only
    where the ball did not move next to a bounce; None: not asked, such a frame not told)."""
    n = len(centre)
    lost, repeated = np.zeros(n, np.int64), np.zeros(n, bool)
    shift = np.zeros(n, np.int64)  # frames put in (a copy) before each frame: -1 from there
    step = np.vstack([_steps(centre, usable), np.full((1, 2), np.nan)])  # none after the last
    centre_sd = _centre_sd(step, centre_sd)
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
            elif same is not None and math.hypot(*after) >= least and same(j):
                # the same picture next to a bounce: a copy, put in or in a lost frame's place,
                # which the flights tell (lost_at_bounces); not a ball at rest in contact,
                # whose frame's noise is its own
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
    _lost_at_ends(step, size, lost, repeated, centre_sd, least)
    index = np.arange(n) + np.cumsum(lost) - np.cumsum(shift)
    return FrameTiming(index.astype(np.float64), lost, repeated, np.zeros(n, bool))


def _lost_at_ends(step: np.ndarray, size: np.ndarray, lost: np.ndarray, repeated: np.ndarray,
                  sd: float, least: float) -> None:
    """Frames lost next to where the track starts or breaks off (the ball coming into view,
    flagged frames), told into ``lost`` in place: there the step before (or after) the long
    one is missing, and the two steps on its other side, which agree, take its place (a 12 px
    ball cut by the frame's edge for its first 9 frames, a frame lost after them: not told,
    the kinematics refused the flight)."""
    n = len(lost)
    j = np.arange(1, n - 2)
    first = np.isnan(size[j - 1]) & (size[j + 1] >= least) & (size[j] >= 1.5 * size[j + 1])
    last = np.isnan(size[j + 1]) & (size[j - 1] >= least) & (size[j] >= 1.5 * size[j - 1])
    for k in j[first | last].tolist():
        if lost[k] or repeated[k] or repeated[k - 1]:
            continue
        near, far = (step[k + 1], step[k + 2]) if np.isnan(size[k - 1]) else \
            (step[k - 1], step[k - 2])
        if not (np.isfinite(far).all() and _agree(near, far, sd)):
            continue
        m = round(float(step[k] @ near) / float(near @ near))
        if 2 <= m <= MAX_LOST + 1 and _agree(step[k], m * near, sd):
            lost[k] = m - 1


def timing_message(timing: FrameTiming) -> str | None:
    """In words, where frames were lost or repeated and what was done; None where none."""
    lost, repeated = np.flatnonzero(timing.lost), np.flatnonzero(timing.repeated)
    if not lost.size and not repeated.size:
        return None
    parts = []
    if lost.size:
        bounce = np.flatnonzero(timing.at_bounce)
        why = "the ball's step there is a whole multiple of the steps either side"
        if bounce.size:
            why += (f"; at the bounce before frame(s) {_list(bounce)}, the flights either side "
                    "meet only so")
        parts.append(f"{int(timing.lost.sum())} frame(s) lost before frame(s) {_list(lost)} "
                     f"({why}): the times of the frames after each are later by as many frame "
                     "intervals")
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


FIT_FRAMES = 8  # frames of each flight next to a bounce that are fitted (a parabola) ...
MIN_FIT = 5     # ... at least
TRIM = 2        # frames next to the bounce left out where a flight misfits there (contact)
MISFIT_SD = 5.0  # a frame misfits its flight beyond this many SDs (plus 5 % of its step)
MEET_SD = 4.0    # the flights meet where they are apart by at most the slide and this many SEs
#                  (the slide taken at its largest: the noise alone then 6e-5 of the time)


class _Flight(NamedTuple):
    """One side of a bounce: the frames' times (frame intervals), positions along and normal
    to the surface (px)."""

    t: np.ndarray
    x: np.ndarray
    h: np.ndarray


def lost_at_bounces(timing: FrameTiming, centre: np.ndarray, usable: np.ndarray,
                    along: np.ndarray, normal: np.ndarray, centre_sd: float) -> FrameTiming:
    """``timing`` with the frames lost at each bounce told, from the flights either side.

    Next to a bounce the steps either side differ and :func:`frame_timing` tells nothing. The
    flights do: fitted (a parabola each, along the surface ``along`` and normal to it
    ``normal``, image unit vectors), they cross at the impact, and there the ball's position
    along the surface is one, apart from how far it slid in contact (at most the change of its
    velocity along the surface times the longer part of the gap between the frames either
    side that the crossing divides). With ``k`` frames lost at the bounce every frame after
    it is ``k`` intervals later than its place says, and the flights so placed meet only where
    ``k`` is right (a ball 1.3 px a frame along the surface: 1.3 px apart for each frame
    lost). Told where ``k = 0`` cannot be (the flights apart beyond the slide by ``MEET_SD``
    SEs) and some ``k`` up to ``MAX_LOST`` can, the one whose flights meet closest; ``k =
    -1`` (a copy put in) too where a repeated picture lies between the flights. The ball must
    step ``CLEAR`` SDs a frame normal to the surface on both sides. A 12 px ball rendered with
    a frame lost at its bounce: the rebound angle came out 0.18 deg (1.7 SE) off, with one
    more lost before it 0.44 deg (3.1 SE).
    """
    usable = usable & ~timing.repeated
    idx = np.flatnonzero(usable)
    if len(idx) < 2 * MIN_FIT + 1:
        return timing
    t, pos = timing.place[idx], centre[idx]
    x, h = pos @ np.asarray(along, float), pos @ np.asarray(normal, float)
    sd = _centre_sd(_steps(centre, usable), centre_sd)
    least = CLEAR * math.sqrt(2.0) * sd
    dh = np.diff(h) / np.maximum(np.diff(t), 1.0)  # a step a frame interval
    lost, at_bounce = timing.lost.copy(), timing.at_bounce.copy()
    moved = np.zeros(len(centre), np.int64)  # each frame's place moved by, from there on
    # the lowest frames (the steps next to them may span the impact: clear one further out)
    low = 1 + np.flatnonzero((dh[:-1] < 0) & (dh[1:] >= 0))
    low = low[(low >= 2) & (low + 1 < len(dh))]
    for m in low[(dh[low - 2] <= -least) & (dh[low + 1] >= least)].tolist():
        # a repeated picture between the flights (flagged, so not among them) may be a copy
        # put in: then the later flight's places are one too many
        copy = bool(timing.repeated[idx[m - 2]:idx[min(m + 2, len(idx) - 1)]].any())
        told = _bounce(_Flight(t, x, h), m, sd, copy)
        if told is not None:
            first, k = told
            moved[idx[first]] += k
            if k > 0:
                lost[idx[first]] += k
                at_bounce[idx[first]] = True
    if not moved.any():
        return timing
    place = timing.place + np.cumsum(moved)
    return FrameTiming(place, lost, timing.repeated, at_bounce)


def _bounce(f: _Flight, m: int, sd: float, copy: bool = False) -> tuple[int, int] | None:
    """The frames lost at the bounce whose lowest frame is ``m`` (of ``f``'s): the first frame
    after them and how many (-1: a copy was put in there, where ``copy`` says a repeated
    picture lies between the flights), or None where none are told."""
    n = len(f.t)
    pre = _trimmed(f, np.arange(max(0, m - FIT_FRAMES), m), sd, last=True)
    post = _trimmed(f, np.arange(m + 1, min(n, m + 1 + FIT_FRAMES)), sd, last=False)
    if pre is None or post is None:
        return None
    # the lowest frame: with the flight before where it follows it, else after
    if _follows(f, pre, m, sd):
        pre = np.append(pre, m)
    elif post[0] == m + 1 and _follows(f, post, m, sd):
        post = np.insert(post, 0, m)
    # (apart, slide, SE per sd) for k = 0, 1, ... lost (-1: a copy put in); None: the flights
    # do not cross in the gap
    ks = range(-1 if copy else 0, MAX_LOST + 1)
    res = {k: _meeting(f, pre, post, k) for k in ks}
    fits = {k: r is not None and abs(r[0]) <= r[1] + MEET_SD * sd * r[2] for k, r in res.items()}
    if fits[0] or res[0] is None and res[1] is None or not any(fits.values()):
        return None  # none lost, or the flights do not meet near the gap at all
    apart = {k: math.inf if r is None else abs(r[0]) for k, r in res.items()}
    k = min((k for k in ks if fits[k]), key=apart.__getitem__)
    # the frames left out between the flights: later than their places from the first that
    # does not follow the flight before (in contact, or after the lost frames)
    between = [g for g in range(int(pre[-1]) + 1, int(post[0])) if not _follows(f, pre, g, sd)]
    return (between[0] if between else int(post[0])), k


def _trimmed(f: _Flight, sel: np.ndarray, sd: float, last: bool) -> np.ndarray | None:
    """The frames ``sel`` of one flight, less up to ``TRIM`` next to the bounce (the ``last``
    ones, else the first) where they misfit its parabola; None where under ``MIN_FIT`` are
    left or it still misfits."""
    for _ in range(TRIM + 1):
        if len(sel) < MIN_FIT:
            return None
        if _fits_flight(f, sel, sd):
            return sel
        sel = sel[:-1] if last else sel[1:]
    return None


def _misfit_limit(f: _Flight, sel: np.ndarray, sd: float) -> float:
    """How far (px) a frame may lie off the flight of the frames ``sel``: ``MISFIT_SD`` SDs
    plus 5 % of the ball's step a frame."""
    step = math.hypot(np.ptp(f.x[sel]), np.ptp(f.h[sel])) / max(np.ptp(f.t[sel]), 1.0)
    return MISFIT_SD * sd + 0.05 * step


def _fits_flight(f: _Flight, sel: np.ndarray, sd: float) -> bool:
    """Whether the frames ``sel`` lie on one parabola (:func:`_misfit_limit`)."""
    t, limit = f.t[sel] - f.t[sel].mean(), _misfit_limit(f, sel, sd)
    return all(np.abs(v - np.polyval(np.polyfit(t, v, 2), t)).max() <= limit
               for v in (f.x[sel], f.h[sel]))


def _follows(f: _Flight, sel: np.ndarray, m: int, sd: float) -> bool:
    """Whether frame ``m`` follows the flight of the frames ``sel`` (:func:`_misfit_limit`)."""
    t0, limit = f.t[sel].mean(), _misfit_limit(f, sel, sd)
    return all(abs(np.polyval(np.polyfit(f.t[sel] - t0, v[sel], 2), f.t[m] - t0) - v[m])
               <= limit for v in (f.x, f.h))


def _meeting(f: _Flight, pre: np.ndarray, post: np.ndarray, k: int
             ) -> tuple[float, float, float] | None:
    """With ``k`` frames lost before the flight ``post``: how far apart along the surface
    (px) the flights are where they cross normal to it (at ``r``), how far the ball could
    have slid in the gap, and the SE of the first per px of the centres' SD; None where they
    do not cross within the gap."""
    t0 = f.t[pre[-1]]
    tp, tq = f.t[pre] - t0, f.t[post] + k - t0
    ap, aq = _projector(tp), _projector(tq)  # a parabola's coefficients: A @ values
    hp, hq, xp, xq = ap @ f.h[pre], aq @ f.h[post], ap @ f.x[pre], aq @ f.x[post]
    gap = tq[0]  # the last frame before at 0
    if gap <= 0:
        return None
    roots = np.roots(hp - hq) if np.any(hp != hq) else np.zeros(0)
    roots = roots[np.isreal(roots)].real
    roots = roots[(roots >= -0.5) & (roots <= gap + 0.5)]
    if not roots.size:
        return None
    r = float(roots[np.argmin(np.abs(roots - 0.5 * gap))])
    phi, dphi = np.array([r * r, r, 1.0]), np.array([2 * r, 1.0, 0.0])
    apart = float(phi @ (xq - xp))
    dvx, dvh = float(dphi @ (xq - xp)), float(dphi @ (hp - hq))
    if dvh == 0.0:
        return None
    # the delta method: apart moves with the x's directly and through the crossing r with
    # the h's (dr = -(dh_p - dh_q) / (vh_p - vh_q)); the centres' errors independent
    gx_p, gx_q = -(phi @ ap), phi @ aq
    gh_p, gh_q = -(dvx / dvh) * (phi @ ap), (dvx / dvh) * (phi @ aq)
    se = math.sqrt(sum(float(g @ g) for g in (gx_p, gx_q, gh_p, gh_q)))
    # sliding in contact (from t1 >= 0 to t2 <= gap, the velocity along the surface turning
    # monotonically from the one flight's to the other's) moves them apart by at most the
    # change times the longer of r - t1 and t2 - r
    return apart, abs(dvx) * max(r, gap - r), se


def _projector(t: np.ndarray) -> np.ndarray:
    """The least-squares parabola's coefficients (``t^2, t, 1``) as a matrix on the values."""
    return np.linalg.pinv(np.column_stack([t * t, t, np.ones_like(t)]))
