"""The ball tracker, on synthetic 1000 fps videos rendered from known trajectories.

Expected values come from the renderer (``tests/video_helpers.py``): the ball centre at
mid-exposure, exact plane-frame positions, the scale and the surface line it was drawn with, and
the bounce's rebound velocity. Accuracy thresholds are the tracker's targets (0.1 px RMS clean, 0.5 px with
noise and blur); the values measured when this file was written are noted beside each test.
"""

from __future__ import annotations

import argparse
import functools
import json
import math
import re

import cv2
import numpy as np
import pytest
from video_helpers import (Bounce, Scene, plane_positions, render, true_centres,
                           write_png_sequence, write_video)

import bouncebayes as bb
from bouncebayes._errors import InputFileError
from bouncebayes.cli._track import add_track_subcommand, parse_numbers
from bouncebayes.tracking import _track
from bouncebayes.tracking import (CENTROID, EDGE_FIT, NOT_FOUND, Calibration, Surface,
                                  TrackerConfig, background_model, detect_surface, overlay_image,
                                  read_frames, read_image, to_plane_frame, track_ball,
                                  track_video)
from bouncebayes.data import write_trajectory

NOISY = dict(exposure=1.0, noise_sigma=4.0, shadow=True)  # full-frame blur, noise, shadow


def rms(a: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum(a**2, axis=-1))))


def no_refined_centres(monkeypatch) -> None:
    """Switch the per-frame centre fits (tracking/_refine.py) off: the coverage centroids stay."""
    from bouncebayes.tracking import _refine

    monkeypatch.setattr(_refine, "refine_centres", lambda frames, *args: _refine.Refined(
        np.zeros(len(frames), bool), np.full((len(frames), 2), np.nan)))


def surface_of(scene: Scene) -> Surface:
    x1, y1, x2, y2 = scene.surface_points()
    return Surface.from_points((x1, y1), (x2, y2))


@pytest.fixture(scope="module")
def clean():
    scene, bounce = Scene(), Bounce()
    return scene, bounce, render(scene, bounce)


@pytest.fixture(scope="module")
def noisy():
    scene, bounce = Scene(**NOISY), Bounce()
    return scene, bounce, render(scene, bounce)


# --------------------------------------------------------------------------- accuracy


def test_clean_frames_are_tracked_to_a_tenth_of_a_pixel(clean):
    scene, bounce, frames = clean
    track = track_ball(frames)
    assert track.found.all() and (track.method == CENTROID).all()
    assert rms(track.centre - true_centres(scene, bounce)) < 0.1  # measured 0.009 px
    assert track.polarity == "bright"


def test_blur_noise_and_shadow_stay_below_half_a_pixel(noisy):
    scene, bounce, frames = noisy
    track = track_ball(frames)
    assert track.found.all()
    assert rms(track.centre - true_centres(scene, bounce)) < 0.5  # measured 0.041 px
    assert track.noise == pytest.approx(scene.noise_sigma, rel=0.2)


def visible_fraction(u: np.ndarray, r: float) -> np.ndarray:
    """Area fraction of a disk of radius ``r`` centred at column ``u`` right of the frame's
    left edge (at u = -0.5): circular segment, closed form."""
    d = np.clip(u + 0.5, -r, r)
    return (r * r * np.arccos(-d / r) + d * np.sqrt(r * r - d * d)) / (math.pi * r * r)


def test_a_ball_entering_the_frame_is_fitted_on_its_visible_edge_or_marked():
    scene, bounce = Scene(), Bounce(x_contact=0.02)  # enters from the left edge
    truth = true_centres(scene, bounce)
    track = track_ball(render(scene, bounce))
    seen = visible_fraction(truth[:, 0], scene.radius_px)
    assert (track.method[seen == 0] == NOT_FOUND).all()
    assert np.isnan(track.centre[seen == 0]).all()
    partial = (seen >= 0.35) & (seen < 0.99)
    assert partial.sum() >= 5 and (track.method[partial] == EDGE_FIT).all()
    assert rms(track.centre[partial] - truth[partial]) < 0.1  # measured 0.019 px


def test_dark_ball_under_flicker_is_found_with_automatic_polarity():
    scene = Scene(ball_centre_grey=20, ball_rim_grey=45, background_grey=140, flicker=0.1)
    bounce = Bounce()
    track = track_ball(render(scene, bounce))
    assert track.polarity == "dark"
    assert rms(track.centre - true_centres(scene, bounce)) < 0.1  # measured 0.007 px


def test_frames_without_the_ball_are_marked_not_invented(clean):
    scene, bounce, frames = clean
    hidden = frames.copy()
    gone = np.arange(30, 35)
    hidden[gone] = np.median(frames, axis=0).astype(np.uint8)  # the empty scene
    track = track_ball(hidden)
    assert (track.method[gone] == NOT_FOUND).all() and np.isnan(track.centre[gone]).all()
    rest = np.setdiff1d(np.arange(len(frames)), gone)
    assert track.found[rest].all()
    assert rms(track.centre[rest] - true_centres(scene, bounce)[rest]) < 0.1


@pytest.mark.parametrize("n", [1, 2, 3, 8, 24, 25, 31])
def test_background_models_median_is_numpys(n):
    frames = np.random.default_rng(n).integers(0, 256, (n, 7, 9), dtype=np.uint8)
    expected = np.median(frames, axis=0)  # reference: numpy
    np.testing.assert_array_equal(_track._median_image(list(frames)), expected)
    floats = list(frames.astype(np.float32) / 3)
    np.testing.assert_allclose(_track._median_image(floats), expected / 3, rtol=1e-6)
    # steady light: the background model is that median
    np.testing.assert_array_equal(background_model(np.repeat(frames[:1], n, axis=0), n),
                                  frames[0].astype(np.float32))


def test_the_background_model_holds_under_a_flickering_lamp():
    # expected: the wall as drawn (50 +- 10 grey levels), 80 frames of it at 1.5 grey levels
    # of noise under a lamp's 100 Hz flicker (+-12 %, 1000 fps). The median of frames lit
    # unequally is as uncertain as their spread: measured RMS error 0.83 grey levels against
    # 0.47 in steady light; each frame divided by its gain first, 0.39 (less rounded)
    rng = np.random.default_rng(3)
    wall = 50.0 + 10.0 * rng.standard_normal((60, 90))
    t = np.arange(80) / 1000.0
    gains = 1 + 0.12 * np.sin(2 * np.pi * 100 * t + 0.3)

    def frames(g):
        noisy = g[:, None, None] * wall + rng.normal(0.0, 1.5, (80, *wall.shape))
        return np.clip(np.rint(noisy), 0, 255).astype(np.uint8)

    steady = background_model(frames(np.ones(80)), 25)
    lit = background_model(frames(gains), 25)
    plain = _track._median_image([f for f in frames(gains)[_track._background_index(80, 25)]])

    def err(bg):  # RMS error, the background's overall brightness fitted out
        return rms((bg * np.sum(bg * wall) / np.sum(bg * bg) - wall)[..., None])

    assert err(lit) < 1.2 * err(steady)
    assert err(plain) > 1.5 * err(steady)  # the plain median: can fail


def test_the_fits_background_leaves_the_ball_out():
    # A dark 10 px ball on a plain noisy wall (render_pbr: the wall is exactly 170 grey levels
    # there, the truth). The per-pixel median takes in the frames the ball covers, so along its
    # path it sits below the wall (measured -0.68 grey levels in the band 0-8 px outside the
    # rim); the background the edge and centre fits get (the median over the frames in which
    # the ball is clear of the pixel, of up to CLEAN_FRAMES frames) does not (measured -0.01),
    # and is NumPy's median of those frames.
    from render_pbr import render

    from bouncebayes.tracking._track import (CLEAN_FRAMES, MIN_CLEAR, _background_index,
                                             _ball_free_background)

    shot = pbr_shot(10.0, 1.5, 0.0, **{**DARK, "texture": 0.0})
    frames = render(shot)
    config = TrackerConfig()
    track = track_ball(frames, config=config)
    gains = np.ones(len(frames))  # no flicker in this scene: the frames' gains are 1
    plain = track.background.astype(np.float64)
    clean, kappa = _ball_free_background(frames, plain, gains, track.centre, track.radius,
                                         config)(track.centre)  # around every tracked centre
    truth = shot.true_centres()
    vv, uu = np.mgrid[:frames.shape[1], :frames.shape[2]]
    band = np.zeros(plain.shape, bool)
    for k in range(5, len(frames) - 5, 4):  # 0-8 px outside the rim, above the surface
        rho = np.hypot(uu - truth[k, 0], vv - truth[k, 1])
        band |= (rho > 10.0) & (rho < 18.0) & (vv < shot.surface_v - 2)
    assert plain[band].mean() - 170.0 < -0.5        # the plain median's bias: can fail
    assert abs(clean[band].mean() - 170.0) < 0.2
    # reference: NumPy, pixel by pixel, over the frames of the median clear of the ball
    idx = _background_index(len(frames), max(config.background_frames, CLEAN_FRAMES))
    found = ~np.isnan(track.centre[:, 0])
    step = np.hypot(*np.diff(track.centre[found], axis=0).T)
    reach = float(np.nanmedian(track.radius)) * 1.25 + 6.0 + 0.5 * float(step.max())
    expected = plain.copy()
    # and its variance in units of a frame's: pi / (2 m) for a median of m frames (closed
    # form, large m), m those clear of the ball
    expected_kappa = np.full(plain.shape, 0.5 * math.pi / config.background_frames)
    c = track.centre[idx]
    for i, j in zip(*np.nonzero(band), strict=True):
        d = np.hypot(j - c[:, 0], i - c[:, 1])
        near = d <= reach
        if near.any() and (~near).sum() >= MIN_CLEAR:
            expected[i, j] = np.median(frames[idx[~near], i, j])
            expected_kappa[i, j] = 0.5 * math.pi / (~near).sum()
    np.testing.assert_allclose(clean[band], expected[band], rtol=0, atol=1e-9)
    np.testing.assert_allclose(kappa[band], expected_kappa[band], rtol=1e-12)
    assert (expected_kappa[band] < 0.5 * math.pi / config.background_frames).any()  # m > 25
# --------------------------------------------------------------------------- calibration, frame


def test_ball_diameter_calibration_recovers_the_rendered_scale(clean):
    scene, _, frames = clean
    track = track_ball(frames)
    cal = Calibration.from_ball_diameter(scene.ball_diameter, track.ball_radius)
    assert cal.metres_per_px == pytest.approx(scene.metres_per_px, rel=0.01)  # measured 0.3%


def test_default_ball_is_the_papers():
    import bouncebayes as bb
    from bouncebayes.tracking import PAPER_BALL_DIAMETER

    assert PAPER_BALL_DIAMETER == bb.PAPER_BALL.diameter == Scene().ball_diameter


def test_reference_calibration_is_length_over_pixel_distance():
    cal = Calibration.from_reference((10, 20), (13, 24), 0.5)  # a 3-4-5 triangle: 5 px
    assert cal.metres_per_px == pytest.approx(0.1) and cal.source == "reference"


@pytest.mark.parametrize("inclination, point", [(15.0, (0.0, 150.0)), (-20.0, (0.0, 200.0))])
def test_surface_line_is_detected_in_the_background(inclination, point):
    scene = Scene(inclination=inclination, surface_point=point, noise_sigma=3.0, n_frames=30)
    track = track_ball(render(scene, Bounce()))
    surface = detect_surface(track.background)
    assert surface is not None and surface.source == "detected"
    # Surface.angle is counter-clockwise on screen; the scene's inclination is clockwise.
    assert surface.angle == pytest.approx(-inclination, abs=0.1)  # measured 0.02 deg
    _, normal = scene.axes()
    offset = (np.asarray(surface.point) - scene.surface_point) @ normal
    assert abs(offset) < 2.0  # the plane's edge, within its 2 px highlight


def test_the_detected_surface_is_an_edge_the_ball_does_not_cross():
    # expected: the plane's edge as drawn (row 80, horizontal). A bright cable across the scene
    # (a diagonal stripe, longer than the plane's edge and of higher contrast) is the longest
    # straight edge, and without the ball's track the detector takes it; the ball's path
    # crosses it, so with the track it cannot be the surface the ball bounces off. (Found on a
    # rendered H.264 clip, where the wall's texture made a 45-degree "edge" through the path.)
    rng = np.random.default_rng(4)
    vv, uu = np.mgrid[:100, :160].astype(float)
    bg = np.where(vv >= 80.0, 30.0, 60.0)
    bg[np.abs(vv - (70.0 - 70.0 / 160.0 * uu)) <= 1.0] = 200.0  # the cable
    bg = np.clip(bg + rng.normal(0.0, 1.0, bg.shape), 0, 255)
    t = np.linspace(-1.0, 1.0, 41)
    centres = np.column_stack([60.0 + 50.0 * t, 70.0 - 40.0 * np.abs(t)])  # touches row 80
    cable = detect_surface(bg)
    assert cable is not None and cable.angle == pytest.approx(23.6, abs=0.5)  # can fail
    surface = detect_surface(bg, centres=centres, radius=10.0)
    assert surface is not None and surface.angle == pytest.approx(0.0, abs=0.2)
    assert surface.point[1] == pytest.approx(79.5, abs=1.0)  # between the rows 79 and 80
    # an edge it crosses everywhere: none
    assert detect_surface(np.where(uu >= 80.0, 30.0, 60.0), centres=centres, radius=10.0) \
        is None


def test_the_detected_surface_is_the_edge_the_ball_touches():
    # expected: the plane's edge as drawn (row 80, horizontal, 70 of 160 px wide). A shelf's
    # edge across the whole frame at row 20, above the ball's path, is longer and not crossed
    # either; the ball comes within its radius of the plane's edge (the contact) and no nearer
    # than 22 px to the shelf's, so the plane's edge is the surface. (Found on a rendered MJPEG
    # clip, where a 151 px edge of the wall's texture at 23 degrees beat the surface's broken
    # 124 px edge, and the kinematics would have been turned by 21 degrees.)
    rng = np.random.default_rng(5)
    vv, uu = np.mgrid[:100, :160].astype(float)
    bg = np.where(vv < 20.0, 150.0, 60.0)  # the shelf
    bg = np.where((vv >= 80.0) & (uu >= 45.0) & (uu < 115.0), 20.0, bg)  # the plane
    bg = np.clip(bg + rng.normal(0.0, 1.0, bg.shape), 0, 255)
    t = np.linspace(-1.0, 1.0, 41)
    centres = np.column_stack([80.0 + 30.0 * t, 70.0 - 28.0 * np.abs(t)])  # touches row 80
    shelf = detect_surface(bg)
    assert shelf is not None and shelf.point[1] == pytest.approx(19.5, abs=1.0)  # can fail
    surface = detect_surface(bg, centres=centres, radius=10.0)
    assert surface is not None and surface.angle == pytest.approx(0.0, abs=0.5)
    assert surface.point[1] == pytest.approx(79.5, abs=1.0)


def test_an_edge_along_the_balls_path_is_not_the_surface(monkeypatch):
    # expected: the plane's edge as drawn (row 80, horizontal). A bright bar of the wall runs
    # along the ball's incoming path 4 degrees off it, one radius (10 px) from the first
    # centre and farther on: the ball comes as near to touching it as to the plane's fainter
    # edge, but nearest where its track starts, so it does not bounce off it. (Found on a
    # rendered clip under flickering light: a texture line at 28 degrees, 0.6 px off the
    # contact, nearest at the last frame, was taken for the surface.)
    from bouncebayes.tracking import _geometry

    rng = np.random.default_rng(5)
    vv, uu = np.mgrid[:100, :160].astype(float)
    bg = np.where((vv >= 80.0) & (uu >= 45.0) & (uu < 115.0), 45.0, 60.0)  # the plane
    t = np.linspace(-1.0, 1.0, 41)
    centres = np.column_stack([80.0 + 30.0 * t, 70.0 - 28.0 * np.abs(t)])  # touches row 80
    a = math.atan2(28.0, 30.0) + math.radians(4.0)
    d, n = np.array([math.cos(a), math.sin(a)]), np.array([-math.sin(a), math.cos(a)])
    p0 = centres[0] + 10.0 * np.array([-28.0, 30.0]) / math.hypot(28.0, 30.0)
    along = (uu - p0[0]) * d[0] + (vv - p0[1]) * d[1]
    across = (uu - p0[0]) * n[0] + (vv - p0[1]) * n[1]
    bg = np.where((across >= 0) & (across < 6) & (along > -45) & (along < 25), 150.0, bg)
    bg = np.clip(bg + rng.normal(0.0, 1.0, bg.shape), 0, 255)
    surface = detect_surface(bg, centres=centres, radius=10.0)
    assert surface is not None and surface.angle == pytest.approx(0.0, abs=0.5)
    assert surface.point[1] == pytest.approx(79.5, abs=1.0)
    monkeypatch.setattr(_geometry, "_bounces_off", lambda segment, ball: True)  # before
    bar = detect_surface(bg, centres=centres, radius=10.0)
    assert bar is not None and bar.angle == pytest.approx(-47.0, abs=2.0)


def test_the_surface_line_is_refitted_until_its_pixels_settle(monkeypatch):
    from bouncebayes.tracking import _geometry

    # expected: the line drawn (3 degrees, edge pixels jittered by a pixel either way, as a
    # textured wall moves Canny's). A Hough segment 1.5 degrees off it through its middle
    # reaches its pixels only near the middle, and the pixels within 2 px of it are the ones
    # jittered towards it: fitted once, measured 3.58 degrees; refitted to the pixels near
    # each fit in turn, 3.04 (a rendered MJPEG clip: 2.46 +- 0.11 once, 2.97 +- 0.08 refitted,
    # the truth 3)
    rng = np.random.default_rng(3)
    edges = np.zeros((200, 320), np.uint8)
    u = np.arange(320)
    v = np.rint(100 - u * math.tan(math.radians(3.0)) + rng.integers(-1, 2, 320)).astype(int)
    edges[v, u] = 255
    c = (160.0, 100 - 160 * math.tan(math.radians(3.0)))
    a = math.radians(4.5)
    segment = (c[0] - 100 * math.cos(a), c[1] + 100 * math.sin(a),
               c[0] + 100 * math.cos(a), c[1] - 100 * math.sin(a))
    line = _geometry._refined(segment, edges)
    assert line.angle == pytest.approx(3.0, abs=max(2 * line.angle_sd_deg, 0.06))
    monkeypatch.setattr(_geometry, "REFIT_ROUNDS", 1)
    assert _geometry._refined(segment, edges).angle > 3.4  # fitted once: can fail


def test_a_surface_edge_broken_by_a_textured_wall_is_found(monkeypatch):
    # tests/render_pbr.py's default wall (50 +- 10 grey levels of texture) over its plane (30),
    # a surface sloping by 2 degrees (truth: the renderer's line, v = 140 + u tan 2 deg): Canny
    # keeps under half of the edge's length, and no segment bridging 6 px spans 30 % of the
    # width (a stranger's clip, 2026-11-28: `track` asked for --surface). Bridging 12-20 px,
    # a step only (the wall's texture makes long lines there, the same side brighter along
    # 0.5-0.6 of them): measured -1.96 deg, SD 0.044, the point 0.34 px above the line
    from render_pbr import Shot, Throw, render

    from bouncebayes.tracking import _geometry

    shot = Shot(width=320, height=160, radius_px=12.0, n_frames=60, surface_v=140.0,
                slope_deg=2.0, sigma_px=0.8, supersample=2, seed=41,
                throw=Throw(speed_in=2.2, angle_in=40.0, t_contact=0.03, x_contact=0.06))
    frames = render(shot)
    bg, centres = background_model(frames, 25), shot.true_centres()
    surface = detect_surface(bg, centres=centres, radius=12.0)
    assert surface is not None
    assert surface.angle == pytest.approx(-2.0, abs=3 * surface.angle_sd_deg + 0.05)
    u, v = surface.point
    assert v - (140.0 + u * math.tan(math.radians(2.0))) == pytest.approx(0.0, abs=1.0)
    monkeypatch.setattr(_geometry, "BROKEN_GAPS", (6,))  # without the gaps bridged ...
    step = detect_surface(bg, centres=centres, radius=12.0)  # ... the lines' steps find it
    assert step.angle == pytest.approx(-2.0, abs=3 * step.angle_sd_deg + 0.05)
    monkeypatch.setattr(_geometry, "_step_line", lambda *args: None)  # the search before: none
    assert detect_surface(bg, centres=centres, radius=12.0) is None


def test_plane_frame_matches_the_rendered_trajectory(clean):
    scene, bounce, frames = clean
    track = track_ball(frames)
    cal = Calibration(metres_per_px=scene.metres_per_px, source="truth")
    t, x, y = to_plane_frame(track, cal, surface_of(scene), scene.fps)
    truth = plane_positions(scene, bounce, t)
    np.testing.assert_allclose(t, np.arange(len(frames)) / scene.fps)
    np.testing.assert_allclose(x, truth[:, 0] - truth[0, 0], atol=0.05e-3)  # origin: 1st point
    np.testing.assert_allclose(y, truth[:, 1], atol=0.05e-3)  # y: height above the surface


def test_plane_frame_follows_the_direction_of_travel_in_a_mirrored_video(clean):
    scene, bounce, frames = clean
    mirrored = np.ascontiguousarray(frames[:, :, ::-1])  # the ball now travels to the left
    track = track_ball(mirrored)
    x1, y1, x2, y2 = scene.surface_points()
    w = scene.width - 1
    surface = Surface.from_points((w - x1, y1), (w - x2, y2))
    cal = Calibration(metres_per_px=scene.metres_per_px, source="truth")
    t, x, y = to_plane_frame(track, cal, surface, scene.fps)
    truth = plane_positions(scene, bounce, t)
    np.testing.assert_allclose(x, truth[:, 0] - truth[0, 0], atol=0.05e-3)
    np.testing.assert_allclose(y, truth[:, 1], atol=0.05e-3)


