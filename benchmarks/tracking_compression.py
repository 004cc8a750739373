"""The scale under strong JPEG compression: the calibration of ``COMPRESSION_PX``.

Scenes of ``benchmarks/tracking_accuracy.py`` (``tests/render_pbr.py``, independent of the
tracker): radius 5, 10 and 15 px; lens blur 0 and 0.7 px; exposure 40 %; side-lit, glossy and
dark balls; textured wall. Each frame is coded as a JPEG at quality 70, 60, 50, 40 and 30
(``cv2.imencode``, libjpeg's IJG tables; the quality the tracker reads back from such frames is
the one set, ``tests/test_tracking.py``) and decoded, then tracked; the scale's stated relative
SD is the tracker's (``Calibration.from_ball_diameter`` with the frames' quality). Seeds 8 and 3
chose ``COMPRESSION_PX`` (``calibration``); seed 5 was not used to choose it (``held_out``).

Per scene: the radius error (= the ``--ball-diameter`` scale's), the stated SD, z, the method
(edge model, small-ball fit). Summary per group and per quality and radius: the largest |error|
and |z| and the RMS z.

``python benchmarks/tracking_compression.py`` writes
``benchmarks/results/tracking_compression.json``; the last stdout line is the summary.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import json  # noqa: E402
import math  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402

import cv2  # noqa: E402
import numpy as np  # noqa: E402

from bouncebayes.tracking import Calibration, track_ball  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from render_pbr import render  # noqa: E402
from tracking_accuracy import shot_for  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results" / "tracking_compression.json"
GROUPS = {"calibration": (8, 3), "held_out": (5,)}
QUALITIES = (70, 60, 50, 40, 30)


def jpeg(frames: np.ndarray, quality: int) -> np.ndarray:
    """Each frame through a JPEG of ``quality`` and back."""
    return np.stack([cv2.imdecode(cv2.imencode(".jpg", f, [cv2.IMWRITE_JPEG_QUALITY, quality])[1],
                                  cv2.IMREAD_GRAYSCALE) for f in frames])


def scene_rows(seed: int, radius: float, sigma: float, light: str) -> list[dict]:
    """One rendered scene at every quality."""
    shot = shot_for(radius, sigma, 0.4, light, None, seed, "textured")
    frames = render(shot)
    rows = []
    for q in QUALITIES:
        track = track_ball(jpeg(frames, q))
        cal = Calibration.from_track(shot.diameter_m, track, q)
        err = 100 * (track.ball_radius / radius - 1)
        sd = 100 * cal.relative_sd
        rows.append({"seed": seed, "quality": q, "radius_px": radius, "sigma_px": sigma,
                     "lighting": light, "scale_error_pct": round(err, 3),
                     "stated_sd_pct": round(sd, 3), "z": round(err / sd, 2),
                     "method": track.radius_fit.method})
        print(json.dumps(rows[-1]), file=sys.stderr, flush=True)
    return rows


def summary(rows: list[dict]) -> dict:
    """Largest |error| and |z|, RMS z, per quality and radius."""
    out = {}
    for q in QUALITIES:
        for r in (5.0, 10.0, 15.0):
            sel = [x for x in rows if x["quality"] == q and x["radius_px"] == r]
            if not sel:
                continue
            z = np.array([x["z"] for x in sel])
            out[f"q{q}_r{r:g}"] = {
                "n": len(sel),
                "max_abs_error_pct": max(abs(x["scale_error_pct"]) for x in sel),
                "max_abs_z": float(np.abs(z).max()),
                "rms_z": round(math.sqrt(float(np.mean(z * z))), 2)}
    z = np.array([x["z"] for x in rows])
    out["all"] = {"n": len(rows), "max_abs_z": float(np.abs(z).max()),
                  "rms_z": round(math.sqrt(float(np.mean(z * z))), 2)}
    return out


def main() -> dict:
    rows = {group: [row for seed in seeds for radius in (5.0, 10.0, 15.0)
                    for sigma in (0.0, 0.7) for light in ("side", "glossy", "dark")
                    for row in scene_rows(seed, radius, sigma, light)]
            for group, seeds in GROUPS.items()}
    result = {"benchmark": "tracking_compression",
              "summary": {group: summary(r) for group, r in rows.items()},
              "rows": [row for r in rows.values() for row in r]}
    RESULTS.write_text(json.dumps(result, indent=1) + "\n")
    print(json.dumps({g: s["all"] for g, s in result["summary"].items()}))
    return result


if __name__ == "__main__":
    main()
