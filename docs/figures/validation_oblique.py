"""Draw docs/figures/validation_oblique.png: Chung & Ooi (2011) Test 4 and the Kharaz et al.
(2001) experiment against the model with and without tangential compliance.

Run from the repository root: ``python docs/figures/validation_oblique.py``. The model values
come from the same functions as ``tests/test_model_validation.py`` (alumina sphere, 3.9 m/s,
mu = 0.092, e = 0.98; Mindlin's spring at the stiffness ratio of nu = 0.23).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests"))

import test_model_validation as V  # noqa: E402

PANELS = [("et", "tangential restitution $u'/u$", "tangential_COR_et", 1.0),
          ("spin", "rebound spin $\\omega'$ (rad/s)", "angular_velocity_after", 1.0),
          ("patch", "contact-point rebound angle (deg)", "rebound_angle_contact_patch", 1.0)]


def main(out: Path = ROOT / "docs" / "figures" / "validation_oblique.png") -> None:
    """Draw the three panels (e_t, spin, contact-point angle) and write ``out``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ball = V.T4_BALLS["oxide"]
    angles = np.concatenate([np.linspace(0.5, 10.0, 20), np.linspace(10.5, 89.0, 80)])
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.4), constrained_layout=True)
    for ax, (q, ylabel, kharaz_name, sign) in zip(axes, PANELS, strict=True):
        spring = V.bench4_compliant_model(ball, q)(angles)
        rigid = V.bench4_compliant_model(ball, q, "none")(angles)
        ax.plot(angles, spring, "-", color="C0", lw=2,
                label="bouncebayes, Mindlin spring (tangential = \"mindlin\")")
        ax.plot(angles, rigid, "--", color="C3", lw=1.5,
                label="bouncebayes, rigid tangential contact (tangential = \"none\")")
        k = V.read_kharaz("kratos_chung_ooi_fig", kharaz_name)
        ax.plot(k[:, 0], sign * k[:, 1], "o", color="k", ms=6, mfc="none",
                label="Kharaz et al. 2001, experiment (digitized)")
        if q != "patch":
            lethe = V.read_kharaz("lethe_postprocessing", kharaz_name)
            s = -1.0 if q == "spin" else 1.0  # Lethe stores |spin|
            ax.plot(lethe[:, 0], s * lethe[:, 1], "s", color="0.4", ms=4, mfc="none",
                    label="Kharaz et al. 2001 (second digitization)")
        label = {"et": "Oxide", "spin": "Al. oxide", "patch": "Al. oxide"}[q]
        co = V.read_kratos(V.T4_FILES[q])[label]
        ax.plot(co[:, 0], co[:, 1], "^", color="C2", ms=6,
                label="Chung & Ooi 2011, Test 4 DEM (digitized)")
        run = V.read_kratos(f"test4_kratos_dem_output_{V.T4_KRATOS_RUN[q]}.dat")[""]
        ax.plot(run[:, 0], run[:, 1], "x", color="C1", ms=6, label="Kratos DEM run")
        ax.axvspan(0.0, V.T4_COMPLIANT_FROM, color="0.92", zorder=0)
        ax.axvline(32.5, color="0.6", lw=0.8, ls=":")
        ax.set_xlabel("incidence angle from the normal (deg)")
        ax.set_ylabel(ylabel)
        ax.set_xlim(0.0, 90.0)
        ax.grid(alpha=0.3)
    axes[0].text(33.5, 0.42, "gross slip\nbeyond 32.5°", fontsize=8, color="0.4")
    axes[0].set_ylim(0.4, 1.0)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=3, fontsize=9, frameon=False)
    fig.suptitle("5 mm alumina sphere on glass at 3.9 m/s (mu = 0.092, e = 0.98): "
                 "oblique impact with and without tangential compliance "
                 "(shaded: below 9°, not tested)", fontsize=11)
    fig.savefig(out, dpi=110)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