def test_rebound_from_tracked_video_is_within_the_kinematics_uncertainty(noisy, tmp_path):
    import dataclasses

    from bouncebayes.kinematics import fit_kinematics, read_trajectory

    scene, bounce, frames = noisy
    track = track_ball(frames)
    cal = Calibration(metres_per_px=scene.metres_per_px, source="truth")
    path = write_trajectory(tmp_path / "bounce.csv",
                            *to_plane_frame(track, cal, surface_of(scene), scene.fps))
    # the centres' stated per-frame SD, as the tracker's record gives it to the kinematics (a
    # correlated error: they follow the texture under the ball)
    assert track.refined.all() and 0.0 < track.radius_fit.centre_sd < 0.1
    traj = dataclasses.replace(read_trajectory(path),
                               position_sd=track.radius_fit.centre_sd * scene.metres_per_px)
    fit = fit_kinematics(traj)
    # 3 standard errors. Over seeds 0-5 of this scene |z| <= 1.73 (speeds and angles, incidence
    # and rebound; seed 0: rebound speed 1.73, angle 0.41). With white-noise standard errors
    # the rebound speed's z was 4.96 at seed 0 (RMS 2.3 over the speeds of seeds 0-3; the
    # coverage centroids' 1.9, incidence up to -5.0): the errors are correlated along the track.
    for got, want, se in ((fit.rebound_speed, bounce.rebound_speed(), fit.rebound_speed_se),
                          (fit.rebound_angle, bounce.rebound_angle(), fit.rebound_angle_se),
                          (fit.incidence_speed, bounce.incidence_speed(), fit.incidence_speed_se)):
        assert abs(got - want) < 3 * se
    assert fit.rebound_speed == pytest.approx(bounce.rebound_speed(), rel=2e-3)
    assert fit.incidence_speed == pytest.approx(bounce.incidence_speed(), rel=2e-3)


# --------------------------------------------------------------------------- reading


def test_with_a_tone_curve_the_surface_is_looked_for_in_the_stored_levels_too(clean, tmp_path,
                                                                              monkeypatch):
    # Frames decoded by a tone curve: where no surface is found in the decoded background, the
    # background as stored (the stored frames' median) is searched too -- a curve moves no
    # edge (a rendered sRGB clip, a plane of 30 under a wall of 50 +- 14 in light: its surface
    # found as stored at 3.00 deg for the truth 3, not in light). Expected: the second search
    # gets exactly background_model of the stored frames, and its line is the one returned.
    from bouncebayes.tracking import _output

    _, _, frames = clean
    folder = write_png_sequence(frames, tmp_path / "seq")
    seen = []
    line = Surface.from_points((0.0, 150.0), (300.0, 150.0))

    def detect(bg, **kw):
        seen.append(np.asarray(bg, dtype=np.float64))
        return None if len(seen) == 1 else line

    monkeypatch.setattr(_output, "detect_surface", detect)
    video = track_video(folder, fps=1000, config=TrackerConfig(tone_curve="srgb"))
    assert len(seen) == 2 and video.surface is line
    np.testing.assert_array_equal(seen[1], background_model(frames))
    assert not np.array_equal(seen[0], seen[1])  # the first was in light
    seen.clear()  # linear frames: one search only, and the error names the file
    with pytest.raises(InputFileError, match=r"seq: no surface line detected"):
        track_video(folder, fps=1000)
    assert len(seen) == 1


def test_image_folder_is_sorted_naturally_and_needs_fps(clean, tmp_path):
    _, _, frames = clean
    folder = write_png_sequence(frames[:12], tmp_path / "seq")  # frame_2.png < frame_10.png
    source = read_frames(folder, fps=1000)
    np.testing.assert_array_equal(source.frames, frames[:12])
    assert (source.name, source.fps, source.fps_source) == ("seq", 1000.0, "argument")
    assert not source.frames.flags.writeable
    with pytest.raises(InputFileError, match=r"seq: frame rate unknown .*--fps"):
        read_frames(folder)


def test_video_file_gives_its_frame_rate_and_lossless_frames(clean, tmp_path):
    _, _, frames = clean
    path = write_video(frames[:20], tmp_path / "clip.avi", 1000.0, "FFV1")
    source = read_frames(path)
    assert (source.name, source.fps, source.fps_source) == ("clip", 1000.0, "file")
    np.testing.assert_array_equal(source.frames, frames[:20])
    assert read_frames(path, fps=500).fps == 500.0  # the capture rate overrides the file's


def _colour_clip(folder, ball_bgr, wall_bgr=(50.0, 110.0, 60.0), n=30):
    """A disk of colour ``ball_bgr`` crossing a wall of ``wall_bgr`` (BGR, noise 2 grey
    levels), written into ``folder`` as PNG frames (``png/``) and as a colour MJPEG video;
    their paths and the frames."""
    rng = np.random.default_rng(8)
    v, u = np.mgrid[:60, :120].astype(float)
    frames = []
    for k in range(n):
        disk = (np.hypot(u - 15.0 - 3.0 * k, v - 30.0) < 8.0)[..., None]
        img = np.where(disk, np.array(ball_bgr), np.array(wall_bgr))
        frames.append(np.clip(np.rint(img + rng.normal(0.0, 2.0, img.shape)), 0, 255
                              ).astype(np.uint8))
    png = folder / "png"
    png.mkdir(parents=True)
    for k, f in enumerate(frames):
        cv2.imwrite(str(png / f"f{k:03d}.png"), f)
    video = folder / "clip.avi"
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"MJPG"), 1000.0, (120, 60),
                             isColor=True)
    for f in frames:
        writer.write(f)
    writer.release()
    return png, video, np.array(frames)


def test_a_ball_faint_in_the_luma_is_read_in_the_colour_channel_it_stands_out_in(tmp_path):
    # a red ball (BGR 40, 48, 200) on a green wall (50, 110, 60): luma (BT.601) 92.6 against
    # 88.2, 2.2 noise SDs; in the red channel 200 against 60 (measured: 29 times as far as in
    # the luma from the MJPEG video). Expected: the red channel, the frames exactly the files'
    # red (PNG), and the luma where asked
    folder, video, frames = _colour_clip(tmp_path, (40.0, 48.0, 200.0))
    source = read_frames(folder, fps=1000.0)
    assert source.channel == "red" and "red channel" in source.channel_note
    np.testing.assert_array_equal(source.frames, frames[..., 2])
    assert read_frames(video).channel == "red"  # faint in the luma: even at half size
    grey = read_frames(folder, fps=1000.0, channel="grey")
    assert grey.channel == "grey" and grey.channel_note is None
    np.testing.assert_array_equal(grey.frames[0], cv2.cvtColor(frames[0], cv2.COLOR_BGR2GRAY))
    assert read_frames(folder, fps=1000.0, channel="green").channel == "green"
    np.testing.assert_array_equal(read_image(folder / "f000.png", "red"), frames[0, ..., 2])
    with pytest.raises(ValueError, match="channel"):
        read_frames(folder, fps=1000.0, channel="purple")


def test_a_ball_clear_in_the_luma_keeps_it_unless_a_lossless_channel_is_far_clearer(tmp_path):
    # a bright ball (BGR 180, 180, 180) on the green wall: 92 grey levels above it in the luma,
    # 120 in the red channel: the luma kept. A red ball (BGR 50, 90, 200: luma 118.3 against
    # 88.2) stands out ~3 times as far in red (140 grey levels at noise 2, against 30 at the
    # luma's 1.35): taken from PNG frames (colour at full size), not from MJPEG (colour at
    # half size: 5x wanted)
    folder, video, _ = _colour_clip(tmp_path / "grey", (180.0, 180.0, 180.0))
    assert read_frames(folder, fps=1000.0).channel == "grey"
    assert read_frames(video).channel == "grey"
    folder, video, _ = _colour_clip(tmp_path / "red", (50.0, 90.0, 200.0))
    assert read_frames(folder, fps=1000.0).channel == "red"
    assert read_frames(video).channel == "grey"


def test_a_grey_video_decoded_to_colour_is_read_as_grey(clean, tmp_path):
    # OpenCV decodes every video to BGR; a grey one (its channels equal) is its luma, one
    # plane read (the frames as written: FFV1 is lossless)
    _, _, frames = clean
    path = write_video(frames[:10], tmp_path / "grey.avi", 1000.0, "FFV1")
    source = read_frames(path)
    assert source.channel == "grey" and source.channel_note is None
    np.testing.assert_array_equal(source.frames, frames[:10])


@pytest.mark.parametrize("fourcc, suffix", [("MJPG", ".avi"), ("mp4v", ".mp4")])
def test_lossy_video_is_tracked_below_half_a_pixel(noisy, tmp_path, fourcc, suffix):
    scene, bounce, frames = noisy
    source = read_frames(write_video(frames, tmp_path / f"v{suffix}", scene.fps, fourcc))
    track = track_ball(source.frames)
    assert track.found.all()
    assert rms(track.centre - true_centres(scene, bounce)) < 0.5  # measured 0.056 / 0.066 px


def test_bad_inputs_name_the_file(tmp_path, clean):
    with pytest.raises(InputFileError, match=r"missing\.avi: no such file or folder"):
        read_frames(tmp_path / "missing.avi")
    garbage = tmp_path / "garbage.avi"
    garbage.write_bytes(b"not a video" * 100)
    with pytest.raises(InputFileError, match=r"garbage\.avi: cannot be opened as a video"):
        read_frames(garbage)
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(InputFileError, match=r"empty: no image frames \(\.png"):
        read_frames(empty, fps=1000)
    folder = write_png_sequence(clean[2][:3], tmp_path / "mixed", pad=True)
    cv2.imwrite(str(folder / "frame_0003.png"), np.zeros((10, 10), np.uint8))
    with pytest.raises(InputFileError, match=r"frame_0003\.png: frame size 10x10 differs from "
                                             r"320x240 of frame_0000\.png"):
        read_frames(folder, fps=1000)
    with pytest.raises(InputFileError, match=r"frame_0000\.png: is a single image"):
        read_frames(folder / "frame_0000.png", fps=1000)
    with pytest.raises(ValueError, match=r"`fps` must be a finite number > 0 frames/s; got -1"):
        read_frames(folder, fps=-1)


def test_a_video_without_a_ball_is_an_error_naming_the_file(tmp_path):
    scene = Scene(noise_sigma=3.0, n_frames=20)
    empty = np.stack([render(scene, Bounce(x_contact=-1.0))[0]] * 20)  # ball far out of view
    path = write_video(empty, tmp_path / "static.avi", 1000.0)
    with pytest.raises(InputFileError, match=r"static\.avi: ball found in none of the 20 "
                                             r"frames .*--polarity"):
        track_video(path)


def test_a_resting_ball_needs_a_background_image(clean, tmp_path):
    scene, bounce, frames = clean
    still = np.repeat(frames[40:41], 20, axis=0)  # the median background holds the ball
    path = write_video(still, tmp_path / "still.avi", 1000.0)
    with pytest.raises(InputFileError, match=r"still\.avi: ball found in none of the 20"):
        track_video(path)
    empty = render(Scene(n_frames=1), Bounce(x_contact=-1.0))[0]  # same scene, no ball
    cv2.imwrite(str(tmp_path / "empty.png"), empty)
    result = track_video(path, background=tmp_path / "empty.png",
                         surface=surface_of(scene))
    assert result.track.found.all()
    assert rms(result.track.centre - true_centres(scene, bounce)[40]) < 0.1
    cv2.imwrite(str(tmp_path / "small.png"), empty[:100])
    with pytest.raises(InputFileError, match=r"small\.png: background image is 320x100 but the "
                                             r"frames of .*still\.avi are 320x240"):
        track_video(path, background=tmp_path / "small.png")


def test_arguments_are_checked_at_the_boundary():
    with pytest.raises(ValueError, match=r"`polarity` must be one of 'auto', 'bright', 'dark'; "
                                         r"got 'white'"):
        TrackerConfig(polarity="white")
    with pytest.raises(ValueError, match=r"`background_frames` must be an integer >= 3; got 2"):
        TrackerConfig(background_frames=2)
    with pytest.raises(TypeError, match=r"`frames` must be a uint8 array .* got an array of "
                                        r"dtype float64 and shape \(2, 3, 4\)"):
        track_ball(np.zeros((2, 3, 4)))
    with pytest.raises(ValueError, match=r"surface points must differ"):
        Surface.from_points((1, 2), (1, 2))
    with pytest.raises(ValueError, match=r"reference points must differ"):
        Calibration.from_reference((1, 2), (1, 2), 0.1)
    with pytest.raises(ValueError, match=r"`reference length` must be a finite number > 0 m"):
        Calibration.from_reference((1, 2), (3, 4), 0.0)


# --------------------------------------------------------------------------- outputs, CLI


def test_overlay_is_a_png_of_the_scaled_frame(clean, tmp_path):
    scene, _, frames = clean
    track = track_ball(frames)
    path = overlay_image(frames, track, tmp_path / "o.png", surface=surface_of(scene),
                         calibration=Calibration(metres_per_px=1e-3, source="test"))
    img = cv2.imread(str(path))
    assert img.shape == (scene.height * 3, scene.width * 3, 3)  # zoomed to >= 800 px wide
    # the legend, top right, names the surface line and axes (red, BGR (60, 60, 255)) where
    # they are drawn, and only there
    bare = cv2.imread(str(overlay_image(frames, track, tmp_path / "bare.png")))
    legend = (slice(0, 100), slice(2 * scene.width, None))

    def red(im):
        return int(np.all(np.abs(im[legend].astype(int) - (60, 60, 255)) <= 30, axis=2).sum())

    assert red(img) >= 10 and red(bare) == 0


def test_the_overlays_circles_have_the_radius_that_sets_the_scale(tmp_path):
    # A blurred dark ball (render_pbr, radius 10 px, blur 1.5 px): its coverage radius is 1.2x
    # its radius, and circles of it looked too large for the ball. The circles now have the
    # edge model's radius, the one a --ball-diameter scale comes from: the drawn ring's pixels
    # (the centres' green, BGR (80, 220, 80)) lie at that radius from a sampled centre.
    # Measured: ring at 10.37 px for an edge radius of 10.39 and a coverage radius of 12.6.
    from render_pbr import render

    from bouncebayes.tracking._output import _spaced_frames

    shot = pbr_shot(10.0, 1.5, 0.0, **{**DARK, "texture": 0.0})
    frames = render(shot)
    track = track_ball(frames)
    zoom = 4  # 160 px wide: zoomed x4 (at most 4, towards 800 px)
    img = cv2.imread(str(overlay_image(frames, track, tmp_path / "o.png")))
    assert img.shape[1] == frames.shape[2] * zoom
    green = np.all(np.abs(img.astype(int) - (80, 220, 80)) <= 40, axis=2)
    k = int(_spaced_frames(track)[2])
    cx, cy = (track.centre[k] + 0.5) * zoom - 0.5
    yy, xx = np.nonzero(green)
    d = np.hypot(xx - cx, yy - cy) / zoom
    ring = d[(d > 0.7 * track.ball_radius) & (d < 1.15 * track.ball_radius)]
    assert ring.size > 50
    assert float(np.median(ring)) == pytest.approx(track.ball_radius, abs=0.3)
    assert np.nanmedian(track.radius) > 1.15 * track.ball_radius  # the coverage radius: larger


