"""The surface line and the lens read from it, on rendered clips with and without a lens.

``track_video`` finds the surface line in the background model (``detect_surface``) and reads
the lens from the bow of its edge (``_lens.bend``; docs/tracking.md §1). Both go wrong
where a wall's texture makes edges of its own by a faint surface step. This benchmark renders
(``tests/render_pbr.py``, independent of the tracker) three scenes x four lenses x four walls:

- ``wide``: 480 x 270, an 8 px ball, the surface flat 35 px from the bottom, blur 0.7 px (the
  scene of ``tests/test_tracking_lens.py``);
- ``faint``: 320 x 200, a 10 px ball, the surface at 2 degrees over a faint step (a wall of 50
  +- 10 grey levels over a plane of 30), blur 0.6 px, MJPEG;
- ``small``: 160 x 96, a glossy 5 px ball, the surface flat 8 px from the bottom, blur 1.5 px,
  MJPEG (``tracking_accuracy.shot_for``'s scene);

each bent by a polynomial lens ``r_d = r_u (1 + k1 r_u^2)`` (``r`` in frame widths from the
centre; k1 0, -0.08, -0.25, +0.1: another model than the division model the tracker fits),
tracked (``track_ball``) and the surface and lens read as ``track_video`` reads them.

For each: the surface's angle, its stated SD and, without a lens, z against the renderer's;
the bow's sagitta, SE, explained variance, spread, vertex, coverage and lambda, whether a lens
is said, the bow the lens gives the renderer's line (``true_sagitta``), and the share of 15
small moves of the line given (0.3 px across, 0.1 degree turned; ``MOVES``) under which a lens
is said: a call that flips under them is on a knife-edge. Summary per scene and lens: how many
said a lens, the share under the moves and the clips whose call a move changes; the sagitta's
RMS error; without a lens, the surfaces' z RMS and largest |z|.

``python benchmarks/tracking_lens.py [--jobs 2]`` writes
``benchmarks/results/tracking_lens.json`` (~10 min on 2 cores).
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import itertools  # noqa: E402
import math  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

SCENES, LENSES, SEEDS = ("wide", "faint", "small"), (0.0, -0.08, -0.25, 0.1), tuple(range(8))
# the line given moved across (px) and turned (degrees): is the lens said the same?
MOVES = tuple(itertools.product((-0.3, 0.0, 0.3), (-0.1, -0.03, 0.0, 0.03, 0.1)))


def shot_for(scene: str, seed: int):
    from render_pbr import Shot, Throw
    from tracking_accuracy import shot_for as accuracy_shot

    if scene == "wide":
        return Shot(width=480, height=270, radius_px=8.0, n_frames=110, surface_v=235.0,
                    slope_deg=0.0, sigma_px=0.7, exposure=0.3, supersample=2, seed=seed,
                    throw=Throw(speed_in=3.0, angle_in=40.0, t_contact=0.05, x_contact=0.16))
    if scene == "faint":
        return Shot(width=320, height=200, radius_px=10.0, n_frames=90, surface_v=170.0,
                    slope_deg=2.0, sigma_px=0.6, exposure=0.2, supersample=3, seed=seed,
                    codec="MJPG",
                    throw=Throw(speed_in=2.5, angle_in=35.0, t_contact=0.045, x_contact=0.1))
    return accuracy_shot(5.0, 1.5, 0.3, "glossy", "MJPG", seed + 7)


def bent(frames: np.ndarray, k1: float) -> np.ndarray:
    """The frames seen through ``r_d = r_u (1 + k1 r_u^2)`` (r in frame widths from the
    centre): each pixel of the bent frame sampled where its undistorted point lies (Newton
    for r_u, bicubic)."""
    import cv2

    if k1 == 0.0:
        return frames
    h, w = frames.shape[1:]
    vv, uu = np.mgrid[:h, :w].astype(np.float64)
    xd, yd = (uu - w / 2) / w, (vv - h / 2) / w
    rd = np.hypot(xd, yd)
    ru = rd.copy()
    for _ in range(30):
        ru -= (ru * (1 + k1 * ru**2) - rd) / (1 + 3 * k1 * ru**2)
    g = np.where(rd > 0, ru / np.maximum(rd, 1e-12), 1.0)
    mu, mv = (w / 2 + w * xd * g).astype(np.float32), (h / 2 + w * yd * g).astype(np.float32)
    return np.array([cv2.remap(f, mu, mv, cv2.INTER_CUBIC, borderMode=cv2.BORDER_REPLICATE)
                     for f in frames])


def true_sagitta(scene: str, k1: float, seed: int = 0) -> float:
    """The bow (px) the lens gives the renderer's surface line, read as ``_lens.bend`` reads
    it (a parabola across the chord of its part in the frame; positive for a barrel's): the
    line's points mapped through ``r_d = r_u (1 + k1 r_u^2)``."""
    shot = shot_for(scene, seed)
    w, h = shot.width, shot.height
    u = np.linspace(-0.3 * w, 1.3 * w, 4001)
    v = shot.surface_v - math.tan(math.radians(shot.slope_deg)) * (u - w / 2)
    xu, yu = (u - w / 2) / w, (v - h / 2) / w
    g = 1 + k1 * (xu**2 + yu**2)
    ud, vd = w / 2 + w * xu * g, h / 2 + w * yu * g
    keep = (ud >= 0) & (ud <= w - 1) & (vd >= 0) & (vd <= h - 1)
    ud, vd = ud[keep], vd[keep]
    e = np.array([ud[-1] - ud[0], vd[-1] - vd[0]]) / math.hypot(ud[-1] - ud[0], vd[-1] - vd[0])
    along = (ud - ud[0]) * e[0] + (vd - vd[0]) * e[1]
    across = (ud - ud[0]) * e[1] - (vd - vd[0]) * e[0]
    x = (along - along.mean()) / (0.5 * (along.max() - along.min()))
    # signed as ``bend`` signs it: positive where the middle lies away from the frame's centre
    cu, cv, mu, mv = (w - 1) / 2, (h - 1) / 2, ud.mean(), vd.mean()
    towards = math.copysign(1.0, (cu - mu) * e[1] - (cv - mv) * e[0])
    return float(np.polyfit(x, across, 2)[0]) * towards


def said_moved(background: np.ndarray, line) -> float:
    """The share of ``MOVES`` of the line given under which a lens is said."""
    from bouncebayes.tracking._lens import bend

    a0 = math.atan2(line.direction[1], line.direction[0])
    said = []
    for across, turn in MOVES:
        a = a0 + math.radians(turn)
        e = np.array([math.cos(a), math.sin(a)])
        lens = bend(background, np.asarray(line.point) + across * np.array([-e[1], e[0]]), e)
        said.append(lens is not None and lens.significant)
    return float(np.mean(said))


def clip(g: tuple) -> dict:
    """One clip: the surface and the lens as ``track_video`` reads them."""
    from render_pbr import render

    from bouncebayes.tracking import detect_surface, track_ball
    from bouncebayes.tracking._lens import bend

    scene, k1, seed = g
    shot = shot_for(scene, seed)
    track = track_ball(bent(render(shot), k1))
    line = detect_surface(track.background, centres=track.centre[track.found],
                          radius=track.ball_radius)
    row = {"scene": scene, "k1": k1, "seed": seed, "surface_found": line is not None}
    if line is None:
        return row
    truth = -shot.slope_deg  # the image's v points down
    row.update(angle_deg=round(line.angle, 4), angle_sd_deg=round(line.angle_sd_deg, 4),
               z=round((line.angle - truth) / line.angle_sd_deg, 2) if k1 == 0 else None)
    lens = bend(track.background, line.point, line.direction)
    if lens is not None:
        row.update(sagitta_px=round(lens.sagitta_px, 3), sagitta_se_px=round(lens.sagitta_se_px, 3),
                   explained=round(lens.explained, 3), spread=round(lens.spread, 3),
                   vertex=round(lens.vertex, 3), coverage=round(lens.coverage, 3),
                   lam=round(lens.lam, 4), said=bool(lens.significant),
                   said_moved=round(said_moved(track.background, line), 3),
                   true_sagitta_px=round(true_sagitta(scene, k1, seed), 3))
    else:
        row["said"] = False
    return row


def summary(rows: list[dict]) -> dict:
    out = {}
    for scene, k1 in itertools.product(SCENES, LENSES):
        sel = [r for r in rows if r["scene"] == scene and r["k1"] == k1]
        moved = [r["said_moved"] for r in sel if "said_moved" in r]
        entry = {"n": len(sel), "surface_found": sum(r["surface_found"] for r in sel),
                 "lens_said": sum(bool(r.get("said")) for r in sel),
                 "said_under_moves": round(float(np.mean(moved)), 3) if moved else None,
                 "clips_whose_call_a_move_changes": sum(0 < m < 1 for m in moved)}
        if k1 != 0.0:
            err = [r["sagitta_px"] - r["true_sagitta_px"] for r in sel if "sagitta_px" in r]
            entry["sagitta_error_rms_px"] = round(float(np.sqrt(np.mean(np.square(err)))), 3) \
                if err else None
        if k1 == 0.0:
            z = np.array([r["z"] for r in sel if r.get("z") is not None])
            if z.size:
                entry.update(z_rms=round(float(np.sqrt(np.mean(z**2))), 2),
                             max_abs_z=round(float(np.max(np.abs(z))), 2))
        out[f"{scene} k1={k1:g}"] = entry
    return out


def main(argv=None) -> dict:
    from _grid import run_grid

    return run_grid("tracking_lens", __doc__.splitlines()[0], clip,
                    list(itertools.product(SCENES, LENSES, SEEDS)), summary, argv)


if __name__ == "__main__":
    main()
