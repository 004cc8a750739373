"""Start-up and the demo as a new user meets them: ``bouncebayes --help`` and ``bouncebayes demo``.

Timed, in one run, as separate processes (the command as installed, ``python -m
bouncebayes.cli``), each the best of ``--repeats``:

- ``help``: ``bouncebayes --help``, against the baseline of the same run ``help_baseline``: a
  process importing what every command imported before start-up was made lazy (OpenCV,
  ArviZ, matplotlib, numba: 4.8 s for ``--help`` on this machine then);
- ``demo``: ``bouncebayes demo`` into a temporary folder with a warm numba cache (one run
  first, untimed, compiles or loads the kernels), against ``demo_serial``, the same with the
  figures rendered in the main process only (``BOUNCEBAYES_FIGURE_WORKERS=1``), the two
  alternating.

Wall clock and CPU time (the process's and its children's, ``os.times``: the figures are
rendered by forked processes) are reported, with the 1-minute load average before and after
(on a shared machine other processes stretch the wall clock, not the CPU time).

``python benchmarks/startup.py [--quick]``; the last stdout line is one JSON object, also
written to ``benchmarks/results/startup.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

RESULTS = Path(__file__).resolve().parent / "results" / "startup.json"
CLI = [sys.executable, "-m", "bouncebayes.cli"]
HEAVY = "import cv2, arviz_base, arviz_stats, matplotlib.pyplot, numba"


def timed(cmd: list[str], env: dict | None = None) -> tuple[float, float]:
    """(wall, CPU) seconds of a child process."""
    before = os.times()
    wall = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, env=env)
    wall = time.perf_counter() - wall
    after = os.times()
    return wall, (after.children_user + after.children_system
                  - before.children_user - before.children_system)


def best(cmd: list[str], repeats: int, env: dict | None = None) -> tuple[float, float]:
    runs = [timed(cmd, env) for _ in range(repeats)]
    return min(r[0] for r in runs), min(r[1] for r in runs)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="2 demo runs instead of 3")
    args = parser.parse_args()
    env = os.environ | {"OPENBLAS_NUM_THREADS": "1"}
    load_before = os.getloadavg()[0]
    record: dict = {"benchmark": "startup", "python": platform.python_version(),
                    "machine": f"{platform.machine()}, {os.cpu_count()} cpus"}
    help_ = best(CLI + ["--help"], 5, env)
    base = best([sys.executable, "-c", HEAVY], 5, env)
    record |= {"help_wall_s": help_[0], "help_cpu_s": help_[1],
               "help_baseline_wall_s": base[0], "help_baseline_cpu_s": base[1],
               "help_ratio": base[0] / help_[0]}
    print(f"--help: {help_[0]:.2f} s wall, {help_[1]:.2f} CPU-s; importing the heavy "
          f"libraries: {base[0]:.2f} s, {base[1]:.2f} CPU-s", flush=True)
    with tempfile.TemporaryDirectory(prefix="startup-") as tmp:
        demo = CLI + ["demo", "--out", str(Path(tmp) / "demo")]
        timed(demo, env)  # warm-up: numba cache, closed-form tables, font cache
        repeats = 2 if args.quick else 3
        # alternating, so that both meet the same load on a shared machine
        runs = [(timed(demo, env | {"BOUNCEBAYES_FIGURE_WORKERS": "1"}), timed(demo, env))
                for _ in range(repeats)]
        serial = min(r[0][0] for r in runs), min(r[0][1] for r in runs)
        fast = min(r[1][0] for r in runs), min(r[1][1] for r in runs)
    record |= {"demo_wall_s": fast[0], "demo_cpu_s": fast[1],
               "demo_serial_wall_s": serial[0], "demo_serial_cpu_s": serial[1],
               "demo_ratio": serial[0] / fast[0], "repeats_demo": repeats,
               "load_average_1min_before": load_before,
               "load_average_1min_after": os.getloadavg()[0]}
    print(f"demo (warm cache): {fast[0]:.2f} s wall, {fast[1]:.2f} CPU-s; figures rendered in "
          f"one process: {serial[0]:.2f} s, {serial[1]:.2f} CPU-s", flush=True)
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(json.dumps(record, indent=2) + "\n", encoding="utf-8")
    print(json.dumps(record))


if __name__ == "__main__":
    main()
