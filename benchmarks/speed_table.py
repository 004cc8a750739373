"""Write the README's speed table from the stored benchmark results.

Every number in the table is read from ``benchmarks/results/*.json`` (written by the
benchmark scripts, each against a baseline measured in the same run), so the README cannot
drift from what was measured. ``make bench`` runs the benchmarks and then this script; run it
alone to refresh the table from the stored files::

    python benchmarks/speed_table.py            # rewrite the table in README.md
    python benchmarks/speed_table.py --check    # exit 1 if README.md is out of date

The table sits between the two marker comments ``<!-- speed-table:start -->`` and
``<!-- speed-table:end -->`` in README.md.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results"
#: the same benchmarks on an idle server pinned to two cores (benchmarks/quiet_2core.sh)
QUIET = RESULTS / "quiet"
README = ROOT / "README.md"
START, END = "<!-- speed-table:start -->", "<!-- speed-table:end -->"


def _get(data: dict, path: str):
    for key in path.split("."):
        if not isinstance(data, dict) or key not in data:
            return None
        data = data[key]
    return data


def _num(fmt: str, suffix: str = "") -> Callable[[object], str]:
    def show(value) -> str:
        return format(float(value), fmt) + suffix  # type: ignore[arg-type]
    return show


# (what, results file, key, how to show it, target, key of the baseline ratio or None)
ROWS: tuple[tuple[str, str, str, Callable[[object], str], str, str | None], ...] = (
    ("fast exact path, bounces per second (wall clock, 2 threads)", "forward", "fast_per_s",
     _num(".3g"), "5e6 (aim 1e7)", "fast_ratio_to_ode"),
    ("fast exact path, bounces per CPU-second", "forward", "fast_per_cpu_s", _num(".3g"), "",
     "fast_ratio_to_ode_cpu"),
    ("ODE path against SciPy `solve_ivp` at the same accuracy", "forward", "ratio",
     _num(".0f", "x"), "300x", None),
    ("ODE path against SciPy `solve_ivp`, CPU time", "forward", "ratio_cpu", _num(".0f", "x"),
     "300x", None),
    ("tangentially compliant ODE path against SciPy", "forward_compliant", "ratio",
     _num(".0f", "x"), "300x", None),
    ("paper's MH run, gaussian likelihood, 55 trials (s, wall clock)", "inference",
     "mh_gaussian_seconds", _num(".2f"), "< 1 s", "mh_gaussian_ratio"),
    ("paper's MH run, gaussian likelihood (CPU-s)", "inference", "mh_gaussian_cpu_seconds",
     _num(".2f"), "", "mh_gaussian_ratio_cpu"),
    ("paper's MH run, kde likelihood (s)", "inference", "mh_seconds", _num(".2f"), "",
     "mh_ratio"),
    ("512 x 512 (mu, eta) grid, 55 trials (s)", "inference", "grid_seconds", _num(".2f"), "",
     "grid_ratio"),
    ("drag kinematics of a 60-point trajectory (ms, wall clock)", "kinematics", "one_ms",
     _num(".1f"), "20 ms", "speedup_one"),
    ("drag kinematics of a 60-point trajectory (CPU-ms)", "kinematics", "one_cpu_ms",
     _num(".1f"), "", "speedup_one_cpu"),
    ("100 trajectory files with drag (s, wall clock)", "kinematics", "folder_s", _num(".2f"),
     "5 s", None),
    ("figures of a run (s, wall clock)", "figures", "default_wall_s", _num(".2f"), "3 s",
     "speedup_wall"),
    ("figures of a run (CPU-s, with the rendering processes)", "figures", "default_cpu_s",
     _num(".2f"), "", "speedup_cpu"),
    ("`bouncebayes --help` (s, wall clock)", "startup", "help_wall_s", _num(".2f"), "0.5 s",
     "help_ratio"),
    ("`bouncebayes demo`, warm numba cache (s, wall clock)", "startup", "demo_wall_s",
     _num(".1f"), "8 s", "demo_ratio"),
    ("`bouncebayes demo`, warm numba cache (CPU-s, with children)", "startup", "demo_cpu_s",
     _num(".1f"), "", None),
    ("tracking, 640 x 480 frames per second", "tracking", "640x480.frames_per_s", _num(".0f"),
     "1000", "640x480.ratio_to_baseline"),
    ("tracking, 224 x 64 frames per second", "tracking", "224x64.frames_per_s", _num(".0f"),
     "5000", "224x64.ratio_to_baseline"),
    ("population likelihood, 55 trials, two parameters (s)", "population", "infer_seconds",
     _num(".1f"), "10 s", "likelihood_speedup"),
    ("SBC study on a local Dask cluster of 2 workers, speed-up over serial (wall clock)", "dask",
     "speedup_wall", _num(".2f", "x"), "", None),
)


def table() -> str:
    """The markdown table of the stored results."""
    cache: dict[Path, dict | None] = {}

    def load(path: Path) -> dict | None:
        if path not in cache:
            cache[path] = json.loads(path.read_text()) if path.is_file() else None
        return cache[path]

    lines = ["| what | development machine, 2 cores | idle server, 2 cores | target "
             "| against the baseline of the same run (development; idle) | file |",
             "|---|---|---|---|---|---|"]
    for what, name, key, show, target, ratio_key in ROWS:
        values, ratios = [], []
        for folder in (RESULTS, QUIET):
            data = load(folder / f"{name}.json")
            value = None if data is None else _get(data, key)
            ratio = None if ratio_key is None or data is None else _get(data, ratio_key)
            values.append("" if value is None else show(value))
            ratios.append(f"{float(ratio):.3g}x" if isinstance(ratio, int | float) else "")
        if not any(values):
            continue
        shown_ratio = "; ".join(r for r in ratios if r) if any(ratios) else ""
        lines.append(f"| {what} | {values[0]} | {values[1]} | {target} | {shown_ratio} | "
                     f"`benchmarks/results/{name}.json` |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Rewrite (or, with ``--check``, compare) the README's table."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--check", action="store_true", help="exit 1 if README.md is out of date")
    args = p.parse_args(argv)
    text = README.read_text()
    if START not in text or END not in text:
        print(f"README.md has no {START} ... {END} markers", file=sys.stderr)
        return 2
    head, rest = text.split(START, 1)
    _, tail = rest.split(END, 1)
    new = f"{head}{START}\n{table()}\n{END}{tail}"
    if args.check:
        return 0 if new == text else 1
    if new != text:
        README.write_text(new)
    return 0


if __name__ == "__main__":
    sys.exit(main())
