"""Lost and repeated frames told by the ball's steps (bouncebayes.tracking._timing).

Expected values: the frames removed or copied by the test itself (a flight sampled at known
frame times, a rendered clip with known frames taken out), and the renderer's throw
(tests/render_pbr.py) for the kinematics."""

from __future__ import annotations

import numpy as np
import pytest

from bouncebayes.tracking import timing_warning, track_ball
from bouncebayes.tracking._timing import MIN_STEP_PX, frame_timing, lost_at_bounces, timing_message


def flight(n: int = 60, step=(3.0, -2.0), accel=(0.0, 0.02), bounce_at: int | None = None,
           noise: float = 0.03, seed: int = 0) -> np.ndarray:
    """Centres (px) of a ball in free flight at frames 0..n-1 (constant acceleration, px per
    frame^2), its vertical step reversed at ``bounce_at``, with Gaussian noise."""
    k = np.arange(n, dtype=float)
    c = np.column_stack([10 + step[0] * k + 0.5 * accel[0] * k**2,
                         200 + step[1] * k + 0.5 * accel[1] * k**2])
    if bounce_at is not None:  # mirrored about the height at the bounce: the step reverses
        low = c[bounce_at, 1]
        c[bounce_at:, 1] = low - 0.8 * (c[bounce_at:, 1] - low)
    return c + np.random.default_rng(seed).normal(0.0, noise, c.shape)


def timing_of(centres: np.ndarray, sd: float = 0.03):
    # a frame's picture is the one before again where its centre is (the test's copies)
    return frame_timing(centres, np.ones(len(centres), bool), sd,
                        lambda j: bool(np.array_equal(centres[j], centres[j - 1])))


def test_a_clean_flight_and_bounce_tell_nothing():
    # every frame where the camera took it: nothing lost or repeated, places 0..n-1, over 200
    # seeds (a false "lost" frame would move every later time by a frame interval)
    for seed in range(200):
        c = flight(bounce_at=30, seed=seed, noise=0.05)
        t = timing_of(c, 0.05)
        assert not t.lost.any() and not t.repeated.any(), seed
        assert np.array_equal(t.place, np.arange(len(c)))


@pytest.mark.parametrize("gone", [[9], [9, 10], [9, 10, 11]])
def test_lost_frames_are_counted_and_the_later_frames_placed_after_them(gone):
    c = flight()
    kept = np.setdiff1d(np.arange(len(c)), gone)
    t = timing_of(c[kept])
    assert t.lost.tolist() == [len(gone) if k == 9 else 0 for k in range(len(kept))]
    assert np.array_equal(t.place, kept)  # each frame's place: its true frame number
    assert not t.repeated.any()


def test_lost_frames_in_both_flights_of_a_bounce():
    c = flight(n=80, bounce_at=40)
    kept = np.array([k for k in range(80) if k % 10 != 9])
    t = timing_of(c[kept])
    told = kept[np.flatnonzero(t.lost)]
    # the frames lost at 9, 19, 29 (before the bounce) and 49, 59, 69 (after); 39 is next to
    # the bounce, where the steps either side differ: not told by the steps (by the flights,
    # test_frames_lost_at_a_bounce_are_told_by_the_flights_either_side)
    assert told.tolist() == [10, 20, 30, 50, 60, 70]
    flights = (kept < 39) | (kept > 41)
    assert np.array_equal(t.place[flights & (kept < 39)], kept[flights & (kept < 39)])
    assert np.all(t.place[kept > 41] == kept[kept > 41] - 1)  # off by the one not told


ALONG, NORMAL = np.array([1.0, 0.0]), np.array([0.0, 1.0])  # flight()'s surface: y = low


def at_bounces(centres: np.ndarray, sd: float = 0.03):
    return lost_at_bounces(timing_of(centres, sd), centres, np.ones(len(centres), bool),
                           ALONG, NORMAL, sd)


@pytest.mark.parametrize("gone", [[39], [40], [41], [39, 40], [40, 41], [39, 40, 41],
                                  [9, 19, 29, 39, 49, 59, 69]])
