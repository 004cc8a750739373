"""The scale from the ball's edge in footage stored through a camera's tone curve.

Videos rendered by ``tests/render_pbr.py`` (independent of the tracker; the scenes of
``benchmarks/tracking_accuracy.py``: radius 5, 10 and 15 px, lens blur 0.7 and 1.5 px, no
exposure, side-lit, glossy and dark balls on a textured wall), their frames stored through the
sRGB curve (IEC 61966-2-1) or the BT.709 camera curve, then tracked twice: taken as linear in
light (``TrackerConfig()``, the tone curve not given) and decoded by the right curve
(``TrackerConfig(tone_curve=...)``). For each: the radius' relative error (= the
``--ball-diameter`` scale's) and the stated relative SD (``Calibration.from_ball_diameter``).

``python benchmarks/tracking_tone.py [--seed 4]`` writes ``benchmarks/results/tracking_tone.json``;
the last stdout line is the JSON summary.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import itertools  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from bouncebayes.tracking import Calibration, TrackerConfig, track_ball  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from render_pbr import render  # noqa: E402
from tracking_accuracy import shot_for  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results" / "tracking_tone.json"
GRID = list(itertools.product((5.0, 10.0, 15.0), (0.7, 1.5), ("side", "glossy", "dark"),
                              ("srgb", "rec709")))


def scenario(radius: float, sigma: float, lighting: str, tone: str, seed: int) -> dict:
    shot = dataclasses.replace(shot_for(radius, sigma, 0.0, lighting, None, seed), tone=tone)
    frames = render(shot)
    row: dict = {"radius_px": radius, "sigma_px": sigma, "lighting": lighting, "tone": tone,
                 "seed": seed}
    for name, config in (("as_linear", TrackerConfig()),
                         ("decoded", TrackerConfig(tone_curve=tone))):
        track = track_ball(frames, config=config)
        fit = track.radius_fit
        cal = Calibration.from_ball_diameter(shot.diameter_m, track.ball_radius,
                                             track.ball_radius_se, fit.sigma, fit.method)
        err = cal.metres_per_px / shot.metres_per_px - 1.0
        row[name] = {"scale_error_pct": round(100 * err, 3),
                     "stated_sd_pct": round(100 * cal.relative_sd, 3),
                     "z": round(err / cal.relative_sd, 2)}
    return row


def summary(rows: list[dict]) -> dict:
    out = {}
    for name in ("as_linear", "decoded"):
        for label, keep in (("radius_5", lambda r: r["radius_px"] == 5.0),
                            ("radius_10_plus", lambda r: r["radius_px"] >= 10.0)):
            sel = [r[name] for r in rows if keep(r)]
            err = np.array([s["scale_error_pct"] for s in sel])
            z = np.array([s["z"] for s in sel])
            out[f"{name}_{label}"] = {"n": len(sel),
                                      "max_abs_scale_error_pct": float(np.abs(err).max()),
                                      "median_abs_scale_error_pct": float(np.median(np.abs(err))),
                                      "max_abs_z": float(np.abs(z).max()),
                                      "beyond_3_sd": int((np.abs(z) > 3).sum())}
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=4, help="render seed")
    args = parser.parse_args()
    rows = []
    for radius, sigma, lighting, tone in GRID:
        row = scenario(radius, sigma, lighting, tone, args.seed)
        rows.append(row)
        print(json.dumps(row), flush=True)
    result = {"benchmark": "tracking_tone", "renderer": "tests/render_pbr.py",
              "summary": summary(rows), "scenarios": rows}
    RESULTS.parent.mkdir(exist_ok=True)
    tmp = RESULTS.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(result, indent=1) + "\n", encoding="utf-8")
    tmp.replace(RESULTS)
    print(json.dumps(result["summary"]))


if __name__ == "__main__":
    main()