def run_cli(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(prog="bouncebayes")
    add_track_subcommand(parser.add_subparsers(dest="command", required=True))
    args = parser.parse_args(argv)
    return args.run(args)


def test_track_command_writes_trajectory_overlay_and_record(noisy, tmp_path, capsys):
    scene, bounce, frames = noisy
    folder = write_png_sequence(frames, tmp_path / "throw1")
    out = tmp_path / "out"
    x1, y1, x2, y2 = scene.surface_points()
    assert run_cli(["track", str(folder), "--out", str(out), "--fps", "1000",
                    "--surface", f"{x1},{y1},{x2},{y2}"]) == 0
    assert "throw1: ball in 100/100 frames" in capsys.readouterr().out
    rows = np.loadtxt(out / "throw1.csv", delimiter=",", skiprows=1)
    assert (out / "throw1.csv").read_text().startswith("t,x,y,residual,visible,flag\n")
    assert rows.shape == (100, 6) and (rows[:, 5] == 0).all()
    # ball-diameter scale (default: the paper's 25.6 mm ball, which the scene draws)
    truth = plane_positions(scene, bounce, rows[:, 0])
    # 1% scale, and 0.5 px for the frame whose exposure straddles the bounce
    np.testing.assert_allclose(rows[:, 2], truth[:, 1], rtol=0.01, atol=0.5 * scene.metres_per_px)
    record = json.loads((out / "throw1.track.json").read_text())
    assert record["fps_source"] == "argument" and record["surface"]["source"] == "points"
    # the scene's surface edge spans the frame (measured: on the line along 0.79 of it);
    # points given: no warning
    assert record["surface"]["edge_share"] > 0.7 and record["surface"]["warning"] is None
    assert record["calibration"]["source"] == "ball diameter"
    assert len(record["per_frame"]["u_px"]) == 100
    assert record["provenance"]["bouncebayes_version"] == bb.__version__
    assert 0 < record["ball"]["centre_sd_px"] < 0.5  # the centres' stated per-frame SD
    assert 0 <= record["ball"]["light_elevation_deg"] <= 90  # the edge model's light
    assert cv2.imread(str(out / "throw1.overlay.png")) is not None


def test_track_command_checks_the_scale_and_the_frame_rate_against_the_fall(noisy, tmp_path,
                                                                           capsys):
    """The scene falls at 9.81 m/s^2 (tests/video_helpers.py). Tracked at its own 1000 fps,
    the flights' fall agrees with the ball-diameter scale; told 800 fps, every time is 1.25
    times too long, so the fall is 9.81 / 1.25^2 (closed form) and the warning names the frame
    rate at which the fall is g: 1.25 times the one used."""
    scene, _, frames = noisy
    folder = write_png_sequence(frames, tmp_path / "throw1")
    x1, y1, x2, y2 = scene.surface_points()
    said = {}
    for fps in (1000, 800):
        out = tmp_path / f"out{fps}"
        assert run_cli(["track", str(folder), "--out", str(out), "--fps", str(fps),
                        "--surface", f"{x1},{y1},{x2},{y2}"]) == 0
        record = json.loads((out / "throw1.track.json").read_text())
        # the fall is in the tracker's metres, whose scale (the ball's edge) is its own
        scale = record["calibration"]["metres_per_pixel"] / scene.metres_per_px
        said[fps] = (capsys.readouterr().out, record["gravity"], scale)
    text, right, scale = said[1000]
    assert right["agrees"] and right["n_flights"] == 2 and not right["drag_corrected"]
    assert abs(right["fall_m_s2"] - 9.81 * scale) < 3 * right["fall_se_m_s2"]
    assert re.search(r"\n  gravity: the 2 free flights fall at .*: consistent", text)
    text, wrong, scale = said[800]
    assert not wrong["agrees"]
    assert abs(wrong["fall_m_s2"] - 9.81 / 1.25**2 * scale) < 3 * wrong["fall_se_m_s2"]
    rate = float(re.search(r"the fall is g at ([\d.]+) times the rate used", text).group(1))
    assert rate == pytest.approx(1.25, abs=0.02)
    assert "\n  warning: that is" in text


def test_track_command_tracks_the_good_inputs_and_names_the_bad(noisy, tmp_path, capsys):
    _, _, frames = noisy
    good = write_video(frames, tmp_path / "good.avi", 1000.0)
    bad = tmp_path / "bad.avi"
    bad.write_bytes(b"junk" * 100)
    with pytest.raises(ValueError, match=r"1 of 2 inputs could not be tracked \(.*bad\.avi\)"):
        run_cli(["track", str(bad), str(good), "--out", str(tmp_path / "out")])
    captured = capsys.readouterr()
    assert "bad.avi: cannot be opened as a video" in captured.err
    assert "good: ball in 100/100 frames" in captured.out
    assert (tmp_path / "out" / "good.csv").exists()


def test_an_unreadable_mp4_gets_one_line_and_no_ffmpeg_log(tmp_path):
    import subprocess
    import sys

    # FFmpeg logs "moov atom not found" to the process's stderr for a broken MP4; the tool
    # prints only its own line
    bad = tmp_path / "bad.mp4"
    bad.write_bytes(b"not a video")
    done = subprocess.run([sys.executable, "-c", "from bouncebayes.cli import main; main()",
                           "track", str(bad), "--out", str(tmp_path / "out")],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode != 0
    assert done.stderr.strip().splitlines() == [
        f"bouncebayes track: error: {bad}: cannot be opened as a video (readable: .mp4, .avi, "
        ".mov, .mkv, .m4v, .mpg, .mpeg, .wmv and other FFmpeg formats, or a folder of image "
        "frames)"]


def test_track_command_option_errors_are_one_clear_message(tmp_path):
    with pytest.raises(ValueError, match=r"`--reference` must be X1,Y1,X2,Y2,METRES \(5 numbers "
                                         r"separated by commas\); got '1,2,3'"):
        run_cli(["track", "a.avi", "--out", str(tmp_path), "--reference", "1,2,3"])
    with pytest.raises(ValueError, match=r"`--fps` must be a finite number > 0 frames/s; "
                                         r"got 0.0"):
        run_cli(["track", "a.avi", "b.avi", "--out", str(tmp_path), "--fps", "0"])
    with pytest.raises(ValueError, match=r"would write the same DIR/<name>.csv"):
        run_cli(["track", "a/v.avi", "b/v.mp4", "--out", str(tmp_path)])
    assert parse_numbers("--surface", "0,1.5,-2,3e2", ("X1", "Y1", "X2", "Y2")) == [
        0.0, 1.5, -2.0, 300.0]


# ------------------------------ scale, quality, uncertainty on an independent renderer (render_pbr)
# The expected values in this section come from tests/render_pbr.py, a renderer that shares no
# code with the tracker or video_helpers.py (physically based shading, supersampled edge, lens
# PSF, exposure along the true path, sensor noise, codecs): the ball's true radius and centres,
# and the bounce's true rebound velocity.


def pbr_shot(radius: float, sigma: float, exposure: float, n_frames: int = 72,
             t_contact: float = 0.040, **kw):
    """A bounce (72 frames, the impact at 40 ms, by default) in which the ball moves ~1.5 px
    per frame whatever its size; 90 frames with the impact at 45 ms are the scenes of
    benchmarks/tracking_accuracy.py (``shot_for``) and tracking_centres.py."""
    from render_pbr import Shot, Throw

    width, height = int(max(160, 16 * radius)), int(max(96, 10 * radius))
    mpp = 0.0256 / (2 * radius)
    throw = Throw(speed_in=1.5 * mpp * 1000.0 / 0.8, angle_in=50.0, t_contact=t_contact,
                  x_contact=0.5 * width * mpp)
    return Shot(width=width, height=height, radius_px=radius, n_frames=n_frames, slope_deg=0.0,
                surface_v=height - 8.0, sigma_px=sigma, exposure=exposure, supersample=4,
                throw=throw, **kw)


DARK = dict(albedo=0.12, ambient=0.5, wall=170.0, plane=150.0, texture=12.0)
GLOSSY = dict(specular=1.2, shininess=30.0, limb_u=0.5)


def _clear_background(frames, truth, radius):
    """Each pixel's grey level from a frame in which the ball is far from it."""
    h, w = frames.shape[1:]
    vv, uu = np.mgrid[0:h, 0:w]
    bg, done = np.zeros((h, w)), np.zeros((h, w), bool)
    for frame, c in zip(frames, truth, strict=True):
        far = (np.hypot(uu - c[0], vv - c[1]) > radius + 12) & ~done
        bg[far] = frame[far]
        done |= far
    return bg


def test_the_edge_model_holds_the_shadow_of_a_ball_lit_from_the_side():
    from render_pbr import render

    from bouncebayes.tracking._edge import fit_edge

    # a 15 px ball lit from the upper left (Lambert with limb darkening, the renderer's default
    # light), blurred by 1.5 px, on a plain wall, without noise: the truth is the renderer's
    # radius, centre and light; blur held at the truth, one frame
    shot = pbr_shot(15.0, 1.5, 0.0, texture=0.0, read_noise=0.0, shot=0.0)
    frames, truth = render(shot).astype(float), shot.true_centres()
    bg = _clear_background(frames, truth, 15.0)
    lx, ly, lz = np.asarray(shot.light) / np.linalg.norm(shot.light)
    az, el = math.atan2(-ly, lx), math.asin(lz)  # image v runs down
    k = 10
    c = truth[k] + np.array([0.2, -0.2])
    free = fit_edge(frames[k], bg, c, (0.0, 0.0), 16.5)
    assert free is not None
    # the light found: within 2 and 3 degrees (measured: 0.0 and 1.1)
    assert abs(math.degrees(free.az - az)) < 2 and abs(math.degrees(free.el - el)) < 3
    held = fit_edge(frames[k], bg, c, (0.0, 0.0), 16.5, held=(1.5, 0.0, free.az, free.el))
    # measured +0.1 %; without the shadow (elevation pi/2: lit from the camera) +1.6 %
    assert abs(held.r / 15.0 - 1) < 0.004
    assert np.hypot(held.cx - truth[k][0], held.cy - truth[k][1]) < 0.03
    plain = fit_edge(frames[k], bg, c, (0.0, 0.0), 16.5, held=(1.5, 0.0, 0.0, 0.5 * math.pi))
    assert plain.r / 15.0 - 1 > 0.012


@pytest.mark.parametrize("shading", ["side-lit", "glossy"])
def test_the_frames_together_find_the_light_of_a_blurred_ball(shading):
    from render_pbr import render

    from bouncebayes.tracking._edge import SHADOW_MAX_BLUR

    # a 10 px ball lit from the upper left (the renderer's default light, elevation 50 deg),
    # blurred by 1.5 px, on a plain wall, without noise (the model's own error; with noise the
    # joint fit's formal SE of the radius is 0.5-0.65 % here): the truth is the renderer's
    # radius and light. Blurred by more than SHADOW_MAX_BLUR of its radius, a frame alone does
    # not look for the shadow; the frames together find it and the blur with it. Measured:
    # side-lit -0.09 % (the columns blurred along the radius only -> 2-D: +0.12 -> -0.09 %;
    # without the light and with the frames' median blur, before 2026-11-28, +3.5 % on a noisy
    # draw); glossy (limb darkening 0.5, a Blinn-Phong highlight that saturates) +0.16 % (the
    # radial columns -2.33 %; the 2-D ones with only the saturated pixels' neighbours left out
    # +7.9 %: the highlight's light the blur carries towards the rim)
    kw = {} if shading == "side-lit" else GLOSSY
    shot = pbr_shot(10.0, 1.5, 0.0, texture=0.0, seed=0, read_noise=0.0, shot=0.0, **kw)
    fit = track_ball(render(shot)).radius_fit
    lx, ly, lz = np.asarray(shot.light) / np.linalg.norm(shot.light)
    az, el = math.degrees(math.atan2(-ly, lx)), math.degrees(math.asin(lz))
    assert fit.sigma > SHADOW_MAX_BLUR * 10.0
    assert abs(math.degrees(fit.light[0]) - az) < 4 and abs(math.degrees(fit.light[1]) - el) < 4
    assert abs(fit.radius / 10.0 - 1) < 0.005
    assert abs(fit.sigma - 1.5) < 0.05


def test_a_ball_lit_from_the_camera_gets_no_shadow():
    from render_pbr import render

    # lit from the camera there is no terminator on the visible sphere: the model keeps none
    # (elevation 90 degrees; two of the five first fits found one in the wall's texture) and
    # the radius is the model's without the shadow: +0.56 % (the truth: the renderer's radius;
    # stated SD 1.1 %; +0.13 % with 9 frames, before a blurred ball got 25, and -0.11 % before
    # the wall's occlusion term; with the shadow forced on every frame of this scene on a
    # plain wall: +2.9 %)
    shot = pbr_shot(10.0, 0.7, 0.0, light=(0.0, 0.0, 1.0))
    track = track_ball(render(shot))
    assert track.radius_fit.light[1] == pytest.approx(0.5 * math.pi)
    assert abs(track.radius_fit.radius / 10.0 - 1) < 0.01


@pytest.mark.parametrize("radius,sigma,exposure,light,limit", [
    (10.0, 0.7, 0.4, {}, 0.01),           # side-lit bright ball, limb darkening, motion blur
    (10.0, 0.0, 0.0, DARK, 0.01),         # dark ball on a bright textured wall
    (5.0, 0.7, 0.0, DARK, 0.03),          # a 10 px ball
])
def test_the_scale_comes_from_the_balls_edge(radius, sigma, exposure, light, limit):
    from render_pbr import render

    shot = pbr_shot(radius, sigma, exposure, **light)
    track = track_ball(render(shot))
    fit = track.radius_fit
    cal = Calibration.from_ball_diameter(shot.diameter_m, track.ball_radius,
                                         track.ball_radius_se, fit.sigma, fit.method)
    err = cal.metres_per_px / shot.metres_per_px - 1.0
    # the targets (docs/tracking.md) are 0.5 % at radius >= 10 px and 2 % at 5 px; the sweep of
    # benchmarks/tracking_accuracy.py reaches 0.9 % and 5.4 % (sigma <= 0.7 px): the limits
    # here are what the tracker holds, not the targets. Measured: +0.90 and +0.17 % (the edge
    # model; stated SD 1.2 and 0.8 %), +0.09 % (the small-ball fit's radius, stated 2.6 %)
    assert abs(err) <= limit
    assert abs(err) <= 3 * cal.relative_sd  # the stated uncertainty covers the error
    assert track.radius_fit is not None and len(track.radius_fit.frames) >= 5
    # the stated per-frame centre SD against the centres' true RMS error per coordinate
    # (renderer's truth; the fitted centres' stated SD is at least twice their formal
    # standard error, _refine.SE_FACTOR): measured 0.030 vs 0.022, 0.0106 vs 0.0061 and 0.026
    # vs 0.027 px
    ok = track.trusted
    assert track.refined[ok].all()
    true_sd = float(np.sqrt(np.mean((track.centre[ok] - shot.true_centres()[ok]) ** 2)))
    assert 0.6 * true_sd <= track.radius_fit.centre_sd <= 2.2 * true_sd


def test_a_small_glossy_balls_scale_under_a_blur_states_what_the_shading_can_do():
    from render_pbr import render

    from bouncebayes.tracking import radius_warning

    # expected: the renderer's radius (5 px). A glossy ball (limb darkening 0.5, a saturating
    # Blinn-Phong highlight) blurred by 1.2 px, a quarter of its radius: the shading near the
    # rim trades against the radius (measured 4.01 px, -19.8 %, the small-ball fit's fitted
    # blur 1.44 px; with the renderer's true blur held, -6 to -12 % on such scenes), stated
    # 12.5 %. On this textured wall the frames fitted together with the blur free
    # (_edge._small_blur_free) hold it: measured -2.03 % at a fitted blur of 1.25 px (stated
    # 2.1 %; -2.25 % without the wall's occlusion term, _edge.OCCLUSION_MIN_RADIUS)
    shot = pbr_shot(5.0, 1.2, 0.0, specular=1.2, shininess=30.0, limb_u=0.5, seed=0)
    track = track_ball(render(shot))
    cal = Calibration.from_track(shot.diameter_m, track)
    err = track.ball_radius / 5.0 - 1.0
    assert track.radius_fit.method == "frames' joint fit"
    assert abs(err) <= min(0.03, 2.0 * cal.relative_sd)
    # on a plain wall the frames cannot hold the radius (its Cramer-Rao bound 3.6-5.3 % at a
    # 1.5 px blur, docs/tracking.md §3): the joint fit is not kept, and the stated SD is wide
    shot = pbr_shot(5.0, 1.5, 0.0, specular=1.2, shininess=30.0, limb_u=0.5, seed=1,
                    texture=0.0)
    track = track_ball(render(shot))
    cal = Calibration.from_track(shot.diameter_m, track)
    assert track.radius_fit.method != "frames' joint fit"
    assert abs(track.ball_radius / 5.0 - 1.0) <= 2.0 * cal.relative_sd
    assert cal.relative_sd > 0.10 and "reference" in radius_warning(track)


def test_the_radius_bound_of_the_frames_together_is_the_inverse_information():
    from bouncebayes.tracking._edge import _Pixels, _joint_radius_sd

    # expected: a linear model's parameter SE, sqrt(inv(J^T J)[0, 0] s^2), s^2 the residuals'
    # mean square (Gauss-Markov). A uniform dark disk (r = 4 px, blur 1 px) on a wall with a
    # gradient: the bound falls as the noise does, in proportion, and is finite
    rng = np.random.default_rng(3)
    vv, uu = np.mgrid[0:20, 0:20].astype(float)
    u, v = uu.ravel(), vv.ravel()
    n = u.size
    wall = 100.0 + 3.0 * u

    def pixels(noise):
        rho = np.hypot(u - 10.0, v - 10.0)
        from scipy.special import ndtr
        grey = wall * (1 - ndtr((4.0 - rho) / 1.04)) + 20.0 * ndtr((4.0 - rho) / 1.04)
        grey = grey + noise * rng.standard_normal(n)
        full = functools.partial(np.full, n)
        return _Pixels(u, v, grey, wall, full(0.0), full(0.0), full(10.0), full(10.0),
                       full(1.0), full(0.0), full(0.0), np.zeros(n, np.intp), 1, np.ones(n),
                       np.zeros(n))

    q = np.array([4.0, 1.0, 0.0, 0.0, 0.5 * math.pi])
    c = np.array([[10.0, 10.0]])
    low, high = (_joint_radius_sd(pixels(s), q, c) for s in (1.0, 4.0))
    assert 0.0 < low < high < math.inf
    assert high / low == pytest.approx(4.0, rel=0.15)


SHADOW_SHOT = dict(width=160, height=96, radius_px=10.0, n_frames=60, surface_v=80.0,
                   slope_deg=2.0, sigma_px=0.7, exposure=0.3, supersample=2, seed=4)


def test_the_balls_shadow_on_the_wall_is_left_out_and_said(monkeypatch):
    from render_pbr import Shot, Throw, render

    from bouncebayes.tracking import _cast, radius_warning

    # expected: the renderer's radius (10 px) and centres. A lamp casts the ball's shadow on
    # the wall just behind it (tests/render_pbr.py's cast: offset 0.6, 0.5 radii, half as
    # bright as the wall), overlapping the ball's edge on one side in every frame alike:
    # before, the radius came out 10.82 px and the centres 1.23 px RMS off, no frame flagged
    # and nothing said. Where the shadow model (_cast) does not take it (here turned off: a
    # shadow that is no disk, a reflection, a lit patch), the sectors of the rim whose wall is
    # not the background's are left out (_edge_kernel.foreign_sectors): measured 9.995 px and
    # 0.068 px, and a warning
    monkeypatch.setattr(_cast, "CAST_MIN_RADIUS", math.inf)
    kw = dict(SHADOW_SHOT, throw=Throw(speed_in=2.0, angle_in=35.0, t_contact=0.03,
                                       x_contact=0.05))
    shot = Shot(**kw, cast=(0.6, 0.5, 0.5))
    track = track_ball(render(shot))
    assert track.radius_fit.cast is None
    assert abs(track.radius_fit.radius / 10.0 - 1) < 0.015
    assert rms(track.centre - shot.true_centres()) < 0.15
    assert track.radius_fit.foreign == 1.0 and "shadow" in radius_warning(track)
    # and the scale's stated SD holds what the shadow's penumbra can still do (_edge.
    # FOREIGN_REL_SD: rendered shadows of bright 10-15 px balls, scale errors RMS 1.4 %)
    from bouncebayes.tracking._edge import FOREIGN_REL_SD

    assert Calibration.from_track(shot.diameter_m, track).relative_sd >= FOREIGN_REL_SD
    clear = track_ball(render(Shot(**kw)))  # no shadow: nothing left out, nothing said
    assert clear.radius_fit.foreign == 0.0 and radius_warning(clear) is None
    assert Calibration.from_track(shot.diameter_m, clear).relative_sd < FOREIGN_REL_SD


@pytest.mark.parametrize("cast,lighting", [
    ((0.6, 0.5, 0.5), {}),            # beside the ball (the foreign sectors' case above)
    ((0.3, 0.0, 0.6), {}),            # hugging it: no sector's wall beyond it is off
    ((0.1, 0.1, 0.6), {}),            # nearly behind it
    ((0.3, 0.3, 0.6), DARK),          # a dark ball's
])
def test_the_balls_shadow_that_hugs_its_edge_is_held(cast, lighting):
    from render_pbr import Shot, Throw, render

    from bouncebayes.tracking import cast_message, radius_warning

    # expected: the renderer's radius (10 px), centres and shadow (its offset cast[:2] radii,
    # radius 1 radius: full to 0.85, a linear penumbra to 1.15; depth cast[2]). Measured
    # before the shadow model (_cast), bright balls: +5.3 %, +8.7 %, +5.0 % in radius,
    # centres 0.96, 0.94, 0.43 px off, only the first said (its sides left out); the dark ball
    # +22 %. With it: -0.3 to +0.7 %, centres <= 0.05 px, the shadow's offset within 0.2 px
    kw = dict(SHADOW_SHOT, **lighting,
              throw=Throw(speed_in=2.0, angle_in=35.0, t_contact=0.03, x_contact=0.05))
    shot = Shot(**kw, cast=cast)
    track = track_ball(render(shot))
    found = track.radius_fit.cast
    assert found is not None
    assert math.hypot(found.du - 10.0 * cast[0], found.dv - 10.0 * cast[1]) < 0.4
    if math.hypot(*cast[:2]) >= 0.3:  # (nearly behind the ball: its depth, radius and
        # penumbra trade against each other, measured depth 0.36 for 0.6)
        assert abs(found.depth - cast[2]) < 0.1 and abs(found.radius / 10.0 - 1) < 0.05
    assert abs(track.radius_fit.radius / 10.0 - 1) < 0.012
    assert rms(track.centre - shot.true_centres()) < 0.1
    assert track.radius_fit.foreign == 0.0 and radius_warning(track) is None
    assert "shadow" in cast_message(track)


@pytest.mark.parametrize("radius,light,cast,seed,shading", [
    (5.0, (-0.15, 0.25, 0.95), (0.3, 0.2, 0.6), 1, {}),   # the paper's camera, lit from near it
    (6.5, (-0.6, 0.3, 0.75), (0.5, -0.3, 0.5), 1, {}),    # lit from the side
    (5.0, (-0.15, 0.25, 0.95), (0.0, 0.0, 0.0), 1, {}),   # no shadow on the wall: none held
    (5.0, (-0.15, 0.25, 0.95), (0.3, 0.2, 0.6), 5, {}),   # two frames of four fit another shape
    (5.0, (-0.15, 0.25, 0.95), (0.3, 0.2, 0.6), 1, GLOSSY),
])
def test_a_small_balls_shadow_that_hugs_its_edge_is_held(radius, light, cast, seed, shading):
    from render_pbr import Shot, Throw, render

    from bouncebayes.tracking import Calibration

    # expected: the renderer's radius, centres and shadow. The paper's camera (224 x 64 px,
    # MJPEG) with the ball's shadow on a wall close behind it. Before, balls under 8 px were
    # not looked at for one: +9.1 % (z 3.8) and +5.6 % (z 2.9) in radius, centres 0.52 and
    # 0.78 px RMS off (the camera's target 0.15), nothing said; with it +0.6 and +0.8 %,
    # 0.085 and 0.050 px. Seed 5 and the glossy ball were not held until the frames' fits were
    # judged by their cost with a plausible shadow only and a frame apart tried with the
    # shapes the others agree on (_cast._cost, _cast._consensus): +9.4 % (z 3.9) and +7.6 %
    # (z 3.1), centres 0.41 and 0.52 px; now +0.6 and +0.4 %, 0.05 and 0.13 px. Over 32
    # rendered shadows at 5 and 6.5 px (four lights, blur 0.5 and 1.0 px) 30 held (24
    # before), |z| <= 1.34 where held; none on 16 clear clips nor the 32 of
    # benchmarks/paper_camera.py
    shot = Shot(width=224, height=64, radius_px=radius, n_frames=120, surface_v=50.0,
                slope_deg=3.0, sigma_px=0.5, exposure=0.5, supersample=4, seed=seed,
                codec="MJPG", light=light, cast=cast, **shading,
                throw=Throw(speed_in=2.0, angle_in=35.0, t_contact=0.05, x_contact=0.05))
    track = track_ball(render(shot))
    found = track.radius_fit.cast
    if cast[2] == 0.0:
        assert found is None
    else:
        assert found is not None
        assert math.hypot(found.du - radius * cast[0], found.dv - radius * cast[1]) \
            < 0.25 * radius
    error = track.ball_radius / radius - 1
    assert abs(error) < 0.02
    assert abs(error) < 2 * Calibration.from_track(shot.diameter_m, track).relative_sd
    assert rms((track.centre - shot.true_centres())[track.trusted]) < 0.15


def test_a_faint_ring_about_the_ball_is_not_held_as_its_shadow():
    from bouncebayes.tracking._cast import CAST_MIN_DEPTH, _shape

    # expected: _shape's rule. A ball out of focus (a disk PSF, which the model's Gaussian
    # blur does not follow) got a ring 0.18 dark, 1.2 radii, held as a shadow
    # (benchmarks/tracking_accuracy.py, radius +1.2 -> -2.6 %): the median depth of the frames
    # that agree must reach CAST_MIN_DEPTH. Each frame: (cx, cy, r, sigma, du, dv, R_s, w),
    # its depth, its costs without and with the shadow (a gain of 50 residual variances)
    p = np.array([50.0, 40.0, 10.0, 1.0, 1.4, 0.6, 12.0, 0.8])
    assert _shape({i: (p, 0.18, 100.0, 50.0) for i in range(3)}, 3) is None
    held = _shape({i: (p, CAST_MIN_DEPTH + 0.1, 100.0, 50.0) for i in range(3)}, 3)
    assert held is not None and held[0].depth == pytest.approx(CAST_MIN_DEPTH + 0.1)
    assert held[2] == 10.0 and sorted(held[1]) == [0, 1, 2]


def test_a_ring_nearly_concentric_with_the_ball_is_not_held_as_its_shadow():
    from bouncebayes.tracking._cast import CAST_MIN_OFFSET, _shape

    # expected: _shape's rule. A shadow within CAST_MIN_OFFSET radii of the ball's centre
    # shows as a thin ring all round its rim, which the fits cannot tell from the ball's own
    # dark rim (a turning stripe held one 0.087 radii off). The same frames as above, 0.56
    # dark, the offset (px) just under and just over the bound for a 10 px ball
    def shape(offset):
        p = np.array([50.0, 40.0, 10.0, 1.0, 0.6 * offset, -0.8 * offset, 11.0, 0.8])
        return _shape({i: (p, 0.56, 100.0, 50.0) for i in range(3)}, 3)

    assert shape(0.98 * CAST_MIN_OFFSET * 10.0) is None
    held = shape(1.02 * CAST_MIN_OFFSET * 10.0)
    assert held is not None and held[0].offset == pytest.approx(1.02 * CAST_MIN_OFFSET * 10.0)


def test_a_striped_ball_turning_about_the_cameras_axis_gets_no_shadow():
    from render_pbr import render

    # benchmarks/tracking_centres.py's striped 15 px ball (seed 2; no shadow in the scene):
    # its stripe, a great circle through the centre turning at 150 rad/s, meets the rim at two
    # opposite points, and the fits held it as a ring 0.56 dark, 0.087 radii off (centres
    # 0.217 -> 0.276 px). Expected: no shadow (CAST_MIN_OFFSET), and the radius within the
    # stated scale SD and 1 % (the benchmark's 0.6 % before, +0.5 % since the edge model
    # leaves out the rim's sectors the stripe misfits, _edge.EDGE_MISFIT; the centres then
    # 0.255 px, the rim's radius they hold moved by 1.1 %)
    shot = pbr_shot(15.0, 0.7, 0.3, n_frames=90, t_contact=0.045, seed=2, mark=0.25)
    track = track_ball(render(shot))
    assert track.radius_fit.cast is None
    error = track.ball_radius / 15.0 - 1
    assert abs(error) < min(0.01, 2 * Calibration.from_track(shot.diameter_m, track).relative_sd)
    assert rms((track.centre - shot.true_centres())[track.trusted]) < 0.27


def test_the_shadows_note_says_where_it_lies():
    from types import SimpleNamespace

    from bouncebayes.tracking import cast_message
    from bouncebayes.tracking._cast import CastShadow

    # image axes: u right, v down; the offset's direction in eighths, a small one a halo
    def note(du, dv):
        return cast_message(SimpleNamespace(radius_fit=SimpleNamespace(
            cast=CastShadow(du, dv, 10.0, 1.2, 0.6))))

    assert "towards the lower right" in note(3.0, 3.0) and "60 % dark" in note(3.0, 3.0)
    assert "towards the left" in note(-4.0, 0.5) and "towards the top" in note(0.2, -3.0)
    assert "a halo all round it" in note(0.2, -0.1)
    assert cast_message(SimpleNamespace(radius_fit=SimpleNamespace(cast=None))) is None
    assert cast_message(SimpleNamespace(radius_fit=None)) is None


def test_the_velocities_the_per_frame_fits_smear_by_take_the_slower_side_where_the_ball_jumps():
    from bouncebayes.tracking._refine import _velocities

    # expected, by hand: a parabola's central difference is its derivative exactly (u = t / 2,
    # v = 0.3 t + 0.05 t^2: (0.5, 0.3 + 0.1 t)); at the impact (frame 5: in at (0.5, 0.75), out
    # at (0.5, -0.6)) their mean still; where the ball jumps (the clip again after frame 9:
    # 4.5 px back) the one-sided difference before the jump, and after it the one after;
    # one-sided at the ends, and 0 beside a frame where the ball was not found (13)
    t = np.arange(16.0)
    centre = np.column_stack([0.5 * t, 0.3 * t + 0.05 * t**2])
    centre[6:10, 1] = centre[5, 1] - 0.6 * (t[6:10] - 5)  # the rebound from frame 5
    centre[10:] = centre[:6]  # the clip again from its start
    centre[13] = np.nan
    idx = np.array([i for i in range(16) if i != 13])
    vel = dict(zip(idx.tolist(), _velocities(centre, idx), strict=True))
    np.testing.assert_allclose(vel[3], [0.5, 0.6])
    np.testing.assert_allclose(vel[5], [0.5, 0.075])
    np.testing.assert_allclose(vel[9], [0.5, -0.6])
    np.testing.assert_allclose(vel[10], [0.5, 0.35])
    np.testing.assert_allclose(vel[0], [0.5, 0.35])
    np.testing.assert_allclose(vel[15], [0.5, 0.75])
    np.testing.assert_array_equal(vel[12], [0.0, 0.0])
    np.testing.assert_array_equal(vel[14], [0.0, 0.0])


def test_a_ball_smeared_over_more_than_its_radius_is_said_and_its_scale_widened():
    from types import SimpleNamespace

    from bouncebayes.tracking import radius_warning
    from bouncebayes.tracking._edge import (
        SMEAR_RADII,
        SMEAR_REL_SD,
        SMEAR_SQ,
        UNCERTAIN_RADIUS,
        RadiusFit,
        radius_relative_sd,
        smear_radii,
    )

    # expected (by hand): exposure 0.9 of the interval, the ball 14.8 px a frame (a phone at
    # 120 fps), radius 10 px: smeared over 0.9 * 14.8 / 10 = 1.33 radii, where the rendered
    # radius came out 11-12 % too large at a stated 2.7-3.8 % (benchmarks/tracking_phone.py);
    # at exposure 0.5, 0.74 radii: SMEAR_SQ 0.74^2 in quadrature. A frame not found (NaN) is
    # skipped
    centre = np.column_stack([14.8 * np.arange(20.0), np.full(20, 50.0)])
    centre[7] = np.nan

    def fit(exposure):
        return RadiusFit(10.0, 0.02, 0.8, exposure, 1.0, tuple(range(9)), np.zeros((9, 2)))

    assert smear_radii(fit(0.9), centre) == pytest.approx(1.332)
    assert smear_radii(fit(0.5), centre) == pytest.approx(0.74) and smear_radii(None, centre) == 0
    plain = radius_relative_sd(10.0, 0.02, 0.8)
    assert plain < 0.05 and radius_relative_sd(10.0, 0.02, 0.8, smear=0.74) == pytest.approx(
        math.hypot(plain, SMEAR_SQ * 0.74**2))
    assert radius_relative_sd(10.0, 0.02, 0.8, smear=SMEAR_RADII) == SMEAR_REL_SD == 0.12
    smeared = SimpleNamespace(radius_fit=fit(0.9), centre=centre)
    said = radius_warning(smeared)  # type: ignore[arg-type]
    assert "moves 1.3 of its radius" in said and "+-12 %" in said and "--reference" in said
    # at 0.74 radii the smear's share (2.5 %) is over UNCERTAIN_RADIUS: said, with its share
    said = radius_warning(SimpleNamespace(radius_fit=fit(0.5), centre=centre))  # type: ignore
    assert "moves 0.74 of its radius" in said and "+-2.5 %" in said and "pixel" not in said
    # at 0.37 radii, 0.6 %: under it, not said for the smear
    assert SMEAR_SQ * smear_radii(fit(0.5), centre / 2) ** 2 < UNCERTAIN_RADIUS
    cal = Calibration.from_track(0.0256, SimpleNamespace(  # type: ignore[arg-type]
        radius_fit=fit(0.9), centre=centre, ball_radius=10.0, ball_radius_se=0.02))
    assert cal.relative_sd == pytest.approx(SMEAR_REL_SD)


def test_a_fast_ball_of_a_slow_motion_phone_clip_is_not_fitted_across_its_bounce():
    from render_pbr import Shot, Throw, render

    # expected: the renderer's mid-exposure centres. A phone's slow motion: 240 fps, the ball
    # 8.6 px a frame and its exposure half the interval. Before, the per-frame fits' pass
    # backwards predicted the last frame before the impact from the two after it, on the
    # rebound's line; its fit from there was kept, and the frames before it followed, up to
    # 16 px off (measured; 27 px on a 480 px wide clip), nothing flagged, and the kinematics
    # found no crossing of the flights
    shot = Shot(width=320, height=270, fps=240.0, radius_px=10.0, n_frames=26, surface_v=240.0,
                slope_deg=0.0, sigma_px=0.8, exposure=0.5, supersample=3, seed=3,
                throw=Throw(speed_in=3.0, angle_in=35.0, t_contact=0.05, x_contact=0.13))
    track = track_ball(render(shot))
    ok = track.trusted
    assert ok.sum() >= 24 and track.refined[ok].all()
    ok[12] = False  # the impact frame (t = 0.05 s), its exposure over the bounce: 0.89 px off
    error = np.hypot(*(track.centre[ok] - shot.true_centres()[ok]).T)
    assert error.max() < 0.5  # measured 0.23 px


def test_the_polar_sector_by_comparisons_is_the_one_atan2_gives():
    from bouncebayes.tracking._edge_kernel import SECTORS, sector_of

    # expected: the independent formula it replaces, floor((atan2(dv, du) + pi) / (2 pi / 24)),
    # on random offsets and on sectors' edges given exactly (the axes and the diagonals; an
    # edge from cos and sin, 6e-17 off the axis, can round either way)
    rng = np.random.default_rng(3)
    points = [*rng.normal(size=(5000, 2)), (1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-1, -1),
              (0, -1), (1, -1)]
    for du, dv in points:
        assert sector_of(du, dv) == int((math.atan2(dv, du) + math.pi) / (2 * math.pi)
                                        * SECTORS) % SECTORS


def test_the_run_of_misfit_sectors_left_out_reaches_one_past_each_end_and_is_bounded():
    from bouncebayes.tracking._edge_kernel import MISFIT_SECTOR, MISFIT_SECTORS, grow_run

    # expected, by hand: from the worst sector the run goes each way while the misfit is at
    # least half MISFIT_SECTOR, whatever its sign, and takes one sector more each side
    score = np.zeros(24)
    score[[3, 4, 5, 6]] = [-0.5, -0.6, 0.4, 0.5]
    score[7] = 0.6 * MISFIT_SECTOR
    score[8] = 0.4 * MISFIT_SECTOR
    drop = np.zeros(24, bool)
    assert grow_run(score, 4, drop)
    assert np.flatnonzero(drop).tolist() == [2, 3, 4, 5, 6, 7, 8]
    # round the circle: sector 0's run takes in 23
    drop = np.zeros(24, bool)
    assert grow_run(np.roll(score, -4), 0, drop)
    assert np.flatnonzero(drop).tolist() == [0, 1, 2, 3, 4, 22, 23]
    # a run longer than MISFIT_SECTORS in all leaves the sectors as they were
    drop = np.zeros(24, bool)
    drop[[12, 13, 14, 15]] = True
    assert not grow_run(score, 4, drop)
    assert drop.sum() == 4 and MISFIT_SECTORS < 11


def test_the_pixels_of_the_sectors_left_out_are_those_in_them():
    from bouncebayes.tracking._edge_kernel import SECTORS, in_sectors

    # expected, by hand: sector j holds atan2(dv, du) + pi from 15 j to 15 (j + 1) degrees
    # (sector_of), so a point at 7.5 + 15 j degrees of that lies in sector j
    angle = np.radians(7.5 + 15.0 * np.arange(SECTORS)) - np.pi
    du, dv = 4.0 * np.cos(angle), 4.0 * np.sin(angle)
    drop = np.zeros(SECTORS, bool)
    drop[[0, 5, 23]] = True
    assert np.flatnonzero(in_sectors(du, dv, drop)).tolist() == [0, 5, 23]


def test_a_logo_turning_near_the_rim_moves_neither_the_shared_blur_nor_the_centres():
    from render_pbr import render

    from bouncebayes.tracking import radius_warning

    # A dark spot near the rim (a logo, 0.5 rad, its centre 1.2 rad from the axis to the
    # camera) turning with a 10 px ball: the frames together, which share one shading, took
    # their blur from 0.77 to 1.54 px and the radius -15 % (the frames' median -2.0 %).
    # Expected: the frames' median kept (_edge.JOINT_BLUR_AGREE), the radius within 4 % and
    # two stated SDs (truth: the renderer's radius); -2.0 % so, and -0.9 % since the edge
    # model leaves out the rim's sectors the logo misfits (_edge.EDGE_MISFIT): within 1.5 %
    shot = pbr_shot(10.0, 0.7, 0.3, n_frames=90, t_contact=0.045, seed=1, spot=0.5)
    track = track_ball(render(shot))
    error = track.ball_radius / 10.0 - 1
    assert abs(error) < min(0.015, 2 * Calibration.from_track(shot.diameter_m, track).relative_sd)
    assert track.radius_fit.sigma < 1.0
    # and the per-frame fits followed the bite the logo takes out of the rim: the trusted
    # centres 0.715 px RMS from the renderer's (2.91 px at most), none flagged. With the rim's
    # sectors that misfit left out (_refine._fit_clean) measured 0.122 px (0.50 at most), and
    # the 20 frames where the logo could not be told from the rim flagged
    centres = track.centre[track.trusted] - shot.true_centres()[track.trusted]
    assert rms(centres) < 0.25
    assert 0 < (~track.trusted).sum() < 30
    # and said with the radius (20 of 90 flagged, _output.MISFIT_WARNING a fifth)
    assert "logo" in radius_warning(track)


@pytest.mark.parametrize("lighting", [
    {}, GLOSSY, dict(mark=0.3), DARK])
def test_a_ball_without_a_shadow_on_the_wall_gets_none(lighting):
    from render_pbr import Shot, Throw, render

    from bouncebayes.tracking import cast_message

    # side-lit, glossy, striped and dark 10 px balls with no shadow on the wall: none found
    # (the grid's gain 2-20 residual variances on such balls, CAST_GATE 15 on the median)
    kw = dict(SHADOW_SHOT, **lighting,
              throw=Throw(speed_in=2.0, angle_in=35.0, t_contact=0.03, x_contact=0.05))
    track = track_ball(render(Shot(**kw)))
    assert track.radius_fit.cast is None and cast_message(track) is None


@pytest.mark.parametrize("seed", [0, 2])
def test_a_blurred_small_ball_on_a_plain_wall_is_not_taken_for_a_larger_sharper_one(seed):
    # A dark 5 px ball blurred by 1.5 px on a plain wall: its coverage radius is 7.5 px, and a
    # 7.6 px disk blurred by 0.4 px with shading that brightens its rim towards the wall is a
    # second, worse minimum of the edge model's cost. The fit's starting grid took the coverage
    # radius' 0.8-1.25 and the pixels outside 0.65 of it (none inside a 5 px ball's rim):
    # measured radius +45 % (seed 0) and +53 % (seed 2) with a stated SD of 4 and 2.5 %. Now
    # measured -0.25 % and -2.4 % (stated 19 %). Truth: the renderer's radius.
    from render_pbr import render

    shot = pbr_shot(5.0, 1.5, 0.0, **{**DARK, "texture": 0.0}, seed=seed)
    track = track_ball(render(shot))
    assert np.nanmedian(track.radius) > 7.0  # the coverage radius: the trap is set
    fit = track.radius_fit
    cal = Calibration.from_ball_diameter(shot.diameter_m, track.ball_radius,
                                         track.ball_radius_se, fit.sigma, fit.method)
    err = cal.metres_per_px / shot.metres_per_px - 1.0
    assert abs(err) <= 0.05
    assert abs(err) <= 2 * cal.relative_sd
    assert abs(track.radius_fit.sigma - 1.5) <= 0.2


def _rms_about_mean(track, truth) -> float:
    """The trusted centres' RMS error per coordinate about its mean (px)."""
    ok = track.trusted
    err = track.centre[ok] - truth[ok]
    return rms(err - err.mean(axis=0)) / math.sqrt(2.0)


def test_a_larger_balls_centres_are_fitted_on_its_rim_every_frame(monkeypatch):
    # A side-lit 10 px ball over a textured wall (blur 0.7 px, exposure 30 %): the coverage
    # centroid follows the texture under the blurred rim, an error that drifts along the track;
    # the per-frame fit of the rim does not. Truth: the renderer's centres; the error about its
    # mean (a constant moves no velocity). Measured 0.017 px fitted (stated SD 0.031), 0.083 as
    # centroids (benchmarks/tracking_centres.py: median 0.028 against 0.083 over 48 bounces).
    from render_pbr import render

    shot = pbr_shot(10.0, 0.7, 0.3, seed=2)
    frames, truth = render(shot), shot.true_centres()
    track = track_ball(frames)
    assert track.refined[track.trusted].all()
    fitted = _rms_about_mean(track, truth)
    assert fitted < 0.04
    assert 0.5 * fitted < track.radius_fit.centre_sd < 3.0 * fitted
    no_refined_centres(monkeypatch)
    centroids = _rms_about_mean(track_ball(frames), truth)
    assert fitted < 0.4 * centroids


def test_a_striped_balls_centres_are_not_stated_better_than_they_are():
    # The same ball with a dark stripe painted on it, turning at 150 rad/s: the shading model
    # has no stripe, and the fitted centres err (truth: the renderer's centres, about their
    # mean) by 0.23-0.25 px here (seeds 2 and 1; the centroids' 0.15-0.16; over
    # benchmarks/tracking_centres.py's four striped bounces the fitted 0.23 px median against
    # the centroids' 0.48; 0.21 before one held a false shadow, 2026-11-29). Their stated SD, at least their
    # disagreement with the edge fits' centres, covers that: measured 0.28 and 0.30 px (the
    # formal errors alone 0.6-0.9x the true error on the benchmark's).
    from render_pbr import render

    shot = pbr_shot(10.0, 0.7, 0.3, seed=2, mark=0.25)
    frames, truth = render(shot), shot.true_centres()
    track = track_ball(frames)
    err = _rms_about_mean(track, truth)
    assert 0.1 < err < 0.4  # the stripe does pull them (the test can fail both ways)
    assert track.radius_fit.centre_sd >= 0.9 * err


def test_a_blurred_side_lit_balls_centroids_get_the_edge_fits_offset(monkeypatch):
    # Radius 10 px, blur 1.5 px, exposure 80 %, lit from the upper left: the coverage centroid
    # sits towards the lit side; the edge fits' median offset removes that unless the fitted
    # blur is more than CENTRE_FIT_BLUR of the radius (here it is 15.8 %; the limit was 15 %).
    # Truth: the renderer's centres. Measured RMS 0.213 px; 0.875 without the offset; the
    # centres fitted on the ball's rim every frame (which the tracker gives): 0.056 px.
    from render_pbr import render

    from bouncebayes.tracking import _quality

    shot = pbr_shot(10.0, 1.5, 0.8)
    frames, truth = render(shot), shot.true_centres()
    track = track_ball(frames)
    ok = track.trusted
    assert track.refined[ok].all() and rms(track.centre[ok] - truth[ok]) < 0.1
    no_refined_centres(monkeypatch)
    centroids = track_ball(frames)
    assert 0.15 < centroids.radius_fit.sigma / centroids.ball_radius <= 0.2
    assert not centroids.refined.any()
    assert rms(centroids.centre[ok] - truth[ok]) < 0.35
    monkeypatch.setattr(_quality, "CENTRE_FIT_BLUR", 0.0)
    raw = track_ball(frames)
    assert rms(raw.centre[ok] - truth[ok]) > 0.6


def test_the_coverage_radius_the_edge_model_replaces_was_biased():
    # the old estimate's bias (docs/tracking.md §1), kept as a check that the scenes above can fail: the median
    # coverage radius (edge_model=False) is off by more than the target on the first scene
    from render_pbr import render

    shot = pbr_shot(10.0, 0.7, 0.4)
    old = track_ball(render(shot), config=TrackerConfig(edge_model=False))
    assert abs(old.ball_radius / shot.radius_px - 1.0) > 0.02  # measured -7 %


def test_the_tone_curves_decode_as_their_standards():
    # closed forms: IEC 61966-2-1 decodes 0.5 to ((0.5 + 0.055) / 1.055)^2.4 = 0.21404, BT.709's
    # camera curve inverts 0.5 to (0.599 / 1.099)^(1 / 0.45) = 0.25959; and both invert
    # tests/render_pbr.py's encoders (written apart from the package) to rounding error
    from render_pbr import _encode

    from bouncebayes.tracking._tone import decode, decode_table

    assert decode(127.5, "srgb") / 255 == pytest.approx(0.214041, abs=1e-6)
    assert decode(127.5, "rec709") / 255 == pytest.approx(0.259589, abs=1e-6)
    assert decode(127.5, 2.2) / 255 == pytest.approx(0.5**2.2)
    x = np.linspace(0.0, 1.0, 1001)
    for curve in ("srgb", "rec709"):
        assert np.allclose(decode(255 * _encode(x, curve), curve), 255 * x, atol=1e-9)
    assert decode_table("linear") is None
    table = decode_table("srgb")
    assert table.dtype == np.uint8 and table[0] == 0 and table[255] == 255
    assert table[128] == 55 and np.all(np.diff(table.astype(int)) >= 0)


@pytest.mark.parametrize("value", ["sRGB", "gamma", 0.5, 5, True, [2.2]])
def test_a_tone_curve_not_known_is_refused(value):
    with pytest.raises(ValueError, match=r"`tone_curve` must be one of linear, srgb, rec709 "
                                         r"or a gamma from 1 to 4.*got"):
        TrackerConfig(tone_curve=value)
    assert TrackerConfig(tone_curve="2.2").tone_curve == 2.2
    assert TrackerConfig().tone_curve is None  # not given: taken as linear, and warned of


@pytest.mark.parametrize("tone, light", [("srgb", {}), ("rec709", DARK)],
                         ids=["srgb-bright", "rec709-dark"])
def test_the_scale_of_footage_stored_through_a_tone_curve(tone, light):
    # a 10 px ball blurred by 0.7 px, its frames stored through the camera's tone curve
    # (tests/render_pbr.py; truth: the renderer's radius). Taken as light, the blurred edge's
    # mixed pixels are off their share (a bright ball larger, a dark one smaller): measured
    # +2.16 % (sRGB, side-lit) and -4.00 % (BT.709, dark ball); decoded (tone_curve) -0.02 and
    # +0.14 %. The same scenes stored linearly: -0.07 / 0.00 % taken as light, -4.7 / +4.1 %
    # wrongly decoded
    from render_pbr import render

    shot = pbr_shot(10.0, 0.7, 0.0, tone=tone, seed=3, **light)
    frames = render(shot)
    taken = track_ball(frames).ball_radius / 10.0 - 1.0
    config = TrackerConfig(tone_curve=tone)
    decoded = track_ball(frames, config=config).ball_radius / 10.0 - 1.0
    assert abs(taken) > 0.015 and (taken > 0) == (tone == "srgb")
    assert abs(decoded) < 0.005
    # a background image given, in the camera's levels as the frames, is decoded with them:
    # the frames' median in stored levels gives the radius of the median of the decoded ones
    # (measured -0.005 / +0.29 % against -0.02 / +0.14 %; with it left in stored levels
    # -1.37 / -0.73 %)
    given = track_ball(frames, config=config, background=background_model(frames, 25))
    assert given.found.all()
    assert abs(given.ball_radius / 10.0 - 1.0 - decoded) < 0.003


@pytest.mark.parametrize("light, seed", [((-0.15, 0.25, 0.95), 6), ((0.0, 0.0, 1.0), 7)],
                         ids=["lit-from-above", "frontal-light"])
def test_the_papers_camera(tmp_path, capsys, light, seed):
    """224 x 64 px at 1000 fps, a 10 px ball, MJPEG (Casio EX-ZR100, paper §3). The frontal
    light (seed 7) is the clip of benchmarks/paper_camera.py whose radius came out +15 % (5.75
    px, a fitted blur of 0.2 px against the true 0.6), and its rebound speed's z -7.1 with the
    small-ball term of the radius' stated uncertainty before it was set from that benchmark
    (tracking/_edge.py); since the edge model's starts reach below the coverage radius it
    comes out 4.77 px (-4.6 %), z +0.44; the scale now comes from the small-ball fit's radius:
    +1.8 %, z +0.60 with its stated 2.7 %."""
    from render_pbr import Shot, Throw, render, write

    from bouncebayes.kinematics import fit_kinematics, read_trajectory
    from bouncebayes.tracking import radius_warning, write_track_files

    shot = Shot(width=224, height=64, radius_px=5.0, n_frames=120, surface_v=50.0,
                slope_deg=3.0, sigma_px=0.6, exposure=0.5, light=light,
                supersample=4, seed=seed, throw=Throw(speed_in=2.0, angle_in=35.0,
                                                      t_contact=0.05, x_contact=0.05))
    path = write(render(shot), tmp_path / "casio.avi", 1000.0, "MJPG")
    x1, y1, x2, y2 = shot.surface_points()
    video = track_video(path, fps=1000.0, surface=Surface.from_points((x1, y1), (x2, y2)))
    truth = shot.true_centres()
    r = shot.radius_px
    whole = ((truth[:, 0] >= r) & (truth[:, 0] <= shot.width - 1 - r)
             & (truth[:, 1] >= r) & (truth[:, 1] <= shot.height - 1 - r))
    tr = video.track
    assert tr.found[whole].all()  # found in every frame it is fully in
    ok = tr.trusted & whole
    assert ok.sum() >= 0.9 * whole.sum()
    # the target for the paper's camera, 0.15 px RMS (docs/tracking.md): measured 0.063 px
    # (seed 6; 0.103 before the small-ball fit's shadow columns, lit from 73 degrees) and 0.045
    # (seed 7) (0.19 px with the coverage centroid before the small-ball fit,
    # tracking/_refine.py); the velocities below are what the centres are for (measured z:
    # rebound speed -0.64 and +0.44, angle -1.80 and -0.22)
    assert tr.refined[ok].mean() > 0.9
    assert rms(tr.centre[ok] - truth[ok]) < 0.15
    written = write_track_files(video, tmp_path)
    record = json.loads(written["record"].read_text(encoding="utf-8"))
    assert record["per_frame"]["refined"] == tr.refined.astype(int).tolist()
    assert record["quality"]["refined_frames"] == int(tr.refined.sum())
    # the radius, and the scale, from the small-ball fit (tracking/_refine.py): measured
    # scale errors -0.5 % (seed 6) and +1.8 % (seed 7) against the renderer's radius, where the
    # edge model's radius gave -4.3 and +4.8 % (benchmarks/paper_camera.py, the same clips)
    assert record["ball"]["method"] == "small-ball fit"
    assert abs(video.calibration.metres_per_px / shot.metres_per_px - 1.0) < 0.02
    # a ball this small: the record and `track` say the scale is uncertain, and by how much
    # (the small-ball fit's systematic 0.13 px: 2.6 % here); not where the scale came from a
    # length in the scene
    assert radius_warning(tr) is not None
    assert record["ball"]["warning"] == radius_warning(tr)
    assert "give --reference" in record["ball"]["warning"]
    if seed == 7:
        surface = ",".join(f"{v:g}" for v in (x1, y1, x2, y2))
        # an MJPEG file scaled from the ball's diameter, its tone curve not given: warned
        # that it was taken as linear (tracking.tone_curve_warning); given, or scaled from a
        # length in the scene, not
        diameter = ["--ball-diameter", f"{shot.diameter_m}"]
        for scale, warned, toned in ((diameter, True, True),
                                     ([*diameter, "--tone-curve", "linear"], True, False),
                                     (["--reference", "0,0,100,0,0.256,0.0005"], False, False)):
            assert run_cli(["track", str(path), "--out", str(tmp_path / "cli"), "--fps",
                            "1000", "--surface", surface, *scale]) == 0
            printed = capsys.readouterr().out
            assert ("warning: the ball is" in printed) == warned, printed
            assert ("warning: the frames were taken as linear" in printed) == toned, printed
            kept = json.loads((tmp_path / "cli" / "casio.track.json").read_text("utf-8"))
            assert kept["tone_curve"] == ("linear" if "--tone-curve" in scale
                                          else "linear (not given)")
            assert kept["settings"]["tone_curve"] == kept["tone_curve"]
            assert (kept["tone_curve_warning"] is not None) == toned
    fit = fit_kinematics(read_trajectory(written["trajectory"]))
    speed_sd = math.hypot(fit.rebound_speed_se, fit.rebound_speed * fit.scale_rel_sd)
    assert abs(fit.rebound_speed - shot.throw.rebound_speed()) < 3 * speed_sd
    assert abs(fit.rebound_angle - shot.throw.rebound_angle()) < 3 * fit.rebound_angle_se


def test_a_rolling_shutters_rows_are_timed_by_their_readout(tmp_path):
    # tests/render_pbr.py reads row j of the 64 at k / fps + readout j / 64, readout = 1 ms (the
    # whole frame interval at 1000 fps, as a consumer camera's high-speed mode may): the ball
    # falls 1.42 px a frame (2.5 m/s at 25 deg, 1.6 mm/px), so a global shutter's times make
    # its speeds off by ~1.42 / 64 = 2.2 % to first order. Truth: the renderer's throw; the
    # scale exact (--reference), so that only the timing is tested. Measured: incidence
    # speed +2.11 % and rebound -1.34 % (5.7 SE) taken as a global shutter; +0.05 % (rebound)
    # and -0.13 % (incidence) with --readout
    from render_pbr import Shot, Throw, render

    from bouncebayes.kinematics import fit_kinematics, read_trajectory
    from bouncebayes.tracking import write_track_files

    shot = Shot(width=224, height=64, radius_px=8.0, n_frames=90, surface_v=56.0, slope_deg=0.0,
                sigma_px=0.5, supersample=4, seed=1, readout=0.001,
                throw=Throw(speed_in=2.5, angle_in=25.0, t_contact=0.04, x_contact=0.05))
    path = tmp_path / "rolling"  # lossless frames
    path.mkdir()
    for i, frame in enumerate(render(shot)):
        cv2.imwrite(str(path / f"{i:04d}.png"), frame)
    x1, y1, x2, y2 = shot.surface_points()
    reference = ((0.0, 0.0), (100.0, 0.0), 100.0 * shot.metres_per_px)
    errors = {}
    for readout in (0.0, 0.001):
        video = track_video(path, fps=1000.0, surface=Surface.from_points((x1, y1), (x2, y2)),
                            reference=reference, readout=readout)
        tr = video.track
        k = np.flatnonzero(tr.found)
        # each centre at its frame's time plus its row's share of the readout (closed form)
        np.testing.assert_allclose(video.trajectory.t, k / 1000.0 + readout * tr.centre[k, 1] / 64,
                                   rtol=0, atol=1e-12)
        files = write_track_files(video, tmp_path / f"out{readout}")
        fit = fit_kinematics(read_trajectory(files["trajectory"]))
        errors[readout] = ((fit.rebound_speed - shot.throw.rebound_speed()) / fit.rebound_speed_se,
                           fit.incidence_speed / shot.throw.speed_in - 1.0)
    assert errors[0.0][0] < -3 and errors[0.0][1] > 0.015  # a global shutter's times: off
    assert abs(errors[0.001][0]) < 2 and abs(errors[0.001][1]) < 0.005
    with pytest.raises(InputFileError, match="readout of 0.002 s is not from 0 to the frame "
                                             "interval, 0.001 s at 1000 frames/s"):
        track_video(path, fps=1000.0, readout=0.002)
    # `track --readout`: the same times in the trajectory file, the readout in the record
    out = tmp_path / "cli"
    assert run_cli(["track", str(path), "--out", str(out), "--fps", "1000", "--readout", "0.001",
                    "--surface", ",".join(f"{v:g}" for v in (x1, y1, x2, y2))]) == 0
    record = json.loads((out / "rolling.track.json").read_text("utf-8"))
    assert record["settings"]["readout_s"] == 0.001
    written = read_trajectory(out / "rolling.csv").t  # the rows the kinematics keep
    assert len(written) > 60
    assert np.abs(written[:, None] - video.trajectory.t[None, :]).min(axis=1).max() < 1e-9


def test_frames_the_ball_model_does_not_fit_are_flagged_and_left_out(noisy, tmp_path):
    from bouncebayes.kinematics import read_trajectory
    from bouncebayes.tracking import write_track_files

    scene, bounce, frames = noisy
    truth = true_centres(scene, bounce)
    post = int(truth[20, 0])  # a dark post in front of the ball's path, before the bounce
    frames = frames.copy()
    frames[:, :, post - 3:post + 3] = 30
    track = track_ball(frames)
    gap = np.abs(truth[:, 0] - post)
    behind = (gap < scene.radius_px - 2.0) & track.found  # it hides a good part of the ball
    clear = gap > scene.radius_px + 4.0  # it does not touch the ball
    assert behind.sum() >= 3
    assert track.flag[behind].mean() >= 0.8  # measured 1.0
    assert track.flag[clear].mean() <= 0.05  # measured 0
    # the flagged frames' centres are the ones pulled off (what the flag is for)
    bad = behind & track.flag
    assert rms(track.centre[bad] - truth[bad]) > 5 * rms(track.centre[clear] - truth[clear])
    video = track_video_from_frames(frames, tmp_path, surface_of(scene))
    files = write_track_files(video, tmp_path / "out")
    header, *rows = files["trajectory"].read_text().splitlines()
    assert header == "t,x,y,residual,visible,flag"
    assert sum(r.endswith(",1.0") for r in rows) == int(video.track.flag.sum())
    assert any("flagged by the tracker" in n for n in read_trajectory(files["trajectory"]).notes)
    record = json.loads(files["record"].read_text())
    assert record["quality"]["flagged"] == int(video.track.flag.sum()) > 0
    assert record["per_frame"]["flag"] == video.track.flag.astype(int).tolist()
    overlay = cv2.imread(str(files["overlay"]))
    magenta = (overlay[..., 0] > 200) & (overlay[..., 1] < 100) & (overlay[..., 2] > 200)
    assert magenta.sum() > 20  # flagged centres and the legend's swatch


def test_kinematics_leave_flagged_frames_out_and_say_so(noisy, tmp_path):
    from dataclasses import replace

    from bouncebayes.kinematics import fit_kinematics, read_trajectory
    from bouncebayes.tracking import write_track_files

    scene, bounce, frames = noisy
    video = track_video_from_frames(frames, tmp_path, surface_of(scene))
    # frames 10-14 displaced by 3 px and flagged, as the tracker flags a hidden ball
    centre, flag = video.track.centre.copy(), video.track.flag.copy()
    centre[10:15] += 3.0
    flag[10:15] = True
    track = replace(video.track, centre=centre, flag=flag)
    video = replace(video, track=track, trajectory=to_plane_frame(
        track, video.calibration, video.surface, scene.fps))
    files = write_track_files(video, tmp_path / "out")
    fit = fit_kinematics(read_trajectory(files["trajectory"]))
    assert any("5 row(s) flagged by the tracker (flag = 1) left out" in n for n in fit.notes)
    assert fit.n_before + fit.n_after <= int(video.track.found.sum()) - 5
    assert abs(fit.rebound_speed - bounce.rebound_speed()) < 3 * math.hypot(
        fit.rebound_speed_se, fit.rebound_speed * fit.scale_rel_sd)


def track_video_from_frames(frames, tmp_path, surface):
    folder = write_png_sequence(frames, tmp_path / "frames")
    return track_video(folder, fps=1000.0, surface=surface)


def test_calibration_and_surface_uncertainty_reach_the_kinematics(noisy, tmp_path):
    from bouncebayes.kinematics import read_trajectory
    from bouncebayes.tracking import write_track_files

    scene, _, frames = noisy
    folder = write_png_sequence(frames, tmp_path / "throw")
    video = track_video(folder, fps=1000.0)  # ball-diameter scale, detected surface
    assert 0 < video.calibration.relative_sd < 0.02
    # the detected surface's angle is within 3 of its stated SD of the rendered one
    # (video_helpers draws the plane at `inclination` clockwise on screen: angle -15 deg)
    sd = video.surface.angle_sd_deg
    assert 0 < sd < 0.2 and abs(video.surface.angle + scene.inclination) < 3 * sd + 1e-3
    files = write_track_files(video, tmp_path / "out")
    traj = read_trajectory(files["trajectory"])
    assert traj.scale_rel_sd == pytest.approx(video.calibration.relative_sd, rel=1e-3)
    assert traj.surface_angle_sd_deg == pytest.approx(sd, rel=1e-3)


def test_reference_precision_is_the_scales_uncertainty():
    cal = Calibration.from_reference((0, 0), (300, 400), 0.5, 0.001)
    assert cal.metres_per_px == pytest.approx(0.001) and cal.relative_sd == pytest.approx(0.002)
    assert Calibration.from_reference((0, 0), (3, 4), 0.5).relative_sd is None


def test_the_scales_uncertainty_follows_what_measured_the_radius():
    from bouncebayes.tracking._edge import (
        BLUR_PX3,
        SMALL_FIT_SYSTEMATIC_PX,
        edge_model_systematic_px,
    )

    # closed form: the radius' SE and the method's systematic error in quadrature, over it
    edge = Calibration.from_ball_diameter(0.0256, 5.0, 0.03, 0.6)
    small = Calibration.from_ball_diameter(0.0256, 5.0, 0.03, 0.6, "small-ball fit")
    assert edge.relative_sd == pytest.approx(math.hypot(0.03, edge_model_systematic_px(5.0, 0.6))
                                             / 5.0)
    assert small.relative_sd == pytest.approx(
        math.hypot(0.03, SMALL_FIT_SYSTEMATIC_PX, BLUR_PX3 * 0.6**3) / 5.0)
    assert small.metres_per_px == edge.metres_per_px == pytest.approx(0.0256 / 10.0)
    # the small-ball fit under a blur that is a large part of the radius: SMALL_FIT_BLURRED_REL
    # of it more, ramped over SMALL_FIT_BLURRED_FROM..TO of the radius (half-way: half of it)
    from bouncebayes.tracking._edge import (
        SMALL_FIT_BLURRED_FROM,
        SMALL_FIT_BLURRED_REL,
        SMALL_FIT_BLURRED_TO,
    )

    half = 5.0 * 0.5 * (SMALL_FIT_BLURRED_FROM + SMALL_FIT_BLURRED_TO)
    blurred = Calibration.from_ball_diameter(0.0256, 5.0, 0.03, half, "small-ball fit")
    assert blurred.relative_sd == pytest.approx(math.hypot(
        math.hypot(0.03, SMALL_FIT_SYSTEMATIC_PX, BLUR_PX3 * half**3) / 5.0,
        0.5 * SMALL_FIT_BLURRED_REL))
    beyond = Calibration.from_ball_diameter(0.0256, 5.0, 0.03, 1.5, "small-ball fit")
    assert beyond.relative_sd == pytest.approx(math.hypot(
        math.hypot(0.03, SMALL_FIT_SYSTEMATIC_PX, BLUR_PX3 * 1.5**3) / 5.0,
        SMALL_FIT_BLURRED_REL))
    # the frames fitted together with the blur free: their Cramer-Rao bound as the SE and
    # JOINT_FIT_SYSTEMATIC_REL of the radius in quadrature, whatever the blur
    from bouncebayes.tracking._edge import JOINT_FIT_SYSTEMATIC_REL

    joint = Calibration.from_ball_diameter(0.0256, 5.0, 0.03, 1.5, "frames' joint fit")
    assert joint.relative_sd == pytest.approx(math.hypot(0.03 / 5.0, JOINT_FIT_SYSTEMATIC_REL))
    with pytest.raises(ValueError, match=r"`method` must be one of 'edge model', 'small-ball "
                                         r"fit', \"frames' joint fit\"; got 'coverage'"):
        Calibration.from_ball_diameter(0.0256, 5.0, 0.03, 0.6, "coverage")
    # from a track: its radius, SE, fitted blur and method, and the frames' coding (the same
    # closed form with those fields given one by one)
    from types import SimpleNamespace

    from bouncebayes.tracking._edge import compression_px

    from bouncebayes.tracking._edge import FOREIGN_REL_SD, depth_change

    fit = SimpleNamespace(sigma=0.6, method="small-ball fit", foreign=0.0, frames=(), radii=(),
                          exposure=0.0, radius=5.0)  # no smear (_edge.smear_radii)
    track = SimpleNamespace(ball_radius=5.0, ball_radius_se=0.03, radius_fit=fit,
                            centre=np.zeros((0, 2)))
    coded = Calibration.from_track(0.0256, track, None, 0.05)
    assert coded.metres_per_px == small.metres_per_px
    rel = math.hypot(0.03, SMALL_FIT_SYSTEMATIC_PX, BLUR_PX3 * 0.6**3,
                     compression_px(None, 0.05)) / 5.0
    assert coded.relative_sd == pytest.approx(rel)
    # sides of the rim left out in every frame fitted (a lamp's shadow): FOREIGN_REL_SD more
    shadowed = SimpleNamespace(**{**vars(track), "radius_fit": SimpleNamespace(
        **{**vars(fit), "foreign": 1.0})})
    assert Calibration.from_track(0.0256, shadowed, None, 0.05).relative_sd == \
        pytest.approx(math.hypot(rel, FOREIGN_REL_SD))
    # the ball's picture growing 3 % over the frames fitted (it comes closer): half of it more
    frames = tuple(range(0, 90, 10))
    closer = SimpleNamespace(**{**vars(track), "radius_fit": SimpleNamespace(**{
        **vars(fit), "frames": frames,
        "radii": tuple(5.0 * (1.0 + 0.03 * k / 80.0) for k in frames)})})
    growth = depth_change(frames, closer.radius_fit.radii)[0]
    assert growth == pytest.approx(0.03, rel=0.02)
    assert Calibration.from_track(0.0256, closer, None, 0.05).relative_sd == \
        pytest.approx(math.hypot(rel, 0.5 * growth))
    unfitted = Calibration.from_track(0.0256, SimpleNamespace(ball_radius=5.0,
                                                              ball_radius_se=0.03,
                                                              radius_fit=None,
                                                              centre=np.zeros((0, 2))))
    assert unfitted.relative_sd == pytest.approx(
        math.hypot(0.03, edge_model_systematic_px(5.0, None)) / 5.0)


def test_the_blurs_shape_term_is_a_ramp_in_blur_over_radius():
    from bouncebayes.tracking._edge import (
        BLUR_PX3,
        SMALL_BALL_PX5,
        SYSTEMATIC_PX,
        edge_model_systematic_px,
        psf_shape_px,
    )

    # closed form: 6 % of the radius, ramped from a fitted blur of 7 % of it to 12 %
    assert psf_shape_px(10.0, 0.7) == 0.0
    assert psf_shape_px(10.0, 0.95) == pytest.approx(0.06 * 10.0 * 0.5)
    assert psf_shape_px(10.0, 1.5) == psf_shape_px(10.0, 3.0) == pytest.approx(0.6)
    assert psf_shape_px(10.0, None) == 0.0
    assert edge_model_systematic_px(10.0, 0.95) == pytest.approx(math.hypot(
        SYSTEMATIC_PX + BLUR_PX3 * 0.95**3 + SMALL_BALL_PX5 / 10.0**4, 0.3))


def test_the_renderers_out_of_focus_psf_has_the_stated_sd():
    from render_pbr import _disk_kernel

    # closed form: a uniform disk of radius R has a variance R^2 / 4 per axis; the kernel is
    # the disk's coverage of each cell (sampled 8 x 8), whose second moment about the cells'
    # centres is R^2 / 4 + 0.12-0.13 cell^2 (measured: the rim's partly covered cells; at 4x
    # supersampling 0.008 px^2, 0.8 % of the variance of a disk of SD 1 px)
    for radius in (4.0, 8.0, 12.0):
        k = _disk_kernel(radius).astype(float)
        n = k.shape[0] // 2
        y, x = np.mgrid[-n:n + 1, -n:n + 1]
        assert k.sum() == pytest.approx(1.0, rel=1e-6)
        assert float((k * x).sum()) == pytest.approx(0.0, abs=1e-9)
        assert 0.0 < float((k * x * x).sum()) - radius**2 / 4 < 0.15


def test_a_ball_out_of_focus_gets_an_uncertainty_that_covers_it():
    from render_pbr import Shot, Throw, render

    from bouncebayes.tracking._output import radius_warning

    # a lens out of focus: the PSF a uniform disk (radius 2 px, SD 1 px per axis), not the
    # Gaussian of the edge model; a side-lit 10 px ball (the scene of
    # benchmarks/tracking_accuracy.py, seed 3). The edge model's radius is off by +5.7 %
    # (here the metres per pixel: -5.4 %; -1.4 % since the blurred ball's frames are fitted
    # together, 2026-11-28); without the blur's shape term the stated SD was 1.8 % (z 3.1),
    # with it 4.6 %
    mpp = 0.0256 / 20.0
    shot = Shot(width=160, height=100, radius_px=10.0, n_frames=90, slope_deg=0.0,
                surface_v=92.0, sigma_px=1.0, psf="disk", supersample=4, seed=3,
                throw=Throw(speed_in=1.5 * mpp * 1000.0 / 0.8, angle_in=50.0, t_contact=0.045,
                            x_contact=80.0 * mpp))
    track = track_ball(render(shot))
    fit = track.radius_fit
    cal = Calibration.from_ball_diameter(shot.diameter_m, track.ball_radius,
                                         track.ball_radius_se, fit.sigma, fit.method)
    err = cal.metres_per_px / shot.metres_per_px - 1.0
    assert cal.relative_sd > 0.03  # the blur's shape term: can fail
    assert abs(err) <= 2.0 * cal.relative_sd
    assert "out of focus" in radius_warning(track)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_rebound_speed_z_scores_of_a_rendered_campaign(seed, tmp_path):
    # one campaign, one calibration per video from the ball's edge; z with the stated
    # standard error and the scale's relative SD (a shared systematic in the inference)
    from bouncebayes.kinematics import fit_kinematics, read_trajectory
    from bouncebayes.tracking import write_track_files

    scene, bounce = Scene(seed=seed, **NOISY), Bounce(speed_in=1.8 + 0.2 * seed)
    folder = write_png_sequence(render(scene, bounce), tmp_path / f"throw{seed}")
    x1, y1, x2, y2 = scene.surface_points()
    video = track_video(folder, fps=1000.0, surface=Surface.from_points((x1, y1), (x2, y2)))
    fit = fit_kinematics(read_trajectory(write_track_files(video, tmp_path)["trajectory"]))
    sd = math.hypot(fit.rebound_speed_se, fit.rebound_speed * fit.scale_rel_sd)
    assert abs(fit.rebound_speed - bounce.rebound_speed()) < 3 * sd


def test_run_writes_the_same_tracking_record_as_track(noisy, tmp_path, capsys):
    from types import SimpleNamespace

    from bouncebayes.pipeline import _track_videos

    scene, _, frames = noisy
    data = tmp_path / "videos"
    data.mkdir()
    write_video(frames, data / "throw.avi", 1000.0)
    stage = tmp_path / "stage"
    experiment = SimpleNamespace(ball=SimpleNamespace(diameter=scene.ball_diameter))
    folder = _track_videos(data, experiment, stage, print, {"fps": None, "surface": None,
                                                            "tone_curve": None}, False)
    run_record = json.loads((folder / "throw.track.json").read_text())
    x1, y1, x2, y2 = scene.surface_points()
    assert run_cli(["track", str(data / "throw.avi"), "--out", str(tmp_path / "out")]) == 0
    track_record = json.loads((tmp_path / "out" / "throw.track.json").read_text())
    track_record.pop("provenance")
    assert set(run_record) == set(track_record)
    for key in ("calibration", "surface", "ball", "quality", "gravity", "tone_curve",
                "tone_curve_warning"):
        assert run_record[key] == track_record[key]
    assert run_record["calibration"]["relative_sd"] > 0
    assert (stage / "tracking" / "throw.overlay.png").exists()


@pytest.mark.parametrize("quality", [25, 55, 90, 100])
def test_the_jpeg_quality_of_jpeg_frames_is_read(quality, tmp_path):
    from bouncebayes.tracking._video import jpeg_quality

    # expected: the quality libjpeg (through OpenCV) was asked to encode at; its tables are
    # the IJG table scaled (T.81 Annex K.1), which is what jpeg_quality compares them with
    frame = np.random.default_rng(1).integers(0, 256, (48, 64), dtype=np.uint8)
    folder = tmp_path / "frames"
    folder.mkdir()
    for k in range(3):
        cv2.imwrite(str(folder / f"f{k}.jpg"), frame, [cv2.IMWRITE_JPEG_QUALITY, quality])
    assert jpeg_quality(folder) == pytest.approx(quality, abs=0.5)


def test_the_jpeg_quality_of_a_stream_is_its_frames_median(tmp_path):
    from bouncebayes.tracking._video import jpeg_quality

    # three JPEG frames at qualities 40, 40, 70 between bytes of a container (with a stray
    # FF D8 FF that starts no JPEG image): the median, 40; an MJPEG file of OpenCV's writer is
    # read (a quality, whatever its encoder's tables); frames that are not JPEG-coded (PNG,
    # MPEG-4) and a JPEG cut inside its table give none
    frame = np.random.default_rng(2).integers(0, 256, (48, 64), dtype=np.uint8)
    jpg = [cv2.imencode(".jpg", frame, [cv2.IMWRITE_JPEG_QUALITY, q])[1].tobytes()
           for q in (40, 40, 70)]
    (tmp_path / "stream.avi").write_bytes(b"RIFF\xff\xd8\xff\x00junk" + b"00dc".join(jpg))
    assert jpeg_quality(tmp_path / "stream.avi") == pytest.approx(40.0, abs=0.5)
    (tmp_path / "cut.avi").write_bytes(jpg[0][:30])
    assert jpeg_quality(tmp_path / "cut.avi") is None
    mjpg = write_video(np.stack([frame] * 5), tmp_path / "m.avi", 1000.0, "MJPG")
    assert 1.0 <= jpeg_quality(mjpg) <= 100.0
    assert jpeg_quality(write_video(np.stack([frame] * 5), tmp_path / "m.mp4", 1000.0,
                                    "mp4v")) is None
    assert jpeg_quality(write_png_sequence([frame] * 2, tmp_path / "png")) is None
    assert jpeg_quality(tmp_path / "missing.avi") is None


def test_strongly_compressed_frames_get_a_warning(tmp_path, capsys):
    from render_pbr import Shot, render

    from bouncebayes.tracking import compression_warning, read_frames

    # a short clip whose frames are JPEG files at quality 40 (a rendered 10 px ball came out
    # +7.6 % there, docs/tracking.md §3): the record and `track` say so; at 90 nothing is said
    shot = Shot(width=120, height=80, radius_px=8.0, n_frames=30, surface_v=72.0,
                slope_deg=0.0, sigma_px=0.5, supersample=3, seed=4)
    for quality in (40, 90):
        folder = tmp_path / f"q{quality}"
        folder.mkdir()
        for k, f in enumerate(render(shot)):
            cv2.imwrite(str(folder / f"f{k:03d}.jpg"), f, [cv2.IMWRITE_JPEG_QUALITY, quality])
        source = read_frames(folder, fps=1000.0)
        assert source.jpeg_quality == pytest.approx(quality, abs=0.5)
        said = compression_warning(source)
        assert (said is not None) == (quality == 40)
        if quality == 40:
            assert "quality ~40" in said and "--reference" in said
            out = tmp_path / "out"
            assert run_cli(["track", str(folder), "--out", str(out), "--fps", "1000",
                            "--surface", "0,72,100,72"]) == 0
            assert f"warning: {said}" in capsys.readouterr().out
            record = json.loads((out / "q40.track.json").read_text())
            assert record["jpeg_quality"] == pytest.approx(40.0)
            assert record["compression_warning"] == said
            # the stated scale SD holds the compression's 0.3 px (a quality below 60: full)
            ball = record["ball"]
            assert "allows 0.3 px of the ball's radius" in said
            assert record["calibration"]["relative_sd"] * ball["radius_px"] >= 0.3


def test_a_video_files_bits_per_pixel_are_read_and_a_low_rate_gets_a_warning(tmp_path):
    import dataclasses

    from bouncebayes.tracking import compression_warning, read_frames

    # expected: the file's size in bits over its frames' pixels (closed form); none for a
    # folder of frames. An MPEG-4 file of fewer than 0.1 bits per pixel gets the warning, with
    # the compression's share of the stated uncertainty (CODEC_PX at 0.05: 0.4 px); one of 0.5
    # bits per pixel, or JPEG-coded frames of a known quality, none for their rate
    frames = np.random.default_rng(3).integers(0, 256, (6, 48, 64), dtype=np.uint8)
    mp4 = write_video(frames, tmp_path / "v.mp4", 1000.0, "mp4v")
    source = read_frames(mp4)
    assert source.bits_per_pixel == pytest.approx(8.0 * mp4.stat().st_size / frames.size)
    assert read_frames(write_png_sequence(list(frames), tmp_path / "png"),
                       fps=1000.0).bits_per_pixel is None
    low = dataclasses.replace(source, bits_per_pixel=0.05)
    said = compression_warning(low)
    assert said is not None and "0.05 bits per pixel" in said and "0.4 px" in said
    assert "--reference" in said
    assert compression_warning(dataclasses.replace(source, bits_per_pixel=0.5)) is None
    assert compression_warning(dataclasses.replace(low, jpeg_quality=90.0)) is None


def test_the_codec_term_is_linear_in_the_log_of_the_bits_per_pixel():
    """Closed form of CODEC_PX at CODEC_BITS: linear in log(bits) between the knots, flat
    beyond (none from 0.3 bits per pixel up), none where the rate is not known; the JPEG
    quality, where read, decides instead."""
    from bouncebayes.tracking._edge import (
        CODEC_BITS,
        CODEC_PX,
        compression_px,
        edge_model_systematic_px,
        radius_relative_sd,
    )

    for bits, px in zip(CODEC_BITS, CODEC_PX, strict=True):
        assert compression_px(None, bits) == pytest.approx(px)
    assert compression_px(None, 1.0) == 0.0 and compression_px(None, 8.0) == 0.0
    assert compression_px(None, 0.01) == pytest.approx(CODEC_PX[0])
    assert compression_px(None, math.sqrt(0.1 * 0.3)) == pytest.approx(0.15)
    assert compression_px(None, None) == 0.0 and compression_px(None, 0.0) == 0.0
    assert compression_px(90.0, 0.01) == 0.0
    # in quadrature with the scatter and the edge model's systematic error
    sd = radius_relative_sd(10.0, 0.05, 0.7, bits_per_pixel=0.05)
    expected = math.hypot(0.05, edge_model_systematic_px(10.0, 0.7), 0.4) / 10.0
    assert sd == pytest.approx(expected)


def test_the_compression_term_is_a_ramp_in_jpeg_quality():
    """Closed form of COMPRESSION_PX's ramp: none from quality 80 up and where the quality is
    not read, full from 60 down, linear between; in quadrature with the other terms."""
    from bouncebayes.tracking._edge import (
        COMPRESSION_PX,
        compression_px,
        edge_model_systematic_px,
        radius_relative_sd,
    )

    assert compression_px(None) == 0.0 and compression_px(80.0) == 0.0
    assert compression_px(95.0) == 0.0 and compression_px(60.0) == COMPRESSION_PX
    assert compression_px(30.0) == COMPRESSION_PX
    assert compression_px(70.0) == pytest.approx(COMPRESSION_PX / 2)
    plain = radius_relative_sd(10.0, 0.02, 0.5)
    coded = radius_relative_sd(10.0, 0.02, 0.5, jpeg_quality=50.0)
    assert coded == pytest.approx(math.hypot(0.02, edge_model_systematic_px(10.0, 0.5),
                                             COMPRESSION_PX) / 10.0)
    assert plain == pytest.approx(math.hypot(0.02, edge_model_systematic_px(10.0, 0.5)) / 10.0)


def test_bad_calibration_input_is_one_line_naming_the_option(tmp_path):
    with pytest.raises(ValueError, match=r"`--reference` 1,2,3,4,0: `reference length` must be "
                                         r"a finite number > 0 m"):
        run_cli(["track", "a.avi", "--out", str(tmp_path), "--reference", "1,2,3,4,0"])
    with pytest.raises(ValueError, match=r"`--reference` 0,0,3,4,1,-1: `reference length SD`"):
        run_cli(["track", "a.avi", "--out", str(tmp_path), "--reference", "0,0,3,4,1,-1"])


@pytest.mark.parametrize("z", [-4.0, -1.0, 0.0, 0.7, 3.0, 12.0])
def test_the_blurred_limb_is_the_gaussian_moment(z):
    from scipy.integrate import quad

    from bouncebayes.tracking._edge import _sqrt_table

    zs, g = _sqrt_table()
    # independent: E[sqrt(z + Z)_+] by adaptive quadrature of the normal density
    expected, _ = quad(lambda t: math.sqrt(max(z + t, 0.0)) * math.exp(-t * t / 2)
                       / math.sqrt(2 * math.pi), -z, 40.0)
    assert float(np.interp(z, zs, g)) == pytest.approx(expected, rel=1e-5, abs=1e-9)


@pytest.mark.parametrize("s", [0.3, 0.7, 1.5, 3.0])
def test_the_shadow_columns_are_the_blurred_shadow_of_a_lambert_sphere(s):
    from scipy.integrate import quad

    from bouncebayes.tracking._edge import SHADOW_NODES, _shadow_numpy

    # independent: adaptive quadrature of N(w; uu, s^2) min(0, n . L) (and n_z times it) over
    # the depth w inside the rim, n the sphere's normal at w along the polar angle t
    r, az, el = 10.0, 0.3, 0.5
    lz = math.sin(el)
    for uu in np.linspace(-3.0, 6.0, 10):
        for t in np.linspace(az - 1.0, az + 4.0, 9):  # the lit side too (zero there)
            got = _shadow_numpy(np.array([uu]), np.array([s]), r, np.array([math.cos(t)]),
                                np.array([math.sin(t)]), az, el, SHADOW_NODES)[0]
            a = math.cos(el) * math.cos(t - az)

            def f(w, j, uu=uu, a=a):
                nz = math.sqrt(max(w * (2 * r - w), 0.0)) / r
                dens = math.exp(-0.5 * ((w - uu) / s) ** 2) / (s * math.sqrt(2 * math.pi))
                return dens * min(0.0, a * (1 - w / r) + lz * nz) * (nz if j else 1.0)

            for j in range(2):
                expected = quad(f, 0.0, r, args=(j,), epsabs=1e-12, limit=400,
                                points=[x for x in (uu,) if 0 < x < r])[0]
                # the quadrature's 12 nodes and the Gaussian cut at 4 s: within 1e-4
                assert got[j] == pytest.approx(expected, abs=1e-4)
    assert _shadow_numpy(np.array([1.0]), np.array([s]), r, np.array([math.cos(az + 3.0)]),
                         np.array([math.sin(az + 3.0)]), az, el, SHADOW_NODES)[0, 0] < -0.05


@pytest.mark.parametrize("upper", [5.0, 1.2])
def test_the_joint_fits_levenberg_marquardt_is_scipys_least_squares(upper):
    from scipy.optimize import least_squares

    from bouncebayes.tracking._edge import _bounded_lm

    # independent: SciPy's bounded least squares on the same problem, a decaying exponential
    # plus an offset with noise, the rate free (upper 5: the minimum inside) or held by its
    # bound (upper 1.2 below the best rate, ~1.5)
    rng = np.random.default_rng(4)
    t = np.linspace(0.0, 4.0, 200)
    y = 3.0 * np.exp(-1.5 * t) + 0.5 + rng.normal(0.0, 0.02, t.size)

    def fun(p):
        return p[0] * np.exp(-p[1] * t) + p[2] - y

    def fun_jac(p):
        e = np.exp(-p[1] * t)
        return fun(p), np.column_stack([e, -p[0] * t * e, np.ones_like(t)])

    lo, hi = np.array([0.0, 0.1, -1.0]), np.array([10.0, upper, 2.0])
    x0 = np.array([1.0, 0.5, 0.0])
    x, cost, status = _bounded_lm(fun_jac, x0, lo, hi, 0.05, 1e-10, 1e-12, 200)
    ref = least_squares(fun, x0, jac=lambda p: fun_jac(p)[1], bounds=(lo, hi), xtol=1e-12,
                        ftol=1e-14, gtol=1e-14)
    assert status > 0
    np.testing.assert_allclose(x, ref.x, rtol=0, atol=1e-5)
    assert cost == pytest.approx(ref.cost, rel=1e-8)
    if upper < 1.5:
        assert x[1] == pytest.approx(upper)


def test_the_exact_columns_are_the_disks_functions_blurred_in_two_dimensions():
    from bouncebayes.tracking._edge import _design_numpy, _Pixels

    # independent: each column's function of the sphere's normal on a 10 px disk (1, n_x,
    # n_y, n_z, n_x n_y, n_x^2 - n_y^2, n_x n_z, n_y n_z, n_z^2, cos m t and sin m t for m = 2,
    # 3, 4), drawn on a grid 8x finer than the pixels, blurred by OpenCV's Gaussian (sigma
    # 1.5 px) and averaged over each pixel. The model stands the pixel's box in with a
    # Gaussian of variance 1/12 (~3e-4 of a column here); the columns blurred along the
    # radius only were off by up to 13 % (n_x n_z) and 40 % (cos 4t) of their largest value
    sub, n, r, sigma, cx, cy = 8, 48, 10.0, 1.5, 24.3, 23.6
    grid = (np.arange(n)[:, None] + (np.arange(sub) + 0.5) / sub - 0.5).ravel()
    uu, vv = np.meshgrid(grid, grid)
    du, dv = uu - cx, vv - cy
    rho = np.hypot(du, dv)
    cover = np.clip((r - rho) * sub + 0.5, 0.0, 1.0)
    nx, ny = du / r, dv / r
    nz = np.sqrt(np.clip(1 - nx * nx - ny * ny, 0.0, None))
    t = np.arctan2(dv, du)
    functions = [np.ones_like(nx), nx, ny, nz, 2 * nx * ny, nx * nx - ny * ny, nx * nz, ny * nz,
                 nz * nz] + [f(m * t) for m in (2, 3, 4) for f in (np.cos, np.sin)]

    def optics(hi):
        hi = cv2.GaussianBlur(hi, (0, 0), sigma * sub, borderType=cv2.BORDER_REFLECT)
        return hi.reshape(n, sub, n, sub).mean(axis=(1, 3))

    pv, pu = np.mgrid[0:n, 0:n].astype(float)
    near = (np.hypot(pu - cx, pv - cy) > 5.0) & (np.hypot(pu - cx, pv - cy) < 15.0)
    m = int(near.sum())

    def full(x):
        return np.full(m, x)

    px = _Pixels(pu[near], pv[near], full(0.0), full(0.0), full(0.0), full(0.0), full(cx),
                 full(cy), full(1.0), full(0.0), full(0.0), np.zeros(m, np.intp), 1, full(1.0),
                 full(0.0))
    q = np.array([r, sigma, 0.0, 0.0, 0.5 * math.pi])
    exact, _ = _design_numpy(q, px, exact=True)
    radial, _ = _design_numpy(q, px)
    worst_radial = 0.0
    for j, f in enumerate(functions):
        expected = optics(cover * f)[near]
        top = np.abs(expected).max()
        np.testing.assert_allclose(exact[:, j], expected, rtol=0, atol=1e-3 * top)
        worst_radial = max(worst_radial, np.abs(radial[:, j] - expected).max() / top)
    assert worst_radial > 0.05  # the comparison can tell the two apart


def _edge_pixels(n_frames: int, seed: int = 3):
    from bouncebayes.tracking._edge import _Pixels

    # pixels 4-14 px from a centre near (20.3, 19.7), a ball of radius ~10 px, on n_frames
    # frames whose centres differ; random grey levels, background and weights
    rng = np.random.default_rng(seed)
    n = 500
    frame = rng.integers(0, n_frames, n)
    cx, cy = 20.3 + 0.4 * frame, 19.7 - 0.3 * frame
    ang, rad = rng.uniform(0, 2 * np.pi, n), rng.uniform(4, 14, n)
    # the background's gradient: up to 10 grey levels per px (a textured wall's, blurred); its
    # variance 0-0.5 of the frame's noise (a median of 3 or more frames)
    return _Pixels(cx + rad * np.cos(ang), cy + rad * np.sin(ang), rng.uniform(0, 255, n),
                   rng.uniform(0, 255, n), rng.uniform(-10, 10, n), rng.uniform(-10, 10, n),
                   cx, cy, np.full(n, 0.6), np.full(n, 0.8),
                   np.full(n, 1.7), frame, n_frames, rng.uniform(0.5, 1, n),
                   rng.uniform(0, 0.5, n))


@pytest.mark.parametrize("exact", [False, True])
def test_the_compiled_edge_model_is_the_numpy_one(exact):
    from bouncebayes.tracking._edge import _design_numpy, _residual

    # independent: the NumPy reference of the same design matrix (_edge._design_numpy) and
    # the linear coefficients by NumPy (LU) with the same small ridge, two frames (the centres held)
    # and one (the centre shifted), the blur, exposure and smear across the range the fits use;
    # the columns blurred along the radius and (exact) in two dimensions
    for n_frames in (2, 1):
        px = _edge_pixels(n_frames)
        # (r, sigma, exposure, the light's azimuth and elevation): a shadow on the rim, and
        # none (lit from the camera)
        for q in ((10.0, 0.7, 0.5, 2.2, 0.6), (5.0, 1.5, 0.0, -0.5, 0.2),
                  (15.0, 0.05, 1.0, 1.0, 0.5 * math.pi)):
            ref = px
            if n_frames == 1:  # the centre moved by (0.2, -0.1) px
                ref = px._replace(cx=px.cx + 0.2, cy=px.cy - 0.1)
                got = _residual(np.array([px.cx[0] + 0.2, px.cy[0] - 0.1, *q]), px, exact)
            else:
                got = _residual(np.array(q), px, exact)
            a, fixed = _design_numpy(np.array(q), ref, exact)
            # each residual over its SD, the background's variance where it shows (1 - step;
            # the design's first column is the step)
            w = ref.weight / np.sqrt(1.0 + ref.kappa * (1.0 - a[:, 0]) ** 2)
            y = (ref.grey - fixed) * w
            aw = a * w[:, None]
            ata = aw.T @ aw
            ata.flat[:: len(ata) + 1] += 1e-9 * (np.trace(ata) / len(ata) + 1.0)  # its ridge
            beta = np.linalg.solve(ata, aw.T @ y)
            np.testing.assert_allclose(got, y - aw @ beta, rtol=0, atol=1e-8)


@pytest.mark.parametrize("exact", [False, True])
@pytest.mark.parametrize("q", [(20.3, 19.7, 10.0, 0.7, 0.5, 2.2, 0.6),
                               (20.1, 19.9, 9.0, 1.5, 0.05, -0.5, 0.2),
                               (20.4, 19.5, 11.0, 0.3, 1.0, 1.0, 0.9)])
def test_the_edge_models_jacobian_is_the_derivative_of_its_residual(q, exact):
    from bouncebayes.tracking._edge import _evaluate, _residual

    # expected: central differences of the same residual (_residual: the compiled model with
    # the linear coefficients solved), steps 1e-7 (centre, radius), 1e-8 (blur), 1e-5 (the
    # exposure's column is ~100x smaller: rounding). The limb's table is linearly interpolated
    # (kinks every 0.01 in z), so where a pixel's z crosses a kink within the step the
    # differences are off there and, through the linear coefficients, a little everywhere;
    # they converge to the Jacobian as the step shrinks (step 1e-5 to 1e-8: the largest
    # difference falls from ~2e-3 to ~7e-5 of the column's largest entry); so is the exact
    # columns' table of Bessel functions (kinks every 0.005 in the argument)
    # the grey levels: the model's at q plus noise (with random ones the linear coefficients
    # of the two near-collinear shadow columns reach thousands and magnify the table's kinks
    # a hundredfold), evaluated a little away from q
    px = _model_frame(q, 3.0)
    q = np.array(q) + np.array([0.1, -0.1, 0.2, 0.1, 0.1, 0.1, 0.1])
    for free in (np.ones(7, bool), np.array([1, 1, 1, 0, 0, 0, 0], bool)):
        res, jac = _evaluate(q, px, free, True, exact)
        np.testing.assert_array_equal(res, _residual(q, px, exact))
        assert jac.shape == (px.u.size, free.sum())
        for col, k in enumerate(np.flatnonzero(free)):
            e = np.zeros(7)
            e[k] = (1e-7, 1e-7, 1e-7, 1e-8, 1e-5, 1e-7, 1e-7)[k]
            fd = (_residual(q + e, px, exact) - _residual(q - e, px, exact)) / (2 * e[k])
            scale = np.abs(fd).max()
            assert scale > 0.1  # every parameter moves the residual
            # (exact: the quadrature's own error, ~3e-6 of a column, moves with the blur and
            # radius, which the Jacobian of the integral leaves out: up to 3.4e-4 at a pixel)
            np.testing.assert_allclose(jac[:, col], fd, rtol=0,
                                       atol=(1e-3 if exact else 3e-4) * scale)
            assert np.median(np.abs(jac[:, col] - fd)) < 5e-5 * scale


def _fit_frame(px, q0, lo, hi, max_nfev=200, tol=1e-12):
    from bouncebayes.tracking._edge import (RIM_ORDER, _bessel_table, _hankel_nodes, _nodes,
                                            _sqrt_table)
    from bouncebayes.tracking._edge_kernel import fit_frame

    zt, gt = _sqrt_table()
    return fit_frame(np.array(q0, float), np.ones(7, bool), np.array(lo, float),
                     np.array(hi, float), 0.05, tol, tol, max_nfev, px.u, px.v, px.dir_u,
                     px.dir_v, px.speed, px.frame, px.n_frames, px.weight, px.kappa, px.grey,
                     px.bg, px.gbu, px.gbv, float(zt[0]), float(zt[1] - zt[0]), gt, _nodes(),
                     RIM_ORDER, False, _hankel_nodes(), *_bessel_table())


def _model_frame(q, noise: float, seed: int = 5):
    """One frame's pixels whose grey levels are the edge model's at ``q = (cx, cy, r, sigma,
    exposure, az, el)`` (NumPy reference design, chosen linear coefficients), plus Gaussian
    noise."""
    from bouncebayes.tracking._edge import _design_numpy

    px = _edge_pixels(1)
    px = px._replace(cx=np.full(px.u.size, q[0]), cy=np.full(px.u.size, q[1]))
    a, fixed = _design_numpy(np.array(q[2:]), px)
    beta = np.zeros(a.shape[1])
    beta[:4] = (150.0, 6.0, -4.0, 30.0)  # ball level, a shading gradient, the limb
    beta[-5:] = (-60.0, -20.0, 5.0, 0.5, -0.3)  # the shadow, the background's offset and gradient
    grey = fixed + a @ beta + np.random.default_rng(seed).normal(0, noise, fixed.size)
    return px._replace(grey=grey, weight=np.ones(fixed.size))


def _ball_on_a_bowl(sigma: float, radius: float = 10.0, sub: int = 8, base: float = 60.0,
                    curvature: float = 0.2):
    """A uniform dark disk (grey 30) of ``radius`` px centred at (24.3, 23.8) on a wall whose
    grey rises as the square of the distance from that centre (``base + curvature rho^2``; by
    default 4 grey levels per px at the rim, the same all round), an exact Gaussian lens blur
    of ``sigma`` px on a ``sub`` x ``sub`` grid, then pixel integration; and the wall alone,
    the same way."""
    n = 48
    offs = (np.arange(sub) + 0.5) / sub - 0.5
    grid = (np.arange(n)[:, None] + offs).ravel()
    uu, vv = np.meshgrid(grid, grid)
    rho2 = (uu - 24.3) ** 2 + (vv - 23.8) ** 2
    wall = base + curvature * rho2
    disk = (rho2 <= radius * radius).astype(float)

    def optics(hi):
        hi = cv2.GaussianBlur(hi, (0, 0), sigma * sub, borderType=cv2.BORDER_REFLECT)
        return hi.reshape(n, sub, n, sub).mean(axis=(1, 3))

    return optics(wall * (1 - disk) + 30.0 * disk), optics(wall)


def test_the_edge_model_holds_the_wall_the_ball_hides(monkeypatch):
    from bouncebayes.tracking import _edge

    # expected: the disk's radius as rendered (10 px). The ball hides the wall before the lens
    # blurs it: K * (W (1 - D)) = B (1 - S) - k grad B . grad S + (k^2 / 2) H : grad grad S
    # for a quadratic wall (B = K * W, S = K * D, k = sigma^2 + 1/12; the Gaussian's moments),
    # so with the first-order term the model is off only by the last (~0.15 grey levels at
    # sigma 1.0, where the term itself reaches 2 grey levels; measured on this image: with it
    # +0.003, +0.009, +0.033 px at sigma 0.5, 0.7, 1.0, without -0.025, -0.042, -0.078). At
    # 1.5 px the radius is too weakly held by the edge for a test (+0.13 px with, -0.16 without:
    # docs/tracking.md §3)
    for sigma in (0.5, 0.7, 1.0):
        img, bg = _ball_on_a_bowl(sigma)
        held = (sigma, 0.0, 0.0, 0.5 * math.pi)
        with_term = _edge.fit_edge(img, bg, (24.3, 23.8), (0.0, 0.0), 10.3, held=held)
        monkeypatch.setattr(_edge, "OCCLUSION_MIN_RADIUS", math.inf)
        without = _edge.fit_edge(img, bg, (24.3, 23.8), (0.0, 0.0), 10.3, held=held)
        monkeypatch.undo()
        assert with_term is not None and without is not None
        assert abs(with_term.r - 10.0) < 0.04, (sigma, with_term.r)
        assert abs(without.r - 10.0) > 2 * abs(with_term.r - 10.0), (sigma, without.r)


def test_the_backgrounds_noise_does_not_pull_the_radius_out():
    from bouncebayes.tracking import _edge

    # expected: the radius the same frames give with the exact background (the wall as
    # rendered), pair by pair. A background that is a median of a few frames carries their
    # noise (here variance kappa = 0.3 of a frame's: ~5 frames); the plain sum of squares sheds
    # kappa noise variances for each pixel the ball is made to cover, so it pulls the radius
    # out (closed form: its expectation falls by kappa (1 - S)^2 sigma^2 per pixel), which the
    # edge model's weights 1 / sqrt(1 + kappa (1 - S)^2) undo (._edge_kernel.varpro). Measured:
    # without them +0.49 px (SE 0.04) over 40 draws, with them -0.05 (0.03). A dark disk (30)
    # on a flat wall (170), noise 3 grey levels, blur 1.5 px held (there the radius is weakly
    # held by the edge and moves most; at a contrast of 50 the bias is +1.6 px, and the
    # weights leave -0.19, SE 0.06: they are exact to first order in the noise)
    img, wall = _ball_on_a_bowl(1.5, base=170.0, curvature=0.0)
    rng = np.random.default_rng(2)
    kappa, held = 0.3, (1.5, 0.0, 0.0, 0.5 * math.pi)
    weighted, plain = [], []
    for _ in range(40):
        frame = img + rng.normal(0.0, 3.0, img.shape)
        bg = wall + rng.normal(0.0, 3.0 * math.sqrt(kappa), img.shape)
        fits = [_edge.fit_edge(frame, b, (24.3, 23.8), (0.0, 0.0), 10.3, held=held, kappa=k)
                for b, k in ((bg, np.full(img.shape, kappa)), (bg, None), (wall, None))]
        assert all(f is not None for f in fits)
        weighted.append(fits[0].r - fits[2].r)
        plain.append(fits[1].r - fits[2].r)
    assert abs(np.mean(weighted)) < 0.12, np.mean(weighted)
    assert np.mean(plain) > 0.3, np.mean(plain)  # the bias the weights remove: can fail


def test_the_edge_models_jacobian_holds_each_frames_centre():
    from bouncebayes.tracking._edge import _evaluate, _residual

    # expected: central differences of the same residual (the compiled model, three frames
    # sharing the ball's shading) as one frame's centre moves; the columns are each frame's
    # (cx, cy), then the radius (joint_radius's layout)
    px = _edge_pixels(3)
    q = np.array([10.0, 0.7, 0.5, 2.2, 0.6])
    res, jac = _evaluate(q, px, np.array([1, 1, 1, 0, 0, 0, 0], bool), True)
    assert jac.shape == (px.u.size, 7)
    for f in range(3):
        for k, name in enumerate(("cx", "cy")):
            shift = 1e-6 * (px.frame == f)
            up = px._replace(**{name: getattr(px, name) + shift})
            down = px._replace(**{name: getattr(px, name) - shift})
            fd = (_residual(q, up) - _residual(q, down)) / 2e-6
            assert np.abs(fd[px.frame == f]).max() > 0.1
            np.testing.assert_allclose(jac[:, 2 * f + k], fd, rtol=0, atol=1e-4 * np.abs(fd).max())
    e = np.array([1e-7, 0, 0, 0, 0])
    fd = (_residual(q + e, px) - _residual(q - e, px)) / 2e-7
    np.testing.assert_allclose(jac[:, 6], fd, rtol=0, atol=1e-4 * np.abs(fd).max())


def test_frames_fitted_together_hold_the_radius_a_frame_alone_does_not():
    from bouncebayes.tracking import _edge

    # expected: the disk's radius as rendered (10 px; _ball_on_a_bowl, exact). Blurred by 1.5
    # px, a frame alone hardly holds the radius (its shading trades against it) and the noise
    # pulls it out: 12 frames at 3 grey levels, the blur held at the truth, exact background:
    # the frames' median radius +0.08, +0.06, +0.40 px over three draws (measured); fitted
    # together, one shading for all (joint_radius), +0.014, +0.007, +0.072, each frame's
    # centre within 0.04 px
    img, wall = _ball_on_a_bowl(1.5, base=170.0, curvature=0.0)
    held = (1.5, 0.0, 0.0, 0.5 * math.pi)
    joint, median = [], []
    for seed in range(3):
        rng = np.random.default_rng(seed)
        args = [(img + rng.normal(0.0, 3.0, img.shape), wall, (24.3, 23.8), (0.0, 0.0))
                for _ in range(12)]
        fits = [_edge.fit_edge(*a, 10.3, held=held) for a in args]
        assert all(f is not None for f in fits)
        out = _edge.joint_radius(args, fits, held, None)
        assert out is not None
        r, centres = out.radius, out.centres
        assert abs(r - 10.0) < 0.1, (seed, r)
        assert abs(out.sigma - 1.5) < 0.05 and out.light[1] == 0.5 * math.pi, out
        np.testing.assert_allclose(centres, np.tile([24.3, 23.8], (12, 1)), rtol=0, atol=0.06)
        joint.append(r - 10.0)
        median.append(float(np.median([f.r for f in fits])) - 10.0)
    assert abs(np.mean(joint)) < 0.05, joint
    assert np.mean(median) > 0.1, median  # what the frames alone give: can fail


@pytest.mark.parametrize("light", ["flicker", "fall-off"])
def test_frames_fitted_together_follow_the_balls_brightness(light, monkeypatch):
    from bouncebayes.tracking import _edge

    # expected: the disk's radius as drawn (10 px; _ball_on_a_bowl, exact), a ball of 200 on a
    # wall of 60, blurred by 1.5 px (held), 12 frames at 1 grey level of noise. One shading
    # for all the frames (joint_radius) holds only if each frame's is scaled by how brightly
    # the ball is lit there: "flicker", the whole scene by a lamp's 100 Hz (+-12 %, the
    # frames' gains given); "fall-off", the ball alone 15 % darker to 15 % brighter along its
    # path (a lens's vignetting, a lamp's fall-off; from the ball's inside, _ball_levels).
    # Measured 9.995 and 9.992 px; one shading unscaled: 9.24 and 9.56 px
    img, _ = _ball_on_a_bowl(1.5, base=170.0, curvature=0.0)
    step = (170.0 - img) / 140.0  # the blurred disk's coverage
    held = (1.5, 0.0, 0.0, 0.5 * math.pi)
    k = np.arange(12)
    gains = 1 + 0.12 * np.sin(2 * np.pi * k / 10 + 0.3) if light == "flicker" else np.ones(12)
    ball = np.ones(12) if light == "flicker" else 1 + 0.15 * (k - 5.5) / 5.5
    rng = np.random.default_rng(1)
    args = [(g * (60.0 * (1 - step) + 200.0 * b * step) + rng.normal(0.0, 1.0, img.shape),
             np.full(img.shape, 60.0 * g), (24.3, 23.8), (0.0, 0.0))
            for g, b in zip(gains, ball, strict=True)]
    fits = [_edge.fit_edge(*a, 10.3, held=held) for a in args]
    assert all(f is not None for f in fits)
    out = _edge.joint_radius(args, fits, held, None, gains)
    assert out is not None and out.radius == pytest.approx(10.0, abs=0.03)
    monkeypatch.setattr(_edge, "_ball_levels", lambda *a: np.ones(12))
    unscaled = _edge.joint_radius(args, fits, held, None)
    assert unscaled is not None and unscaled.radius < 9.7  # can fail


def test_the_edge_fit_finds_the_least_squares_point_within_its_bounds():
    from scipy.optimize import least_squares

    from bouncebayes.tracking._edge import _evaluate

    truth = (20.3, 19.7, 10.0, 0.7, 0.5, 2.2, 0.6)
    start = (20.6, 19.4, 10.4, 0.9, 0.2, 2.0, 0.8)
    lo, hi = (18.0, 17.0, 7.5, 0.05, 0.0, -1.0, 0.0), (23.0, 22.0, 13.0, 3.0, 1.0, 5.0, 1.57)
    # noise-free: the generating parameters (zero residual) from a start 0.4 px away
    q, res, status = _fit_frame(_model_frame(truth, 0.0), start, lo, hi)
    assert status > 0
    np.testing.assert_allclose(q, truth, rtol=0, atol=1e-6)
    assert float(res @ res) < 1e-8  # grey levels^2 over 500 pixels (the ridge, the table)
    # with noise: the same point as SciPy's least_squares (trust-region reflective, the same
    # analytic Jacobian) run to convergence, an independent optimiser
    px = _model_frame(truth, 3.0)
    q, res, status = _fit_frame(px, start, lo, hi)
    ref = least_squares(lambda x: _evaluate(x, px, np.ones(7, bool), False)[0], start,
                        jac=lambda x: _evaluate(x, px, np.ones(7, bool), True)[1],
                        bounds=(lo, hi), x_scale=0.05, xtol=1e-12, ftol=1e-12, gtol=1e-12)
    # (5e-6: the exposure, the least determined, ends 1.4e-6 apart with the shadow's columns
    # and 3.7e-6 with the background's variance in the weights, the compiled fit's cost the
    # lower by 2e-8 of 3635)
    np.testing.assert_allclose(q, ref.x, rtol=0, atol=5e-6)
    assert float(res @ res) == pytest.approx(2 * ref.cost, rel=1e-9)
    # a bound in the way: exposure held at most 0.1 (the truth 0.5), the fit ends on it, with
    # the other parameters where SciPy puts them under the same bound
    hi_exposure = (*hi[:4], 0.1, *hi[5:])
    start = (*start[:4], 0.05, *start[5:])
    q, res, status = _fit_frame(px, start, lo, hi_exposure)
    ref = least_squares(lambda x: _evaluate(x, px, np.ones(7, bool), False)[0], start,
                        jac=lambda x: _evaluate(x, px, np.ones(7, bool), True)[1],
                        bounds=(lo, hi_exposure), x_scale=0.05, xtol=1e-12, ftol=1e-12,
                        gtol=1e-12)
    assert q[4] == pytest.approx(0.1, abs=1e-9)
    np.testing.assert_allclose(q, ref.x, rtol=0, atol=1e-5)
    # the evaluations' limit: it stops there (status 0), at the last point accepted, below
    # the start's cost
    _, res0, _ = _fit_frame(px, start, lo, hi, max_nfev=1)
    _, res3, status3 = _fit_frame(px, start, lo, hi, max_nfev=3)
    assert status3 == 0 and float(res3 @ res3) < float(res0 @ res0)


# --------------------------------------------------------------------------- small-ball centres


def _side_lit_small_ball():
    from render_pbr import Shot, Throw, render

    # the paper's camera (224 x 64, 1000 fps), a 5 px ball lit from the left, lens blur 0.6 px,
    # uncompressed: the lighting's bias alone
    shot = Shot(width=224, height=64, radius_px=5.0, n_frames=100, surface_v=50.0,
                slope_deg=3.0, sigma_px=0.6, exposure=0.5, light=(-0.6, 0.3, 0.75),
                supersample=3, seed=2, throw=Throw(speed_in=2.0, angle_in=35.0,
                                                    t_contact=0.05, x_contact=0.05))
    truth = shot.true_centres()
    r = shot.radius_px
    whole = ((truth[:, 0] >= r) & (truth[:, 0] <= shot.width - 1 - r)
             & (truth[:, 1] >= r) & (truth[:, 1] <= shot.height - 1 - r))
    return render(shot), truth, whole


def test_a_small_side_lit_balls_centres_are_not_pulled_to_the_lit_side(monkeypatch):
    from bouncebayes.tracking import _refine

    frames, truth, whole = _side_lit_small_ball()
    track = track_ball(frames)
    ok = track.trusted & whole
    assert ok.sum() >= 80 and track.refined[ok].mean() >= 0.9
    err = track.centre[ok] - truth[ok]
    # the renderer's truth (mid-exposure centres). Measured: RMS 0.045 px, mean error (+0.02,
    # +0.02) px; the target is 0.15 px RMS (docs/tracking.md)
    assert rms(err) < 0.06
    assert np.all(np.abs(err.mean(axis=0)) < 0.04)
    # with the shadow columns at the light the fit found (the renderer's: azimuth -153.4
    # degrees in the image, elevation 48.2; found: -161, 49), which the record carries
    az, el = np.degrees(track.radius_fit.light)
    assert abs(az + 153.4) < 15.0 and 45.0 < el < 75.0
    # without them (the clamped Lambert shading's kink at the terminator, near the rim on the
    # dark side, not followed), the centres are pulled to the dark side (+u): measured RMS
    # 0.051 px, mean error (+0.04, +0.01) (0.119, (+0.11, +0.04) with a held blur of 0.599 px
    # instead of 0.623, before the background's variance entered the edge model's weights;
    # 0.080, (+0.07, +0.03) with the blur of 5 free fits)
    monkeypatch.setattr(_refine, "LIGHT_GAIN", math.inf)
    unlit = track_ball(frames)
    assert unlit.radius_fit.light[1] == pytest.approx(0.5 * math.pi)
    unlit_err = unlit.centre[ok] - truth[ok]
    assert rms(unlit_err) > rms(err)
    assert unlit_err.mean(axis=0)[0] > err.mean(axis=0)[0] + 0.01
    # the coverage centroid, which this replaces, fails both: measured RMS 0.448 px, mean error
    # (-0.39, -0.18) px, towards the lit side; with the edge fits' offset 0.146 px, 3.6x this
    # fit's (0.160 before the edge model's blur came from 13 free fits instead of 5; 0.345 px,
    # (-0.27, -0.17) before the fits' background left the ball out and their starts reached
    # below the coverage radius)
    from bouncebayes.tracking import _quality

    no_refined_centres(monkeypatch)
    old = track_ball(frames)
    assert not old.refined.any()
    old_err = old.centre[ok] - truth[ok]
    assert rms(old_err) > 2.5 * rms(err)
    monkeypatch.setattr(_quality, "CENTRE_FIT_BLUR", 0.0)  # no offset either
    raw = track_ball(frames)
    raw_err = raw.centre[ok] - truth[ok]
    assert rms(raw_err) > 0.3 and raw_err.mean(axis=0)[0] < -0.25


def _refine_residual_numpy(q, u, v, grey, back, sigma, r=None, light=None):
    """The model of tracking/_refine.py in NumPy (exact normal CDF, NumPy least squares): the
    residual at centre ``q[:2]`` (and radius ``q[2]``), the linear coefficients solved; with
    ``light = (az, el)`` the edge model's two shadow columns (``_edge._shadow_numpy``, itself
    checked against SciPy's quadrature) added."""
    from scipy.special import ndtr

    from bouncebayes.tracking._edge import _shadow_numpy, _sqrt_table
    from bouncebayes.tracking._refine import SHADOW_NODES

    cx, cy = q[0], q[1]
    r = q[2] if len(q) == 3 else r
    du, dv = u - cx, v - cy
    rho = np.hypot(du, dv)
    base = sigma**2 + 1 / 12  # no exposure smear: the ball at rest
    s = math.sqrt(base)
    z = (r - base / (2 * r) - rho) / s
    step = ndtr(z)
    zt, gt = _sqrt_table()
    root = math.sqrt(s) * np.interp(z, zt, gt, right=np.nan)
    root = np.where(np.isnan(root), np.sqrt(np.maximum(z * s, 0.0)), root)
    nz = root * np.sqrt(1 / r + rho / r**2)
    x, y, ct, st = du / r, dv / r, du / rho, dv / rho
    a = np.column_stack([step, step * x, step * y, nz, step * x * y, step * (x * x - y * y),
                         1 - step, (1 - step) * ct, (1 - step) * st])
    if light is not None:
        a = np.hstack([a, _shadow_numpy(z * s, np.full(rho.size, s), r, ct, st, *light,
                                        SHADOW_NODES)])
    target = grey - back * (1 - step)
    beta = np.linalg.lstsq(a, target, rcond=None)[0]
    return target - a @ beta


@pytest.mark.parametrize("light", [None, (-2.68, 0.85)], ids=["no-shadow", "shadow"])
@pytest.mark.parametrize("r_free", [False, True])
def test_the_compiled_small_ball_fit_finds_the_least_squares_centre(r_free, light):
    from scipy.optimize import least_squares

    from bouncebayes.tracking._edge import _nodes, _sqrt_table
    from bouncebayes.tracking._refine import REACH_BLURS, REACH_PX, SHADOW_NODES, _fit_frame

    # an independent image: a 5 px ball lit from the left (clamped Lambert, limb darkening) on
    # a textured wall, 4 x 4 supersampled, blurred by 0.6 px, noise, 8 bits
    rng = np.random.default_rng(11)
    sub, h, w, c, r, sigma = 4, 32, 36, (17.3, 15.6), 5.0, 0.6
    g = (np.arange(w * sub) + 0.5) / sub - 0.5
    yy, xx = np.meshgrid((np.arange(h * sub) + 0.5) / sub - 0.5, g, indexing="ij")
    wall = 50 + 8 * np.sin(0.4 * xx + 0.3 * yy) + 5 * np.cos(0.7 * yy)
    X, Y = (xx - c[0]) / r, (yy - c[1]) / r
    inside = X * X + Y * Y < 1
    nz = np.sqrt(np.clip(1 - X * X - Y * Y, 0, 1))
    shade = 60 + 150 * np.clip(-0.6 * X - 0.3 * Y + 0.75 * nz, 0, None) * (0.7 + 0.3 * nz)
    hi = cv2.GaussianBlur(np.where(inside, shade, wall), (0, 0), sigma * sub)
    img = hi.reshape(h, sub, w, sub).mean(axis=(1, 3)) + rng.normal(0, 1.5, (h, w))
    frame = np.clip(np.rint(img), 0, 255).astype(np.uint8)
    bg = wall.reshape(h, sub, w, sub).mean(axis=(1, 3))
    start = (c[0] + 0.3, c[1] - 0.25)
    r0 = 4.8 if r_free else r  # a radius to start from, or the true one held
    zt, gt = _sqrt_table()
    az, el = light or (0.0, 0.5 * math.pi)  # elevation pi/2: no shadow columns
    ok, out = _fit_frame(frame, bg, 1.0, start[0], start[1], 0.0, 0.0, r0, sigma, 0.0, r_free,
                         12, float(zt[0]), float(zt[1] - zt[0]), gt, np.gradient(gt, zt), az, el,
                         _nodes(SHADOW_NODES), 0.0, False, np.zeros(5), np.zeros(24, bool),
                         np.zeros(24))
    assert ok
    cx, cy, rr, se_x, se_y = out[:5]
    # the formal standard errors, from the residual (the noise, 1.5 grey levels, and the
    # shading the model does not follow) on a contrast of ~150 over ~150 pixels: measured
    # 0.028-0.036 px; the fit of the same frame moves by ~0.1 px with the model's error
    assert 0.01 < se_x < 0.06 and 0.01 < se_y < 0.06
    # expected: the same cost minimised by scipy's least_squares (central differences, to
    # convergence) on the same pixels (within r + REACH_PX + REACH_BLURS blurs of the start),
    # with the exact normal CDF. The compiled fit's is Abramowitz & Stegun's (1.5e-7) and its
    # Jacobian takes the limb table's derivative from np.gradient, not the slope of the linear
    # interpolation its value uses, so its Gauss-Newton steps stop at a slightly different
    # point: measured 1e-4 px away
    vv, uu = np.mgrid[:h, :w].astype(float)
    reach = r0 + REACH_PX + REACH_BLURS * math.sqrt(sigma**2 + 1 / 12)
    near = np.hypot(uu - start[0], vv - start[1]) <= reach
    args = (uu[near], vv[near], frame[near].astype(float), bg[near], sigma)
    if r_free:
        ref = least_squares(_refine_residual_numpy, [*start, r0], args=args,
                            kwargs={"light": light}, xtol=1e-12, ftol=1e-12, gtol=1e-12).x
        assert rr == pytest.approx(ref[2], abs=5e-4)
    else:
        ref = least_squares(_refine_residual_numpy, start, args=args,
                            kwargs={"r": r0, "light": light}, xtol=1e-12, ftol=1e-12, gtol=1e-12,
                            jac="3-point").x
        assert rr == r0
    assert cx == pytest.approx(ref[0], abs=5e-4) and cy == pytest.approx(ref[1], abs=5e-4)
    # and the fit is near the drawn centre (the model is not the drawing: measured 0.0x px)
    if not r_free:
        # with the true radius held the fit is near the drawn centre (the model's shading is
        # not the drawing's clamped one, and there is noise: measured 0.097 px; with the
        # shadow columns at the drawing's light, which hold the clamp: 0.064 px); a single
        # frame's free radius is not (measured 4.68 px, the centre 0.26 px off): the tracker
        # holds the median of 15 frames' radii
        assert math.hypot(cx - c[0], cy - c[1]) < (0.15 if light is None else 0.08)


@pytest.mark.parametrize("radius", [8.0, 12.0, 15.0])
def test_a_dark_balls_shadow_merged_with_it_is_not_taken_for_the_ball(radius):
    from render_pbr import Shot, Throw, render

    from bouncebayes.tracking import _edge, cast_message, radius_warning

    # expected: the renderer's radius and centres. A dark ball (albedo 0.2 on a wall of 200
    # grey levels) with its shadow cast on the wall by a lamp, offset 0.6, 0.5 radii and 0.7
    # of the wall's light dark, as dark as the ball: the coverage takes ball and shadow for
    # one blob. Before, the edge model fitted from it one larger disk: measured +32.7 % (8 px)
    # and +32.6 % (12 px), centres 4.6 px off, nothing said; with the misfit's restarts
    # (_edge.MISFIT: RMS residual 2.4 and 3.4 times the noise) -0.07 % and -0.08 %, the
    # shadow's sides left out; since the shadow is held (_cast) +0.22 % and -0.01 %, centres
    # 0.026 and 0.025 px, and said. At 15 px the ball enters the frame cut by its top edge,
    # whose frame-edge disk fits took in the shadow (5.5 px off) and whose per-frame fits
    # started from them: frames 4-6, wholly or nearly in view, 3.6-4.2 px off and not
    # flagged; fitted again from the frames after them (_refine._backward) 0.05 px
    kw = dict(width=240, height=120, radius_px=radius, n_frames=80, surface_v=100.0,
              slope_deg=2.0, sigma_px=0.7, exposure=0.3, supersample=3, wall=200.0,
              plane=170.0, albedo=0.2, ambient=0.2,
              throw=Throw(speed_in=2.4, angle_in=35.0, t_contact=0.04, x_contact=0.07))
    shot = Shot(**kw, cast=(0.6, 0.5, 0.7))
    frames = render(shot)
    track = track_ball(frames)
    assert np.nanmedian(track.radius) > 1.2 * radius  # the coverage took in the shadow
    assert abs(track.radius_fit.radius / radius - 1) < 0.01
    assert rms(track.centre - shot.true_centres()) < 0.1
    error = np.hypot(*(track.centre - shot.true_centres()).T)
    assert np.nanmax(error) < 0.3
    assert track.radius_fit.rms < _edge.MISFIT * track.noise
    found = track.radius_fit.cast
    assert found is not None and math.hypot(found.du - 0.6 * radius,
                                            found.dv - 0.5 * radius) < 0.1 * radius
    assert "shadow" in cast_message(track)
    assert "shadow" not in (radius_warning(track) or "")  # no sides left out: it is held


def test_a_frame_counter_burned_in_across_the_balls_path():
    from render_pbr import Shot, Throw, burn_counter, render

    from bouncebayes.tracking import radius_warning

    # expected: the renderer's radius (10 px) and centres. A high-speed camera's frame counter
    # (a black box, white digits that change every frame) burned in where the ball passes
    # under it twice, hiding part of it in 15 frames. Before, two of the edge model's five
    # free fits were of such frames (radii -34 and -18 %, blurs 1.82 px against 0.7) and,
    # with a third, outvoted the two that had the light's shadow: every frame was fitted
    # with a 1.82 px blur and no light, the radius -13 % (said only as "blurred"), every
    # centre 0.3-1.2 px off, and 12 frames 0.5-3.6 px off unflagged. Now those fits are left
    # out of what the frames share (_edge._alike) and of the joint fit, and the frames whose
    # per-frame fit misfits are flagged (_quality.refit_misfit)
    shot = Shot(width=320, height=200, radius_px=10.0, n_frames=90, surface_v=170.0,
                slope_deg=2.0, sigma_px=0.6, exposure=0.2, supersample=3, seed=5, wall=120.0,
                plane=60.0, throw=Throw(speed_in=2.5, angle_in=35.0, t_contact=0.045,
                                        x_contact=0.1))
    frames = render(shot)
    burn_counter(frames, 62, 120)
    track = track_ball(frames)
    assert abs(track.radius_fit.radius / 10.0 - 1) < 0.01 and radius_warning(track) is None
    error = np.hypot(*(track.centre - shot.true_centres()).T)
    # the hidden frames flagged (one left, 0.56 px off: its fit's residual 1.85 times the
    # median, under the 2 at which frames are flagged)
    assert np.all(track.flag[error > 0.6])
    assert np.nanmax(error[track.trusted]) < 0.6 and track.trusted.sum() >= 70


def test_the_surface_angles_se_holds_an_edge_that_wanders():
    import cv2

    import bouncebayes.tracking._geometry as geometry
    from bouncebayes.tracking._geometry import _angle_sd

    # expected: the true angle, 0. Edge pixels along 320 px whose offset across the line
    # wanders smoothly (a wall's texture bending the edge: three sinusoids of 60-320 px period,
    # 0.5 px each) plus noise of 0.1 px and whole-pixel rounding, as Canny gives them; over
    # 300 edges the Huber line's angle over the stated SE has an RMS of 0.76 (within 0.6-1.25
    # asserted); the pixels' scatter alone, the SE before, gave 2.5
    rng = np.random.default_rng(5)
    along = np.arange(320, dtype=float)
    z, z_pixels = [], []
    keep = geometry._block_sd
    for _ in range(300):
        wander = sum(0.5 * np.sin(2 * np.pi * along / rng.uniform(60, 320)
                                  + rng.uniform(0, 2 * np.pi)) for _ in range(3))
        pts = np.column_stack([along, np.round(50.0 + wander + rng.normal(0, 0.1, 320))])
        pts = pts.astype(np.float32)
        dx, dy, px, py = cv2.fitLine(pts, cv2.DIST_HUBER, 0, 0.01, 0.01).ravel()
        angle = (math.degrees(math.atan2(dy, dx)) + 90.0) % 180.0 - 90.0
        z.append(angle / _angle_sd(pts, (dx, dy), (px, py)))
        geometry._block_sd = lambda a, r: 0.0
        try:
            z_pixels.append(angle / _angle_sd(pts, (dx, dy), (px, py)))
        finally:
            geometry._block_sd = keep
    assert 0.6 <= math.sqrt(np.mean(np.square(z))) <= 1.25
    assert math.sqrt(np.mean(np.square(z_pixels))) > 1.5


def test_the_surface_angles_se_holds_a_wall_texture_that_tilts_a_faint_edge():
    from render_pbr import Shot, Throw, render

    import bouncebayes.tracking._geometry as geometry

    # expected: the renderer's surface, at 2 degrees (the angle -2: v points down). A faint
    # step (wall 50 +- 10 grey levels over a plane of 30) whose wall texture bends the edge's
    # sub-pixel positions smoothly along it, 0.75 px over 260 px: the line came out -1.797 +-
    # 0.030 degrees, z 6.8. The angles with the image smoothed by 0.5 and 2 px (-1.88,
    # -1.69) tell that its texture moves it: half their range in the SE, +- 0.10, z 2.0
    shot = Shot(width=320, height=200, radius_px=10.0, n_frames=90, surface_v=170.0,
                slope_deg=2.0, sigma_px=0.6, exposure=0.2, supersample=3, seed=4, codec="MJPG",
                throw=Throw(speed_in=2.5, angle_in=35.0, t_contact=0.045, x_contact=0.1))
    track = track_ball(render(shot))
    line = detect_surface(track.background, centres=track.centre[track.found],
                          radius=track.ball_radius)
    assert abs(line.angle + 2.0) < 3 * line.angle_sd_deg
    assert abs(line.angle + 2.0) > 0.15  # (the texture's pull itself, as measured)
    keep = geometry.OTHER_SMOOTH_PX
    geometry.OTHER_SMOOTH_PX = ()
    try:
        alone = detect_surface(track.background, centres=track.centre[track.found],
                               radius=track.ball_radius)
    finally:
        geometry.OTHER_SMOOTH_PX = keep
    assert alone.angle == line.angle and abs(alone.angle + 2.0) > 5 * alone.angle_sd_deg


def test_a_faint_step_that_makes_no_edge_is_found():
    from render_pbr import Shot, Throw, render

    import bouncebayes.tracking._geometry as geometry

    # expected: the renderer's surface, at 1 degree (the angle -1: v points down). A faint
    # step (a wall of 40 +- 8 grey levels over a plane of 32) makes no straight Canny edge;
    # the lines pieced together over gaps found a line of the wall's texture that the ball
    # passes, taken for the surface (the test of the test: more than 5 degrees off)
    shot = Shot(width=240, height=140, radius_px=7.0, n_frames=90, surface_v=128.0,
                slope_deg=1.0, wall=40.0, plane=32.0, texture=8.0, sigma_px=1.0, exposure=0.3,
                supersample=3, codec="MJPG", seed=23,
                throw=Throw(speed_in=2.5, angle_in=38.0, t_contact=0.045, x_contact=0.09))
    background = np.median(render(shot), axis=0)
    centres = shot.true_centres()
    line = detect_surface(background, centres=centres, radius=7.0)
    assert abs(line.angle + 1.0) < 3 * line.angle_sd_deg and line.angle_sd_deg < 0.3
    keep = geometry._step_line
    geometry._step_line = lambda *args: None
    try:
        texture = detect_surface(background, centres=centres, radius=7.0)
    finally:
        geometry._step_line = keep
    assert abs(texture.angle + 1.0) > 5.0


def _step_image(width: int, height: int, blur: float, wall, seed: int) -> np.ndarray:
    """A flat surface edge along v = 87.5 (the plane of 30 grey levels below, ``wall(u, v)``
    above), blurred by ``blur`` px (erf), noise 1 grey level, rounded."""
    from scipy.special import erf

    v, u = np.mgrid[:height, :width].astype(float)
    step = 0.5 * (1 - erf((v - 87.5) / (math.sqrt(2) * blur)))
    img = 30 + (wall(u, v) - 30) * step + np.random.default_rng(seed).normal(0, 1.0, v.shape)
    return np.clip(np.rint(img), 0, 255).astype(np.uint8)


def test_a_surface_edge_along_part_of_the_frame_is_said():
    from types import SimpleNamespace

    from bouncebayes.tracking import surface_warning
    from bouncebayes.tracking._geometry import EDGE_SHARE, edge_share

    # expected (closed form): a flat step along v = 87.5 (a wall of 70 grey levels over a plane
    # of 30) across the whole 320 px, or over its first 128 px (40 %) only, the rest plane:
    # the edge lies on the line along 1.0 and 0.4 of the frame; on a line 4 px off it, along
    # none. A line detected there is said (a wall's texture over a faint step, taken for the
    # surface, benchmarks/tracking_surface.py); one given by points is not
    flat = Surface.from_points((0.0, 87.5), (319.0, 87.5))
    whole = _step_image(320, 160, 1.0, lambda u, v: 70.0 + 0 * u, seed=1)
    part = _step_image(320, 160, 1.0, lambda u, v: np.where(u < 128, 70.0, 30.0), seed=1)
    assert edge_share(whole, flat) > 0.97
    assert abs(edge_share(part, flat) - 0.4) < 0.03
    assert edge_share(whole, Surface.from_points((0.0, 91.5), (319.0, 91.5))) < 0.03

    def said(img, source):
        surface = Surface(point=flat.point, direction=flat.direction, source=source)
        return surface_warning(SimpleNamespace(surface=surface,  # type: ignore[arg-type]
                                               track=SimpleNamespace(background=img)))

    assert said(whole, "detected") is None and EDGE_SHARE > 0.4
    assert "along only 40 %" in said(part, "detected") and "--surface" in said(part, "detected")
    assert said(part, "points") is None


def test_a_stretch_where_the_wall_hides_the_surface_does_not_tilt_it():
    from scipy.special import erf

    from bouncebayes.tracking import _geometry

    # expected (by construction): the surface flat along v = 87.5, angle 0. Over u 5-50 the
    # wall just above it is as dark as the plane (31) and rises to 50 about v = 83.5: an edge
    # of its own 4 px above the surface's, which hides it there (the wall's texture over a
    # faint step in a rendered MJPEG clip; the line came out -2.17 +- 0.46 degrees). Given
    # the Hough segment of that clip, tilted from (58, 85) to (142, 88), one read within 2.5 px
    # of it (as before) is tilted as much (the test of the test)
    def wall(u, v):
        patch = 0.5 * (erf((u - 5) / 3) - erf((u - 50) / 3))
        dark = 31 + 19 * 0.5 * (1 - erf((v - 83.5) / (math.sqrt(2) * 1.5)))
        return 50 * (1 - patch) + dark * patch

    img = _step_image(160, 96, 1.5, wall, 1)
    edges, _, _ = _geometry.canny_edges(img)
    line = _geometry._refined((58.0, 85.0, 142.0, 88.0), edges, img)
    assert abs(line.angle) < 3 * line.angle_sd_deg and abs(line.angle) < 0.3
    assert abs(line.point[1] + (80 - line.point[0]) * line.direction[1] - 87.5) < 0.3
    d = np.array([84.0, 3.0]) / math.hypot(84.0, 3.0)
    once = _geometry._subpixel((58.0, 85.0), tuple(d), img, -53.0, 100.0)
    assert once.angle < -1.5 and abs(once.angle) > 5 * once.angle_sd_deg


def test_a_strong_edge_beside_the_surface_does_not_take_its_line():
    from scipy.special import erf

    from bouncebayes.tracking import _geometry

    # expected (by construction): the surface flat along v = 87.5 (a step of 20 grey levels),
    # angle 0; a black box (a frame counter) from v = 91.5 down and u = 120 right, whose top
    # edge, 4 px under the surface and stronger, takes a line read out to 6 px either side
    # (the first read that finds a surface its texture hid, the test above; the test of the
    # test: tilted by more than 1 degree)
    def wall(u, v):
        return 50.0 + 0 * u

    box = 0.25 * np.multiply(*[1 + erf((x - c) / (math.sqrt(2) * 0.7)) for x, c in zip(
        np.mgrid[:110, :200].astype(float), (91.5, 120.0), strict=True)])
    img = (_step_image(200, 110, 1.0, wall, 2) * (1 - box)).astype(np.uint8)
    edges, _, _ = _geometry.canny_edges(img, 1.5, 80.0)
    line = _geometry._refined((10.0, 87.5, 190.0, 87.5), edges, img)
    assert abs(line.angle) < 3 * line.angle_sd_deg and abs(line.angle) < 0.3
    wide = _geometry._subpixel((10.0, 87.5), (1.0, 0.0), img, 0.0, 180.0,
                               reach=_geometry.WIDE_REACH)
    assert abs(wide.angle) > 1.0


def test_the_surface_line_is_fitted_to_the_edges_sub_pixel_positions():
    from scipy.special import erf

    import bouncebayes.tracking._geometry as geometry

    # expected (closed form): a straight step edge falling 1.5 degrees to the right (the
    # surface's angle -1.5: v points down), blurred by a Gaussian of
    # 1 px (the fraction of each pixel above the line: erf), 100 grey levels above, 30 below,
    # noise 1.5; over 12 noise draws the line's angle is within 3 of its stated SEs and its
    # mean error under 0.01 degrees (the whole-pixel Canny fit: its mean error larger)
    v, u = np.mgrid[:160, :320].astype(float)
    slope = math.radians(1.5)
    across = ((v - 110.0) - u * math.tan(slope)) * math.cos(slope)  # px below the line
    clean = 30.0 + 70.0 * 0.5 * (1.0 - erf(across / math.sqrt(2.0)))
    rng = np.random.default_rng(4)
    errors, coarse = [], []
    for _ in range(12):
        img = np.clip(np.rint(clean + rng.normal(0.0, 1.5, clean.shape)), 0, 255)
        line = detect_surface(img.astype(np.uint8))
        assert abs(line.angle + 1.5) < 3 * line.angle_sd_deg, (line.angle, line.angle_sd_deg)
        errors.append(line.angle + 1.5)
        keep = geometry._settled
        geometry._settled = lambda *args: None
        try:
            coarse.append(detect_surface(img.astype(np.uint8)).angle + 1.5)
        finally:
            geometry._settled = keep
    assert abs(np.mean(errors)) < 0.01
    assert np.sqrt(np.mean(np.square(errors))) < np.sqrt(np.mean(np.square(coarse)))