def test_frames_lost_at_a_bounce_are_told_by_the_flights_either_side(gone):
    # expected: the frames the test took out. The ball touches at frame 40; with frames lost
    # there the flights, placed by the frames' numbers, cross 3 px apart along the surface
    c = flight(n=80, bounce_at=40)
    kept = np.setdiff1d(np.arange(80), gone)
    t = at_bounces(c[kept])
    assert np.array_equal(t.place, kept)  # every frame in its place, the later flight's too
    at = [g for g in gone if 38 <= g <= 41]
    assert kept[t.at_bounce].tolist() == [max(at) + 1]
    assert t.lost[t.at_bounce].tolist() == [len(at)]
    assert "at the bounce before frame(s)" in timing_message(t)
    clean = at_bounces(c)
    assert not clean.lost.any() and not clean.at_bounce.any()


@pytest.mark.parametrize("copied", [38, 39, 40, 41])
def test_a_copy_at_a_bounce_is_flagged_and_placed_by_the_flights(copied):
    # expected: the copies the test put in. A frame's picture again right after it next to
    # the bounce (frame 40): the steps either side differ and told nothing; put in, every later
    # frame's time came one interval late, in a lost frame's place it was a sample at the
    # wrong time
    c = flight(n=80, bounce_at=40)
    put_in = [*range(copied + 1), copied, *range(copied + 1, 80)]
    t = at_bounces(c[put_in])
    assert np.flatnonzero(t.repeated).tolist() == [copied + 1] and not t.lost.any()
    ok = ~t.repeated
    assert np.array_equal(t.place[ok], np.array(put_in, float)[ok])
    replaced = [*range(copied + 1), copied, *range(copied + 2, 80)]
    t = at_bounces(c[replaced])
    assert np.flatnonzero(t.repeated).tolist() == [copied + 1]
    assert np.array_equal(t.place, np.arange(80.0))


def test_a_rendered_copy_at_the_bounce_is_told_by_its_pixels():
    from render_pbr import Shot, Throw, render

    from bouncebayes.tracking import detect_surface
    from bouncebayes.tracking._geometry import plane_axes
    from bouncebayes.tracking._timing import same_picture
    from bouncebayes.tracking._track import timed_at_bounces

    # expected: the copy the test put in (frame 40's picture again after it; the ball touches
    # at 40.5). Its centre is not its original's to the last digit (each frame's fit reads
    # the ball's velocity from its neighbours: 0.009 px apart), so the pixels tell
    shot = Shot(width=240, height=120, radius_px=12.0, n_frames=80, surface_v=100.0,
                slope_deg=2.0, sigma_px=0.7, exposure=0.3, supersample=2,
                throw=Throw(speed_in=2.4, angle_in=35.0, t_contact=0.0405, x_contact=0.07))
    frames = render(shot)
    order = [*range(41), 40, *range(41, 80)]
    track = track_ball(frames[order])
    assert np.flatnonzero(track.timing.repeated).tolist() == [41]
    surface = detect_surface(track.background, centres=track.centre[track.found],
                             radius=track.ball_radius)
    track = timed_at_bounces(track, *plane_axes(track, surface))
    ok = ~track.timing.repeated
    assert np.array_equal(track.timing.place[ok], np.array(order, float)[ok])
    # two frames the camera took are not the same picture, the ball at the bounce included
    clean = track_ball(frames)
    same = same_picture(frames, clean.centre, clean.ball_radius, clean.noise)
    assert not any(same(j) for j in range(1, 80)) and not clean.timing.repeated.any()


def contact(t1: float, tc: float, vx_out: float, seed: int, n: int = 80) -> np.ndarray:
    """Centres (px) of a ball that touches the surface (y = 50) at frame time ``t1`` for
    ``tc`` frames, squashed by up to 0.3 px a frame of contact, its velocity along the surface
    turning from 2 to ``vx_out`` px a frame as it slides (at a steady rate), normal 2 px a
    frame in and 1.6 out, gravity 0.02 px a frame^2; noise 0.03 px."""
    t = np.arange(n, dtype=float)
    t2 = t1 + tc
    pre, post = t < t1, t >= t2
    mid = ~pre & ~post
    h = np.zeros(n)
    h[pre] = 2.0 * (t1 - t[pre]) - 0.01 * (t[pre] - t1) ** 2
    h[post] = 1.6 * (t[post] - t2) - 0.01 * (t[post] - t2) ** 2
    h[mid] = -0.3 * min(tc, 2.0) * np.sin(np.pi * (t[mid] - t1) / max(tc, 1e-9))
    slid = 0.5 * (2.0 + vx_out) * tc  # along the surface in contact (a steady change)
    u = t[mid] - t1
    x = np.where(pre, 2.0 * (t - t1), slid + vx_out * (t - t2))
    x[mid] = 2.0 * u + 0.5 * (vx_out - 2.0) * u**2 / max(tc, 1e-9)
    c = np.column_stack([100.0 + x, 50.0 + h])
    return c + np.random.default_rng(seed).normal(0.0, 0.03, c.shape)


