#!/usr/bin/env bash
# Render benchmark of `mcvo synth`: wall time per frame and per megapixel for
# every preset at full resolution, with 1 and 2 threads. Writes
# results/synth_render.md (and prints it).
#
#   tools/bench_synth.sh [FRAMES] [MCVO]     defaults: 6 frames, build/mcvo
#
# Each run renders FRAMES frames of the preset's default scene into a scratch
# folder; the time covers the whole command (scene and BVH build, per-camera
# bearing caches, rendering, PNG encoding), as a user pays it.
set -euo pipefail
cd "$(dirname "$0")/.."
FRAMES=${1:-6}
MCVO=${2:-build/mcvo}
SCRATCH=$(mktemp -d)
trap 'rm -rf "$SCRATCH"' EXIT
OUT=results/synth_render.md

cpu=$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')
{
  echo "# mcvo synth render benchmark"
  echo
  echo "$(date -u +%Y-%m-%d), commit $(git rev-parse --short HEAD 2>/dev/null || echo unknown), $(nproc) cores ($cpu)."
  echo "$FRAMES frames per run at full resolution, 2x2 samples per pixel (default), seed 0, preset's default scene."
  echo "Times are wall clock for the whole command (scene build, bearing caches, rendering, PNG encoding)."
  echo
  echo "| preset | scene | cameras | Mpx/frame | threads | s/frame | s/Mpx |"
  echo "|---|---|---|---|---|---|---|"
} > "$SCRATCH/table.md"

for preset in kitti360 kitti360-3cam stereo multicam6 irregular5; do
  for threads in 1 2; do
    start=$(date +%s.%N)
    log=$("$MCVO" synth --preset "$preset" --frames "$FRAMES" --threads "$threads" \
          --out "$SCRATCH/$preset-$threads" 2>&1)
    end=$(date +%s.%N)
    mpx=$(echo "$log" | sed -n 's/.*(\([0-9.]*\) Mpx per frame.*/\1/p')
    cams=$(echo "$log" | sed -n 's/.* x \([0-9]*\) cameras.*/\1/p')
    scene=$(sed -n 's/.*"scene": "\([a-z]*\)".*/\1/p' "$SCRATCH/$preset-$threads/meta.json")
    awk -v p="$preset" -v s="$scene" -v c="$cams" -v m="$mpx" -v t="$threads" -v a="$start" -v b="$end" -v f="$FRAMES" \
      'BEGIN { w = (b - a) / f; printf "| %s | %s | %s | %.2f | %d | %.3f | %.3f |\n", p, s, c, m, t, w, w / m }' \
      >> "$SCRATCH/table.md"
    rm -rf "${SCRATCH:?}/$preset-$threads"
  done
done
mkdir -p results
cp "$SCRATCH/table.md" "$OUT"
cat "$OUT"
