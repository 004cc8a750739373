"""Slow-motion clips as a phone takes them: 120-480 fps, the ball 5-20 px a frame.

The tests and the other tracking benchmarks move the ball ~1.5 px a frame, as a high-speed
camera at 1000 fps does. A phone's slow motion (120 or 240 fps, some 480) moves a ball thrown
at 3 m/s 5-20 px a frame, and its exposure smears it over up to a radius or more. This
benchmark renders (``tests/render_pbr.py``, independent of the tracker) a 480 x 270 scene: a
10 px ball thrown at 3 m/s, 35 degrees, onto a flat surface 30 px above the bottom, a lens blur
of 0.8 px, MJPEG; at 120, 240 and 480 fps, exposures of 25, 50 and 90 % of the frame interval,
two seeds (the impact a quarter or three quarters of an interval after a frame); 0.2 s of
flight. Each is tracked as ``bouncebayes track`` tracks it (``track_video``: the scale from the
ball's diameter, the surface detected) and its kinematics fitted (``fit_kinematics``).

For each: the ball's step and the exposure's smear (px), the centres' RMS and largest error
over the trusted frames but the one nearest the impact (px), the scale's error and stated SD,
the incidence and rebound angles' and speeds' z against the renderer's throw (the speeds' SE
and the scale's SD in quadrature), or why the tracking or the kinematics refused the clip.
Summary per frame rate: the clips tracked and fitted, the largest centre error, the largest
|z| and the scale errors.

``python benchmarks/tracking_phone.py [--jobs 2]`` writes
``benchmarks/results/tracking_phone.json`` (~3 min on 2 cores).
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import itertools  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

RATES, EXPOSURES, SEEDS = (120.0, 240.0, 480.0), (0.25, 0.5, 0.9), (0, 1)
SPEED, FLIGHT = 3.0, 0.1  # m/s at impact; s of flight either side of it


def shot_for(fps: float, exposure: float, seed: int):
    from render_pbr import Shot, Throw

    return Shot(width=480, height=270, fps=fps, radius_px=10.0, n_frames=int(2 * FLIGHT * fps),
                surface_v=240.0, slope_deg=0.0, sigma_px=0.8, exposure=exposure,
                supersample=3, seed=seed, codec="MJPG",
                throw=Throw(speed_in=SPEED, angle_in=35.0,
                            t_contact=FLIGHT + (0.25 + 0.5 * seed) / fps, x_contact=0.3))


def z_scores(fit, throw) -> dict:
    """The kinematics' z against the throw: angles by their SE, speeds by their SE and the
    scale's relative SD in quadrature."""
    def speed_z(value, se, truth):
        return round((value - truth) / float(np.hypot(se, value * fit.scale_rel_sd)), 2)

    return {"incidence_angle_z": round((fit.incidence_angle - throw.angle_in)
                                       / fit.incidence_angle_se, 2),
            "rebound_angle_z": round((fit.rebound_angle - throw.rebound_angle())
                                     / fit.rebound_angle_se, 2),
            "incidence_speed_z": speed_z(fit.incidence_speed, fit.incidence_speed_se,
                                         throw.speed_in),
            "rebound_speed_z": speed_z(fit.rebound_speed, fit.rebound_speed_se,
                                       throw.rebound_speed())}


def clip(g: tuple) -> dict:
    """One clip, tracked and its kinematics fitted as the command line does."""
    from render_pbr import render, write

    from bouncebayes._errors import InputFileError
    from bouncebayes.kinematics import fit_kinematics, read_trajectory
    from bouncebayes.tracking import track_video, write_track_files

    fps, exposure, seed = g
    shot = shot_for(fps, exposure, seed)
    truth = shot.true_centres()
    step = float(np.median(np.hypot(*np.diff(truth, axis=0).T)))
    row = {"fps": fps, "exposure": exposure, "seed": seed, "step_px": round(step, 2),
           "smear_px": round(step * exposure, 2)}
    with tempfile.TemporaryDirectory() as tmp:
        path = write(render(shot), Path(tmp) / "clip.avi", fps, "MJPG")
        try:
            video = track_video(path, fps=fps, ball_diameter=shot.diameter_m)
        except InputFileError as exc:  # the tracking refused the video: said
            return row | {"tracked": False, "accepted": False,
                          "refused_because": str(exc).replace(str(path), "clip.avi")}
        files = write_track_files(video, Path(tmp) / "out")
        tr, cal = video.track, video.calibration
        ok = tr.trusted.copy()
        ok[int(round(shot.throw.t_contact * fps))] = False  # the impact frame (its exposure)
        error = np.hypot(*(tr.centre[ok] - truth[ok]).T)
        row.update(tracked=True, found=int(tr.found.sum()), frames=len(tr.found),
                   flagged=int(tr.flag.sum()),
                   centre_rms_px=round(float(np.sqrt(np.mean(error**2))), 3),
                   centre_max_px=round(float(error.max()), 3),
                   scale_error_pct=round(100 * (cal.metres_per_px / shot.metres_per_px - 1), 2),
                   scale_sd_pct=round(100 * (cal.relative_sd or 0.0), 2))
        try:
            fit = fit_kinematics(read_trajectory(files["trajectory"]))
        except InputFileError as exc:  # a gate refused the track: said, and no z-scores
            return row | {"accepted": False, "refused_because": str(exc)}
    return row | {"accepted": True} | z_scores(fit, shot.throw)


def summary(rows: list[dict]) -> dict:
    out = {}
    for fps in RATES:
        sel = [r for r in rows if r["fps"] == fps]
        tracked = [r for r in sel if r["tracked"]]
        fitted = [r for r in sel if r["accepted"]]
        zs = [abs(r[k]) for r in fitted for k in r if k.endswith("_z")]
        out[f"{fps:g} fps"] = {
            "clips": len(sel), "tracked": len(tracked), "accepted": len(fitted),
            "step_px": sel[0]["step_px"],
            "centre_max_px": max((r["centre_max_px"] for r in tracked), default=None),
            "max_abs_z": max(zs) if zs else None,
            "scale_error_pct": [r["scale_error_pct"] for r in tracked],
            "scale_sd_pct": [r["scale_sd_pct"] for r in tracked]}
    return out


def main(argv=None) -> dict:
    from _grid import run_grid

    return run_grid("tracking_phone", __doc__.splitlines()[0], clip,
                    list(itertools.product(RATES, EXPOSURES, SEEDS)), summary, argv)


if __name__ == "__main__":
    main()