def test_a_bounce_in_contact_for_frames_or_sliding_tells_nothing():
    # the flights of a ball in contact for up to 5 frames, sliding or turning back along the
    # surface (its flights then cross apart by up to its change of velocity times the
    # contact), at three phases of the frames, 10 seeds each: nothing lost
    for tc in (0.0, 0.5, 1.0, 2.0, 3.5, 5.0):
        for vx_out in (2.0, 1.4, 0.6, -0.5):
            for t1 in (40.0, 40.3, 40.7):
                for seed in range(10):
                    t = at_bounces(contact(t1, tc, vx_out, seed))
                    assert not t.lost.any(), (tc, vx_out, t1, seed)
    # and where frames were lost there, told where the ball slides little (the sliding it
    # could have done is not enough to part the flights as far as a frame lost does)
    for tc in (0.0, 0.5, 1.0):
        for t1 in (40.0, 40.3, 40.7):
            c = contact(t1, tc, 1.4, 0)
            kept = np.setdiff1d(np.arange(80), [41])
            t = at_bounces(c[kept])
            assert np.array_equal(t.place[kept > 42], kept[kept > 42]), (tc, t1)


@pytest.mark.parametrize("gone, unusable", [([9], range(0, 8)), ([49], range(51, 60))])
def test_a_frame_lost_where_the_track_starts_or_breaks_off(gone, unusable):
    # expected: the frame the test took out, next to frames the tracker could not use (the
    # ball coming into view cut by the frame's edge, flagged): the step before (or after)
    # the long one is missing, and the two on its other side tell; over 200 noisy clean
    # flights with such breaks, nothing
    c = flight()
    kept = np.setdiff1d(np.arange(60), gone)
    usable = ~np.isin(kept, list(unusable))
    t = frame_timing(c[kept], usable, 0.03)
    assert np.array_equal(t.place[usable], kept[usable])
    assert t.lost.sum() == 1
    for seed in range(200):
        c = flight(seed=seed, noise=0.05, bounce_at=30)
        usable = np.ones(60, bool)
        usable[:5] = usable[40:43] = usable[56:] = False
        assert not frame_timing(c, usable, 0.05).lost.any(), seed


def test_a_copy_put_in_and_a_copy_in_a_lost_frames_place():
    c = flight()
    inserted = c[[*range(12), 11, *range(12, 60)]]  # frame 12 a copy of 11, put in
    t = timing_of(inserted)
    assert np.flatnonzero(t.repeated).tolist() == [12] and not t.lost.any()
    truth = np.array([*range(12), 11, *range(12, 60)], float)
    assert np.array_equal(t.place[~t.repeated], truth[~t.repeated])
    replaced = c.copy()
    replaced[12] = replaced[11]  # frame 12 lost, a copy of 11 in its place
    t = timing_of(replaced)
    assert np.flatnonzero(t.repeated).tolist() == [12] and not t.lost.any()
    assert np.array_equal(t.place, np.arange(60))
    last = c.copy()
    last[-1] = last[-2]  # the last frame a copy
    assert np.flatnonzero(timing_of(last).repeated).tolist() == [59]


def test_a_slow_or_noisy_ball_tells_nothing():
    slow = flight(step=(0.6, -0.4), accel=(0.0, 0.0))  # below MIN_STEP_PX a frame
    assert np.hypot(0.6, 0.4) < MIN_STEP_PX
    kept = np.setdiff1d(np.arange(60), [20])
    assert not timing_of(slow[kept]).lost.any()
    # centres 0.4 px off at 1.5 px a frame (a 5 px ball blurred by 1.5 px): a step twice its
    # neighbours' comes by chance; the centres' scatter read from their second differences
    # (not the stated 0.03 px) keeps it from being told, over 100 seeds
    for seed in range(100):
        noisy = flight(step=(1.2, -0.9), accel=(0.0, 0.0), noise=0.4, seed=seed)
        t = timing_of(noisy, 0.03)
        assert not t.lost.any() and not t.repeated.any(), seed


