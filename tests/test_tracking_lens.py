"""A lens that bends straight lines, told by the surface edge (bouncebayes.tracking._lens).

Expected values: the division model's closed form (a straight line bent by a known lambda),
and, for a rendered clip, the bend the test applies (a polynomial lens, ``r_d = r_u (1 + k1
r_u^2)``, another model than the one fitted) in its own arithmetic."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bouncebayes.tracking._lens import bend, bend_message


def step(line_v: np.ndarray, shape=(270, 480)) -> np.ndarray:
    """A step image: grey 40 above the line ``v = line_v[u]`` (one value a column), 200 below,
    each pixel the share of it below the line (its area, the line straight across it)."""
    vv = np.arange(shape[0], dtype=np.float64)[:, None]
    return 40.0 + 160.0 * np.clip(vv + 0.5 - line_v[None, :], 0.0, 1.0)


def bent_edge(lam: float, shape=(270, 480), height: float = 235.0) -> np.ndarray:
    """A step image (:func:`step`) along the line ``v = height`` seen through the division model
    ``x_u = c + (x_d - c) / (1 + lam r_d^2)`` (``r_d`` in half-diagonals from the centre):
    each undistorted point mapped to the distorted image by solving for ``r_d`` (bisection),
    the edge's row in each column interpolated between them."""
    h, w = shape
    c, scale = np.array([(w - 1) / 2, (h - 1) / 2]), math.hypot(w, h) / 2
    points = []
    for u in np.linspace(-200.0, w + 200.0, 8 * w):
        p = np.array([u, height]) - c
        ru = math.hypot(*p) / scale
        lo, hi = 0.0, 3.0  # r_u = r_d / (1 + lam r_d^2), increasing in r_d over this range
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if mid / (1 + lam * mid * mid) < ru else (lo, mid)
        points.append(c + p * (lo / ru))
    uq, vq = np.array(points).T
    return step(np.interp(np.arange(w, dtype=np.float64), uq, vq), shape)


@pytest.mark.parametrize("lam", [-0.10, -0.03, 0.05])
def test_the_division_model_that_bent_an_edge_is_found(lam):
    lens = bend(bent_edge(lam), (0.0, 235.0), (1.0, 0.0))
    assert lens.significant
    assert abs(lens.lam - lam) <= max(4 * lens.lam_se, 0.004)
    assert (lens.sagitta_px > 0) == (lam < 0)  # barrel: the middle away from the centre
    assert ("barrel" in bend_message(lens)) == (lam < 0)


def test_a_straight_edge_is_not_said_to_bend():
    lens = bend(bent_edge(0.0), (0.0, 235.0), (1.0, 0.0))
    assert not lens.significant and abs(lens.lam) < 0.003 and bend_message(lens) is None


@pytest.mark.parametrize("x0", [0.0, 0.3, 0.7])
def test_a_bow_whose_vertex_is_not_over_the_centre_is_not_a_lens(x0):
    from bouncebayes.tracking._lens import EXPLAINED, VERTEX

    # expected (closed form): a step edge along v = 235 + 3 (x - x0)^2, x = (u - 239.5) /
    # 239.5, whose vertex is x0 half-lengths from the foot of the frame's centre on the line
    # (x = 0), where a lens centred on the frame puts it. The division model straightens
    # each as well (explained 0.92-0.93); only the vertex tells the one at 0.7, an edge the
    # wall's texture made over a third of the surface's (benchmarks/tracking_lens.py)
    u = np.arange(480)
    lens = bend(step(235 + 3.0 * ((u - 239.5) / 239.5 - x0) ** 2), (0.0, 235.0), (1.0, 0.0))
    assert abs(lens.vertex - x0) < 0.05 and lens.explained >= EXPLAINED
    assert lens.significant == (x0 <= VERTEX)


