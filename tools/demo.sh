#!/usr/bin/env bash
# The default job on built-in data (run by `make demo`). Outputs go to out/demo/.
#
# Renders a synthetic sequence of the real KITTI-360 rig (4 cameras: a stereo
# pair and two MEI fisheyes; urban scene with exact ground truth), runs the
# whole pipeline on it (frontend, metric initialisation, sliding-window BA with
# scale correction) and evaluates the trajectory; then tracks the sequence
# once more into a track file and replays the back end from it, which gives
# the same trajectory byte for byte.
set -euo pipefail
cd "$(dirname "$0")/.."
MCVO=${1:-build/mcvo}
OUT=out/demo
FRAMES=${MCVO_DEMO_FRAMES:-130}
mkdir -p "$OUT"

echo "== mcvo synth --preset kitti360 ($FRAMES frames at half resolution, urban scene)"
"$MCVO" synth --preset kitti360 --frames "$FRAMES" --image-scale 0.5 --out "$OUT/kitti360" --force

echo
echo "== mcvo info --dataset $OUT/kitti360"
"$MCVO" info --dataset "$OUT/kitti360"

echo
echo "== mcvo run (config/kitti360_4cam.json)"
"$MCVO" run --dataset "$OUT/kitti360" --config config/kitti360_4cam.json --out "$OUT/run" --force
echo
cat "$OUT/run/eval/eval.md"

echo
echo "== mcvo track, then mcvo run --tracks (the back end replayed from the track file)"
"$MCVO" track --dataset "$OUT/kitti360" --config config/kitti360_4cam.json --out "$OUT/tracks.bin" \
  --stats "$OUT/track_stats.csv"
"$MCVO" run --dataset "$OUT/kitti360" --config config/kitti360_4cam.json --tracks "$OUT/tracks.bin" \
  --out "$OUT/replay" --force
if cmp -s "$OUT/run/trajectory.tum" "$OUT/replay/trajectory.tum"; then
  echo "replay: trajectory identical to the run from images"
else
  echo "replay: trajectory DIFFERS from the run from images" >&2
  exit 1
fi

if command -v colmap >/dev/null; then
  echo
  echo "== colmap model_analyzer on the run's COLMAP model"
  colmap model_analyzer --path "$OUT/run/colmap/sparse/0" 2>&1 | grep -E "Cameras|Images|Points|Observations|reprojection"
fi

echo
echo "demo outputs: $OUT/kitti360 (synthetic sequence: rig.json, frames.csv, images/, groundtruth.tum)"
echo "              $OUT/run (trajectory.tum, keyframes.tum, scale_log.csv, frame_stats.csv, run.json, eval/,"
echo "                report.html: open it in a browser, colmap/: the keyframes and landmarks as a COLMAP model)"
echo "              $OUT/tracks.bin, $OUT/replay (the same run from the track file)"
