#!/usr/bin/env bash
# Initializer benchmark: scale error and initialisation delay of the metric
# initializer on synthetic tracks of every preset rig (kitti360,
# kitti360_3cam, kitti360_stereo, irregular5, multicam6), for three motions
# (a city corner, a sharp turn, a straight drive), with and without
# cross-camera observations, at 0.5, 1 and 2 px of pixel noise. Writes
# results/initializer_benchmark.md (aggregates, also printed) and
# results/initializer_benchmark.csv (one row per run).
#
#   tools/bench_initializer.sh [BUILD_DIR] [mcvo_bench_initializer options...]
#       BUILD_DIR defaults to build; e.g. tools/bench_initializer.sh build --seeds 8
#
# The numbers are deterministic (seeded synthetic tracks, deterministic
# initializer); only the wall-time line varies. THREADS (default 2) runs
# that many segments in parallel. About 5 minutes on 2 cores with the
# defaults (4 seeds per row).
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=${1:-build}
shift || true
THREADS=${THREADS:-2}
BENCH="$BUILD/mcvo_bench_initializer"
if [[ ! -x "$BENCH" ]]; then
  echo "building $BENCH ..." >&2
  cmake --build "$BUILD" --target mcvo_bench_initializer -j "$THREADS" >&2
fi
mkdir -p results
"$BENCH" --out results/initializer_benchmark --threads "$THREADS" "$@"
