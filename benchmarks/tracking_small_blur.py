"""The scale of a small ball blurred by a large part of its radius, between the sweep's blurs.

``benchmarks/tracking_accuracy.py`` renders blurs of 0, 0.7 and 1.5 px; at radius 5 px the
tracker changes how it takes the radius between them (docs/tracking.md §1 and §3): the
small-ball fit with the blur of the edge model's free fits held, or, above a fitted blur of
``_edge.WIDE_BLUR`` (0.15) of the radius on a textured wall, the frames fitted together with the
blur free
(``"frames' joint fit"``). This sweep fills the gap: ``tests/render_pbr.py`` (independent of
the tracker), 90-frame bounces in which the ball moves ~1.5 px a frame (as
``tracking_accuracy.py``'s scenes), radius 5 and 6.5 px x lens blur 1.0, 1.2, 1.5 px x
side-lit, glossy, dark ball x seeds 4, 5 x exposure 0 and 50 %, textured wall.

For each: the radius' error against the renderer's, the stated relative SD of the
``--ball-diameter`` scale (``Calibration.from_track``), their ratio (z), the method and the
fitted blur. Summary per method: how many, the error's range, mean and RMS, how many within
the 2 % target, the largest |z|.

``python benchmarks/tracking_small_blur.py [--jobs 2]`` writes
``benchmarks/results/tracking_small_blur.json`` (~6 min on 2 cores).
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import itertools  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

RADII, BLURS, SEEDS, EXPOSURES = (5.0, 6.5), (1.0, 1.2, 1.5), (4, 5), (0.0, 0.5)
LIGHTS = ("side", "glossy", "dark")


def scene(g: tuple) -> dict:
    """One rendered bounce tracked: the radius' error (%), stated SD (%), z, method, blur."""
    from render_pbr import render
    from tracking_accuracy import shot_for

    from bouncebayes.tracking import Calibration, track_ball

    radius, sigma, lighting, seed, exposure = g
    shot = shot_for(radius, sigma, exposure, lighting, None, seed)
    track = track_ball(render(shot))
    cal = Calibration.from_track(shot.diameter_m, track)
    err = track.ball_radius / radius - 1.0
    return {"radius_px": radius, "sigma_px": sigma, "lighting": lighting, "seed": seed,
            "exposure": exposure, "method": track.radius_fit.method,
            "error_pct": round(100 * err, 3), "stated_sd_pct": round(100 * cal.relative_sd, 3),
            "z": round(err / cal.relative_sd, 2),
            "fitted_sigma_px": round(track.radius_fit.sigma, 3)}


def summary(rows: list[dict]) -> dict:
    out = {}
    for method in sorted({r["method"] for r in rows}):
        sel = [r for r in rows if r["method"] == method]
        errs = np.array([r["error_pct"] for r in sel])
        out[method] = {"n": len(sel), "min_error_pct": float(errs.min()),
                       "max_error_pct": float(errs.max()),
                       "mean_error_pct": round(float(errs.mean()), 3),
                       "rms_error_pct": round(float(np.sqrt(np.mean(errs**2))), 3),
                       "within_2_pct": int(np.sum(np.abs(errs) <= 2.0)),
                       "max_abs_z": float(max(abs(r["z"]) for r in sel))}
    return out


def main(argv=None) -> dict:
    from _grid import run_grid

    return run_grid("tracking_small_blur", __doc__.splitlines()[0], scene,
                    list(itertools.product(RADII, BLURS, LIGHTS, SEEDS, EXPOSURES)), summary, argv)


if __name__ == "__main__":
    main()
