"""Writes the trajectory corpus in this folder: files as they come, one condition each.

Run from the repository root: ``python tests/data/trajectories/make_corpus.py``. The files are
committed; tests/test_kinematics.py (``test_corpus_*``) states what each must give. Every
bounce is closed-form ballistic flight of a ball with radius 20 mm on each side of an
instantaneous impact (``y = r + v t - g t^2 / 2``), sampled with Gaussian noise; the writer is
plain text, not the package's (so the reader is tested on files it did not write).

| file | condition |
|---|---|
| one_bounce.csv | one clean bounce, 1 kHz, 0.2 mm noise |
| three_bounces.csv | three bounces (restitution 0.8), 500 Hz |
| repeated_agree.csv | two rows written twice (same time, same position) |
| repeated_disagree.csv | a time stamp repeated with a position 3 mm away (line 40) |
| out_of_order.csv | one row moved 10 rows down (line 31 holds t earlier than line 30) |
| short_for_drag.csv | the rebound flight has 6 samples: too short for a drag fit |
| divergent_drag.csv | the rebound slows as with a drag coefficient of 20 /m, which no ball in air has: the drag fit runs to its bound and falls back, and the drag-free fit leaves a trend |
| nan_rows.csv | three rows with NaN positions (untracked frames) |
| no_bounce.csv | a ball falling, never bouncing |
| mm_units.csv | positions in mm in a file read as metres |
| ms_times.csv | times in ms |
| outlier_1e300.csv | one position written as 1e300 (line 25) |
| tracked_quality.csv | the tracker's layout: quality columns, three frames flagged 1, a provenance comment, and a sidecar with the calibration uncertainty |
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

HERE = Path(__file__).resolve().parent
G, R = 9.81, 0.02


def flight(t, p, v, a=(0.0, -G)):
    t = np.asarray(t)[:, None]
    return np.asarray(p) + np.asarray(v) * t + 0.5 * np.asarray(a) * t**2


def one_bounce(rng, rate=1000.0, span=0.05, noise=2e-4, v_in=(1.5, -2.6), v_out=(1.2, 2.1),
               a_out=(0.0, -G)):
    """Times and positions of one bounce at t = 0.5 s + a random phase."""
    dt = 1.0 / rate
    k = np.arange(-round(span * rate), round(span * rate) + 1)
    tc = rng.uniform(0.1, 0.9) * dt
    s = k * dt - tc
    pos = np.where(s[:, None] < 0, flight(s, (0.1, R), v_in), flight(s, (0.1, R), v_out, a_out))
    return 0.5 + k * dt, pos + rng.normal(0.0, noise, pos.shape)


def three_bounces(rng, rate=500.0, noise=2e-4):
    dt = 1.0 / rate
    t = np.arange(0.0, 1.2, dt) + rng.uniform(0, dt)
    vx, vy, y0, t0 = 0.8, 0.0, 0.35, 0.0  # dropped from 0.35 m with 0.8 m/s forward
    pos = np.empty((t.size, 2))
    x0 = 0.0
    for _ in range(4):
        # time to reach y = R from (y0, vy): y0 + vy s - g s^2 / 2 = R
        s_hit = (vy + math.sqrt(vy * vy + 2 * G * (y0 - R))) / G
        inside = (t >= t0) & (t < t0 + s_hit)
        pos[inside] = flight(t[inside] - t0, (x0, y0), (vx, vy))
        x0, t0 = x0 + vx * s_hit, t0 + s_hit
        y0, vy = R, 0.8 * (G * s_hit - vy)
    inside = t >= t0
    pos[inside] = flight(t[inside] - t0, (x0, y0), (vx, vy))
    return t, pos + rng.normal(0.0, noise, pos.shape)


def write(name, t, pos, header="t,x,y", cells=None, comments=()):
    lines = [*comments, header]
    for i, (ti, p) in enumerate(zip(t, pos, strict=True)):
        row = [repr(float(ti)), *(repr(float(v)) for v in p)]
        lines.append(",".join(row + (cells[i] if cells else [])))
    (HERE / name).write_text("\n".join(lines) + "\n", encoding="utf-8")


def main():
    rng = np.random.default_rng(20260611)
    write("one_bounce.csv", *one_bounce(rng))
    write("three_bounces.csv", *three_bounces(rng))

    t, pos = one_bounce(rng)
    keep = np.r_[np.arange(20), 19, np.arange(20, 70), 69, np.arange(70, t.size)]
    write("repeated_agree.csv", t[keep], pos[keep])

    t, pos = one_bounce(rng)
    t2, pos2 = np.insert(t, 38, t[37]), np.insert(pos, 38, pos[37] + [0.003, 0.0], axis=0)
    write("repeated_disagree.csv", t2, pos2)  # line 40 = header + row index 38 + 1

    t, pos = one_bounce(rng)
    order = np.r_[np.arange(20), np.arange(21, 30), 20, np.arange(30, t.size)]
    write("out_of_order.csv", t[order], pos[order])

    t, pos = one_bounce(rng, span=0.05)
    keep = t < 0.5 + 0.0075  # 7 samples after the impact (6 after the guard)
    write("short_for_drag.csv", t[keep], pos[keep])

    t, pos = one_bounce(rng, span=0.08)
    after = t > 0.5 + 1e-3
    tau = t[after] - t[after][0]
    sol = solve_ivp(lambda _, s: np.r_[s[2:], -20.0 * np.hypot(*s[2:]) * s[2:] - [0.0, G]],
                    (0.0, tau[-1]), [*pos[after][0], 1.2, 2.1], method="DOP853", rtol=1e-11,
                    atol=1e-13, dense_output=True)
    pos[after] = sol.sol(tau)[:2].T + rng.normal(0.0, 2e-4, (tau.size, 2))
    write("divergent_drag.csv", t, pos)

    t, pos = one_bounce(rng)
    pos[[10, 11, 60]] = np.nan
    write("nan_rows.csv", t, pos)

    t, pos = one_bounce(rng)
    fall = t < 0.5
    write("no_bounce.csv", t[fall], pos[fall])

    t, pos = one_bounce(rng)
    write("mm_units.csv", t, 1000 * pos)
    write("ms_times.csv", 1000 * t, pos)

    t, pos = one_bounce(rng)
    pos[23, 1] = 1e300  # line 25
    write("outlier_1e300.csv", t, pos)

    t, pos = one_bounce(rng)
    n = t.size
    residual = rng.uniform(2.0, 4.0, n)
    visible = np.ones(n)
    flag = np.zeros(n, dtype=int)
    flag[[5, 6, 80]] = 1
    pos[[5, 6, 80]] += 0.01  # what the tracker did not trust is wrong
    cells = [[f"{residual[i]:.3f}", f"{visible[i]:.2f}", str(flag[i])] for i in range(n)]
    provenance = {"bouncebayes_version": "0.1.0", "stage": "track", "video": "clip.mp4"}
    write("tracked_quality.csv", t, pos, header="t,x,y,residual,visible,flag", cells=cells,
          comments=["# provenance: " + json.dumps(provenance, separators=(",", ":"))])
    sidecar = {"calibration": {"metres_per_pixel": 2.5e-4, "relative_sd": 0.004},
               "surface": {"angle_deg": 1.2, "angle_sd_deg": 0.3}, "fps": 1000.0}
    (HERE / "tracked_quality.track.json").write_text(json.dumps(sidecar, indent=2) + "\n")


if __name__ == "__main__":
    main()
