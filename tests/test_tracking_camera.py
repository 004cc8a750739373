"""The camera's motion (``bouncebayes.tracking._camera``): shifts measured against the
background model, frames moved back, and a shaken camera's clip tracked in the scene's pixels."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bouncebayes.tracking import _camera, background_model, track_ball


def _wall(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """A smooth textured wall (grey levels, 60 +- ~14) at any real points: its value at a
    shifted point is exact (no resampling)."""
    k = [(0.31, 0.12, 0.4), (-0.17, 0.27, 1.3), (0.45, -0.08, 2.2), (0.07, 0.38, 0.9)]
    return 60.0 + sum(7.0 * np.sin(a * u + b * v + c) for a, b, c in k)


def test_a_frame_moved_back_is_the_ramp_moved_exactly():
    # expected (closed form): cubic convolution reproduces a linear ramp, so a ramp frame moved
    # by d is the ramp at p - d (inside, away from the replicated edge); unmoved, the frame
    # as it was
    v, u = np.mgrid[:30, :40].astype(np.float64)
    ramp = (20.0 + 2.0 * u + 3.0 * v).astype(np.uint8)[None]
    for du, dv in [(0.3, -0.7), (1.25, 0.05), (-2.6, 1.9)]:
        out = _camera.shift_frames(ramp, np.array([[du, dv]]))[0]
        expect = 20.0 + 2.0 * (u - du) + 3.0 * (v - dv)
        np.testing.assert_allclose(out[4:-4, 4:-4], expect[4:-4, 4:-4], atol=1e-4)
    np.testing.assert_array_equal(_camera.shift_frames(ramp, np.zeros((1, 2)))[0], ramp[0])
    # turned and zoomed as well (two-dimensional cubic convolution): the ramp at p - m(p),
    # m(p) = d + t J q + z q, q = (p - c) / L
    half = 0.5 * math.hypot(39, 29)
    qu, qv = (u - 19.5) / half, (v - 14.5) / half
    for du, dv, t, z in [(0.3, -0.7, 0.4, 0.0), (0.0, 0.0, -0.25, 0.6), (1.1, 0.2, 0.9, -0.3)]:
        out = _camera.shift_frames(ramp, np.array([[du, dv, t, z]]))[0]
        expect = (20.0 + 2.0 * (u - du + t * qv - z * qu)
                  + 3.0 * (v - dv - t * qu - z * qv))
        np.testing.assert_allclose(out[4:-4, 4:-4], expect[4:-4, 4:-4], atol=1e-4)


def test_each_frames_shift_is_measured_against_the_background():
    # expected: the shifts drawn (the wall evaluated at p + d, exact), within 4 of their stated
    # standard errors, under a lamp's flicker (+-5 %) and with a ball (a bright disk) in each
    # frame; measured SEs ~0.004 px
    rng = np.random.default_rng(2)
    v, u = np.mgrid[:96, :160].astype(np.float64)
    bg = _wall(u, v)
    shifts = rng.uniform(-0.1, 0.1, (12, 2))
    gains = 1 + 0.05 * np.sin(np.arange(12))
    frames = []
    for k, (du, dv) in enumerate(shifts):
        img = gains[k] * _wall(u + du, v + dv)
        img = np.where(np.hypot(u - 30 - 8 * k, v - 40) < 9, 220.0, img)
        frames.append(np.clip(np.rint(img + rng.normal(0, 1.5, img.shape)), 0, 255))
    est, se = _camera.frame_shifts(np.array(frames, np.uint8), bg, _camera.FINE_GRID)
    assert np.all(se[:, :2] < 0.01)
    truth = np.column_stack([shifts, np.zeros((12, 2))])  # no turn, no zoom
    assert np.all(np.abs(est - truth) < 4 * se + 0.002), np.abs(est - truth) / se


def test_each_frames_turn_and_zoom_are_measured_against_the_background():
    # expected: the turns and zooms drawn, about the frame's centre (the wall evaluated at
    # c + (1 + zoom) R(turn) (p - c) + d, exact), within 4 of their stated standard errors;
    # as px at the half-diagonal (frame_shifts) and as degrees and a fraction (turn_and_zoom)
    rng = np.random.default_rng(3)
    v, u = np.mgrid[:96, :160].astype(np.float64)
    cu, cv, half = 79.5, 47.5, 0.5 * math.hypot(159, 95)
    bg = _wall(u, v)
    shifts = rng.uniform(-0.1, 0.1, (12, 2))
    turns, zooms = rng.uniform(-0.15, 0.15, 12), rng.uniform(-0.002, 0.002, 12)
    frames = []
    for k in range(12):
        a, z = math.radians(turns[k]), 1.0 + zooms[k]
        su = cu + z * (math.cos(a) * (u - cu) - math.sin(a) * (v - cv)) + shifts[k, 0]
        sv = cv + z * (math.sin(a) * (u - cu) + math.cos(a) * (v - cv)) + shifts[k, 1]
        img = np.where(np.hypot(u - 30 - 8 * k, v - 40) < 9, 220.0, _wall(su, sv))
        frames.append(np.clip(np.rint(img + rng.normal(0, 1.5, img.shape)), 0, 255))
    est, se = _camera.frame_shifts(np.array(frames, np.uint8), bg, _camera.FINE_GRID)
    truth = np.column_stack([shifts, np.radians(turns) * half, zooms * half])
    # first order in the turn and zoom (one Gauss-Newton step): their squares, ~1e-3 px
    assert np.all(np.abs(est - truth) < 4 * se + 0.003), np.abs(est - truth) / se
    told = _camera.turn_and_zoom(est[:, 2:], bg.shape)
    tolerance = _camera.turn_and_zoom(4 * se[:, 2:] + 0.003, bg.shape)  # a scaling
    assert np.all(np.abs(told - np.column_stack([turns, zooms])) < tolerance)
    back = _camera.motion_px(est[:, :2], told, bg.shape)
    np.testing.assert_allclose(back, est, atol=1e-12)


def test_a_still_cameras_frames_are_left_as_they_are():
    # expected: a still camera (tests/render_pbr.py, a 5 px ball on a plain wall: the scene
    # whose background gave the largest spurious shifts over 39 still clips, 5.3 standard
    # errors) is not taken for a moving one: the frames unchanged, no shift
    from render_pbr import Shot, Throw, render

    shot = Shot(width=160, height=64, radius_px=5.0, n_frames=50, surface_v=56.0,
                slope_deg=1.0, sigma_px=1.5, exposure=0.4, texture=0.0, supersample=3,
                throw=Throw(speed_in=2.5, angle_in=40.0, t_contact=0.025, x_contact=0.05))
    frames = render(shot)
    out, bg, shift, turn = _camera.stabilise(frames, lambda f: background_model(f, 25))
    assert out is frames and not shift.any() and not turn.any()


def test_a_shaken_cameras_clip_is_tracked_in_the_scenes_pixels(monkeypatch):
    # expected: the renderer's centres (tests/render_pbr.py, the scene's pixels) and its camera
    # shifts: a camera on the struck table shaking after the impact (180 Hz, 0.6 px, decaying
    # over 10 ms). Measured: the shifts within 0.010 px RMS, the centres 0.032 px RMS about
    # their mean (the same clip with a still camera: 0.027); not moved back, 0.135 px
    from render_pbr import Shot, Throw, render

    n, tc = 60, 0.03
    t = np.arange(n) / 1000.0
    a = np.where(t > tc, 0.6 * np.exp(-(t - tc) / 0.01) * np.sin(2 * np.pi * 180 * (t - tc)),
                 0.0)
    camera = np.column_stack([0.3 * a, a])
    shot = Shot(width=160, height=96, radius_px=10.0, n_frames=n, surface_v=80.0,
                slope_deg=2.0, sigma_px=0.7, exposure=0.3, supersample=2, seed=4,
                camera=tuple(map(tuple, camera)),
                throw=Throw(speed_in=2.0, angle_in=35.0, t_contact=tc, x_contact=0.05))
    frames = render(shot)
    truth = shot.true_centres()

    def error(track) -> float:
        e = track.centre - truth
        e -= np.nanmean(e, axis=0)
        return float(np.sqrt(np.nanmean(np.sum(e**2, axis=1))))

    track = track_ball(frames)
    assert math.sqrt(np.mean((track.camera_shift - camera) ** 2)) < 0.025
    assert error(track) < 0.05
    monkeypatch.setattr(_camera, "MOVED_SE", math.inf)  # not moved back: can fail
    still = track_ball(frames)
    assert not still.camera_shift.any() and error(still) > 0.1


def test_a_turning_and_zooming_cameras_clip_gives_the_throws_angles(tmp_path, capsys):
    import json

    import cv2
    from render_pbr import Shot, Throw, render

    from bouncebayes.cli import main
    from bouncebayes.kinematics import fit_kinematics, read_trajectory

    # expected: the renderer's throw and camera (tests/render_pbr.py: the scene drawn again
    # at c + (1 + zoom) R(turn) (p - c) + d each frame). A hand-held camera turning by up to
    # 0.3 deg and zooming by 0.3 % (the frame's corners moved by up to 0.7 px) and drifting
    # 0.6 px: with the shift alone followed, the kinematics refused both flights (a cubic
    # trend in their residuals)
    n, k = 80, np.arange(80)
    camera = np.column_stack([0.6 * np.sin(2 * np.pi * k / 30), 0.3 * np.sin(2 * np.pi * k / 30),
                              0.3 * np.sin(2 * np.pi * k / 40 + 0.5),
                              0.003 * np.sin(2 * np.pi * k / 50)])
    throw = Throw(speed_in=2.4, angle_in=35.0, t_contact=0.0405, x_contact=0.07)
    shot = Shot(width=240, height=120, radius_px=12.0, n_frames=n, surface_v=100.0,
                slope_deg=2.0, sigma_px=0.7, exposure=0.3, supersample=2,
                camera=tuple(map(tuple, camera)), throw=throw)
    folder = tmp_path / "clip"
    folder.mkdir()
    for i, frame in enumerate(render(shot)):
        cv2.imwrite(str(folder / f"{i:04d}.png"), frame)
    assert main(["track", str(folder), "--out", str(tmp_path / "out"), "--fps", "1000",
                 "--ball-diameter", str(shot.diameter_m)]) == 0
    assert "turned by up to" in capsys.readouterr().out
    record = json.loads((tmp_path / "out" / "clip.track.json").read_text())
    told = np.column_stack([record["per_frame"]["camera_turn_deg"],
                            record["per_frame"]["camera_zoom"]])
    # against the background's own pose (the frames' median): the truth less a constant
    off = told - camera[:, 2:]
    off -= np.median(off, axis=0)
    assert np.all(np.sqrt(np.mean(off**2, axis=0)) < [0.02, 0.0002])
    fit = fit_kinematics(read_trajectory(tmp_path / "out" / "clip.csv"))
    assert abs(fit.incidence_angle - throw.angle_in) < 3 * fit.incidence_angle_se
    assert abs(fit.rebound_angle - throw.rebound_angle()) < 3 * fit.rebound_angle_se
    sd = np.hypot(fit.rebound_speed_se, fit.rebound_speed * fit.scale_rel_sd)
    assert abs(fit.rebound_speed - throw.rebound_speed()) < 3 * sd


@pytest.mark.parametrize("size", [(64, 224), (480, 640)])
def test_the_shift_search_reads_a_grid_not_the_frame(size):
    # the cost every video pays: about GRID pixels of each frame read (not the frame), so
    # that the tracker's speed targets hold (benchmarks/tracking.py measures it)
    frames = np.random.default_rng(0).integers(40, 60, (3, *size), dtype=np.uint8)
    seen = []
    real = _camera._shifts
    frame_shifts = _camera.frame_shifts

    def spy(f, *rest):
        seen.append(f.shape[1])
        return real(f, *rest)

    _camera._shifts = spy
    try:
        frame_shifts(frames, background_model(frames, 3))
    finally:
        _camera._shifts = real
    assert 0.5 * _camera.GRID <= seen[0] <= 1.5 * _camera.GRID
