"""The surface line found in backgrounds whose wall texture is not the renderer's.

``tests/render_pbr.py`` paints its wall with a sum of twelve plane waves: long straight streaks,
which is what the surface search (``detect_surface``, docs/tracking.md §1) was first tuned on.
This benchmark builds the background another way, with no ball in it: a wall of isotropic
texture (white noise smoothed by 4 px, ``blobs``; by 1.5 px, ``fine``; ``1/f`` noise, ``pink``)
over a plane of fine texture, their boundary a straight step blurred by 1 px (erf), at -4, 1
and 7 degrees, 30 px above the bottom of a 320 x 160 frame; noise of 1 grey level; JPEG quality
80 (OpenCV). Four contrasts (wall over plane, the wall's texture SD: 50/30/10, 40/32/8, 60/35/15,
120/60/20) x four seeds. The ball's centres are those of a bounce off the line (radius 9 px,
41 frames), from the geometry alone.

For each: the angle found, its stated SD, z against the truth, whether a lens is said
(``_lens.bend`` on the line found, as ``track_video`` reads it: there is none), and the share
of the frame along which the edge lies on the line (``_geometry.edge_share``), under which
``surface_warning`` says the line may be off; none where no surface is found. Summary per
texture and contrast: how many found, the z RMS, how many beyond 3, how many said a lens and
how many the surface warning; of those beyond 3, how many it warned of.

``python benchmarks/tracking_surface.py`` writes ``benchmarks/results/tracking_surface.json``
(~1 min).
"""

from __future__ import annotations

import itertools
import json
import math
from pathlib import Path

import numpy as np

from bouncebayes._io import write_json

RESULTS = Path(__file__).resolve().parent / "results" / "tracking_surface.json"
TEXTURES = ("blobs", "fine", "pink")
CONTRASTS = ((50.0, 30.0, 10.0), (40.0, 32.0, 8.0), (60.0, 35.0, 15.0), (120.0, 60.0, 20.0))
SEEDS, ANGLES = (0, 1, 2, 3), (-4.0, 1.0, 7.0)
W, H, V0, RADIUS = 320, 160, 130.0, 9.0


def texture(rng: np.random.Generator, kind: str) -> np.ndarray:
    """Zero-mean, unit-SD texture of ``kind`` over the frame."""
    import cv2

    noise = rng.normal(0.0, 1.0, (H, W))
    if kind == "pink":
        ky, kx = np.meshgrid(np.fft.fftfreq(H), np.fft.fftfreq(W), indexing="ij")
        k = np.hypot(kx, ky)
        k[0, 0] = 1.0
        t = np.real(np.fft.ifft2(np.fft.fft2(noise) / k))
    else:
        t = cv2.GaussianBlur(noise.astype(np.float32), (0, 0), 4.0 if kind == "blobs" else 1.5)
    return (t - t.mean()) / t.std()


def scene(kind: str, contrast: tuple, seed: int, angle: float):
    """The background (uint8, JPEG-coded) and the ball's centres (px)."""
    import cv2
    from scipy.special import erf

    wall, plane, sd = contrast
    rng = np.random.default_rng(seed)
    v, u = np.mgrid[:H, :W].astype(float)
    a = math.radians(angle)  # the line v = V0 + (u - W / 2) tan a: down to the right for a > 0
    below = 0.5 * (1 + erf(((v - V0) - (u - W / 2) * math.tan(a)) * math.cos(a) / math.sqrt(2)))
    img = (wall + sd * texture(rng, kind)) * (1 - below) + (plane + 2 * texture(rng, "fine")) \
        * below + rng.normal(0.0, 1.0, (H, W))
    img = np.clip(np.rint(img), 0, 255).astype(np.uint8)
    img = cv2.imdecode(cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_QUALITY, 80])[1], 0)
    t = np.linspace(-1.0, 1.0, 41)
    us = 0.4 * W + 60 * t
    dist = RADIUS + np.where(t < 0, 90.0, 55.0) * t**2  # from the line: in, contact, out
    line_v = V0 + (us - W / 2) * math.tan(a)
    return img, np.column_stack([us + dist * math.sin(a), line_v - dist * math.cos(a)])


def run() -> list[dict]:
    from bouncebayes.tracking import detect_surface
    from bouncebayes.tracking._geometry import EDGE_SHARE, edge_share
    from bouncebayes.tracking._lens import bend

    rows = []
    for kind, contrast, seed, angle in itertools.product(TEXTURES, CONTRASTS, SEEDS, ANGLES):
        img, centres = scene(kind, contrast, seed, angle)
        line = detect_surface(img, centres=centres, radius=RADIUS)
        row = {"texture": kind, "wall": contrast[0], "plane": contrast[1],
               "texture_sd": contrast[2], "seed": seed, "truth_deg": -angle,
               "found": line is not None}
        if line is not None:
            lens = bend(img, line.point, line.direction)
            row.update(angle_deg=round(line.angle, 4), angle_sd_deg=round(line.angle_sd_deg, 4),
                       z=round((line.angle + angle) / line.angle_sd_deg, 2),
                       lens_said=bool(lens is not None and lens.significant),
                       edge_share=round(edge_share(img, line), 3),
                       surface_said=bool(edge_share(img, line) < EDGE_SHARE))
        rows.append(row)
    return rows


def summary(rows: list[dict]) -> dict:
    out = {}
    for kind, contrast in itertools.product(TEXTURES, CONTRASTS):
        sel = [r for r in rows if r["texture"] == kind and r["wall"] == contrast[0]]
        z = np.array([r["z"] for r in sel if r["found"]])
        out[f"{kind} {contrast[0]:g}/{contrast[1]:g} +- {contrast[2]:g}"] = {
            "n": len(sel), "found": int(z.size),
            "z_rms": round(float(np.sqrt(np.mean(z**2))), 2) if z.size else None,
            "beyond_3": int(np.sum(np.abs(z) > 3)),
            "lens_said": sum(bool(r.get("lens_said")) for r in sel),
            "surface_said": sum(bool(r.get("surface_said")) for r in sel)}
    z = np.array([r["z"] for r in rows if r["found"]])
    out["all"] = {"n": len(rows), "found": int(z.size),
                  "z_rms": round(float(np.sqrt(np.mean(z**2))), 2),
                  "beyond_3": int(np.sum(np.abs(z) > 3)),
                  "lens_said": sum(bool(r.get("lens_said")) for r in rows),
                  "surface_said": sum(bool(r.get("surface_said")) for r in rows),
                  "beyond_3_said": sum(bool(r.get("surface_said")) for r in rows
                                       if r["found"] and abs(r["z"]) > 3)}
    return out


def main() -> dict:
    rows = run()
    result = {"benchmark": "tracking_surface", "summary": summary(rows), "rows": rows,
              "numpy": np.__version__}
    write_json(RESULTS, result)  # atomic, as the package writes its results
    print(json.dumps(result["summary"]["all"]))
    return result


if __name__ == "__main__":
    main()
