"""The design figure: expected posterior width against incidence angle, per parameter."""

from __future__ import annotations

from pathlib import Path
from typing import Any


def _series(designs: list[dict]) -> dict[tuple, list[dict]]:
    """Designs grouped by everything but the angle, each group sorted by angle."""
    groups: dict[tuple, list[dict]] = {}
    for d in designs:
        key = (d["n_bounces"], d["speed_m_s"], d["frame_rate_hz"], d["position_noise_m"])
        groups.setdefault(key, []).append(d)
    return {k: sorted(v, key=lambda d: d["angle_deg"]) for k, v in sorted(groups.items())}


def _label(key: tuple, varied: list[bool]) -> str:
    n, speed, rate, noise = key
    parts = [f"{n} bounces"]
    if varied[1]:
        parts.append(f"{speed:g} m/s")
    if varied[2]:
        parts.append(f"{rate:g} frames/s")
    if varied[3]:
        parts.append(f"noise {noise * 1e3:g} mm")
    return ", ".join(parts)


def _boundary_lines(ax, boundary: dict, legend: bool) -> None:
    styles = (("contact_mu", "--", "k"), ("prior_upper_mu", ":", "0.4"))
    for key, style, colour in styles:
        b = boundary.get(key)
        if b and b["angle_deg"] is not None:
            ax.axvline(b["angle_deg"], ls=style, color=colour, lw=1.2,
                       label=(f"sliding above this angle for mu = {b['mu']:.3g}"
                              if legend else None))


def design_figure(result: dict[str, Any], path: str | Path) -> list[Path]:
    """Write the figure as ``path`` (.png) and its .svg twin; returns both paths. Drawn on a
    figure detached from pyplot (a library user's backend is left alone) and saved atomically
    (``bouncebayes.plots.save_figure``)."""
    import matplotlib
    from matplotlib.figure import Figure

    from ..plots import save_figure

    units = result["parameters"]
    groups = _series(result["designs"])
    keys = list(groups)
    varied = [len({k[i] for k in keys}) > 1 for i in range(4)]
    with_p = any(d["p_mu_identified"] is not None for d in result["designs"])
    panels = len(units) + int(with_p)
    fig = Figure(figsize=(4.6 * panels, 4.2), layout="constrained")
    axes = fig.subplots(1, panels, squeeze=False)
    cmap = matplotlib.colormaps["viridis"]
    colours = {k: cmap(i / max(1, len(keys) - 1) * 0.9) for i, k in enumerate(keys)}
    for ax, (name, unit) in zip(axes[0], units.items(), strict=False):
        for key, ds in groups.items():
            ax.plot([d["angle_deg"] for d in ds], [d["expected_sd"][name] for d in ds], "o-",
                    ms=3, color=colours[key], label=_label(key, varied))
        target = result["targets"].get(name)
        if target:
            ax.axhline(target, color="tab:red", lw=1, label=f"target {target:g}")
        _boundary_lines(ax, result["boundary"], legend=ax is axes[0][0])
        ax.set_yscale("log")
        ax.set_xlabel("incidence angle from the normal (deg)")
        ax.set_ylabel(f"expected posterior sd of {name}" + (f" ({unit})" if unit else ""))
        ax.grid(alpha=0.3, which="both")
    axes[0][0].legend(fontsize=7, loc="best")
    if with_p:
        ax = axes[0][-1]
        for key, ds in groups.items():
            ax.plot([d["angle_deg"] for d in ds], [d["p_mu_identified"] for d in ds], "o-",
                    ms=3, color=colours[key], label=_label(key, varied))
        _boundary_lines(ax, result["boundary"], legend=False)
        ax.set_ylim(-0.03, 1.03)
        ax.set_xlabel("incidence angle from the normal (deg)")
        ax.set_ylabel("P(mu identified): every bounce slides")
        ax.grid(alpha=0.3)
    fig.suptitle("Expected posterior width against incidence angle; left of a vertical line, "
                 "bounces with that mu leave rolling (mu not identified)", fontsize=10)
    png = Path(path)
    return [save_figure(fig, png), save_figure(fig, png.with_suffix(".svg"))]
