"""Figures of a run: time to draw and save every figure of the report, against a baseline.

Timed, in one run, on a run folder of the bundled demo campaign (55 bounces; the default MH
settings, 15,000 draws), from the loaded run (figure inputs included: the data's density, the
posterior residuals):

- ``default``: :func:`bouncebayes.report.make_figures` as a run calls it: PNG only, panels
  placed from their texts before drawing (no layout engine), one rendering pass per file,
  the figures rendered by forked processes beside this one (one per core, up to four);
- ``serial``: the same, rendered in this process only (``workers=1``);
- ``png_svg``: the same with ``formats=("png", "svg")``;
- ``constrained``: PNG only, laid out by matplotlib's constrained layout engine instead;
- ``baseline``: the same figure functions with the settings the report used before: PNG and
  SVG, ``tight_layout`` on every figure and ``bbox_inches="tight"`` on every save (the figure
  computations, e.g. the KDEs, are today's: the earlier code was slower still).

Each mode runs ``--repeats`` times and the fastest wall-clock and CPU times count (the machine is
shared: the minimum is the least disturbed); CPU time is this process's and its children's
(``os.times``), and the 1-minute load average is recorded. Per figure, the fastest drawing (building the
figure) and saving (layout, rendering, encoding) of the ``default`` mode are reported too.

``python benchmarks/figures.py [--quick] [--run DIR]``; ``--run`` reuses an existing run folder
(otherwise the demo is run into a temporary folder first, which takes a while). The last stdout
line is one JSON object; it is also written to ``benchmarks/results/figures.json``.
"""

from __future__ import annotations

import os

os.environ["OPENBLAS_NUM_THREADS"] = "1"  # before numpy is imported

import argparse  # noqa: E402
import io  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

from bouncebayes import __version__  # noqa: E402
from bouncebayes.data import demo_campaign  # noqa: E402
from bouncebayes.propagation import load_propagation  # noqa: E402
from bouncebayes.report import figure_makers, load_result, load_truth, make_figures  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results" / "figures.json"


def demo_run(out: Path) -> Path:
    from bouncebayes.pipeline import run

    demo = demo_campaign()
    run(demo.experiment, demo.trials, out, seed=0, log=lambda m: None,
        truth=demo.folder / "truth.json")
    return out


def _cpu() -> float:
    """CPU seconds of this process and of its finished children."""
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


def timed(fn) -> tuple[float, float]:
    wall, cpu = time.perf_counter(), _cpu()
    fn()
    return time.perf_counter() - wall, _cpu() - cpu


def baseline(result, prop, folder, truth) -> None:
    """The earlier settings: PNG and SVG, tight_layout on every figure, bbox_inches="tight"."""
    import warnings

    for draw in figure_makers(result, prop, folder, truth).values():
        fig = draw()
        if fig is None:
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # tight_layout's notes on 3-D axes
            fig.tight_layout()
        for fmt in ("svg", "png"):
            fig.savefig(io.BytesIO(), format=fmt, bbox_inches="tight")


def constrained(result, prop, out, truth) -> None:
    """PNG only, but laid out by matplotlib's constrained layout engine (computed once)."""
    import warnings

    from bouncebayes.plots import _figure

    _figure.LAYOUT = "constrained"
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the engine overrides the fixed placement: known
            make_figures(result, prop, out, truth)
    finally:
        _figure.LAYOUT = None


def per_figure(result, prop, folder, truth, repeats: int) -> dict:
    """Fastest drawing and saving (PNG) time of each figure, s."""
    from bouncebayes.plots import save_figure

    best: dict = {}
    out = Path(tempfile.mkdtemp(prefix="figures-"))
    for _ in range(repeats):
        for key, draw in figure_makers(result, prop, folder, truth).items():
            box = {}
            t_draw = timed(lambda box=box, draw=draw: box.setdefault("fig", draw()))[0]
            if box["fig"] is None:
                continue
            t_save = timed(lambda box=box, key=key: save_figure(box["fig"], out / f"{key}.png"))[0]
            old = best.get(key, (float("inf"), float("inf")))
            best[key] = (min(old[0], t_draw), min(old[1], t_save))
    return {k: {"draw_s": round(d, 3), "save_png_s": round(s, 3)} for k, (d, s) in best.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="2 repeats instead of 5")
    parser.add_argument("--run", type=Path, default=None, help="an existing run folder")
    args = parser.parse_args()
    repeats = 2 if args.quick else 5
    folder = args.run or demo_run(Path(tempfile.mkdtemp(prefix="figures-run-")))
    result, prop, truth = load_result(folder), load_propagation(folder), load_truth(folder)
    out = Path(tempfile.mkdtemp(prefix="figures-out-"))
    modes = {
        "default": lambda: make_figures(result, prop, out, truth),
        "serial": lambda: make_figures(result, prop, out, truth, workers=1),
        "png_svg": lambda: make_figures(result, prop, out, truth, formats=("png", "svg")),
        "constrained": lambda: constrained(result, prop, out, truth),
        "baseline": lambda: baseline(result, prop, folder, truth),
    }
    modes["default"]()  # warm-up: imports, numba caches, font cache
    best = {k: (float("inf"), float("inf")) for k in modes}
    for _ in range(repeats):
        for key, fn in modes.items():  # interleaved, so that load changes hit all modes alike
            wall, cpu = timed(fn)
            best[key] = (min(best[key][0], wall), min(best[key][1], cpu))
            print(f"{key:11s} wall {wall:6.2f} s  cpu {cpu:6.2f} s", flush=True)
    record = {
        "benchmark": "figures", "bouncebayes": __version__, "python": platform.python_version(),
        "machine": f"{platform.machine()}, {os.cpu_count()} cpus", "repeats": repeats,
        "n_figures": len(make_figures(result, prop, out, truth)),
        "n_draws": int(result.draws.samples.shape[0] * result.draws.samples.shape[1]),
        **{f"{k}_wall_s": round(v[0], 3) for k, v in best.items()},
        **{f"{k}_cpu_s": round(v[1], 3) for k, v in best.items()},
        "speedup_wall": round(best["baseline"][0] / best["default"][0], 2),
        "speedup_parallel_wall": round(best["serial"][0] / best["default"][0], 2),
        "load_average_1min": round(os.getloadavg()[0], 2),
        "speedup_cpu": round(best["baseline"][1] / best["default"][1], 2),
        "speedup_png_svg_wall": round(best["baseline"][0] / best["png_svg"][0], 2),
        "per_figure": per_figure(result, prop, folder, truth, repeats),
    }
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(json.dumps(record, indent=2) + "\n", encoding="utf-8")
    print(json.dumps(record))


if __name__ == "__main__":
    main()
