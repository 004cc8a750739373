"""Centres of a ball larger than 8 px: coverage centroids against the per-frame fit of its rim.

Renders (``tests/render_pbr.py``: independent of the tracker) 48 bounces drawn at random (seed
5) from radius 10, 15, 20 px x lens blur 0, 0.7, 1.5 px x exposure 0, 80 % x side-lit,
glossy, dark ball x MJPEG or none x textured or plain wall, and 4 of a side-lit ball with a
dark stripe painted on it, turning at 150 rad/s (radius 10 and 15 px, blur 0.7 px, exposure
30 %, textured wall), and 8 of the same ball with a dark spot near its rim instead (a logo:
angular radius 0.3 and 0.5 rad, its centre 1.2 rad from the axis to the camera, turning alike;
seeds 1 and 2). Each is tracked twice, with the surface given and the scale from the
ball (``benchmarks/paper_camera.py``'s ``track_and_fit``: ``track_video`` on the frames,
``write_track_files``, ``fit_kinematics``):

- ``centroid``: the coverage centroids with the edge fits' offset, as the tracker gave every
  ball larger than 8 px before (the per-frame fit switched off for them here);
- ``fitted``: the tracker as it is, each frame's centre from the blurred, shaded disk fitted
  to the pixels near the rim (``bouncebayes.tracking._refine``).

For each: the centres' RMS error against the rendered truth (px) and about its mean (the
part that moves velocities), and the rebound speed's and angle's z-scores against the
rendered bounce (speed: the kinematics' SE and the scale's stated SD in quadrature). Summary
per mode and group (unmarked; marked, the stripe; spotted): medians and largest errors, the
largest scale error, the z-scores' RMS and how many exceed 2 and 3.

``python benchmarks/tracking_centres.py [--cache DIR] [--jobs 2]`` writes
``benchmarks/results/tracking_centres.json`` (~10 min on 2 cores with the renders cached,
~20 without).
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import itertools  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
from concurrent.futures import ProcessPoolExecutor  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from bouncebayes._io import write_json  # noqa: E402

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "tests"))
sys.path.insert(0, str(HERE))
from paper_camera import track_and_fit  # noqa: E402
from render_pbr import render  # noqa: E402
from tracking_accuracy import shot_for  # noqa: E402

RESULTS = HERE / "results" / "tracking_centres.json"
CODING = {"jpeg_quality": None, "bits_per_pixel": None}


def scenes() -> list[tuple]:
    """(radius, blur, exposure, lighting, codec, seed, wall, mark, spot) of every bounce."""
    grid = list(itertools.product((10.0, 15.0, 20.0), (0.0, 0.7, 1.5), (0.0, 0.8),
                                  ("side", "glossy", "dark"), (None, "MJPG"), (3,),
                                  ("textured", "plain"), (0.0,), (0.0,)))
    np.random.default_rng(5).shuffle(grid)
    marked = [(r, 0.7, 0.3, "side", None, seed, "textured", 0.25, 0.0)
              for r in (10.0, 15.0) for seed in (1, 2)]
    spotted = [(r, 0.7, 0.3, "side", None, seed, "textured", 0.0, spot)
               for r in (10.0, 15.0) for spot in (0.3, 0.5) for seed in (1, 2)]
    return grid[:48] + marked + spotted


def _centroids_only():
    """Switch the per-frame fit off for balls larger than ``SMALL_RADIUS`` (this process)."""
    from bouncebayes.tracking import _refine

    original = _refine.refine_centres

    def refine(frames, clean, gains, centre, method, fit):
        if fit is not None and fit.radius > _refine.SMALL_RADIUS:
            return _refine.Refined(np.zeros(len(frames), bool),
                                   np.full((len(frames), 2), np.nan))
        return original(frames, clean, gains, centre, method, fit)

    _refine.refine_centres = refine
    return original


def one(scene: tuple, cache: Path | None) -> dict:
    from bouncebayes.tracking import _refine

    r, sigma, exposure, lighting, codec, seed, wall, mark, spot = scene
    shot = dataclasses.replace(shot_for(r, sigma, exposure, lighting, codec, seed, wall),
                               mark=mark, spot=spot)
    name = "_".join(map(str, scene))
    frames = None
    if cache is not None and (cache / f"{name}.npy").exists():
        frames = np.load(cache / f"{name}.npy")
    if frames is None:
        frames = render(shot)
        if cache is not None:
            cache.mkdir(parents=True, exist_ok=True)
            np.save(cache / f"{name}.npy", frames)
    row: dict = {"radius_px": r, "sigma_px": sigma, "exposure": exposure, "lighting": lighting,
                 "codec": codec or "none", "wall": wall, "mark": mark, "spot": spot,
                 "seed": seed}
    truth = shot.true_centres()
    for mode in ("centroid", "fitted"):
        original = _centroids_only() if mode == "centroid" else None
        try:
            with tempfile.TemporaryDirectory() as tmp:
                track, fitted, _ = track_and_fit(frames, CODING, shot, Path(tmp))
        finally:
            if original is not None:
                _refine.refine_centres = original
        ok = track.trusted
        err = track.centre[ok] - truth[ok]
        about = err - err.mean(axis=0)
        row[mode] = {"centre_rms_px": round(float(np.sqrt(np.mean(np.sum(err**2, 1)))), 4),
                     "centre_rms_about_mean_px": round(
                         float(np.sqrt(np.mean(np.sum(about**2, 1)))), 4),
                     "refined": int(track.refined.sum()), "accepted": fitted["accepted"],
                     "rebound_speed_z": fitted["rebound_speed_z"],
                     "rebound_angle_z": fitted["rebound_angle_z"],
                     "scale_error_pct": fitted["scale_error_pct"]}
    return row


def summary(rows: list[dict], mode: str) -> dict:
    rms = np.array([r[mode]["centre_rms_px"] for r in rows])
    about = np.array([r[mode]["centre_rms_about_mean_px"] for r in rows])
    out = {"n": len(rows), "accepted": sum(r[mode]["accepted"] for r in rows),
           "centre_rms_px_median": round(float(np.median(rms)), 4),
           "centre_rms_px_max": round(float(rms.max()), 4),
           "centre_rms_about_mean_px_median": round(float(np.median(about)), 4),
           "centre_rms_about_mean_px_max": round(float(about.max()), 4),
           "scale_error_pct_max_abs": max(abs(r[mode]["scale_error_pct"]) for r in rows)}
    for key in ("rebound_speed_z", "rebound_angle_z"):
        z = np.array([r[mode][key] for r in rows if r[mode][key] is not None], float)
        if z.size == 0:  # every track rejected by the kinematics' gates
            out[key] = None
            continue
        out[key] = {"rms": round(float(np.sqrt(np.mean(z**2))), 2),
                    "max_abs": round(float(np.abs(z).max()), 2),
                    "beyond_2": int((np.abs(z) > 2).sum()), "beyond_3": int((np.abs(z) > 3).sum())}
    return out


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cache", type=Path, default=None, help="folder of rendered frames")
    ap.add_argument("--jobs", type=int, default=2)
    args = ap.parse_args(argv)
    todo = scenes()
    with ProcessPoolExecutor(args.jobs) as pool:
        rows = list(pool.map(one, todo, [args.cache] * len(todo)))
    groups = {"unmarked": [r for r in rows if r["mark"] == 0 and r["spot"] == 0],
              "marked": [r for r in rows if r["mark"] > 0],
              "spotted": [r for r in rows if r["spot"] > 0]}
    result = {"benchmark": "tracking_centres",
              "summary": {mode: {name: summary(group, mode) for name, group in groups.items()}
                          for mode in ("centroid", "fitted")},
              "rows": rows}
    write_json(RESULTS, result)  # atomic, as the package writes its results
    print(json.dumps(result["summary"]))
    return result


if __name__ == "__main__":
    main()
