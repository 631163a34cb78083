#!/usr/bin/env bash
# The default job on built-in data (run by `make demo`). Outputs go to out/demo/.
#
# Until the tracking and bundle-adjustment stages land, the job is the
# foundation's: load and describe the real KITTI-360 rig, and evaluate an
# example estimated trajectory against its ground truth (ATE, RPE, scale).
set -euo pipefail
cd "$(dirname "$0")/.."
MCVO=${1:-build/mcvo}
OUT=out/demo
mkdir -p "$OUT"

echo "== mcvo info --rig config/rigs/kitti360.json"
"$MCVO" info --rig config/rigs/kitti360.json

echo
echo "== mcvo eval (examples/trajectories: closed 520 m drive, estimate with 0.8 % scale error and yaw drift)"
"$MCVO" eval --gt examples/trajectories/loop_gt.tum --est examples/trajectories/loop_est.tum \
  --align se3 --out "$OUT/eval"
echo
echo "demo outputs in $OUT/eval: eval.json eval.md ate_errors.csv est_aligned.tum"
