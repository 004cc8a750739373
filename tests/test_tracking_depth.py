"""A ball that moves along the camera's axis: its picture grows or shrinks over the frames
(``bouncebayes.tracking._edge.depth_change``), which the tracker tells and words
(``depth_warning``).

Expected values: an independent least-squares line (SciPy's ``linregress``) for the change
and its SE; the renderer's ``approach`` (tests/render_pbr.py: the ball's picture ``1 / (1 -
approach t)`` times its size at ``t = 0``) for the rendered clips."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy import stats

from bouncebayes.tracking import depth_warning, track_ball
from bouncebayes.tracking._edge import DEPTH_WARNING, depth_change, depth_told


def test_the_change_is_a_straight_lines_through_the_radii():
    # expected: scipy.stats.linregress's slope and its SE, times the span over the mean radius
    rng = np.random.default_rng(0)
    frames = np.sort(rng.choice(80, 25, replace=False))
    radii = 12.0 / (1.0 - 0.0003 * frames) + rng.normal(0.0, 0.03, 25)
    fit = stats.linregress(frames, radii)
    span = np.ptp(frames) / radii.mean()
    change, se = depth_change(frames, radii)
    assert change == pytest.approx(fit.slope * span, rel=1e-9)
    assert se == pytest.approx(fit.stderr * span, rel=1e-9)
    # the picture's growth from the first frame to the last, to first order: 1 / (1 - a k)
    truth = (1.0 - 0.0003 * frames[0]) / (1.0 - 0.0003 * frames[-1]) - 1.0
    assert change == pytest.approx(truth, abs=4 * se + 0.003)
    assert depth_change(frames[:4], radii[:4]) is None  # too few radii for a line and its SE


def test_a_steady_picture_tells_nothing_and_a_growing_one_is_told():
    from bouncebayes.tracking._edge import RadiusFit

    frames = tuple(range(0, 80, 9))
    rng = np.random.default_rng(1)

    def fit_of(radii):
        return RadiusFit(12.0, 0.01, 0.7, 0.0, 1.0, frames, np.zeros((9, 2)),
                         radii=tuple(radii))

    # 1000 clips of a still ball's radii scattered by 0.03 px (0.25 %): none told
    for _ in range(1000):
        assert depth_told(fit_of(12.0 + rng.normal(0.0, 0.03, 9))) == 0.0
    grown = 12.0 * (1.0 + 0.02 * np.array(frames) / 72.0)  # 2 % over the frames
    assert depth_told(fit_of(grown + rng.normal(0.0, 0.01, 9))) == pytest.approx(0.02, abs=0.002)
    # clear but under DEPTH_WARNING: not told
    small = 12.0 * (1.0 + 0.5 * DEPTH_WARNING * np.array(frames) / 72.0)
    assert depth_told(fit_of(small)) == 0.0


@pytest.fixture(scope="module")
def approaching():
    from render_pbr import Shot, Throw, render

    def clip(approach: float):
        shot = Shot(width=240, height=120, radius_px=12.0, n_frames=80, surface_v=100.0,
                    slope_deg=2.0, sigma_px=0.7, exposure=0.3, supersample=2,
                    approach=approach,
                    throw=Throw(speed_in=2.4, angle_in=35.0, t_contact=0.0405,
                                x_contact=0.07))
        return shot, render(shot)

    return clip


def test_a_ball_coming_closer_is_told_and_the_scale_holds_it(approaching, tmp_path, capsys):
    import cv2

    from bouncebayes.cli import main
    from bouncebayes.tracking import Calibration

    # expected: the renderer's approach. 0.3 of its distance a second, over 79 ms: the
    # picture 2.4 % larger at the end; before, nothing was said and the incidence angle came
    # out 6 SE off (the trajectory is the ball's picture, not its path in the plane)
    shot, frames = approaching(0.3)
    track = track_ball(frames)
    grow = depth_told(track.radius_fit)
    first, last = min(track.radius_fit.frames), max(track.radius_fit.frames)
    truth = shot.depth_scale(last / shot.fps) / shot.depth_scale(first / shot.fps) - 1.0
    change, se = depth_change(track.radius_fit.frames, track.radius_fit.radii)
    assert grow == change and abs(change - truth) < 3 * se + 0.002
    assert "moves towards the camera" in depth_warning(track)
    # the scale's stated SD holds half the change (the median radius is one distance's)
    cal = Calibration.from_track(shot.diameter_m, track)
    assert cal.relative_sd >= 0.5 * abs(change)
    folder = tmp_path / "clip"
    folder.mkdir()
    for i, frame in enumerate(frames):
        cv2.imwrite(str(folder / f"{i:04d}.png"), frame)
    assert main(["track", str(folder), "--out", str(tmp_path / "out"), "--fps", "1000",
                 "--ball-diameter", str(shot.diameter_m)]) == 0
    assert "moves towards the camera" in capsys.readouterr().out
    ball = json.loads((tmp_path / "out" / "clip.track.json").read_text())["ball"]
    assert ball["picture_growth"] == pytest.approx(change, abs=1e-4)
    assert "moves towards the camera" in ball["depth_warning"]


def test_a_ball_moving_away_is_told_and_a_still_one_not(approaching):
    _, frames = approaching(-0.3)
    assert "moves away from the camera" in depth_warning(track_ball(frames))
    _, still = approaching(0.0)
    track = track_ball(still)
    assert depth_warning(track) is None and depth_told(track.radius_fit) == 0.0
