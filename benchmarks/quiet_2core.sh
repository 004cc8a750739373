#!/usr/bin/env bash
# The benchmarks on an idle machine pinned to two cores, the numbers of the speed table's
# "idle server, 2 cores" column (benchmarks/results/quiet/*.json). Run from the repository root
# on a machine with at least 2 idle cores and the package installed:
#
#     bash benchmarks/quiet_2core.sh [CORES]        # CORES: taskset's list, default 0,1
#
# Each benchmark runs under `taskset -c CORES` with NUMBA_NUM_THREADS=2 and two figure
# workers, then its results file is copied to benchmarks/results/quiet/ (the shared machine's
# results in benchmarks/results/ are restored afterwards).
set -euo pipefail
cd "$(dirname "$0")/.."
CORES=${1:-0,1}
PY=${PYTHON:-python3}
export OPENBLAS_NUM_THREADS=1 NUMBA_NUM_THREADS=2 BOUNCEBAYES_FIGURE_WORKERS=2
mkdir -p benchmarks/results/quiet
keep=$(mktemp -d)
cp benchmarks/results/*.json "$keep"/
trap 'cp "$keep"/*.json benchmarks/results/; rm -rf "$keep"' EXIT
for spec in "startup startup" "inference inference --quick" "figures figures --quick" \
            "kinematics kinematics --quick" "forward forward --quick" \
            "tracking tracking --quick" "population population" "dask dask_speedup"; do
    set -- $spec
    result=$1; shift
    script=$1; shift
    echo "== $script $*"
    taskset -c "$CORES" "$PY" "benchmarks/$script.py" "$@"
    cp "benchmarks/results/$result.json" benchmarks/results/quiet/
done
