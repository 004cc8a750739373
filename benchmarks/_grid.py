"""A rendered benchmark's grid run over a pool of processes, for the tracking benchmarks
(``tracking_lens.py``, ``tracking_small_blur.py``): one row a scene, each printed to stderr as
it comes, the rows and their summary written to ``benchmarks/results/<name>.json``."""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from bouncebayes._io import write_json

RESULTS = Path(__file__).resolve().parent / "results"


def run_grid(name: str, description: str, work: Callable[[tuple], dict],
             grid: Sequence[tuple], summary: Callable[[list[dict]], dict],
             argv: Sequence[str] | None = None) -> dict:
    """``work`` on every point of ``grid`` over ``--jobs`` processes (default 2), and the
    result ``{"benchmark": name, "renderer", "summary": summary(rows), "rows", "numpy"}``
    written atomically (as the package writes its results) and returned."""
    ap = argparse.ArgumentParser(description=description)
    ap.add_argument("--jobs", type=int, default=2)
    args = ap.parse_args(argv)
    rows = []
    with ProcessPoolExecutor(args.jobs) as pool:
        for row in pool.map(work, grid):
            rows.append(row)
            print(json.dumps(row), file=sys.stderr, flush=True)
    result = {"benchmark": name, "renderer": "tests/render_pbr.py", "summary": summary(rows),
              "rows": rows, "numpy": np.__version__}
    write_json(RESULTS / f"{name}.json", result)
    print(json.dumps(result["summary"]))
    return result
