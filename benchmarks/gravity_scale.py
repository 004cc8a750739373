"""The length scale from the flights' fall against the rendered truth (docs/tracking.md §5).

Videos of ``tests/render_pbr.py`` (independent of the tracker; no air, ``g`` = 9.81 m/s^2),
tracked with the ball's diameter for the scale and the renderer's surface line
(``track_video``, ``write_track_files``: each record's ``gravity`` is the video's own check),
then fitted as the kinematics fit them (``read_trajectory``, ``fit_bounces``, no drag: the
renderer has none):

- ``campaign``: eight bounces, radius 10 px under a 1.5 px lens blur (where the edge's stated
  scale uncertainty is ~7 %), 200 x 110 px, flights of ~50 ms, side-lit bright and dark balls
  alternating; the campaign's fall against the clips' mean true scale error;
- ``wrong_diameter``: the same videos tracked with a ball diameter 6.25 % too small (24 mm for
  25.6 mm);
- ``long_flights``: four videos of 640 x 480 px, radius 10 px, blur 1.5 px, flights of 150 ms
  each side: each video's fall (``track``'s check) against its true scale error.

``python benchmarks/gravity_scale.py`` writes ``benchmarks/results/gravity_scale.json``; the
last stdout line is the summary.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import json  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
from pathlib import Path  # noqa: E402

from bouncebayes.kinematics import fit_bounces, read_trajectory  # noqa: E402
from bouncebayes.tracking import Surface, track_video, write_track_files  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from _gravity_check import fall_check  # noqa: E402
from render_pbr import Shot, Throw, render, write  # noqa: E402
from tracking_accuracy import LIGHTING  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results" / "gravity_scale.json"
DARK = LIGHTING["dark"]
DIAMETER = 0.0256


def campaign_shot(seed: int) -> Shot:
    return Shot(width=200, height=110, radius_px=10.0, n_frames=100, surface_v=95.0,
                slope_deg=4.0, sigma_px=1.5, exposure=0.4, supersample=4, seed=seed,
                throw=Throw(speed_in=2.0 + 0.08 * seed, angle_in=30.0 + 2.0 * seed,
                            t_contact=0.05, x_contact=0.1), **(DARK if seed % 2 else {}))


def long_shot(seed: int) -> Shot:
    return Shot(width=640, height=480, radius_px=10.0, n_frames=300, surface_v=440.0,
                slope_deg=2.0, sigma_px=1.5, exposure=0.4, supersample=3, seed=seed,
                throw=Throw(speed_in=2.0 + 0.1 * seed, angle_in=35.0 + 2.0 * seed,
                            t_contact=0.15, x_contact=0.2), **(DARK if seed % 2 else {}))


def tracked(path: Path, shot: Shot, out: Path, diameter: float = DIAMETER) -> dict:
    """Track one video; its row: scale error, stated SD, the video's own fall check, and the
    falls of its bounces as the kinematics fit them."""
    x1, y1, x2, y2 = shot.surface_points()
    video = track_video(path, fps=shot.fps, ball_diameter=diameter,
                        surface=Surface.from_points((x1, y1), (x2, y2)))
    files = write_track_files(video, out)
    record = json.loads(files["record"].read_text(encoding="utf-8"))
    fits = [k for k in fit_bounces(read_trajectory(files["trajectory"]))
            if not isinstance(k, Exception)]
    check = record["gravity"] or {}
    return {"video": path.name, "lighting": "dark" if shot.seed % 2 else "side",
            "scale_error_pct": round(100 * (video.calibration.metres_per_px
                                            / shot.metres_per_px - 1), 3),
            "stated_sd_pct": round(100 * video.calibration.relative_sd, 3),
            "fall_scale_error_pct": None if not check else round(100 * (check["scale"] - 1), 3),
            "fall_sd_pct": None if not check else round(100 * check["scale_sd"], 3),
            "falls": [k.fall for k in fits if k.fall is not None]}


def main() -> dict:
    out: dict = {"benchmark": "gravity_scale"}
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        for name, shots, diameters in (
                ("campaign", [campaign_shot(s) for s in range(8)], (DIAMETER, 0.024)),
                ("long_flights", [long_shot(s) for s in range(4)], (DIAMETER,))):
            videos = [write(render(s), root / f"{name}{s.seed}.avi", s.fps, "MJPG")
                      for s in shots]
            for diameter in diameters:
                key = name if diameter == DIAMETER else "wrong_diameter"
                rows = [tracked(p, s, root / key, diameter)
                        for p, s in zip(videos, shots, strict=True)]
                falls = [f for r in rows for f in r.pop("falls")]
                out[key] = {"campaign": fall_check(falls, [r["scale_error_pct"] for r in rows]),
                            "videos": rows}
                print(json.dumps({key: out[key]["campaign"]}), file=sys.stderr, flush=True)
    RESULTS.write_text(json.dumps(out, indent=1) + "\n")
    print(json.dumps({k: v["campaign"] for k, v in out.items() if isinstance(v, dict)}))
    return out


if __name__ == "__main__":
    main()
