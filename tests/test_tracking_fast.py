"""The compiled per-frame tracking path (``tracking/_fast.py``) against the Python path it
replaces (``tracking/_measure.py``, kept as the reference) and its hand-written building blocks
against OpenCV.

Expected values: the Python path of the same tracker on the same frames (an independent
implementation of the same arithmetic, with OpenCV's connected components and Gaussian blur),
and OpenCV itself for the blocks. Both paths compute in float64, so they agree to rounding
(measured: centres within 3e-13 px here, 2.4e-12 px over 180 random scenes of
tests/video_helpers.py); the tolerance, 1e-6 px, is the one the compiled path was asked to hold.
"""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from video_helpers import Bounce, Scene, render

from bouncebayes.tracking import EDGE_FIT, NOT_FOUND, TrackerConfig
from bouncebayes.tracking._fast import _blur, _largest_blob, gaussian_kernel
from bouncebayes.tracking._track import _track_ball

NO_EDGE_MODEL = TrackerConfig(edge_model=False)


def both(frames, config=NO_EDGE_MODEL):
    return (_track_ball(frames, config, None, compiled=True),
            _track_ball(frames, config, None, compiled=False))


def assert_same(fast, ref):
    np.testing.assert_array_equal(fast.method, ref.method)  # same found / not found, method
    np.testing.assert_array_equal(fast.flag, ref.flag)
    np.testing.assert_allclose(fast.centre, ref.centre, rtol=0, atol=1e-6)  # NaN where lost
    np.testing.assert_allclose(fast.radius, ref.radius, rtol=0, atol=1e-6)
    np.testing.assert_allclose(fast.contrast, ref.contrast, rtol=1e-9)
    np.testing.assert_allclose(fast.residual, ref.residual, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(fast.visible, ref.visible, rtol=0, atol=1e-12)


def test_a_lost_ball_and_the_full_frame_search_that_finds_it_again():
    scene, bounce = Scene(n_frames=60), Bounce()
    frames = render(scene, bounce)
    frames[20:25] = np.median(frames, axis=0).astype(np.uint8)  # the ball gone for 5 frames
    fast, ref = both(frames)
    assert (ref.method[20:25] == NOT_FOUND).all() and ref.found.sum() == 55  # not vacuous
    assert_same(fast, ref)


def test_a_ball_cut_by_the_frame_edge_gets_the_same_edge_fits():
    scene, bounce = Scene(n_frames=60), Bounce(x_contact=0.02)  # enters from the left edge
    fast, ref = both(render(scene, bounce))
    assert (ref.method == EDGE_FIT).sum() >= 5
    assert_same(fast, ref)


@pytest.mark.parametrize("kw", [
    dict(ball_centre_grey=20, ball_rim_grey=45, background_grey=140, flicker=0.1),  # dark
    dict(exposure=1.0, noise_sigma=4.0, shadow=True),  # motion blur, noise, shadow correction
])
def test_dark_flickering_blurred_and_shadowed_balls(kw):
    fast, ref = both(render(Scene(n_frames=60, **kw), Bounce()))
    assert ref.found.all()
    assert_same(fast, ref)


def test_the_papers_camera_after_mjpeg(tmp_path):
    # the independent renderer (tests/render_pbr.py): 224 x 64, a 10 px ball, side light,
    # lens blur, MJPEG. Without the edge model, which both paths share: its least-squares fits
    # move by ~0.005 px when their starting centres move by 1e-13 px (measured on this clip),
    # so it would turn the paths' rounding differences into differences of its own
    from render_pbr import Shot, Throw, render as render_pbr, write

    from bouncebayes.tracking import read_frames

    shot = Shot(width=224, height=64, radius_px=5.0, n_frames=60, surface_v=50.0,
                slope_deg=3.0, sigma_px=0.6, exposure=0.5, light=(-0.15, 0.25, 0.95),
                supersample=2, seed=6, throw=Throw(speed_in=2.0, angle_in=35.0,
                                                    t_contact=0.03, x_contact=0.05))
    frames = read_frames(write(render_pbr(shot), tmp_path / "casio.avi", 1000.0, "MJPG")).frames
    fast, ref = both(frames)
    assert ref.found.sum() >= 40
    assert_same(fast, ref)


@pytest.mark.parametrize("shape", [(3, 3), (5, 40), (17, 9), (66, 70)])
def test_the_blur_is_opencvs(shape):
    rng = np.random.default_rng(sum(shape))
    img = rng.random(shape)
    img[rng.random(shape[0]) < 0.3] = 0.0  # zero rows, which the blur skips
    expected = cv2.GaussianBlur(img, (0, 0), 2.0)  # reference: OpenCV, reflected borders
    np.testing.assert_allclose(_blur(img, gaussian_kernel(), img.any(axis=1)), expected,
                               rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("seed", range(6))
def test_the_largest_blob_is_opencvs(seed):
    mask = np.random.default_rng(seed).random((30, 41)) < 0.45
    # reference: OpenCV's 8-connected components, the largest (first in its numbering on a tie)
    n, labels, stats, cents = cv2.connectedComponentsWithStats(mask.view(np.uint8),
                                                               connectivity=8)
    i = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    blob, area, cx, cy, bw, bh = _largest_blob(mask)
    np.testing.assert_array_equal(blob, labels == i)
    assert (area, bw, bh) == (stats[i, cv2.CC_STAT_AREA], stats[i, cv2.CC_STAT_WIDTH],
                              stats[i, cv2.CC_STAT_HEIGHT])
    assert (cx, cy) == (cents[i][0], cents[i][1])


def test_warmup_compiles_every_version_a_video_needs():
    # `bouncebayes warmup` runs _fast.warm(): afterwards a video -- read-only frames, integer
    # settings where floats are expected -- must not compile anything on the user's run
    from bouncebayes.tracking import _edge_kernel, _fast, _refine, track_ball

    _fast.warm()
    kernels = (_fast.measure_frames, _fast.edge_fits, _fast.quality_misfit,
               _edge_kernel.varpro, _edge_kernel.fit_frame, _refine.refine_frames,
               _refine.light_costs)
    compiled = [len(k.signatures) for k in kernels]
    assert compiled[-2] > 0 and compiled[-1] > 0  # the small-ball fit and its light's search
    frames = render(Scene(n_frames=60), Bounce(x_contact=0.02))
    frames.setflags(write=False)
    track = track_ball(frames, config=TrackerConfig(edge_model=False, min_contrast=12))
    assert (track.method == EDGE_FIT).any()  # the edge fits ran
    track_ball(frames, config=TrackerConfig(min_contrast=12))  # with the edge model
    # a small ball (the paper's camera), whose centres the small-ball fit refines
    small = render(Scene(width=224, height=64, radius_px=5.0, n_frames=60,
                         surface_point=(0.0, 52.0), inclination=3.0, exposure=0.5),
                   Bounce(speed_in=2.0, angle_in=35.0, t_contact=0.03, x_contact=0.05))
    assert track_ball(small).refined.any()
    small.setflags(write=False)
    assert track_ball(small).refined.any()
    assert [len(k.signatures) for k in kernels] == compiled