def test_a_clip_with_lost_frames_gives_the_throws_speeds():
    from render_pbr import Shot, Throw, render

    from bouncebayes.kinematics import fit_kinematics, trajectory_from_arrays
    from bouncebayes.tracking import Calibration, detect_surface, to_plane_frame
    from bouncebayes.tracking._geometry import plane_axes
    from bouncebayes.tracking._track import timed_at_bounces

    # expected: the renderer's throw. Every 10th frame of a 1000 fps clip lost: before, the
    # rebound speed came out +11.8 % (8.7 SE) and the incidence speed +10 %, nothing said;
    # with the frames' steps told but not the flights at the bounce, the rebound angle 4.3 SE
    throw = Throw(speed_in=2.4, angle_in=35.0, t_contact=0.04, x_contact=0.07)
    shot = Shot(width=240, height=120, radius_px=12.0, n_frames=80, surface_v=100.0,
                slope_deg=2.0, sigma_px=0.7, exposure=0.3, supersample=2, throw=throw)
    frames = render(shot)
    kept = [k for k in range(80) if k % 10 != 9]
    track = track_ball(frames[kept])
    assert kept[int(np.flatnonzero(track.timing.lost)[0])] == 10
    assert "lost" in timing_warning(track)
    cal = Calibration.from_track(shot.diameter_m, track)
    surface = detect_surface(track.background, centres=track.centre[track.found],
                             radius=track.ball_radius)
    # the frame lost at the bounce (39, the ball touching at 40) told by the flights: every
    # frame in its place (before, the later flight's times one interval early)
    track = timed_at_bounces(track, *plane_axes(track, surface))
    assert np.array_equal(track.timing.place, kept)
    traj = to_plane_frame(track, cal, surface, shot.fps)
    fit = fit_kinematics(trajectory_from_arrays(traj.t, traj.x, traj.y))
    for value, se, truth in ((fit.rebound_speed, fit.rebound_speed_se, throw.rebound_speed()),
                             (fit.incidence_speed, fit.incidence_speed_se, throw.speed_in)):
        sd = np.hypot(se, value * cal.relative_sd)
        assert abs(value - truth) < 3 * sd, (value, truth, sd)
    # the rebound angle (no scale in it): 4.3 SE off with the later flight's times one
    # interval early, 0.6 with them put right
    assert abs(fit.rebound_angle - throw.rebound_angle()) < 3 * fit.rebound_angle_se
    clean = track_ball(frames)
    assert timing_warning(clean) is None and not clean.timing.lost.any()


def test_track_says_and_records_the_lost_frames(tmp_path, capsys):
    import json

    import cv2
    from render_pbr import Shot, Throw, render

    from bouncebayes.cli import main

    # expected: the frames the test took out (every 10th of a rendered clip)
    shot = Shot(width=240, height=120, radius_px=12.0, n_frames=60, surface_v=100.0,
                slope_deg=2.0, sigma_px=0.7, exposure=0.3, supersample=2,
                throw=Throw(speed_in=2.4, angle_in=35.0, t_contact=0.04, x_contact=0.07))
    frames = render(shot)
    kept = [k for k in range(60) if k % 10 != 9]
    folder = tmp_path / "clip"
    folder.mkdir()
    for i, k in enumerate(kept):
        cv2.imwrite(str(folder / f"{i:04d}.png"), frames[k])
    assert main(["track", str(folder), "--out", str(tmp_path / "out"), "--fps", "1000",
                 "--ball-diameter", str(shot.diameter_m)]) == 0
    out = capsys.readouterr().out
    assert "frame(s) lost before frame(s) 9, 18" in out
    record = json.loads((tmp_path / "out" / "clip.track.json").read_text())
    assert record["timing"]["lost_before_frames"][:2] == [9, 18]
    # frame 39 lost next to the bounce (the ball touches at 40, the record's frame 36)
    assert record["timing"]["lost_at_bounce_before_frames"] == [36]
    assert "at the bounce before frame(s) 36" in out
    assert record["per_frame"]["place"][9] == 10.0
    times = np.loadtxt(tmp_path / "out" / "clip.csv", delimiter=",", skiprows=1,
                       usecols=0, ndmin=1)
    assert np.isclose(times[9] - times[8], 2e-3)  # the trajectory's time after the gap