def test_a_bow_the_edge_follows_over_half_its_length_is_not_a_lens():
    from bouncebayes.tracking._lens import COVERAGE, EXPLAINED

    # expected (closed form): a step edge along the barrel bow v = 235 + 3 (1 - x^2) in every
    # other stretch of 40 px, and along the straight v = 231 between them at half the
    # contrast: the bow is read (3 px, its vertex over the centre, explained by the division
    # model as a lens's is) but the edge follows it over half its length, as a wall's texture
    # over a faint step made one (benchmarks/tracking_surface.py). The same bow over the whole
    # edge is a lens's
    u = np.arange(480)
    bow = 235 + 3.0 * (1 - ((u - 239.5) / 239.5) ** 2)
    whole = bend(step(bow), (0.0, 235.0), (1.0, 0.0))
    assert whole.significant and whole.coverage > 0.95
    half = ((u + 20) // 40) % 2 == 0  # the bow at both ends and over the middle
    img = np.where(half, step(bow), 120.0 + 0.5 * (step(np.full(480, 231.0)) - 120.0))
    lens = bend(img, (0.0, 235.0), (1.0, 0.0))
    assert abs(lens.sagitta_px - 3.0) < 0.3 and lens.vertex < 0.1
    assert lens.explained >= EXPLAINED and abs(lens.sagitta_px) > 5 * lens.sagitta_se_px
    assert abs(lens.coverage - 0.5) < 0.1 and lens.coverage < COVERAGE
    assert not lens.significant


def test_a_clip_through_a_wide_lens_is_said_to_bend_lines_and_undistorted(tmp_path, capsys):
    import json

    import cv2
    from render_pbr import Shot, Throw, render

    from bouncebayes.cli import main
    from bouncebayes.kinematics import fit_kinematics, read_trajectory

    # a 480 x 270 clip bent by a polynomial lens r_d = r_u (1 - 0.25 r_u^2) (r in frame
    # widths from the centre): lengths at the corners 9.8 % short (0.625 -> 0.564 widths).
    # Before, nothing was said: the surface came out at 1.14 degrees (truth 0) and the
    # incidence angle 1.75 degrees off. Expected: the renderer's throw and surface
    throw = Throw(speed_in=3.0, angle_in=40.0, t_contact=0.05, x_contact=0.16)
    shot = Shot(width=480, height=270, radius_px=8.0, n_frames=110, surface_v=235.0,
                slope_deg=0.0, sigma_px=0.7, exposure=0.3, supersample=2, throw=throw)
    frames = render(shot)
    h, w = frames.shape[1:]
    vv, uu = np.mgrid[:h, :w].astype(np.float64)
    xd, yd = (uu - w / 2) / w, (vv - h / 2) / w
    rd = np.hypot(xd, yd)
    ru = rd.copy()
    for _ in range(30):  # Newton: r_u (1 - 0.25 r_u^2) = r_d
        ru -= (ru * (1 - 0.25 * ru**2) - rd) / (1 - 0.75 * ru**2)
    g = np.where(rd > 0, ru / np.maximum(rd, 1e-12), 1.0)
    mu, mv = (w / 2 + w * xd * g).astype(np.float32), (h / 2 + w * yd * g).astype(np.float32)
    bent = np.array([cv2.remap(f, mu, mv, cv2.INTER_CUBIC, borderMode=cv2.BORDER_REPLICATE)
                     for f in frames])
    for name, clip, lens in (("straight", frames, "auto"), ("bent", bent, "none"),
                             ("undistorted", bent, "auto")):
        folder = tmp_path / name
        folder.mkdir()
        for i, f in enumerate(clip):
            cv2.imwrite(str(folder / f"{i:04d}.png"), f)
        out = tmp_path / "out"
        assert main(["track", str(folder), "--out", str(out), "--fps", "1000",
                     "--ball-diameter", str(shot.diameter_m), "--lens", lens]) == 0
        said = capsys.readouterr().out
        record = json.loads((out / f"{name}.track.json").read_text())
        if name == "straight":
            assert "lens:" not in said and record["lens"]["warning"] is None
            continue
        assert "lens: the surface edge bows" in said and "barrel" in said
        # the corners' lengths: -9.8 % in the lens applied; the division model, fitted to one
        # edge, within 2 percentage points
        assert abs(record["lens"]["division_lambda"] - (-0.098)) < 0.02
        fit = fit_kinematics(read_trajectory(out / f"{name}.csv"))
        if name == "bent":
            assert "off with them" in said and not record["lens"]["undistorted"]
            assert abs(record["surface"]["angle_deg"]) > 0.8
        else:
            assert "were undistorted" in said and record["lens"]["undistorted"]
            assert (out / f"{name}.overlay.png").is_file()
            assert abs(record["surface"]["angle_deg"]) < 0.1
            assert abs(fit.incidence_angle - throw.angle_in) < 3 * fit.incidence_angle_se
            assert abs(fit.rebound_angle - throw.rebound_angle()) < 3 * fit.rebound_angle_se


@pytest.mark.parametrize("lam", [-0.15, 0.08])
def test_undistorting_inverts_the_division_model(lam):
    from bouncebayes.tracking._lens import _source, undistort, undistort_points

    # closed form: x_u = c + (x_d - c) / (1 + lam r_d^2), and where each undistorted pixel
    # is sampled in the frame as taken (its root), the same points back
    shape = (270, 480)
    pts = np.random.default_rng(1).uniform([0, 0], [480, 270], (200, 2))
    assert np.allclose(undistort_points(_source(pts, lam, shape), lam, shape), pts, atol=1e-9)
    # a frame: a vertical bar at u = 340 bent, and undistorted, straight again at 340
    frame = np.zeros((1, *shape), np.uint8)
    bar = _source(np.column_stack([np.full(3000, 340.0), np.linspace(-60.0, 330.0, 3000)]),
                  lam, shape)
    for u, v in bar:
        if 0 <= round(v) < 270 and 1 <= round(u) < 479:
            frame[0, int(round(v)), int(round(u)) - 1:int(round(u)) + 2] = 255
    def columns(img):
        img = img.astype(float)[20:250]
        return (img * np.arange(480)).sum(axis=1) / img.sum(axis=1)

    assert np.abs(columns(frame[0]) - 340.0).max() >= 2.0  # bent by the lens
    # straight again, to the drawing's rounding to whole pixels (<= 0.5 px)
    assert np.abs(columns(undistort(frame, lam)[0]) - 340.0).max() < 0.8


def test_a_frame_counter_burned_in_beside_the_surface_is_not_a_lens(tmp_path):
    from render_pbr import Shot, Throw, burn_counter, render, write

    from bouncebayes.tracking import track_video
    from bouncebayes.tracking._lens import EXPLAINED, SPREAD

    # expected: the renderer's radius (10 px) and a straight surface edge (no lens). A high-
    # speed camera's frame counter burned into the lower right corner: a black box whose top
    # edge lies 4 px under a faint surface step (wall 50, plane 30 grey levels) and white
    # digits that change every frame. Before, the box's edge took most of Canny's pixels the
    # bow was read from (3 % of them in the edge's first third) and read as a bow of 7.3 +-
    # 0.5 px: the frames were "undistorted", the radius came out 10.77 px and the picture shrinking
    # by 20 %, all said as the video's. MJPEG, as the camera would store it
    shot = Shot(width=320, height=200, radius_px=10.0, n_frames=90, surface_v=170.0,
                slope_deg=2.0, sigma_px=0.6, exposure=0.2, supersample=3, seed=4,
                throw=Throw(speed_in=2.5, angle_in=35.0, t_contact=0.045, x_contact=0.1))
    frames = render(shot)
    burn_counter(frames, 317, 196, right=True)
    video = track_video(write(frames, tmp_path / "counter.avi", 1000.0, "MJPG"), fps=1000.0,
                        ball_diameter=shot.diameter_m)
    # read from the edge's sub-pixel positions, the bow is the surface's (its positions spread
    # along it) and explains little (0.21): the box's edge pulls the positions near the right
    # end by up to a pixel
    assert video.lens is not None and video.lens.spread >= SPREAD
    assert video.lens.explained < EXPLAINED
    assert not video.lens.significant and video.undistorted is None
    assert abs(video.track.ball_radius / 10.0 - 1) < 0.01
    assert abs(video.surface.angle + 2.0) < 3 * video.surface.angle_sd_deg
