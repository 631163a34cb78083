#!/usr/bin/env bash
# Makes the default ORB vocabulary of loop closure, config/vocabulary_orb.bin
# (docs/loop-closure.md, "Vocabulary").
#
# usage: tools/make_default_vocabulary.sh [MCVO] [OUT]
#   MCVO defaults to build/mcvo, OUT to config/vocabulary_orb.bin.
#   THREADS (environment) sets --threads (default 0: all cores; the file is
#   the same at any thread count). Work files go to out/vocabulary/.
#
# Renders three synthetic sequences, none of them with the seeds of the
# benchmarks (1) or the tests (0), frames 1 s apart so that they are not
# near-duplicates, with mild image noise:
#   urban:  the KITTI-360 rig (2 pinhole + 2 fisheye) at half resolution, 60 frames (about 450 m)
#   indoor: the MultiCamData-like rig (6 x 720x540) at full resolution, 40 frames
#   open:   the KITTI-360 rig at half resolution in the open terrain, 20 frames
# then trains on ORB descriptors (cv::ORB, 500 per camera image, inside the
# masks: what loop closure extracts) with branching 8 and 4 levels: at most
# 8^4 = 4096 words of 32 bytes, a 201 KB file.
set -euo pipefail
cd "$(dirname "$0")/.."
MCVO=${1:-build/mcvo}
OUT=${2:-config/vocabulary_orb.bin}
THREADS=${THREADS:-0}
WORK=out/vocabulary
mkdir -p "$WORK"

echo "== rendering the training sequences into $WORK"
"$MCVO" synth --preset kitti360 --image-scale 0.5 --rate 1 --frames 60 --noise 1 --seed 7 \
  --threads "$THREADS" --out "$WORK/urban" --force
"$MCVO" synth --preset multicam6 --rate 1 --frames 40 --noise 1 --seed 8 \
  --threads "$THREADS" --out "$WORK/indoor" --force
"$MCVO" synth --preset kitti360 --scene open --image-scale 0.5 --rate 1 --frames 20 --noise 1 --seed 9 \
  --threads "$THREADS" --out "$WORK/open" --force

echo "== training $OUT"
"$MCVO" vocab train --dataset "$WORK/urban" --extra-datasets "$WORK/indoor,$WORK/open" \
  --descriptor orb --features 500 --branching 8 --levels 4 --seed 0 --threads "$THREADS" --out "$OUT"
"$MCVO" vocab info "$OUT"
