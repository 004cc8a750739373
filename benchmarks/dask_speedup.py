"""Speed-up of a study on a local Dask cluster of 2 worker processes against the serial run.

The study is the simulation-based calibration's (``bouncebayes.studies.run_sbc`` with its
defaults: 30 bounces per campaign, grid posterior of 512 x 512 cells, 999 draws), ``--campaigns``
campaigns (default 16). Both runs are made in this process, one after the other, after warming
up (numba's compiled kernels loaded, one campaign run in each place), so the ratio is measured
in the same conditions; the results must be identical (asserted). Reported: wall-clock seconds,
CPU seconds of the tasks (summed over the processes that ran them), the speed-up in wall-clock
time, and the CPU seconds per campaign, from which the cost of a 10,000-campaign SBC is
extrapolated (an extrapolation, not a measurement). On a shared machine the wall clock depends
on the other users' load: the CPU seconds per campaign do not.

``python benchmarks/dask_speedup.py [--campaigns N] [--workers 2]`` writes
``benchmarks/results/dask.json``.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy is imported

import argparse  # noqa: E402
import json  # noqa: E402
import logging  # noqa: E402
import platform  # noqa: E402
import time  # noqa: E402
from datetime import datetime, timezone  # noqa: E402
from pathlib import Path  # noqa: E402

from bouncebayes._io import write_json  # noqa: E402
from bouncebayes.studies import run_sbc, worker_environment  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results" / "dask.json"


def timed(**kwargs) -> tuple[dict, float, float]:
    """A study's result, its wall-clock seconds and this process's CPU seconds."""
    wall, cpu = time.perf_counter(), time.process_time()
    result = run_sbc(**kwargs)
    return result, time.perf_counter() - wall, time.process_time() - cpu


def main(argv=None) -> dict:
    from distributed import Client, LocalCluster

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--campaigns", type=int, default=16)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--out", type=Path, default=RESULTS)
    args = ap.parse_args(argv)
    n = args.campaigns
    run_sbc(1, seed=args.seed + 1, scheduler="serial")  # warm-up: kernels loaded here
    serial, serial_wall, serial_cpu = timed(campaigns=n, seed=args.seed, scheduler="serial")
    start = time.perf_counter()
    with LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=True,
                      dashboard_address=None, silence_logs=logging.ERROR,
                      scheduler_kwargs={"dashboard_address": ":0"},  # a free port, not 8787
                      env=worker_environment(args.workers)) as cluster, Client(cluster):
        startup = time.perf_counter() - start
        address = cluster.scheduler_address
        run_sbc(args.workers, seed=args.seed + 2, scheduler=address)  # warm-up on each worker
        remote, remote_wall, _ = timed(campaigns=n, seed=args.seed, scheduler=address)
    assert remote["parameters"] == serial["parameters"], "cluster and serial results differ"
    per_campaign = serial["task_cpu_seconds"] / n
    result = {
        "study": f"SBC, {n} campaigns (30 bounces, 512 x 512 grid, 999 draws)",
        "workers": args.workers, "cores": os.cpu_count(),
        "load_average_1min": os.getloadavg()[0],
        "serial": {"wall_s": serial_wall, "task_cpu_s": serial["task_cpu_seconds"],
                   "process_cpu_s": serial_cpu},
        "cluster": {"wall_s": remote_wall, "task_cpu_s": remote["task_cpu_seconds"],
                    "startup_s": startup},
        "speedup_wall": serial_wall / remote_wall,
        "cpu_ratio_cluster_to_serial": remote["task_cpu_seconds"] / serial["task_cpu_seconds"],
        "identical_results": True,
        "cpu_s_per_campaign": per_campaign,
        "extrapolated_10000_campaigns_cpu_hours": 10_000 * per_campaign / 3600,
        "python": platform.python_version(),
        "generated_at": datetime.now(timezone.utc).isoformat(timespec="seconds"),
    }
    write_json(args.out, result)
    print(json.dumps(result, indent=1))
    return result


if __name__ == "__main__":
    main()
